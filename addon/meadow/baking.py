"""Bakes of simulated meadows for farms (a job source of tussock.bake, see addon/cache.py
and docs/farm.md).

A Point Cache 2 file needs the same points in every frame, but tiles wake up and go back to
sleep while a simulation plays. So the baked mesh `<meadow> blades` holds the blades of
every tile that the colliders touch anywhere in the scene's frame range (in ascending tile
order, each tile's blades as the meadow instances them); in a frame where such a tile is not
simulated, its blades stand in their rest pose, exactly where its instances would be. The
instances of all those tiles are hidden (the meadow's `tsk_hidden` attribute) for the whole
range. What Blender shows without Tussock — the meadow's instances plus the baked ribbons
played by a stock Mesh Cache modifier — is then what Tussock shows with the bake.

Which tiles a range touches depends only on the colliders, so every farm worker computes the
same layout from the collider positions of the whole range (read on the main thread by
playing the frames, as rigid bodies need) without simulating; each worker then simulates
from the first frame to the end of its part and writes its frames. A small manifest beside
the cache (`<name>.layout.json`) records the range and a digest of the layout, settings and
collider paths, so frames of another layout are never mixed in."""

import hashlib
import json
import os

import numpy as np

from .. import cache, compat, native
from ..wind import runtime as wind_runtime
from . import baked, blade_objects, build, identity, playback, simulate, solver

MANIFEST_VERSION = 1


def read_colliders(scene, coll, frames):
    """Collider rows of every frame in `frames`, read by playing them in order (rigid bodies
    move only so) with the live simulation paused; the current frame is restored."""
    rows = {}
    for _ in read_colliders_steps(scene, coll, frames, rows):
        pass
    return rows


def read_colliders_steps(scene, coll, frames, rows):
    """read_colliders in steps: fills `rows`, yields after each frame. Closing the
    generator early (Esc) restores the current frame all the same."""
    current = scene.frame_current
    playback.suspended = True
    try:
        for f in frames:  # one frame_set per frame of the range
            scene.frame_set(f)
            rows[f] = playback.colliders(scene, coll)
            yield
    finally:
        playback.suspended = False
        scene.frame_set(current)


def touched_tiles(definition, rows_per_frame, fps):
    """Sorted int32 indices of every tile that the colliders of frames 2.. of
    `rows_per_frame` (consecutive frames) touch on their way from the frame before, swept as
    the solver's steps sweep them (solver.substep_rows): exactly the tiles the simulation
    wakes up over those frames."""
    lib = native.require()
    sim = lib.blade_sim_create(**definition)
    steps = solver.steps_per_frame(fps)
    touched = set()
    swept = (sub for before, rows in zip(rows_per_frame, rows_per_frame[1:])
             for sub in solver.substep_rows(before, rows, steps))
    for rows in swept:  # one native call per solver step
        lib.blade_sim_set_colliders(sim, np.ascontiguousarray(rows, np.float32).ravel())
        n = lib.blade_sim_pending(sim)
        if n:
            pending = np.empty(n, np.int32)
            lib.blade_sim_pending(sim, pending)
            touched.update(pending.tolist())
    return np.array(sorted(touched), np.int32)


def _atomic_json(path, data):
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        json.dump(data, f, sort_keys=True)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


