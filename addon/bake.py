"""Farm-safe caches (tussock.bake, tussock.free_bake): the operators and the Bake panel.

Trees (trees/baking.py) and simulated meadows (meadow/baking.py) are baked into Point Cache
2 files that Blender's own Mesh Cache modifier reads, so a .blend renders the same frames
where Tussock is not installed. Every frame is first written as its own verified file
(`//tussock_cache/<object>/frame_NNNNNN.tskf`, atomic), then the frames of the scene's range
are assembled into `//tussock_cache/<object>.pc2` (atomic) once all exist. So:
  - a killed bake keeps every completed frame and the next bake resumes after them;
  - farm workers may bake disjoint parts (frame_start/frame_end) of the range in separate
    processes; whichever finishes the last frame assembles the same bytes as one process;
  - a cache from another Tussock version, a corrupt or missing frame is reported, never
    used.
Animated pictures (picture/baking.py) are baked into OpenEXR image sequences that the
compositor's stock Image nodes read. Each feature is a job source with the same interface
(addon/cache.py); the operators go through SOURCES.
Interactive bakes run in slices on Blender's main thread, with progress in the status bar and
the cursor; Esc cancels. Scripts and background runs bake in one go."""

import json
import os
import shutil
import time

import bpy

from . import cache, errors, handlers, native, progress
from .meadow import baking as meadow_baking
from .picture import baking as picture_baking
from .trees import baking as tree_baking
from .ui import SubPanel
from .wind import runtime as wind_runtime

SOURCES = (tree_baking, meadow_baking, picture_baking)  # job sources (see addon/cache.py)


def jobs_for(scene):
    """The scene's bake jobs, of every source, not yet prepared (the caller runs each
    job's prepare(): at once, or in slices with progress)."""
    root = cache.cache_root()
    return [job for source in SOURCES for job in source.jobs(scene, root)]


def cache_key(obj, scene):
    """The inputs key obj's Mesh Cache must carry to be up to date, from the source that
    bakes obj; None when no source does (its cache counts as out of date)."""
    for source in SOURCES:
        key = source.cache_key(obj, scene)
        if key is not None:
            return key
    return None


def cached_range(obj, scene):
    """(start, end) of a complete, up-to-date bake of obj, or None (see cache.cached_range)."""
    return cache.cached_range(obj, scene, cache_key)


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
    """After a bake ended (failed, cancelled or finished): the folders it made but wrote
    nothing into are removed, and the record keeps only the paths that hold something. A
    bake removes files of earlier ones too (a tree's stale frames and .pc2 when its inputs
    changed, a job whose object was deleted meanwhile), so the record is made true again
    each time, whoever removed them. Best effort: a failed bake's own error is what the
    artist must read, not a second one from a read-only or full disk."""
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
    much they write; a picture's compressed frames cannot, so they count as nothing)."""
    need = sum(j.bytes_needed(j.frames(part)) for j in jobs)
    free = shutil.disk_usage(root).free
    if need > free:
        raise OSError(f"No space left for the bake: it needs about {need / 2**20:,.0f} MiB in "
                      f"{root}, where {free / 2**20:,.0f} MiB are free; free some space or "
                      "bake fewer frames")


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
        jobs = jobs_for(scene)
        if not jobs:
            raise ValueError("nothing to bake: add a Tussock tree or a simulated meadow, or "
                             "animate a picture first")
        # every job steps the wind, and meadows play the range's frames before their wind
        # is made: wind settings it cannot step must cancel the bake before that (soak seed
        # 889006: an unstable continuum)
        wind_runtime.check_settings(scene)
        if prepare:
            for job in jobs:
                for _ in job.prepare():
                    pass
        os.makedirs(cache.cache_root(), exist_ok=True)
        return jobs, part

    def _before_writing(self, scene, jobs, part):
        root = cache.cache_root()
        check_free_space(root, jobs, part)
        record_outputs(scene, root, [p for j in jobs for p in j.outputs()])

    def _finish(self, context, jobs):
        done, gone = 0, []
        for job in jobs:
            try:
                job.wire(context.scene)
            except cache.Gone:  # deleted while it baked: its frames serve nothing
                gone.append(job.name)
                remove_outputs(job.outputs())
                continue
            done += job.assemble()
        prune_record(context.scene, cache.cache_root())
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
            prune_record(context.scene, cache.cache_root())
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
        total = sum(j.frames_to_read() for j in jobs)
        progress.begin(context, "Tussock bake", READING, total)
        done = 0
        for job in jobs:
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
            prune_record(scene, cache.cache_root())
            raise

    def modal(self, context, event):
        if event.type == "ESC" and event.value == "PRESS":
            self._end(context)
            prune_record(context.scene, cache.cache_root())
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
        root = cache.cache_root()
        objs = [o for o in scene.objects if o.modifiers.get(cache.MODIFIER) is not None]
        # every path a bake of this scene recorded (a failed bake's frames too), and each
        # cache's own path (a .blend baked before the record existed, or renamed since)
        paths = recorded_outputs(scene, root)
        stems = [cache.cache_stem(o) for o in objs]
        for o, stem in zip(objs, stems):
            paths += [os.path.join(root, stem + ext) for ext in ("", ".pc2", ".layout.json")]
            paths += [os.path.join(root, cache.safe_name(o.name) + ext) for ext in ("", ".pc2")]
        found = any(os.path.exists(p) for p in paths)
        # files first, the scene after: a cache that cannot be deleted (read-only folder)
        # cancels before any object changes
        remove_outputs(paths)
        forget_outputs(scene, root)
        for obj in objs:
            obj.modifiers.remove(obj.modifiers.get(cache.MODIFIER))
            obj.pop("tussock_baked_range", None)
        removed = len(objs) + sum(source.free(scene, root, list(zip(objs, stems)))
                                  for source in SOURCES)
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
            if obj.modifiers.get(cache.MODIFIER) is not None:
                rng = cached_range(obj, context.scene)
                # the object's name and its state side by side: one line of "name: frames
                # a–b" is cut at the sidebar's default width
                split = self.layout.split(factor=0.5)
                split.label(text=obj.name, icon="CHECKMARK" if rng else "ERROR")
                split.label(text=f"frames {rng[0]}–{rng[1]}" if rng else "out of date")
        for source in SOURCES:
            line = source.status(context.scene)
            if line is not None:
                self.layout.label(text=line[0], icon="CHECKMARK" if line[1] else "ERROR")


@bpy.app.handlers.persistent
def _before_save(*_args):
    """A farm renders the saved file at any frame, maybe without Tussock: every complete,
    up-to-date cache is saved switched on (the frame handler switches one off only while
    a frame outside it is shown), with a meadow's baked layout put back."""
    if not native.available():
        return
    for scene in bpy.data.scenes:
        for obj in scene.objects:  # one check per object with a cache
            mod = obj.modifiers.get(cache.MODIFIER)
            if mod is None or cached_range(obj, scene) is None:
                continue
            for source in SOURCES:
                source.restore(obj, scene)
            mod.show_render = mod.show_viewport = True


classes = (TUSSOCK_OT_bake, TUSSOCK_OT_free_bake, TUSSOCK_PT_bake)


def register_extra():
    handlers.add("save_pre", _before_save)
