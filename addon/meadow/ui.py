"""The Meadow panel in the Tussock sidebar tab."""

import bpy

from .. import compat
from ..ui import SubPanel


class TUSSOCK_PT_meadow(SubPanel, bpy.types.Panel):
    bl_label = "Meadow"
    bl_idname = "TUSSOCK_PT_meadow"

    def draw(self, context):
        layout = self.layout
        layout.operator("tussock.add_meadow", icon="OUTLINER_OB_CURVES")
        obj = context.active_object
        s = compat.settings_of(obj, "tussock_meadow")
        if s is None or not s.is_meadow:
            return
        if s.last_error:
            box = layout.box()
            box.alert = True
            box.label(text=s.last_error, icon="ERROR")
        layout.label(text=f"{obj.get('tussock_blades', 0):,} blades, "
                          f"{obj.get('tussock_tiles', 0):,} tiles")
        col = layout.column(align=True)
        col.prop(s, "ground")
        col.prop(s, "models")
        col = layout.column(align=True)
        col.prop(s, "tile_size")
        col.prop(s, "blades_per_tile")
        col.prop(s, "patch_blades")
        col.prop(s, "chunk_blades")
        row = layout.row(align=True)
        row.prop(s, "scale_min")
        row.prop(s, "scale_max")
        layout.prop(s, "density")
        if s.density == "NOISE":
            col = layout.column(align=True)
            col.prop(s, "noise_scale")
            col.prop(s, "noise_octaves")
            col.prop(s, "noise_threshold")
        elif s.density == "IMAGE":
            layout.template_ID(s, "density_image", open="image.open")
        layout.prop(s, "seed")
        layout.prop(s, "display", slider=True)
        box = layout.box()
        box.prop(s, "use_simulation")
        if s.use_simulation:
            box.prop(s, "colliders")
            col = box.column(align=True)
            col.prop(s, "sim_iterations")
            col.prop(s, "sim_damping")
            col.prop(s, "sim_stiffness")
            col.prop(s, "sim_local_stiffness")
            col.prop(s, "sim_settle_time")
            box.label(text=f"{obj.get('tussock_active_tiles', 0)} tiles, "
                           f"{obj.get('tussock_active_blades', 0):,} blades simulated")


classes = (TUSSOCK_PT_meadow,)
