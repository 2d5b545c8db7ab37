"""Tree bakes (a job source of tussock.bake, see addon/cache.py): every frame of the scene's
range posed by the wind as the live tree is, written as a frame file and assembled into a
Point Cache 2 file that Blender's own Mesh Cache modifier plays."""

import hashlib
import json
import os

import numpy as np

from .. import cache, compat, native
from ..wind import runtime as wind_runtime
from . import build


class TreeJob(cache.Job):
    """Everything needed to bake one tree, read from Blender on the main thread."""

    def __init__(self, obj, scene, root):
        if not build.owns_mesh(obj):
            raise ValueError(f"{obj.name}: {build.NOT_OWNED}")
        s = obj.tussock_tree
        self.name = obj.name
        self.pointer = obj.as_pointer()  # the object, should it be renamed meanwhile
        self.points = len(obj.data.vertices)
        self.definition = build.definition(s)
        self.smooth = s.smooth_levels
        # the tree is grown now, not when its frames are baked: invalid settings or a tree
        # too big cancel the bake before it reads any meadow's frames (which takes minutes
        # and shows each frame; soak seed 536054)
        try:
            self.tree = build.native_tree(self.definition, self.smooth)
        except (native.Error, ValueError) as exc:
            raise ValueError(f"{obj.name}: {exc}") from exc
        self.matrix = np.array(obj.matrix_world, np.float64)
        # the wind response of every frame (it may be keyframed), as the live pose reads it
        self.strength = {f: wind_runtime.keyed_value(obj.animation_data,
                                                     "tussock_tree.wind_strength", f, s,
                                                     "wind_strength")
                         for f in range(scene.frame_start, scene.frame_end + 1)}
        safe = cache.safe_name(obj.name)
        self.folder = os.path.join(root, safe)
        self.pc2 = os.path.join(root, safe + ".pc2")
        self.rel_pc2 = cache.CACHE_DIR + "/" + safe + ".pc2"
        self.range = (scene.frame_start, scene.frame_end)
        self.key = inputs_key(obj, scene)
        self.wind_kwargs = wind_runtime.wind_kwargs(scene)
        self.fps = wind_runtime.fps_of(scene)
        # wind sources and keyframed wind settings at every frame of the range, read now
        # (F-curves need bpy)
        self.sources = {f: wind_runtime.sources(scene, f)
                        for f in range(scene.frame_start, scene.frame_end + 1)}
        self.wind_settings = wind_runtime.frame_settings(scene, list(self.sources))

    def outputs(self):
        return [self.folder, self.pc2]

    def bytes_needed(self, frames):
        return (len(frames) + len(range(self.range[0], self.range[1] + 1))) * \
            (self.points * 12 + 64)

    def steps(self, frames, progress):
        lib = native.require()
        cache.clear_temporary(self.folder, frames)
        self._claim_folder()
        todo = []
        for f in frames:
            if cache.frame_done(lib, self.folder, f):
                progress()
            else:
                todo.append(f)
        if not todo:
            self.tree = None  # (the job lives as long as the operator)
            return
        yield
        data = build.compute_from(self.definition, self.smooth, rest=False, tree=self.tree)
        self.tree = None  # data holds it now, and frees it with data
        wind = wind_runtime.Stepper(self.wind_kwargs, self.range[0], self.fps,
                                    lambda f: self.sources.get(f, np.zeros((0, 8), np.float32)),
                                    settings_at=self.wind_settings.__getitem__)
        for f in todo:
            yield
            verts = build.posed_vertices(data, self.matrix, self.strength[f],
                                         lambda xyz, f=f: wind.sample(f, xyz))
            lib.bake_write_frame(cache.frame_path(self.folder, f), f,
                                 np.ascontiguousarray(verts, np.float32).ravel())
            progress()

    def folder_key(self):
        """The inputs key of the frame files: the tree's inputs_key and the wind sources at
        every frame of the range (keyframes included)."""
        h = hashlib.sha256(self.key.encode())
        for f in sorted(self.sources):
            h.update(np.ascontiguousarray(self.sources[f], np.float32).tobytes())
        return h.hexdigest()

    def _claim_folder(self):
        """Frame files made from other inputs (the tree, its placement, the wind or its
        sources changed since) must not be taken for finished frames: when the folder's
        recorded key differs, its frames and the assembled .pc2 are removed first. Workers
        of one split bake have the same key, so they keep each other's frames."""
        key = self.folder_key()
        key_path = os.path.join(self.folder, "inputs.key")
        try:
            with open(key_path) as f:
                old = f.read().strip()
        except OSError:
            old = None
        if old == key:
            return
        if old is not None:  # (no key yet: a fresh folder, or another worker's just begun)
            for name in os.listdir(self.folder):
                if name.endswith(".tskf"):
                    os.remove(os.path.join(self.folder, name))
            if os.path.exists(self.pc2):
                os.remove(self.pc2)
        tmp = f"{key_path}.{os.getpid()}.tmp"
        with open(tmp, "w") as f:
            f.write(key + "\n")
        os.replace(tmp, key_path)

    def assemble(self):
        return cache.assemble_pc2(self.folder, self.pc2, self.range)

    def wire(self, scene):
        obj = cache.find_object(scene, self.pointer, self.name)
        if obj is None:
            raise cache.Gone(self.name)
        cache.wire_mesh_cache(obj, self.rel_pc2, self.range, self.key)


def inputs_key(obj, scene):
    """A digest of everything a tree's baked poses depend on: its definition, smoothing,
    placement and wind response, the scene's wind settings (keyed ones by their
    keyframes), first frame and frame rate (wind time counts from the first frame). A
    cache whose key differs is out of date. Keyframed wind sources are not part of it:
    bake again after changing them."""
    s = obj.tussock_tree
    parts = [json.dumps(build.definition(s), sort_keys=True), s.smooth_levels,
             np.round(np.array(obj.matrix_world, np.float64), 9).tobytes().hex(),
             wind_runtime.keyed_print(obj.animation_data, "tussock_tree.wind_strength",
                                      round(s.wind_strength, 9)),
             scene.frame_start, wind_runtime.fps_of(scene),
             wind_runtime.settings_key(scene)]
    return hashlib.sha256(repr(parts).encode()).hexdigest()


def _is_tree(obj):
    return compat.settings_of(obj, "tussock_tree") is not None and obj.tussock_tree.is_tree


# ---- the job source (see addon/cache.py) -------------------------------------------------

def jobs(scene, root):
    return [TreeJob(o, scene, root) for o in scene.objects if _is_tree(o)]


def cache_key(obj, scene):
    return inputs_key(obj, scene) if _is_tree(obj) else None


def restore(obj, scene):
    pass  # a tree's cache replaces nothing of it


def free(scene, root, freed):
    return 0  # removing the Mesh Cache was all


def status(scene):
    return None  # the panel lists cached objects itself