class MeadowJob(cache.Job):
    """Everything needed to bake one simulated meadow, read from Blender on the main
    thread: settings, native patch and layout, the colliders and wind sources of every
    frame of the scene's range, and the baked layout."""

    def __init__(self, obj, scene, root):
        lib = native.require()
        s = obj.tussock_meadow
        playback.check_animation(obj)
        self.meadow_key = identity.key(obj)  # (the meadow may be renamed while it bakes)
        self.meadow_name = obj.name
        self.name = identity.chunk_name(obj, 0)
        safe = cache.safe_name(self.name)
        self.folder = os.path.join(root, safe)
        self.pc2 = os.path.join(root, safe + ".pc2")
        self.rel_pc2 = cache.CACHE_DIR + "/" + safe + ".pc2"
        self.manifest = os.path.join(root, safe + ".layout.json")
        self.range = (scene.frame_start, scene.frame_end)
        self.key = baked.inputs_key(obj, scene)
        self.wind_kwargs = wind_runtime.wind_kwargs(scene)
        self.fps = wind_runtime.fps_of(scene)
        frames = range(self.range[0], self.range[1] + 1)
        self.sources = {f: wind_runtime.sources(scene, f) for f in frames}
        self.wind_settings = wind_runtime.frame_settings(scene, frames)
        origin, size = build.area_of(obj, s)
        patch = build.make_patch(s)
        meadow = build.make_meadow(s, origin, size)
        info = lib.meadow_info(meadow)
        self.K = lib.patch_info(patch)["knot_count"]
        definition = solver.sim_definition(s, info, self.K, self.fps)
        blade_rand = np.empty(lib.patch_info(patch)["blade_count"], np.float32)
        lib.rand_fill(s.seed, build.BLADE_RAND_STREAM, blade_rand)
        self.instance_tile = np.empty(info["chunk_instances"], np.int32)
        lib.meadow_chunk_instances(meadow, None, None, self.instance_tile)
        self.runner_args = (patch, meadow, definition, blade_rand)
        self.digest = None
        self._check_manifest()  # the range at once, before the frames are played
        self._scene, self._coll = scene, s.colliders
        self._prepared = False

    def frames_to_read(self):
        return self.range[1] - self.range[0] + 1

    def prepare(self):
        """Main thread, in steps (one per frame of the range, each a frame_set): reads the
        colliders of every frame, the tiles they touch and the baked layout."""
        if self._prepared:
            return
        frames = range(self.range[0], self.range[1] + 1)
        self.colliders = {}
        yield from read_colliders_steps(self._scene, self._coll, frames, self.colliders)
        # the state at the first frame is the rest pose: its colliders are only where the
        # second frame's sweep starts
        self.tiles = touched_tiles(self.runner_args[2], [self.colliders[f] for f in frames],
                                   self.fps)
        self.layout = baked.rest_layout(solver.Runner(*self.runner_args), self.tiles)
        counts = self.layout["counts"]
        self.blades = int(counts.sum())
        self.points = self.blades * 2 * self.K
        self.offsets = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        h = hashlib.sha256(self.key.encode())
        for f in frames:
            h.update(self.colliders[f].tobytes())
        h.update(self.tiles.tobytes())
        h.update(counts.tobytes())
        self.digest = h.hexdigest()[:32]
        self._check_manifest()
        self._prepared = True

    def _check_manifest(self):
        """Refuses (with what to do) to mix frames into a cache of another layout."""
        if not os.path.exists(self.manifest):
            return
        try:
            with open(self.manifest) as f:
                m = json.load(f)
            old = (int(m["version"]), tuple(m["range"]), m["digest"])
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"cannot read '{self.manifest}' ({exc}): Free Bake, then bake "
                             "again") from None
        if old[0] != MANIFEST_VERSION:
            raise ValueError(f"'{self.manifest}' is from another Tussock version: Free Bake, "
                             "then bake again")
        if old[1] != self.range:
            raise ValueError(f"'{self.name}' was baked for frames {old[1][0]}–{old[1][1]} but "
                             f"the scene now runs {self.range[0]}–{self.range[1]}: Free Bake, "
                             "then bake again")
        if self.digest is not None and old[2] != self.digest:
            raise ValueError(f"'{self.name}' was baked with other settings or collider "
                             "paths: Free Bake, then bake again")

    def outputs(self):
        if self._prepared and self.blades == 0:
            return []  # nothing touched, nothing written: the record lists only what is
        return [self.folder, self.pc2, self.manifest]

    def bytes_needed(self, frames):
        return (len(frames) + self.range[1] - self.range[0] + 1) * (self.points * 12 + 64)

    def frames(self, part):
        if self.blades == 0:
            return []  # nothing is touched: the meadow needs no bake
        lo, hi = part
        return list(range(max(lo, self.range[0]), min(hi, self.range[1]) + 1))

    def frame_positions(self, runner):
        """The baked mesh's vertex positions for the runner's current frame: the rest
        ribbons, with those of simulated tiles replaced by their current ribbons."""
        k = self.K
        pos = self.layout["rest"].copy()
        tiles, counts = runner.active()
        n = int(counts.sum())
        if n:
            slot = np.searchsorted(self.tiles, tiles)
            inside = self.tiles[np.minimum(slot, len(self.tiles) - 1)]
            if np.any(slot >= len(self.tiles)) or np.any(inside != tiles):
                raise ValueError("internal: a tile outside the baked layout woke up")
            ribbon = np.empty(n * 2 * k * 3, np.float32)
            runner.ribbons(0, runner.per_blade(tiles, 0), runner.per_blade(tiles, 1), ribbon)
            first = np.concatenate([[0], np.cumsum(counts)[:-1]])
            index = np.repeat(self.offsets[slot] - first, counts) + np.arange(n)
            pos.reshape(-1, 2 * k * 3)[index] = ribbon.reshape(-1, 2 * k * 3)
        return pos

    def steps(self, frames, progress):
        """See cache.Job.steps. The simulation runs from the first frame even when earlier
        frames are kept, since a frame depends on every frame before it."""
        lib = native.require()
        if not frames:
            return
        cache.clear_temporary(self.folder, frames)
        todo = set()
        for f in frames:
            if cache.frame_done(lib, self.folder, f, self.points):
                progress()
            else:
                todo.add(f)
        if not todo:
            return
        _atomic_json(self.manifest, dict(version=MANIFEST_VERSION, range=list(self.range),
                                         digest=self.digest, points=self.points))
        runner = solver.Runner(*self.runner_args)
        runner.restart(self.range[0])
        wind = wind_runtime.Stepper(self.wind_kwargs, self.range[0], self.fps,
                                    lambda f: self.sources.get(f, np.zeros((0, 8), np.float32)),
                                    settings_at=self.wind_settings.__getitem__)
        for f in range(self.range[0], max(todo) + 1):
            yield
            if f > self.range[0]:
                runner.step(f, self.colliders[f], self.fps, wind.sample, self.colliders[f - 1])
            if f in todo:
                lib.bake_write_frame(cache.frame_path(self.folder, f), f,
                                     self.frame_positions(runner))
                progress()

    def assemble(self):
        return self.blades > 0 and cache.assemble_pc2(self.folder, self.pc2, self.range)

    def wire(self, scene):
        """Main thread, after baking: the baked layout in the blades object and the
        meadow's hidden instances, and a Mesh Cache modifier reading the .pc2."""
        if self.blades == 0:
            return
        meadow = identity.find(self.meadow_key, scene)
        if meadow is None:
            raise cache.Gone(self.meadow_name)
        child = blade_objects.blades_object(meadow)
        baked.apply_layout(meadow, child, self.tiles, self.layout, self.K, self.instance_tile,
                           self.digest)
        mod = cache.wire_mesh_cache(child, self.rel_pc2, self.range, self.key)
        mod.show_render = mod.show_viewport = True  # reading the colliders may have
        # played frames that the unfinished cache did not hold yet
        child["tussock_bake_layout"] = self.digest
        child["tussock_baked_points"] = self.points
        child["tussock_baked_tiles"] = self.tiles.tolist()


