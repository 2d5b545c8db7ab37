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
Interactive bakes run in slices on Blender's main thread, with progress in the status bar and
the cursor; Esc cancels. Scripts and background runs bake in one go."""

import hashlib
import json
import os
import re
import shutil
import time

import bpy
import numpy as np

from . import compat, errors, native, progress
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


def run_steps(steps, cancel):
    """Runs a job's steps() generator to its end, or until cancel() says so."""
    try:
        for _ in steps:
            if cancel():
                return
    finally:
        steps.close()


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
        self.pointer = obj.as_pointer()  # the object, should it be renamed meanwhile
        self.points = len(obj.data.vertices)
        self.definition = tree_build.definition(s)
        self.smooth = s.smooth_levels
        self.matrix = np.array(obj.matrix_world, np.float64)
        # the wind response of every frame (it may be keyframed), as the live pose reads it
        self.strength = {f: wind_runtime.keyed_value(obj.animation_data,
                                                     "tussock_tree.wind_strength", f, s,
                                                     "wind_strength")
                         for f in range(scene.frame_start, scene.frame_end + 1)}
        self.folder = os.path.join(root, safe_name(obj.name))
        self.pc2 = os.path.join(root, safe_name(obj.name) + ".pc2")
        self.rel_pc2 = CACHE_DIR + "/" + safe_name(obj.name) + ".pc2"
        self.range = (scene.frame_start, scene.frame_end)
        self.key = inputs_key(obj, scene)
        self.wind_kwargs = wind_runtime.wind_kwargs(scene)
        self.fps = wind_runtime.fps_of(scene)
        # wind sources and keyframed wind settings at every frame of the range, read now
        # (F-curves need bpy)
        self.sources = {f: wind_runtime.sources(scene, f)
                        for f in range(scene.frame_start, scene.frame_end + 1)}
        self.wind_settings = wind_runtime.frame_settings(scene, list(self.sources))

    def frames(self, part):
        lo, hi = part
        return list(range(max(lo, self.range[0]), min(hi, self.range[1]) + 1))

    def outputs(self):
        """Every path this job may write (Free Bake removes them)."""
        return [self.folder, self.pc2]

    def bytes_needed(self, frames):
        """Disk bytes the frames and the assembled cache take at most."""
        return (len(frames) + len(range(self.range[0], self.range[1] + 1))) * \
            (self.points * 12 + 64)

    def steps(self, frames, progress):
        """Bakes `frames` (native and file work only), skipping frames whose files verify
        (resume); progress() once per frame; yields between frames so an interactive bake
        can run in slices on Blender's main thread (closing the generator cancels)."""
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
        yield
        data = tree_build.compute_from(self.definition, self.smooth, rest=False)
        wind = wind_runtime.Stepper(self.wind_kwargs, self.range[0], self.fps,
                                    lambda f: self.sources.get(f, np.zeros((0, 8), np.float32)),
                                    settings_at=self.wind_settings.__getitem__)
        for f in todo:
            yield
            verts = tree_build.posed_vertices(data, self.matrix, self.strength[f],
                                              lambda xyz, f=f: wind.sample(f, xyz))
            lib.bake_write_frame(frame_path(self.folder, f), f,
                                 np.ascontiguousarray(verts, np.float32).ravel())
            progress()

    def bake_frames(self, frames, progress, cancel):
        run_steps(self.steps(frames, progress), cancel)

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
    placement and wind response, the scene's wind settings (keyed ones by their
    keyframes), first frame and frame rate (wind time counts from the first frame). A
    cache whose key differs is out of date. Keyframed wind sources are not part of it:
    bake again after changing them."""
    if obj.get("tussock_simulated_blades"):  # a meadow's simulated blades
        from .meadow import baking
        return baking.blades_inputs_key(obj, scene)
    s = obj.tussock_tree
    parts = [json.dumps(tree_build.definition(s), sort_keys=True), s.smooth_levels,
             np.round(np.array(obj.matrix_world, np.float64), 9).tobytes().hex(),
             wind_runtime.keyed_print(obj.animation_data, "tussock_tree.wind_strength",
                                      round(s.wind_strength, 9)),
             scene.frame_start, wind_runtime.fps_of(scene),
             wind_runtime.settings_key(scene)]
    return hashlib.sha256(repr(parts).encode()).hexdigest()


def jobs_for(scene, prepare=True):
    """The scene's bake jobs. A job may have a prepare() generator of main-thread work per
    frame (a meadow plays the range to read its colliders); with prepare=False the caller
    runs it (in slices, with progress), else it is run here."""
    root = cache_root()
    from .meadow import baking
    jobs = [TreeJob(o, scene, root) for o in scene.objects
            if compat.settings_of(o, "tussock_tree") is not None and o.tussock_tree.is_tree] \
        + picture_bake.jobs_for(scene, root) + baking.jobs(scene, root)
    if prepare:
        for job in jobs:
            for _ in getattr(job, "prepare", tuple)():
                pass
    return jobs


def find_object(scene, pointer, name):
    """The scene's object that a job was read from: by its address, which a rename keeps,
    else by name (an undo step may have reallocated it); None once it was deleted."""
    for obj in scene.objects:
        if obj.as_pointer() == pointer:
            return obj
    return scene.objects.get(name)


def wire(scene, job):
    """Points the object's Mesh Cache modifier at the job's .pc2 (stock Blender)."""
    if hasattr(job, "wire"):  # jobs that wire themselves (pictures; meadows: layout, hiding)
        return job.wire(scene)
    obj = find_object(scene, job.pointer, job.name)
    if obj is None:
        raise Gone(job.name)
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


class Gone(Exception):
    """The object a bake job was read from was deleted while it baked."""


# ---- what a bake wrote: Free Bake removes all of it, even after a failed bake ------------
RECORD = "tussock_written.json"  # in the cache folder: {scene name: [paths relative to it]}


def _read_record(root):
    try:
        with open(os.path.join(root, RECORD)) as f:
            data = json.load(f)
        return data if isinstance(data, dict) else {}
    except (OSError, ValueError):
        return {}


def record_outputs(scene, root, paths):
    """Adds `paths` (under root) to the scene's record before anything is written there."""
    data = _read_record(root)
    have = set(data.get(scene.name, []))
    rel = {os.path.relpath(p, root) for p in paths}
    if rel <= have:
        return
    data[scene.name] = sorted(have | rel)
    tmp = os.path.join(root, f"{RECORD}.{os.getpid()}.tmp")
    with open(tmp, "w") as f:
        json.dump(data, f, sort_keys=True, indent=0)
    os.replace(tmp, os.path.join(root, RECORD))


