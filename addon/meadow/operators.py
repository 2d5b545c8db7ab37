"""tussock.add_meadow: a meadow over the selected ground mesh, or over a new plane."""

import math
import time
import types

import bpy

from .. import bounds, budget, errors, meshes, progress
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
        return errors.run(self, self._run, self._grow(context))

    @staticmethod
    def _run(steps):
        while True:
            try:
                next(steps)
            except StopIteration as done:
                return done.value

    def _settings(self, ground):
        values = {name: getattr(self, name) for name in SETTINGS}
        return types.SimpleNamespace(ground=ground, models=None, density_image=None, **values)

    def _grow(self, context):
        """All of Add Meadow, in steps that yield (phase, done, total). Everything is made
        as new data outside the scene and linked into it only in the last step, so the
        scene stays as it was until then (a cancel removes what was made)."""
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
        yield "laying out the tiles", 0, 1
        # everything native first: a bad parameter cancels with the scene unchanged
        key, patch, layout = build.compute(settings, origin, size)
        yield "laying out the tiles", 1, 1

        new_ground = ground is None
        if new_ground:
            mesh = bpy.data.meshes.new("Meadow ground")
            hx, hy = size[0] / 2, size[1] / 2
            mesh.from_pydata([(-hx, -hy, 0), (hx, -hy, 0), (hx, hy, 0), (-hx, hy, 0)], [],
                             [(0, 1, 2, 3)])
            ground = bpy.data.objects.new("Meadow ground", mesh)
            ground.location = (origin[0] + hx, origin[1] + hy, origin[2])
        obj = bpy.data.objects.new("Meadow", bpy.data.meshes.new("Meadow"))
        obj["tussock_meadow_object"] = True
        identity.give_id(obj)
        obj["tussock_origin"] = origin
        obj["tussock_size"] = size
        s = obj.tussock_meadow
        s.ground = ground  # is_meadow is still False: no rebuild on assignment
        for name in SETTINGS:
            setattr(s, name, getattr(self, name))
        for made, chunks in build.write_steps(obj, s, key, patch, layout):
            yield "making the blade chunks", made, chunks
        info = layout["info"]
        if new_ground:
            context.scene.collection.objects.link(ground)
        context.scene.collection.objects.link(obj)
        s.is_meadow = True
        meshes.select_new(context, [obj])
        note = budget.note(layout["memory"])
        self.report({"WARNING"} if note else {"INFO"},
                    f"Meadow: {info['blade_count']:,} blades in {info['nonempty_tiles']:,} "
                    "tiles" + (f"; {note}" if note else ""))
        return {"FINISHED"}

    # ---- interactive: in slices under a modal timer, with progress; Esc cancels ----------
    SLICE = 0.05

    def invoke(self, context, event):
        self._before = errors.snapshot()
        self._steps = self._grow(context)
        self._timer = context.window_manager.event_timer_add(0.01, window=context.window)
        progress.begin(context, "Tussock meadow", "laying out the tiles", 1)
        context.window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC" and event.value == "PRESS":
            self._end(context)
            errors.remove_created(self._before)
            self.report({"INFO"}, "Add Meadow cancelled: nothing was added")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"RUNNING_MODAL"}  # the meadow's new data is not in the scene yet
        t0 = time.perf_counter()
        try:
            while time.perf_counter() - t0 < self.SLICE:
                phase, done, total = next(self._steps)
        except StopIteration as finished:
            self._end(context)
            return finished.value
        except Exception as exc:  # noqa: BLE001 - reported like any operator's failure
            self._end(context)
            return errors.run(self, self._fail, exc)
        progress.update(context, done, total, phase)
        return {"RUNNING_MODAL"}

    def _fail(self, exc):
        errors.remove_created(self._before)
        raise exc

    def cancel(self, context):  # Blender ends the operator (a file is loaded, it quits)
        self._end(context)
        errors.remove_created(self._before)

    def _end(self, context):
        self._steps.close()
        context.window_manager.event_timer_remove(self._timer)
        progress.end(context)


class TUSSOCK_OT_meadow_joined(bpy.types.Operator):
    """Reports that a meadow joined with other objects is a plain mesh now (a handler, which
    found it, cannot report)"""
    bl_idname = "tussock.meadow_joined"
    bl_label = "Meadow Joined"
    bl_options = {"INTERNAL"}

    message: bpy.props.StringProperty(options={"HIDDEN", "SKIP_SAVE"})

    def execute(self, context):
        self.report({"WARNING"}, self.message)
        return {"FINISHED"}


classes = (TUSSOCK_OT_add_meadow, TUSSOCK_OT_meadow_joined)
