"""tussock.refine_blades: the selected blade objects refined to m knots by movement
similarity (seed 000 Algorithm 1). Each keeps its object and gets a refined mesh; the
full-resolution mesh stays in the file (fake user) so the blade can be refined again
with another knot count, and is shown expanded as a ribbon as in seed Fig. 6."""

import bpy
import numpy as np

from .. import errors, meshes, native
from ..capture import blades
from ..nodes import blade_nodes
from . import movement

KNOT_ITEMS = [("64", "64", ""), ("32", "32", ""), ("16", "16", ""), ("8", "8", "")]
METHOD_ITEMS = [
    ("SIMILARITY", "Movement similarity", "Seed 000 Algorithm 1: merge the adjacent knots that "
     "move most alike"),
    ("UNIFORM", "Uniform", "Evenly spaced knots along the blade (needs no movement; measured "
     "closer to the full blade's motion, see docs/performance.md)"),
]
MOVEMENT_ITEMS = [
    ("AUTO", "Automatic", "Tracked through the captured sequence when the blade came from "
     "one with enough frames, otherwise simulated"),
    ("TRACKED", "Tracked", "The knots' motion in the depth sequence the blade was captured from"),
    ("SIMULATED", "Simulated", "The blade bent by Tussock's standard wind (a still capture)"),
]


def is_blade(obj):
    return obj is not None and obj.type == "MESH" and "width" in obj.data.attributes


def full_mesh(obj):
    """The blade's full-resolution mesh: the one it was refined from, or its own."""
    name = obj.get("tussock_full_mesh")
    mesh = bpy.data.meshes.get(name) if name else None
    return mesh if mesh is not None else obj.data


