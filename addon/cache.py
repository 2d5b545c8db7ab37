"""The bake layer's common ground: where caches live, how a frame file and a Point Cache 2 file
are named and checked, and the protocol that every feature's bake follows. It imports no
feature: trees/baking.py, meadow/baking.py and picture/baking.py import it, and the
operators in bake.py import them.

A *job source* is a feature's baking module. It has:
    jobs(scene, root) -> [Job]       the scene's bakes of this feature, read on the main thread;
                                     root is cache_root()
    cache_key(obj, scene) -> str|None  the inputs key an up-to-date Mesh Cache of `obj` must
                                     carry, if `obj` is one this feature bakes into a .pc2
    restore(obj, scene)              before a save, for an object whose cache is up to date:
                                     puts back what live frames replaced (a meadow's layout)
    free(scene, root, freed) -> int  after Free Bake removed the Mesh Cache modifiers of
                                     `freed` [(object, file stem)]: the feature's own files
                                     and state; the number of further caches freed
    status(scene) -> (text, ok)|None   a line for the Bake panel beyond the cached objects

A *job* (the Job class below) is one cache: made on the main thread with everything it needs,
then `prepare()` (main thread, in steps: e.g. a meadow plays the range to read its colliders),
`steps(frames, progress)` (native and file work only, resumable, in slices), `assemble()` (the
.pc2 once every frame exists) and `wire(scene)` (main thread: point Blender at the files;
cache.Gone when its object was deleted meanwhile). `key` is the inputs digest recorded with
the cache, so that an out-of-date cache is never shown."""

import os
import re

import bpy

from . import native

CACHE_DIR = "//tussock_cache"
CACHE_DIR_OVERRIDE = None  # an absolute folder instead of CACHE_DIR (tests of full disks)
MODIFIER = "Tussock Cache"


def cache_root():
    if not bpy.data.filepath:
        raise ValueError("save the .blend first: caches live beside it (//tussock_cache)")
    return CACHE_DIR_OVERRIDE or bpy.path.abspath(CACHE_DIR)


def safe_name(name):
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)


def frame_path(folder, frame):
    return os.path.join(folder, f"frame_{frame:06d}.tskf")


def cache_stem(obj):
    """The name an object's cache files were written under: its Mesh Cache file's (the
    object may have been renamed since, e.g. a meadow's blades with their meadow), else its
    name made safe."""
    mod = obj.modifiers.get(MODIFIER)
    base = os.path.basename(mod.filepath) if mod is not None else ""
    return base[:-len(".pc2")] if base.endswith(".pc2") else safe_name(obj.name)


def run_steps(steps, cancel):
    """Runs a job's steps() generator to its end, or until cancel() says so."""
    try:
        for _ in steps:
            if cancel():
                return
    finally:
        steps.close()


class Gone(Exception):
    """The object a bake job was read from was deleted while it baked."""


def find_object(scene, pointer, name):
    """The scene's object that a job was read from: by its address, which a rename keeps,
    else by name (an undo step may have reallocated it); None once it was deleted."""
    for obj in scene.objects:
        if obj.as_pointer() == pointer:
            return obj
    return scene.objects.get(name)


# ---- frame files and the .pc2 ---------------------------------------------------------------

def clear_temporary(folder, frames):
    """Makes `folder` and removes the temporary files of a killed bake of `frames` only:
    another worker of a split bake may be writing its own frames there right now."""
    os.makedirs(folder, exist_ok=True)
    mine = {os.path.basename(frame_path(folder, f)) for f in frames}
    for name in os.listdir(folder):
        if ".tmp" in name and name.split(".tmp")[0] in mine:
            os.remove(os.path.join(folder, name))


def frame_done(lib, folder, frame, points=None):
    """True when the frame file of `frame` verifies (and holds `points` points, if given): a
    resumed bake keeps it. A file of another Tussock version raises (Free Bake first)."""
    try:
        got, count = lib.bake_frame_info(frame_path(folder, frame))
    except lib.Error as exc:
        if "another Tussock" in str(exc):
            raise
        return False
    return got == frame and (points is None or count == points)