# ---- the job source (see addon/cache.py) -------------------------------------------------

def jobs(scene, root):
    return [MeadowJob(o, scene, root) for o in scene.objects
            if compat.settings_of(o, "tussock_meadow") is not None and o.tussock_meadow.is_meadow
            and o.tussock_meadow.use_simulation]


def cache_key(obj, scene):
    return baked.blades_inputs_key(obj, scene) if obj.get("tussock_simulated_blades") else None


def restore(obj, scene):
    if obj.get("tussock_simulated_blades"):
        baked.restore_layout(obj, scene)


def status(scene):
    return None  # the panel lists the blades objects with the other cached objects


def free(scene, root, freed):
    """After tussock.free_bake removed the Mesh Cache of a meadow's blades: removes the
    manifest, forgets the baked layout and shows the live simulation again. `freed`:
    [(object, the name its files were written under: cache.cache_stem)]."""
    for child, stem in freed:
        if child.get("tussock_simulated_blades"):
            _free_blades(scene, child, root, stem)
    return 0


def _free_blades(scene, child, root, stem):
    path = os.path.join(root, stem + ".layout.json")
    if os.path.exists(path):
        os.remove(path)
    for key in ("tussock_bake_key", "tussock_bake_layout", "tussock_baked_points",
                "tussock_baked_tiles"):
        child.pop(key, None)
    if "tussock_layout" in child.data:
        del child.data["tussock_layout"]  # the next live frame rebuilds the dynamic mesh
    meadow = baked.meadow_of(child, scene)
    if meadow is not None:
        simulate.on_frame(scene)
