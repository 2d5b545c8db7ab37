"""Farm-safe caches (tussock.bake, tussock.free_bake).

Trees and simulated meadows (addon/meadow/baking.py) are baked into Point Cache 2 files
that Blender's own Mesh Cache modifier reads, so a .blend renders the same frames where
Tussock is not installed. Every frame is first written
as its own verified file (`//tussock_cache/<object>/frame_NNNNNN.tskf`, atomic), then the
frames of the scene's range are assembled into `//tussock_cache/<object>.pc2` (atomic)
once all exist. So:
  - a killed bake keeps every completed frame and the next bake resumes after them;
  - farm workers may bake disjoint parts (frame_start/frame_end) of the range in separate
    processes; whichever finishes the last frame assembles the same bytes as one process;
  - a cache from another Tussock version, a corrupt or missing frame is reported, never
    used.
Animated pictures are baked by picture/bake.py (PictureJob, the same interface as
TreeJob): OpenEXR image sequences that the compositor's stock Image nodes read.
Interactive bakes run off Blender's main thread: everything the worker needs is read from
Blender first; the worker does native work only and a modal timer shows progress (Esc
cancels). Scripts and background runs bake in the calling thread."""

import hashlib
import json
import os
import re
import threading

import bpy
import numpy as np

from . import compat, errors, native
from .picture import bake as picture_bake
from .trees import build as tree_build
from .wind import runtime as wind_runtime
from .ui import SubPanel

CACHE_DIR = "//tussock_cache"
CACHE_DIR_OVERRIDE = None  # an absolute folder instead of CACHE_DIR (tests of full disks)
MODIFIER = "Tussock Cache"


def cache_root():
    if not bpy.data.filepath:
        raise ValueError("save the .blend first: caches live beside it (//tussock_cache)")
    return CACHE_DIR_OVERRIDE or bpy.path.abspath(CACHE_DIR)


def safe_name(name):
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)


def cache_stem(obj):
    """The name an object's cache files were written under: its Mesh Cache file's (the
    object may have been renamed since, e.g. a meadow's blades with their meadow), else its
    name made safe."""
    mod = obj.modifiers.get(MODIFIER)
    base = os.path.basename(mod.filepath) if mod is not None else ""
    return base[:-len(".pc2")] if base.endswith(".pc2") else safe_name(obj.name)


def frame_path(folder, frame):
    return os.path.join(folder, f"frame_{frame:06d}.tskf")


