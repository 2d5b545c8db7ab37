"""Capture settings of the scene, shown in the Capture panel and copied into the
operator when the artist presses Capture."""

import bpy

from .. import compat

SOURCE_ITEMS = [
    ("FILES", "Depth images", "A 16-bit PNG (millimetres) or 32-bit OpenEXR (metres), or a "
     "numbered sequence with # for the frame number (depth_####.png)"),
    ("ONI", "OpenNI2 recording", "A recorded .oni file"),
    ("DEVICE", "Depth camera", "A live OpenNI2 depth camera"),
]


class TussockCaptureSettings(bpy.types.PropertyGroup):
    source: bpy.props.EnumProperty(name="Source", items=SOURCE_ITEMS, default="FILES")
    filepath: bpy.props.StringProperty(name="File", subtype="FILE_PATH", options=compat.PATH_OPTIONS)
    device_uri: bpy.props.StringProperty(name="Device", default="",
                                         description="OpenNI2 device URI (empty: the first)")
    auto_band: bpy.props.BoolProperty(name="Auto", default=True,
                                      description="Find the nearest significant depth")
    near: bpy.props.FloatProperty(name="Near", default=0.4, min=0.0, unit="LENGTH")
    far: bpy.props.FloatProperty(name="Far", default=1.0, min=0.0, unit="LENGTH")
    min_area: bpy.props.IntProperty(name="Minimum blade area", default=150, min=1,
                                    subtype="PIXEL")
    frames: bpy.props.IntProperty(name="Frames to average", default=1, min=1, max=300)
    frame: bpy.props.IntProperty(name="First frame", default=0, min=0)


classes = (TussockCaptureSettings,)


def register_extra():
    bpy.types.Scene.tussock_capture = bpy.props.PointerProperty(type=TussockCaptureSettings)


def unregister_extra():
    del bpy.types.Scene.tussock_capture
