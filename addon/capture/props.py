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


# Tooltips shared by the settings and the operator that takes them.
TIPS = {
    "source": "Where the depth frames come from",
    "filepath": "Depth image, numbered depth image sequence (# for the frame number) or .oni "
                "recording",
    "near": "Near end of the depth band in which blades are looked for",
    "far": "Far end of the depth band in which blades are looked for",
    "min_area": "Smaller regions of the depth band are noise, not blades",
    "frames": "Depth frames averaged into one before the blades are found (less sensor noise)",
    "frame": "First frame of the sequence or recording to read",
    "device_uri": "OpenNI2 device URI (empty: the first)",
    "fx": "Horizontal focal length of the depth camera in pixels (0: from the device or defaults)",
    "fy": "Vertical focal length of the depth camera in pixels (0: from the device or defaults)",
    "cx": "Principal point, pixels from the left (0: from the device or defaults)",
    "cy": "Principal point, pixels from the top (0: from the device or defaults)",
}


class TussockCaptureSettings(bpy.types.PropertyGroup):
    source: bpy.props.EnumProperty(name="Source", items=SOURCE_ITEMS, default="FILES",
                                   description=TIPS["source"])
    filepath: bpy.props.StringProperty(name="File", subtype="FILE_PATH",
                                       options=compat.PATH_OPTIONS,
                                       description=TIPS["filepath"])
    device_uri: bpy.props.StringProperty(name="Device", default="",
                                         description=TIPS["device_uri"])
    auto_band: bpy.props.BoolProperty(name="Auto", default=True,
                                      description="Find the nearest significant depth")
    # limits of tsk_capture_def_validate (native/src/capture/capture.c); near < far is
    # checked there, with both values in the message
    near: bpy.props.FloatProperty(name="Near", default=0.4, min=0.0, max=10000.0,
                                  unit="LENGTH",
                                  description=TIPS["near"])
    far: bpy.props.FloatProperty(name="Far", default=1.0, min=0.0, max=10000.0,
                                 unit="LENGTH",
                                 description=TIPS["far"])
    min_area: bpy.props.IntProperty(name="Minimum blade area", default=150, min=1,
                                    max=1 << 26,
                                    subtype="PIXEL",
                                    description=TIPS["min_area"])
    frames: bpy.props.IntProperty(name="Frames to average", default=1, min=1, max=300,
                                  description=TIPS["frames"])
    frame: bpy.props.IntProperty(name="First frame", default=0, min=0,
                                 description=TIPS["frame"])


classes = (TussockCaptureSettings,)


def register_extra():
    bpy.types.Scene.tussock_capture = bpy.props.PointerProperty(type=TussockCaptureSettings)


def unregister_extra():
    del bpy.types.Scene.tussock_capture
