"""The Capture panel in the Tussock sidebar tab."""

import bpy
from ..ui import SubPanel


class TUSSOCK_PT_capture(SubPanel, bpy.types.Panel):
    bl_label = "Capture"
    bl_idname = "TUSSOCK_PT_capture"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = True
        s = context.scene.tussock_capture
        row = layout.row()  # the whole width for the source's long names
        row.use_property_split = False
        row.prop(s, "source", text="")
        col = layout.column()
        if s.source == "DEVICE":
            col.prop(s, "device_uri")
        else:
            col.prop(s, "filepath")
        col = layout.column(heading="Depth")
        col.prop(s, "auto_band", text="Auto Band")
        sub = col.column(align=True)
        sub.enabled = not s.auto_band
        sub.prop(s, "near", text="Near")
        sub.prop(s, "far", text="Far")
        layout.prop(s, "min_area", text="Min Area")
        col = layout.column(align=True)
        col.prop(s, "frames", text="Frames")
        if s.source != "DEVICE":
            col.prop(s, "frame", text="First")
        col = layout.column(align=True)
        col.operator("tussock.capture_preview", icon="HIDE_OFF")
        col.operator("tussock.capture_blades", icon="OUTLINER_OB_CAMERA")
        col = layout.column(align=True)
        col.label(text="Preview: Image Editor", icon="IMAGE_DATA")
        col.label(text="Tussock Capture Preview", icon="BLANK1")


classes = (TUSSOCK_PT_capture,)
