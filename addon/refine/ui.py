"""The Refine panel in the Tussock sidebar tab."""

import bpy
from ..ui import SubPanel


class TUSSOCK_PT_refine(SubPanel, bpy.types.Panel):
    bl_label = "Refine"
    bl_idname = "TUSSOCK_PT_refine"

    def draw(self, context):
        layout = self.layout
        layout.label(text="Select captured blades, then:")
        row = layout.row(align=True)
        for m in (64, 32, 16, 8):
            op = row.operator("tussock.refine_blades", text=str(m))
            op.knots = str(m)
        obj = context.active_object
        if obj is not None and "tussock_refined_knots" in obj:
            col = layout.column(align=True)  # two short lines: nothing cut at any width
            col.label(text=f"{obj.name}: {obj['tussock_refined_knots']} knots")
            col.label(text=f"{str(obj['tussock_refine_movement']).title()} movement")


classes = (TUSSOCK_PT_refine,)
