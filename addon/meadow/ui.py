"""The Meadow panel in the Tussock sidebar tab, with its Density, Performance and
Simulation sub-panels (drawn for the active meadow only)."""

import bpy

from .. import compat
from ..ui import SubPanel
from . import colliders


def _meadow(context):
    """The active object's meadow settings, or None when it is not a meadow."""
    s = compat.settings_of(context.active_object, "tussock_meadow")
    return s if s is not None and s.is_meadow else None


def _split(layout):
    layout.use_property_split = True
    layout.use_property_decorate = True


class TUSSOCK_PT_meadow(SubPanel, bpy.types.Panel):
    bl_label = "Meadow"
    bl_idname = "TUSSOCK_PT_meadow"

    def draw(self, context):
        layout = self.layout
        layout.operator("tussock.add_meadow", icon="OUTLINER_OB_CURVES")
        s = _meadow(context)
        if s is None:
            return
        obj = context.active_object
        if s.last_error:
            box = layout.box()
            box.alert = True
            box.label(text=s.last_error, icon="ERROR")
        layout.label(text=f"{obj.get('tussock_blades', 0):,} blades, "
                          f"{obj.get('tussock_tiles', 0):,} tiles")
        _split(layout)
        col = layout.column()
        col.prop(s, "ground")
        col.prop(s, "models", text="Models")
        col = layout.column(align=True)
        col.prop(s, "tile_size", text="Tile Size")
        col.prop(s, "blades_per_tile", text="Blades")
        col = layout.column(align=True)
        col.prop(s, "scale_min", text="Scale Min")
        col.prop(s, "scale_max", text="Max")
        col = layout.column()
        col.prop(s, "seed")
        col.prop(s, "display", text="Display", slider=True)


class MeadowSubPanel(SubPanel):
    bl_parent_id = "TUSSOCK_PT_meadow"

    @classmethod
    def poll(cls, context):
        return _meadow(context) is not None


class TUSSOCK_PT_meadow_density(MeadowSubPanel, bpy.types.Panel):
    bl_label = "Density"
    bl_idname = "TUSSOCK_PT_meadow_density"

    def draw(self, context):
        layout = self.layout
        _split(layout)
        s = _meadow(context)
        layout.prop(s, "density")
        if s.density == "NOISE":
            col = layout.column(align=True)
            col.prop(s, "noise_scale", text="Scale")
            col.prop(s, "noise_octaves")
            col.prop(s, "noise_threshold")
        elif s.density == "IMAGE":
            layout.template_ID(s, "density_image", open="image.open")


class TUSSOCK_PT_meadow_performance(MeadowSubPanel, bpy.types.Panel):
    bl_label = "Performance"
    bl_idname = "TUSSOCK_PT_meadow_performance"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        _split(layout)
        s = _meadow(context)
        col = layout.column(align=True)
        col.prop(s, "patch_blades", text="Patch Size")
        col.prop(s, "chunk_blades", text="Chunk")


class TUSSOCK_PT_meadow_simulation(MeadowSubPanel, bpy.types.Panel):
    bl_label = "Simulation"
    bl_idname = "TUSSOCK_PT_meadow_simulation"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_header(self, context):
        self.layout.prop(_meadow(context), "use_simulation", text="")

    def draw(self, context):
        layout = self.layout
        _split(layout)
        s = _meadow(context)
        obj = context.active_object
        layout.active = s.use_simulation
        layout.prop(s, "colliders")
        col = layout.column(align=True)
        col.prop(s, "sim_iterations")
        col.prop(s, "sim_damping")
        col = layout.column(align=True)
        col.prop(s, "sim_stiffness", text="Stiffness")
        col.prop(s, "sim_local_stiffness", text="Bending")
        layout.prop(s, "sim_settle_time", text="Settle")
        if s.use_simulation:
            layout.label(text=f"{obj.get('tussock_active_tiles', 0)} tiles, "
                              f"{obj.get('tussock_active_blades', 0):,} blades active")


def collider_of(obj):
    """The meadows whose Colliders collection holds `obj` (not a meadow itself)."""
    if obj is None or _is_meadow(obj):
        return []
    return [m for m in bpy.data.objects  # one look per object of the file
            if _is_meadow(m) and m.tussock_meadow.colliders is not None
            and obj.name in m.tussock_meadow.colliders.all_objects]


def _is_meadow(obj):
    s = compat.settings_of(obj, "tussock_meadow")
    return s is not None and s.is_meadow


_SHAPE_NAMES = {"BONES": "bone capsules", "SPHERES": "spheres", "BOUNDS": "bounds shape"}


class TUSSOCK_PT_collider(SubPanel, bpy.types.Panel):
    """How the active object pushes the blades of the meadows it collides with."""
    bl_label = "Collider"
    bl_idname = "TUSSOCK_PT_collider"

    @classmethod
    def poll(cls, context):
        return bool(collider_of(context.active_object))

    def draw(self, context):
        layout = self.layout
        obj = context.active_object
        s = obj.tussock_collider
        _split(layout)
        layout.prop(s, "shape", text="Shape")
        col = layout.column()
        col.active = s.shape in ("AUTO", "BONES")
        col.prop(s, "min_bone_size")
        col = layout.column()
        col.active = s.shape in ("AUTO", "SPHERES")
        col.prop(s, "max_spheres")
        layout.prop(s, "show_shapes")
        got = colliders.shown(obj)
        if got is not None:
            shape, rows = got
            capsules = int((rows[:, 0] == 1).sum())
            layout.label(text=f"{_SHAPE_NAMES[shape]}: {capsules} capsules, "
                              f"{len(rows) - capsules} spheres")
        names = ", ".join(m.name for m in collider_of(obj))
        layout.label(text=f"Pushes: {names}")


classes = (TUSSOCK_PT_meadow, TUSSOCK_PT_meadow_density, TUSSOCK_PT_meadow_performance,
           TUSSOCK_PT_meadow_simulation, TUSSOCK_PT_collider)