def forget_outputs(scene, root):
    data = _read_record(root)
    if data.pop(scene.name, None) is None:
        return
    path = os.path.join(root, RECORD)
    if not data:
        os.remove(path)
        return
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w") as f:
        json.dump(data, f, sort_keys=True, indent=0)
    os.replace(tmp, path)


def prune_record(scene, root):
    """After a failed bake: the folders it made but wrote nothing into are removed, and the
    record keeps only the paths that hold something. Best effort: the bake's own failure is
    what the artist must read, not a second one from a read-only or full disk."""
    try:
        data = _read_record(root)
        for p in data.get(scene.name, []):
            path = os.path.join(root, p)
            if os.path.isdir(path) and not os.listdir(path):
                os.rmdir(path)
        kept = [p for p in data.get(scene.name, []) if os.path.exists(os.path.join(root, p))]
        if kept == data.get(scene.name, kept):
            return
        forget_outputs(scene, root)
        if kept:
            record_outputs(scene, root, [os.path.join(root, p) for p in kept])
    except OSError:
        pass


def recorded_outputs(scene, root):
    return [os.path.join(root, p) for p in _read_record(root).get(scene.name, [])
            if p and not os.path.isabs(p) and ".." not in p.split(os.sep)]


# Files Tussock writes into a job's folder; anything else there is the artist's, kept.
_OURS = (".tskf", ".exr", ".tski", "inputs.key")


def remove_outputs(paths):
    """Deletes Tussock's files among `paths` (files, or folders of frames); checks that
    every folder involved is writable first, so that nothing is half-deleted."""
    paths = sorted(set(paths))
    for p in paths:
        if not os.path.exists(p):
            continue
        for folder in ([p] if os.path.isdir(p) else []) + [os.path.dirname(p)]:
            if not os.access(folder, os.W_OK):
                raise OSError(f"cannot delete the cache in {folder}: the folder is read-only")
    for p in paths:
        if os.path.isdir(p):
            for name in os.listdir(p):
                if name.endswith(_OURS) or ".tmp" in name:
                    os.remove(os.path.join(p, name))
            if not os.listdir(p):
                os.rmdir(p)
        elif os.path.exists(p):
            os.remove(p)


