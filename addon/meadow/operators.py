"""tussock.add_meadow: a meadow over the selected ground mesh, or over a new plane."""

import math
import types

import bpy

from .. import bounds, errors
from . import build, identity
from .props import TussockMeadowSettings

# settings copied from the operator to the meadow object, in this order
SETTINGS = ("tile_size", "blades_per_tile", "patch_blades", "chunk_blades", "scale_min",
            "scale_max", "density", "noise_scale", "noise_octaves", "noise_threshold", "seed",
            "display")


def _stored(name):
    return bounds.annotation(TussockMeadowSettings, name)


class TUSSOCK_OT_add_meadow(bpy.types.Operator):
    """Grow a meadow of instanced blades over the selected ground mesh (or a new plane)"""
    bl_idname = "tussock.add_meadow"
    bl_label = "Add Meadow"
    bl_options = {"REGISTER", "UNDO"}

    size: bpy.props.FloatVectorProperty(name="Size", size=2, default=(10.0, 10.0), min=0.0,
                                        unit="LENGTH",
                                        description="Size of the new ground plane when no "
                                        "ground mesh is selected")
    # the stored settings' own definitions (bounds.operator_property): checked against the
    # stored limits in _add, never clamped into another value than the one built
    tile_size: bounds.operator_property(_stored("tile_size"))
    blades_per_tile: bounds.operator_property(_stored("blades_per_tile"))
    patch_blades: bounds.operator_property(_stored("patch_blades"))
    chunk_blades: bounds.operator_property(_stored("chunk_blades"))
    scale_min: bounds.operator_property(_stored("scale_min"))
    scale_max: bounds.operator_property(_stored("scale_max"))
    density: bounds.operator_property(_stored("density"))
    noise_scale: bounds.operator_property(_stored("noise_scale"))
    noise_octaves: bounds.operator_property(_stored("noise_octaves"))
    noise_threshold: bounds.operator_property(_stored("noise_threshold"))
    seed: bounds.operator_property(_stored("seed"))
    display: bounds.operator_property(_stored("display"))

    def execute(self, context):
        return errors.run(self, self._add, context)

    def _settings(self, ground):
        values = {name: getattr(self, name) for name in SETTINGS}
        return types.SimpleNamespace(ground=ground, models=None, density_image=None, **values)

    def _add(self, context):
        ground = context.active_object
        if ground is not None and (ground.type != "MESH" or not ground.select_get()
                                   or ground.get("tussock_meadow_object")):
            ground = None
        if ground is None and not all(math.isfinite(v) and v > 0 for v in self.size):
            raise ValueError(f"size: must be positive, got {self.size[0]} x {self.size[1]}")
        bounds.check_operator(self, TussockMeadowSettings, SETTINGS)
        settings = self._settings(ground)
        if ground is not None:
            origin, size = build.ground_area(ground)
        else:
            cur = context.scene.cursor.location
            origin = (cur.x - self.size[0] / 2, cur.y - self.size[1] / 2, cur.z)
            size = tuple(self.size)
        # everything native first: a bad parameter cancels with the scene unchanged
        key, patch, layout = build.compute(settings, origin, size)

        if ground is None:
            mesh = bpy.data.meshes.new("Meadow ground")
            hx, hy = size[0] / 2, size[1] / 2
            mesh.from_pydata([(-hx, -hy, 0), (hx, -hy, 0), (hx, hy, 0), (-hx, hy, 0)], [],
                             [(0, 1, 2, 3)])
            ground = bpy.data.objects.new("Meadow ground", mesh)
            ground.location = (origin[0] + hx, origin[1] + hy, origin[2])
            context.scene.collection.objects.link(ground)
        obj = bpy.data.objects.new("Meadow", bpy.data.meshes.new("Meadow"))
        obj["tussock_meadow_object"] = True
        identity.give_id(obj)
        obj["tussock_origin"] = origin
        obj["tussock_size"] = size
        context.scene.collection.objects.link(obj)
        s = obj.tussock_meadow
        s.ground = ground  # is_meadow is still False: no rebuild on assignment
        for name in SETTINGS:
            setattr(s, name, getattr(self, name))
        info = build.write(obj, s, key, patch, layout)
        s.is_meadow = True
        for o in context.selected_objects:
            o.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        self.report({"INFO"}, f"Meadow: {info['blade_count']:,} blades in "
                              f"{info['nonempty_tiles']:,} tiles")
        return {"FINISHED"}


classes = (TUSSOCK_OT_add_meadow,)
