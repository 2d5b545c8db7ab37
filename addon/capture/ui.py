"""The Capture panel in the Tussock sidebar tab."""

import bpy
from ..ui import SubPanel


class TUSSOCK_PT_capture(SubPanel, bpy.types.Panel):
    bl_label = "Capture"
    bl_idname = "TUSSOCK_PT_capture"

    def draw(self, context):
        layout = self.layout
        s = context.scene.tussock_capture
        layout.prop(s, "source")
        if s.source == "DEVICE":
            layout.prop(s, "device_uri")
        else:
            layout.prop(s, "filepath")
        row = layout.row(align=True)
        row.prop(s, "auto_band", toggle=True)
        sub = row.row(align=True)
        sub.enabled = not s.auto_band
        sub.prop(s, "near")
        sub.prop(s, "far")
        layout.prop(s, "min_area")
        row = layout.row(align=True)
        row.prop(s, "frames")
        if s.source != "DEVICE":
            row.prop(s, "frame")
        row = layout.row(align=True)
        row.operator("tussock.capture_preview", icon="HIDE_OFF")
        row.operator("tussock.capture_blades", icon="OUTLINER_OB_CAMERA")
        layout.label(text="Preview: Image Editor › 'Tussock Capture Preview'", icon="IMAGE_DATA")


classes = (TUSSOCK_PT_capture,)