def check_free_space(root, jobs, part):
    """Refuses a bake whose files would not fit on the cache's disk (most jobs can say how
    much they write; a picture's compressed frames cannot, so it is left out)."""
    need = sum(j.bytes_needed(j.frames(part)) for j in jobs if hasattr(j, "bytes_needed"))
    free = shutil.disk_usage(root).free
    if need > free:
        raise OSError(f"No space left for the bake: it needs about {need / 2**20:,.0f} MiB in "
                      f"{root}, where {free / 2**20:,.0f} MiB are free; free some space or "
                      "bake fewer frames")


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

    def _part(self, scene):
        return (self.frame_start or scene.frame_start, self.frame_end or scene.frame_end)

    def _prepare(self, context, prepare=True):
        scene = context.scene
        native.require()
        part = self._part(scene)
        if part[0] > part[1]:
            raise ValueError(f"frame_start: {part[0]} is after frame_end {part[1]}")
        if part[1] < scene.frame_start or part[0] > scene.frame_end:
            raise ValueError(f"frames {part[0]}-{part[1]} hold no frame of the scene's range "
                             f"{scene.frame_start}-{scene.frame_end}")
        jobs = jobs_for(scene, prepare)
        if not jobs:
            raise ValueError("nothing to bake: add a Tussock tree or a simulated meadow, or "
                             "animate a picture first")
        os.makedirs(cache_root(), exist_ok=True)
        return jobs, part

    def _before_writing(self, scene, jobs, part):
        root = cache_root()
        check_free_space(root, jobs, part)
        record_outputs(scene, root, [p for j in jobs for p in j.outputs()])

    def _finish(self, context, jobs):
        done, gone = 0, []
        for job in jobs:
            try:
                wire(context.scene, job)
            except Gone:  # deleted while it baked: its frames serve nothing
                gone.append(job.name)
                remove_outputs(job.outputs())
                continue
            done += job.assemble_if_complete()
        if self.save:
            bpy.ops.wm.save_mainfile()
        frames = sum(len(j.frames(self._part(context.scene))) for j in jobs)
        if gone:
            self.report({"WARNING"}, f"Baked {frames} frames; {', '.join(gone)} deleted "
                                     "during the bake: its frames were removed")
        else:
            self.report({"INFO"}, f"Baked {frames} frames of {len(jobs)} objects; "
                                  f"{done} caches complete")
        return {"FINISHED"}

    def execute(self, context):  # scripts, background, farm workers: in this thread
        return errors.run(self, self._execute, context)

    def _execute(self, context):
        jobs, part = self._prepare(context)
        self._before_writing(context.scene, jobs, part)
        try:
            for job in jobs:
                job.bake_frames(job.frames(part), lambda: None, lambda: False)
        except BaseException:
            prune_record(context.scene, cache_root())
            raise
        return self._finish(context, jobs)

    # ---- interactive: in slices on Blender's main thread, with progress; Esc cancels ----
    # Each timer tick runs the bake's steps for about SLICE seconds, then Blender draws and
    # handles events. The steps stay on the main thread: Blender 3.4 crashed (about one run
    # in three, in a window) while a Python worker thread wrote frames, and reading a
    # meadow's colliders plays frames, which only the main thread may do.
    SLICE = 0.05

    def invoke(self, context, event):
        return errors.run(self, self._start, context)

    def _start(self, context):
        scene = context.scene
        jobs, part = self._prepare(context, prepare=False)
        self._jobs = jobs
        self._frames = 0
        self._steps = self._work(context, scene, jobs, part)
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _work(self, context, scene, jobs, part):
        """All of an interactive bake, as steps. The progress bar's first half is reading
        the meadows' frames, the second baking."""
        preparing = [j for j in jobs if hasattr(j, "prepare")]
        total = len(preparing) * (scene.frame_end - scene.frame_start + 1)
        progress.begin(context, "Tussock bake", READING, total)
        done = 0
        for job in preparing:
            for _ in job.prepare():
                done += 1
                progress.STATE["done"] = done
                yield
        self._before_writing(scene, jobs, part)
        total = sum(len(j.frames(part)) for j in jobs)
        progress.STATE.update(phase=BAKING, done=0, total=total)

        def one():
            progress.STATE["done"] += 1
            self._frames += 1
        try:
            for job in jobs:
                yield from job.steps(job.frames(part), one)
        except Exception:
            prune_record(scene, cache_root())
            raise

    def modal(self, context, event):
        if event.type == "ESC" and event.value == "PRESS":
            self._end(context)
            self.report({"INFO"}, f"Bake cancelled after {self._frames} frames "
                                  "(they are kept; bake again to resume)")
            return {"CANCELLED"}
        if event.type != "TIMER":
            # while the meadows' frames are played, the timeline and the scene are the
            # bake's: no edits or frame changes in between
            return {"RUNNING_MODAL"} if progress.STATE["phase"] == READING else \
                {"PASS_THROUGH"}
        t0 = time.perf_counter()
        try:
            while time.perf_counter() - t0 < self.SLICE:
                next(self._steps)
        except StopIteration:
            self._end(context)
            return errors.run(self, self._finish, context, self._jobs)
        except Exception as exc:  # noqa: BLE001 - reported like any operator's failure
            self._end(context)
            return errors.run(self, errors.reraise, exc)
        s = progress.STATE
        share = s["done"] / max(1, s["total"])
        progress.update(context, s["done"], fraction=0.5 * share + (s["phase"] == BAKING) * 0.5)
        return {"RUNNING_MODAL"}

    def cancel(self, context):  # Blender ends the operator (a file is loaded, Blender quits)
        self._end(context)

    def _end(self, context):
        self._steps.close()  # a cancelled reading of frames puts the current frame back
        context.window_manager.event_timer_remove(self._timer)
        if progress.STATE["operator"]:
            progress.end(context)