def read_blade(mesh):
    n = len(mesh.vertices)
    co = np.empty(n * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    w = np.empty(n, np.float32)
    mesh.attributes["width"].data.foreach_get("value", w)
    cam = None
    if "camera_co" in mesh.attributes:
        cam = np.empty(n * 3, np.float32)
        mesh.attributes["camera_co"].data.foreach_get("vector", cam)
        cam = cam.reshape(-1, 3)
    return co.reshape(-1, 3), w, cam


class TUSSOCK_OT_refine_blades(bpy.types.Operator):
    """Refine the selected blades to fewer knots, merging the knots that move most alike"""
    bl_idname = "tussock.refine_blades"
    bl_label = "Refine Blades"
    bl_options = {"REGISTER", "UNDO"}

    knots: bpy.props.EnumProperty(name="Knots", items=KNOT_ITEMS, default="16",
                                  description="Knots each refined blade keeps")
    custom_knots: bpy.props.IntProperty(name="Custom knots", default=0, min=0, max=64,
                                        description="Any count from 2 to 64 (0: use Knots)")
    method: bpy.props.EnumProperty(name="Method", items=METHOD_ITEMS, default="SIMILARITY",
                                   description="How the knots to keep are chosen")
    mu: bpy.props.FloatProperty(name="μ", default=0.5, min=0.0, max=1.0,
                                description="Weight of distance against variance of "
                                "distance in the movement difference (seed 000 eq. 1); "
                                "1 = distance only")
    movement: bpy.props.EnumProperty(name="Movement", items=MOVEMENT_ITEMS, default="AUTO",
                                     description="Which motion of the blade guides the choice of "
                                                 "knots")
    frames: bpy.props.IntProperty(name="Frames", default=24, min=1, max=10000,
                                  description="Frames of movement compared")

    def execute(self, context):
        return errors.run(self, self._refine, context)

    def _refine(self, context):
        lib = native.require()
        targets = [o for o in context.selected_objects if is_blade(o)]
        if not targets:
            raise ValueError("select one or more Tussock blades (meshes with a 'width' attribute)")
        for obj in targets:
            meshes.refuse_edit_mode(obj, "refining")
        m = self.custom_knots if self.custom_knots else int(self.knots)
        fps = context.scene.render.fps / context.scene.render.fps_base
        results = []
        for obj in targets:  # one native call per blade object
            mesh = full_mesh(obj)
            local, widths, cam = read_blade(mesh)
            if self.method == "UNIFORM":
                out_k = np.empty(m * 3, np.float32)
                out_w = np.empty(m, np.float32)
                lib.refine_resample(np.ascontiguousarray(local, np.float32).ravel(), widths,
                                    out_k, out_w)
                local_out = out_k.reshape(-1, 3)
                cam_out = (cam[0] + (local_out - local[0]) @ blades.CAMERA_TO_WORLD) \
                    if cam is not None else local_out
                results.append((obj, mesh, local_out, out_w, cam_out, None, "NONE"))
                continue
            mode = self.movement
            if mode == "AUTO":
                tracked = (obj.get("tussock_source") in ("FILES", "ONI") and cam is not None
                           and self._sequence_long_enough(obj))
                mode = "TRACKED" if tracked else "SIMULATED"
            if mode == "TRACKED":
                if cam is None:
                    raise ValueError(f"'{obj.name}' has no camera_co attribute to track")
                traj = movement.tracked(obj, cam, self.frames)
                knots = cam
            else:
                traj = movement.simulated(local, widths, self.frames, fps)
                knots = local
            out_k = np.empty(m * 3, np.float32)
            out_w = np.empty(m, np.float32)
            ranges = np.empty(m * 2, np.int32)
            lib.refine_blade(np.ascontiguousarray(knots, np.float32).ravel(), widths,
                             np.ascontiguousarray(traj, np.float32).ravel(), self.frames, m,
                             self.mu, out_k, out_w, ranges)
            out_k = out_k.reshape(-1, 3)
            if mode == "TRACKED":  # camera frame -> the blade's local frame (root at origin)
                cam_out = out_k
                local_out = (out_k - out_k[0]) @ blades.CAMERA_TO_WORLD.T
            else:
                local_out = out_k
                cam_out = (cam[0] + (out_k - local[0]) @ blades.CAMERA_TO_WORLD
                           if cam is not None else out_k)
            results.append((obj, mesh, local_out, out_w, cam_out, ranges.reshape(-1, 2), mode))
        # everything computed: now change the scene
        for obj, mesh, local_out, out_w, cam_out, ranges, mode in results:
            new = blades.blade_mesh(f"{obj.name} {m} knots", local_out, out_w, cam_out)
            if ranges is not None:  # which original knots each refined knot stands for
                first = new.attributes.new("source_first", "INT", "POINT")
                first.data.foreach_set("value", np.ascontiguousarray(ranges[:, 0]))
                count = new.attributes.new("source_count", "INT", "POINT")
                count.data.foreach_set("value", np.ascontiguousarray(ranges[:, 1]))
            mesh.use_fake_user = True
            obj["tussock_full_mesh"] = mesh.name
            obj["tussock_refined_knots"] = m
            obj["tussock_refine_method"] = self.method
            obj["tussock_refine_mu"] = self.mu
            obj["tussock_refine_movement"] = mode
            old = obj.data
            obj.data = new
            if old is not mesh and old.users == 0:
                bpy.data.meshes.remove(old)
            blade_nodes.show_ribbon(obj)
        from ..meadow import build as meadow_build
        meadow_build.rebuild_growing([r[0] for r in results])
        self.report({"INFO"}, f"Refined {len(results)} blades to {m} knots")
        return {"FINISHED"}

    def _sequence_long_enough(self, obj):
        lib = native.require()
        try:
            src = lib.depth_open_files(bpy.path.abspath(obj["tussock_path"])) \
                if obj["tussock_source"] == "FILES" else \
                lib.depth_open_oni(bpy.path.abspath(obj["tussock_path"]))
        except lib.Error:
            return False
        try:
            info = lib.depth_info(src)
            seen = obj.get("tussock_frame", 0) - info["first_frame"]
            return info["frame_count"] - seen >= self.frames
        finally:
            lib.depth_close(src)


classes = (TUSSOCK_OT_refine_blades,)