class TreeJob:
    """Everything needed to bake one tree, read from Blender on the main thread."""

    def __init__(self, obj, scene, root):
        if not tree_build.owns_mesh(obj):
            raise ValueError(f"{obj.name}: {tree_build.NOT_OWNED}")
        s = obj.tussock_tree
        self.name = obj.name
        self.definition = tree_build.definition(s)
        self.smooth = s.smooth_levels
        self.matrix = np.array(obj.matrix_world, np.float64)
        self.strength = s.wind_strength
        self.folder = os.path.join(root, safe_name(obj.name))
        self.pc2 = os.path.join(root, safe_name(obj.name) + ".pc2")
        self.rel_pc2 = CACHE_DIR + "/" + safe_name(obj.name) + ".pc2"
        self.range = (scene.frame_start, scene.frame_end)
        self.key = inputs_key(obj, scene)
        self.wind_kwargs = wind_runtime.wind_kwargs(scene)
        self.fps = wind_runtime.fps_of(scene)
        # wind sources at every frame of the range, read now (F-curves need bpy)
        self.sources = {f: wind_runtime.sources(scene, f)
                        for f in range(scene.frame_start, scene.frame_end + 1)}

    def frames(self, part):
        lo, hi = part
        return list(range(max(lo, self.range[0]), min(hi, self.range[1]) + 1))

    def bake_frames(self, frames, progress, cancel):
        """Worker part: native only. Skips frames whose files verify (resume)."""
        lib = native.require()
        os.makedirs(self.folder, exist_ok=True)
        # temporary files of a killed bake, of this part's frames only: another worker of a
        # split bake may be writing its own frames in the same folder right now
        mine = {os.path.basename(frame_path(self.folder, f)) for f in frames}
        for name in os.listdir(self.folder):
            if ".tmp" in name and name.split(".tmp")[0] in mine:
                os.remove(os.path.join(self.folder, name))
        self._claim_folder()
        todo = []
        for f in frames:
            try:
                got, _ = lib.bake_frame_info(frame_path(self.folder, f))
                if got == f:
                    progress()
                    continue
            except lib.Error as exc:
                if "another Tussock" in str(exc):
                    raise
            todo.append(f)
        if not todo:
            return
        data = tree_build.compute_from(self.definition, self.smooth, rest=False)
        wind = wind_runtime.Stepper(self.wind_kwargs, self.range[0], self.fps,
                                    lambda f: self.sources.get(f, np.zeros((0, 8), np.float32)))
        for f in todo:
            if cancel():
                return
            verts = tree_build.posed_vertices(data, self.matrix, self.strength,
                                              lambda xyz, f=f: wind.sample(f, xyz))
            lib.bake_write_frame(frame_path(self.folder, f), f,
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

    def assemble_if_complete(self):
        """Assembles the .pc2 when every frame of the range exists; True if it did."""
        lib = native.require()
        paths = [frame_path(self.folder, f) for f in range(self.range[0], self.range[1] + 1)]
        if not all(os.path.exists(p) for p in paths):
            return False
        lib.bake_assemble_pc2(self.pc2, paths, float(self.range[0]), 1.0)
        return True


def inputs_key(obj, scene):
    """A digest of everything a tree's baked poses depend on: its definition, smoothing,
    placement and wind response, the scene's wind settings, first frame and frame rate
    (wind time counts from the first frame). A cache whose key differs is out of date.
    Keyframed wind sources are not part of it: bake again after changing them."""
    if obj.get("tussock_simulated_blades"):  # a meadow's simulated blades
        from .meadow import baking
        return baking.blades_inputs_key(obj, scene)
    s = obj.tussock_tree
    kw = wind_runtime.wind_kwargs(scene)
    parts = [json.dumps(tree_build.definition(s), sort_keys=True), s.smooth_levels,
             np.round(np.array(obj.matrix_world, np.float64), 9).tobytes().hex(),
             round(s.wind_strength, 9), scene.frame_start, wind_runtime.fps_of(scene),
             sorted((k, v.tobytes().hex() if isinstance(v, np.ndarray) else v)
                    for k, v in kw.items())]
    return hashlib.sha256(repr(parts).encode()).hexdigest()


def jobs_for(scene):
    root = cache_root()
    from .meadow import baking
    return [TreeJob(o, scene, root) for o in scene.objects
            if compat.settings_of(o, "tussock_tree") is not None and o.tussock_tree.is_tree] \
        + picture_bake.jobs_for(scene, root) + baking.jobs(scene, root)


def wire(scene, job):
    """Points the object's Mesh Cache modifier at the job's .pc2 (stock Blender)."""
    if hasattr(job, "wire"):  # jobs that wire themselves (pictures; meadows: layout, hiding)
        return job.wire(scene)
    obj = scene.objects[job.name]
    mod = obj.modifiers.get(MODIFIER)
    if mod is None:
        mod = obj.modifiers.new(MODIFIER, "MESH_CACHE")
    mod.cache_format = "PC2"
    mod.filepath = job.rel_pc2
    mod.deform_mode = "OVERWRITE"
    mod.time_mode = "FRAME"
    mod.play_mode = "SCENE"
    mod.frame_start = float(job.range[0])
    mod.frame_scale = 1.0
    obj["tussock_baked_range"] = job.range
    obj["tussock_bake_key"] = job.key


def cached_range(obj, scene):
    """(start, end) of a bake of obj that is complete and made from the inputs obj and
    scene have now, or None (missing, incomplete, or out of date)."""
    mod = obj.modifiers.get(MODIFIER)
    rng = obj.get("tussock_baked_range")
    if mod is None or rng is None or not native.available():
        return None
    if obj.get("tussock_bake_key") != inputs_key(obj, scene):
        return None
    try:
        info = native.lib.pc2_info(bpy.path.abspath(mod.filepath))
    except native.Error:
        return None
    start, end = int(rng[0]), int(rng[1])
    if info["samples"] != end - start + 1 or int(info["start_frame"]) != start:
        return None
    if obj.get("tussock_baked_points", info["points"]) != info["points"]:
        return None
    return start, end


def baked_frame(obj, scene, frame):
    """True when obj's cache holds `frame` (its pose comes from the cache). When the cache
    is out of date or the frame lies outside it, the cache is switched off so that it
    cannot show a wrong frame, and the live tree is used instead."""
    mod = obj.modifiers.get(MODIFIER)
    if mod is None:
        return False
    rng = cached_range(obj, scene)
    ok = rng is not None and rng[0] <= frame <= rng[1]
    if mod.show_render != ok or mod.show_viewport != ok:
        mod.show_render = mod.show_viewport = ok
        if not ok:
            print(f"Tussock: the bake of {obj.name} does not hold frame {frame} (cache "
                  "missing, frame range or settings changed): using the live animation; bake again")
    return ok


class TUSSOCK_OT_bake(bpy.types.Operator):
    """Bake trees, simulated meadows and animated pictures into caches that Blender reads
    without Tussock"""
    bl_idname = "tussock.bake"
    bl_label = "Bake"
    bl_options = {"REGISTER"}

    frame_start: bpy.props.IntProperty(name="From", default=0,
                                       description="First frame of this part (0: the scene's)")
    frame_end: bpy.props.IntProperty(name="To", default=0,
                                     description="Last frame of this part (0: the scene's)")
    save: bpy.props.BoolProperty(name="Save", default=False,
                                 description="Save the .blend after baking (farm workers)")

    _thread = None

    def _part(self, scene):
        return (self.frame_start or scene.frame_start, self.frame_end or scene.frame_end)

    def _prepare(self, context):
        scene = context.scene
        native.require()
        jobs = jobs_for(scene)
        if not jobs:
            raise ValueError("nothing to bake: add a Tussock tree or a simulated meadow, or "
                             "animate a picture first")
        part = self._part(scene)
        if part[0] > part[1]:
            raise ValueError(f"frame_start: {part[0]} is after frame_end {part[1]}")
        if part[1] < scene.frame_start or part[0] > scene.frame_end:
            raise ValueError(f"frames {part[0]}-{part[1]} hold no frame of the scene's range "
                             f"{scene.frame_start}-{scene.frame_end}")
        os.makedirs(cache_root(), exist_ok=True)
        return jobs, part

    def _finish(self, context, jobs):
        done = 0
        for job in jobs:
            wire(context.scene, job)
            done += job.assemble_if_complete()
        if self.save:
            bpy.ops.wm.save_mainfile()
        frames = sum(len(j.frames(self._part(context.scene))) for j in jobs)
        self.report({"INFO"}, f"Baked {frames} frames of {len(jobs)} objects; "
                              f"{done} caches complete")
        return {"FINISHED"}

    def execute(self, context):  # scripts, background, farm workers: in this thread
        return errors.run(self, self._execute, context)

    def _execute(self, context):
        jobs, part = self._prepare(context)
        for job in jobs:
            job.bake_frames(job.frames(part), lambda: None, lambda: False)
        return self._finish(context, jobs)

    def invoke(self, context, event):  # interactive: a worker thread and a modal timer
        return errors.run(self, self._start, context)

    def _start(self, context):
        jobs, part = self._prepare(context)
        self._jobs = jobs
        self._total = sum(len(j.frames(part)) for j in jobs)
        self._state = {"done": 0, "error": None, "cancel": False, "finished": False}
        state = self._state

        def work():
            try:
                for job in jobs:
                    job.bake_frames(job.frames(part),
                                    lambda: state.__setitem__("done", state["done"] + 1),
                                    lambda: state["cancel"])
            except Exception as exc:  # reported by the modal timer on the main thread
                state["error"] = str(exc)
            state["finished"] = True

        self._thread = threading.Thread(target=work, name="tussock-bake", daemon=True)
        self._thread.start()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, max(1, self._total))
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC":
            self._state["cancel"] = True
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        context.window_manager.progress_update(self._state["done"])
        if not self._state["finished"]:
            return {"RUNNING_MODAL"}
        self._thread.join()
        context.window_manager.event_timer_remove(self._timer)
        context.window_manager.progress_end()
        if self._state["error"]:
            self.report({"ERROR"}, f"Tussock: {self._state['error']}")
            return {"CANCELLED"}
        if self._state["cancel"]:
            self.report({"INFO"}, f"Bake cancelled after {self._state['done']} frames "
                                  "(they are kept; bake again to resume)")
            return {"CANCELLED"}
        return errors.run(self, self._finish, context, self._jobs)