def assemble_pc2(folder, pc2, frame_range):
    """Assembles the .pc2 when every frame file of the range exists; True if it did."""
    lib = native.require()
    paths = [frame_path(folder, f) for f in range(frame_range[0], frame_range[1] + 1)]
    if not all(os.path.exists(p) for p in paths):
        return False
    lib.bake_assemble_pc2(pc2, paths, float(frame_range[0]), 1.0)
    return True


def wire_mesh_cache(obj, rel_pc2, frame_range, key):
    """Points obj's Mesh Cache modifier (stock Blender; made if missing) at a .pc2 and
    records the baked range and inputs key (cached_range checks them)."""
    mod = obj.modifiers.get(MODIFIER)
    if mod is None:
        mod = obj.modifiers.new(MODIFIER, "MESH_CACHE")
    mod.cache_format = "PC2"
    mod.filepath = rel_pc2
    mod.deform_mode = "OVERWRITE"
    mod.time_mode = "FRAME"
    mod.play_mode = "SCENE"
    mod.frame_start = float(frame_range[0])
    mod.frame_scale = 1.0
    obj["tussock_baked_range"] = frame_range
    obj["tussock_bake_key"] = key
    return mod


def cached_range(obj, scene, key_of):
    """(start, end) of a bake of obj that is complete and made from the inputs it has now,
    or None (missing, incomplete, or out of date). key_of(obj, scene): the inputs key now
    (the object's source's cache_key), computed only for an object with a cache."""
    mod = obj.modifiers.get(MODIFIER)
    rng = obj.get("tussock_baked_range")
    if mod is None or rng is None or not native.available():
        return None
    if obj.get("tussock_bake_key") != key_of(obj, scene):
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


def baked_frame(obj, scene, frame, key_of):
    """True when obj's cache holds `frame` (its pose comes from the cache); key_of as for
    cached_range. When the cache is out of date or the frame lies outside it, the cache is
    switched off so that it cannot show a wrong frame, and the live animation is used
    instead."""
    mod = obj.modifiers.get(MODIFIER)
    if mod is None:
        return False
    rng = cached_range(obj, scene, key_of)
    ok = rng is not None and rng[0] <= frame <= rng[1]
    if mod.show_render != ok or mod.show_viewport != ok:
        mod.show_render = mod.show_viewport = ok
        if not ok:
            print(f"Tussock: the bake of {obj.name} does not hold frame {frame} (cache "
                  "missing, frame range or settings changed): using the live animation; bake again")
    return ok


class Job:
    """One cache (see the module's docstring). Subclasses set name, range (first, last
    frame of the scene) and key, and implement outputs, steps, assemble and wire."""

    name = ""
    range = (0, -1)
    key = None

    def frames_to_read(self):
        """How many steps prepare() takes (the progress bar's first half)."""
        return 0

    def prepare(self):
        """Main-thread work before anything is written, one yield per step."""
        yield from ()

    def frames(self, part):
        """The frames of `part` (first, last) that this job bakes."""
        lo, hi = part
        return list(range(max(lo, self.range[0]), min(hi, self.range[1]) + 1))

    def outputs(self):
        """Every path this job may write (Free Bake removes them)."""
        raise NotImplementedError

    def bytes_needed(self, frames):
        """Disk bytes the frames (and what is assembled from them) take at most; 0 when the
        job cannot say (compressed images)."""
        return 0

    def steps(self, frames, progress):
        """Bakes `frames` (native and file work only), keeping frames whose files verify
        (resume); progress() once per frame; yields between frames so an interactive bake
        runs in slices on Blender's main thread (closing the generator cancels)."""
        raise NotImplementedError

    def bake_frames(self, frames, progress, cancel):
        run_steps(self.steps(frames, progress), cancel)

    def assemble(self):
        """Puts the frames together once all exist; True when the cache is complete."""
        raise NotImplementedError

    def wire(self, scene):
        """Main thread, after baking: points Blender at the files; Gone if the job's object
        was deleted meanwhile."""
        raise NotImplementedError
