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
    source: bpy.props.EnumProperty(name="Source", items=SOURCE_ITEMS, default="FILES",
                                   description="Where the depth frames come from")
    filepath: bpy.props.StringProperty(name="File", subtype="FILE_PATH",
                                       options=compat.PATH_OPTIONS,
                                       description="Depth image, numbered depth image sequence (# "
                                                   "for the frame number) or .oni recording")
    device_uri: bpy.props.StringProperty(name="Device", default="",
                                         description="OpenNI2 device URI (empty: the first)")
    auto_band: bpy.props.BoolProperty(name="Auto", default=True,
                                      description="Find the nearest significant depth")
    near: bpy.props.FloatProperty(name="Near", default=0.4, min=0.0, unit="LENGTH",
                                  description="Near end of the depth band in which blades are "
                                              "looked for")
    far: bpy.props.FloatProperty(name="Far", default=1.0, min=0.0, unit="LENGTH",
                                 description="Far end of the depth band in which blades are "
                                             "looked for")
    min_area: bpy.props.IntProperty(name="Minimum blade area", default=150, min=1,
                                    subtype="PIXEL",
                                    description="Smaller regions of the depth band are noise, not "
                                                "blades")
    frames: bpy.props.IntProperty(name="Frames to average", default=1, min=1, max=300,
                                  description="Depth frames averaged into one before the blades "
                                              "are found (less sensor noise)")
    frame: bpy.props.IntProperty(name="First frame", default=0, min=0,
                                 description="First frame of the sequence or recording to read")


classes = (TussockCaptureSettings,)


def register_extra():
    bpy.types.Scene.tussock_capture = bpy.props.PointerProperty(type=TussockCaptureSettings)


def unregister_extra():
    del bpy.types.Scene.tussock_capture