class TUSSOCK_OT_free_bake(bpy.types.Operator):
    """Delete Tussock's caches of this scene and go back to live animation"""
    bl_idname = "tussock.free_bake"
    bl_label = "Free Bake"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        return errors.run(self, self._free, context)

    def _free(self, context):
        root = cache_root()
        objs = [o for o in context.scene.objects if o.modifiers.get(MODIFIER) is not None]
        # Files first, the scene after: a cache that cannot be deleted (read-only folder)
        # cancels before any object changes. Folders are checked before anything is deleted.
        stems = [cache_stem(o) for o in objs]
        paths = [(os.path.join(root, stem), os.path.join(root, stem + ".pc2")) for stem in stems]
        for folder, pc2 in paths:
            for d in ([folder] if os.path.isdir(folder) else []) + \
                     ([root] if os.path.exists(pc2) or os.path.isdir(folder) else []):
                if not os.access(d, os.W_OK):
                    raise OSError(f"cannot delete the cache in {d}: the folder is read-only")
        for folder, pc2 in paths:
            if os.path.isdir(folder):
                for f in os.listdir(folder):
                    if f.endswith(".tskf") or ".tmp" in f or f == "inputs.key":
                        os.remove(os.path.join(folder, f))
                if not os.listdir(folder):
                    os.rmdir(folder)
            if os.path.exists(pc2):
                os.remove(pc2)
        for obj, stem in zip(objs, stems):
            obj.modifiers.remove(obj.modifiers.get(MODIFIER))
            obj.pop("tussock_baked_range", None)
            if obj.get("tussock_simulated_blades"):
                from .meadow import baking
                baking.free(context.scene, obj, root, stem)
        removed = len(objs) + picture_bake.free(context.scene, root)
        self.report({"INFO"}, f"Freed the caches of {removed} objects")
        return {"FINISHED"}