READING, BAKING = "reading frames", "baking frames"  # the phases, in progress.STATE


class TUSSOCK_OT_free_bake(bpy.types.Operator):
    """Delete Tussock's caches of this scene and go back to live animation"""
    bl_idname = "tussock.free_bake"
    bl_label = "Free Bake"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        return errors.run(self, self._free, context)

    def _free(self, context):
        scene = context.scene
        root = cache_root()
        objs = [o for o in scene.objects if o.modifiers.get(MODIFIER) is not None]
        # every path a bake of this scene recorded (a failed bake's frames too), and each
        # cache's own path (a .blend baked before the record existed, or renamed since)
        paths = recorded_outputs(scene, root)
        stems = [cache_stem(o) for o in objs]
        for o, stem in zip(objs, stems):
            paths += [os.path.join(root, stem + ext) for ext in ("", ".pc2", ".layout.json")]
            paths += [os.path.join(root, safe_name(o.name) + ext) for ext in ("", ".pc2")]
        found = any(os.path.exists(p) for p in paths)
        # files first, the scene after: a cache that cannot be deleted (read-only folder)
        # cancels before any object changes
        remove_outputs(paths)
        forget_outputs(scene, root)
        for obj, stem in zip(objs, stems):
            obj.modifiers.remove(obj.modifiers.get(MODIFIER))
            obj.pop("tussock_baked_range", None)
            if obj.get("tussock_simulated_blades"):
                from .meadow import baking
                baking.free(scene, obj, root, stem)
        removed = len(objs) + picture_bake.free(scene, root)
        self.report({"INFO"}, f"Freed the caches of {removed} objects" if removed or not found
                    else "Freed the files of an unfinished bake")
        return {"FINISHED"}


class TUSSOCK_PT_bake(SubPanel, bpy.types.Panel):
    bl_label = "Bake"
    bl_idname = "TUSSOCK_PT_bake"

    def draw(self, context):
        row = self.layout.row(align=True)
        row.operator("tussock.bake", icon="FILE_CACHE")
        row.operator("tussock.free_bake", icon="TRASH")
        self.layout.operator("tussock.farm_submit", icon="NETWORK_DRIVE")
        for obj in context.scene.objects:
            if obj.modifiers.get(MODIFIER) is not None:
                rng = cached_range(obj, context.scene)
                # the object's name and its state side by side: one line of "name: frames
                # a–b" is cut at the sidebar's default width
                split = self.layout.split(factor=0.5)
                split.label(text=obj.name, icon="CHECKMARK" if rng else "ERROR")
                split.label(text=f"frames {rng[0]}–{rng[1]}" if rng else "out of date")
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