class TUSSOCK_PT_bake(SubPanel, bpy.types.Panel):
    bl_label = "Bake"
    bl_idname = "TUSSOCK_PT_bake"

    def draw(self, context):
        row = self.layout.row(align=True)
        row.operator("tussock.bake", icon="FILE_CACHE")
        row.operator("tussock.free_bake", icon="TRASH")
        for obj in context.scene.objects:
            if obj.modifiers.get(MODIFIER) is not None:
                rng = cached_range(obj, context.scene)
                self.layout.label(text=f"{obj.name}: " + (f"frames {rng[0]}–{rng[1]}" if rng
                                                         else "cache missing or out of date"),
                                  icon="CHECKMARK" if rng else "ERROR")
        picture = picture_bake.status(context.scene)
        if picture is not None:
            self.layout.label(text=picture[0], icon="CHECKMARK" if picture[1] else "ERROR")


@bpy.app.handlers.persistent
def _before_save(*_args):
    """A farm renders the saved file at any frame, maybe without Tussock: every complete,
    up-to-date cache is saved switched on (the frame handler switches one off only while
    a frame outside it is shown), with a meadow's baked layout put back."""
    if not native.available():
        return
    for scene in bpy.data.scenes:
        for obj in scene.objects:  # one check per object with a cache
            mod = obj.modifiers.get(MODIFIER)
            if mod is None or cached_range(obj, scene) is None:
                continue
            if obj.get("tussock_simulated_blades"):
                from .meadow import baking
                baking.restore_layout(obj, scene)
            mod.show_render = mod.show_viewport = True


classes = (TUSSOCK_OT_bake, TUSSOCK_OT_free_bake, TUSSOCK_PT_bake)


def register_extra():
    from . import handlers
    handlers.add("save_pre", _before_save)
