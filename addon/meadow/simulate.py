"""Blades that objects touch (seed 000 §4.5 with Han & Harada's solver): on every frame
the meadow's colliders — spheres or capsules fitted to the objects of its collider
collection, rigid bodies included — activate the tiles they touch; those tiles' blades are
simulated natively in the shared wind and written into one dynamic mesh per meadow, and the
instances of those tiles are hidden. Tiles at rest are released and blend back into the
instances.

Going back in time (or jumping ahead) resumes from the nearest snapshot of the solver state
at or before the frame, else from rest, and steps on with the collider positions recorded
when those frames were played. Snapshots are taken every SNAPSHOT_EVERY frames while
playing, within SNAPSHOT_BUDGET bytes per meadow: when that is full, every other snapshot
is dropped and they are taken half as often, so they keep covering the whole timeline.

The simulation itself (Runner) holds no Blender data, so the bake worker thread runs the
very same steps and gets the same bytes.

The meadow's Viewport display applies to simulated blades as to its instances: the blades of
the chunk instances the viewport shows (build.viewport_off) go into the dynamic meshes shown
in the viewport, the others into render chunks, objects disabled in the viewport (so Blender
does not evaluate them there) that renders show. Every blade is written every frame, so a
render of any frame shows them all."""

import math
from types import SimpleNamespace

import bpy
import numpy as np

from .. import compat, handlers, meshes, native
from ..wind import runtime as wind_runtime
from . import build, identity, material

STEPS_PER_FRAME = 2  # solver steps per frame, more at low frame rates (steps_per_frame)
MAX_STEP_SECONDS = 1.0 / 20.0  # a step is never longer
MAX_STEPS_PER_FRAME = 240  # below 1/12 fps a frame would take more: refused with a message
SNAPSHOT_EVERY = 10  # frames between snapshots of the solver state (counted from frame_start)
SNAPSHOT_BUDGET = 256 << 20  # bytes of snapshots kept per meadow
CAPACITY_BLOCK = 256  # a dynamic mesh has room for a whole number of blocks of blades;
                      # it grows by half at least and shrinks below a quarter full, so that
                      # its topology changes seldom while tiles come and go (rebuilding a
                      # chunk of ~6,000 blades costs about 24 ms)
FIT_AFTER_FRAMES = 4  # but every vertex of the room costs Blender each frame, used or not:
                      # once the active tiles have held this many frames, a chunk with more
                      # than an eighth of its room unused is rebuilt to fit (blade_playback:
                      # growth had left 45 % unused, ~5 ms per chunk and frame)
CHUNK_MIN_BLADES = 1024  # fewer blades than this per chunk: fewer chunks are used
CHUNKS = 4  # dynamic-mesh objects the simulated blades are shared among, evenly: Blender
            # evaluates separate objects on separate threads, and re-evaluating one
            # 655,000-vertex mesh per frame was most of a frame (docs/performance.md,
            # blade_playback). They are made together, when simulation is switched on:
            # adding an object mid-playback resets Blender's rigid-body cache, which changes
            # the path of a ball that Bullet rolls.
NO_COLLIDERS = np.zeros((0, 8), np.float32)
_cache = {}  # meadow key (identity.key: survives renames, tells linked meadows apart) -> Playback
suspended = False  # True while the bake plays frames only to read collider positions


def sim_settings(s):
    return dict(iterations=s.sim_iterations, damping=s.sim_damping,
                global_stiffness_root=s.sim_stiffness, local_stiffness=s.sim_local_stiffness)


# Meadow settings that may be keyframed on a simulated meadow: they do not change motion.
UNSIMULATED_SETTINGS = ("display",)


def check_animation(obj):
    """Refuses (ValueError) keyframes or drivers on a simulated meadow's settings: the
    blade simulation runs from rest at the first frame with one set of settings, so a
    value that changed along the timeline would make every frame simulate again from rest
    and could not be baked as the artist saw it."""
    ad = obj.animation_data
    if ad is None:
        return
    for fc in list(compat.fcurves(ad)) + list(ad.drivers):
        if not fc.data_path.startswith("tussock_meadow."):
            continue
        name = fc.data_path[len("tussock_meadow."):].split("[")[0]
        if name in UNSIMULATED_SETTINGS:
            continue
        prop = obj.tussock_meadow.bl_rna.properties.get(name)
        label = prop.name if prop is not None else name
        raise ValueError(
            f"{obj.name}: the meadow's '{label}' is keyframed or driven, but the blade "
            "simulation runs from the first frame with the same settings for the whole "
            "shot: remove its keyframes or driver (to change how blades move over time, "
            "keyframe the scene wind or move the colliders)")


def settle_steps(s, fps):
    """Solver steps of the meadow's Settle after time at `fps` (tsk_blade_sim_def's
    settle_frames)."""
    t = s.sim_settle_time
    if not (t > 0.0 and math.isfinite(t)):
        raise ValueError(f"Settle after: must be a positive number of seconds, got {t:g}")
    return min(2 ** 31 - 1, max(1, round(t * fps * steps_per_frame(fps))))


def sim_definition(s, info, knot_count, fps):
    """The native solver definition of a meadow (settings `s`, meadow layout `info`) at
    `fps` frames per second."""
    return dict(origin=tuple(info["origin"]), tile_size=info["tile_size"],
                tiles_x=info["tiles_x"], tiles_y=info["tiles_y"], knot_count=knot_count,
                ground_height=info["origin"][2], settle_frames=settle_steps(s, fps),
                **sim_settings(s))


def colliders(scene, coll, depsgraph=None):
    """float32 (n, 8) collider rows (kind, radius, a xyz, b xyz) fitted to the evaluated
    bounds of the objects in `coll`: a sphere for round objects and sphere rigid bodies,
    else a capsule along the longest axis. Objects without extent (empties, cameras,
    lights) are skipped."""
    rows = []
    if coll is None:
        return np.zeros((0, 8), np.float32)
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    for obj in coll.all_objects:  # one row per collider object
        ev = obj.evaluated_get(depsgraph)
        m = np.array(ev.matrix_world, np.float64)
        corners = np.array(ev.bound_box, np.float64)
        lo, hi = corners.min(axis=0), corners.max(axis=0)
        centre = m[:3, :3] @ ((lo + hi) / 2) + m[:3, 3]
        axes = m[:3, :3] * ((hi - lo) / 2)[None, :]  # columns: half-extent vectors
        half = np.linalg.norm(axes, axis=0)
        if half.max() == 0.0:  # no extent (an empty, camera, light, empty mesh): not a collider
            continue           # (NaN bounds go on, and the native check reports them)
        order = np.argsort(half)
        rb = obj.rigid_body
        if (rb is not None and rb.collision_shape == "SPHERE") or half[order[2]] < 1.5 * half[order[1]]:
            rows.append((0, half.max(), *centre, *centre))
        else:
            r = half[order[1]]
            d = axes[:, order[2]] / half[order[2]] * max(half[order[2]] - r, 0.0)
            rows.append((1, r, *(centre - d), *(centre + d)))
    return np.array(rows, np.float32).reshape(-1, 8)


def steps_per_frame(fps):
    """Solver steps for one frame at `fps`: STEPS_PER_FRAME, or more so that no step is
    longer than MAX_STEP_SECONDS (a slow-motion or time-lapse frame rate). A ValueError with
    the lowest usable rate when a frame would need more than MAX_STEPS_PER_FRAME."""
    if not (fps > 0.0 and math.isfinite(fps)):
        raise ValueError(f"the scene's frame rate ({fps:g} fps) must be a positive number")
    steps = max(STEPS_PER_FRAME, math.ceil(1.0 / (fps * MAX_STEP_SECONDS) - 1e-9))
    if steps > MAX_STEPS_PER_FRAME:
        lowest = 1.0 / (MAX_STEPS_PER_FRAME * MAX_STEP_SECONDS)
        raise ValueError(f"the scene's frame rate, {fps:g} fps, is too low to simulate blades "
                         f"(a frame would take {steps} solver steps); use at least "
                         f"{lowest:.3g} fps (Output Properties > Frame Rate)")
    return steps


class Runner:
    """One meadow's simulation without any Blender data: the native patch and meadow layout
    give the rest blades of tiles as they wake up, and the solver steps them with the
    colliders and wind of each frame. Playback and the bake worker both use it, so a frame
    has the same bytes either way. Wind is sampled once per blade, at its root (the wind
    does not depend on height), and applied along the whole blade."""

    def __init__(self, patch, meadow, definition, blade_rand):
        self.lib = native.require()
        self.patch, self.meadow, self.definition = patch, meadow, definition
        self.K = definition["knot_count"]
        self.blade_rand = blade_rand
        self.tiles = {}  # tile -> (widths, sides, blade rand, roots) of its rest blades
        self.sim = None
        self.frame = None
        self._roots = (None, None)  # (active tiles as bytes, their roots (n, 3))

    def restart(self, frame):
        """Every blade at rest at `frame`."""
        self.sim = self.lib.blade_sim_create(**self.definition)
        self.frame = frame

    def resume(self, snapshot, frame):
        """Continues from a snapshot (a clone of the solver) taken at `frame`; the snapshot
        itself stays as it is."""
        self.sim = self.lib.blade_sim_clone(snapshot)
        self.frame = frame

    def rest_blades(self, tile):
        """(knots n*K*3, widths n*K, sides n*3, blade rand n) of a tile's rest blades, as
        the meadow instances them."""
        lib, t = self.lib, int(tile)
        n = lib.meadow_blade_count(self.meadow, t, t + 1)
        knots = np.empty(n * self.K * 3, np.float32)
        widths = np.empty(n * self.K, np.float32)
        sides = np.empty(n * 3, np.float32)
        index = np.empty(n, np.int32)
        lib.meadow_realise_knots(self.meadow, self.patch, t, t + 1, knots, widths, sides)
        lib.meadow_realise(self.meadow, self.patch, t, t + 1, None, None, None, index)
        return knots, widths, sides, self.blade_rand[index]

    def _provide_pending(self):
        lib, sim = self.lib, self.sim
        n = lib.blade_sim_pending(sim)
        if n == 0:
            return
        pending = np.empty(n, np.int32)
        lib.blade_sim_pending(sim, pending)
        for t in pending:  # one native call per tile that wakes up
            t = int(t)
            knots, widths, sides, rand = self.rest_blades(t)
            lib.blade_sim_provide_tile(sim, t, knots, widths, sides)
            roots = np.ascontiguousarray(knots.reshape(-1, self.K, 3)[:, 0, :])
            self.tiles[t] = (widths, sides, rand, roots)

    def active(self):
        """(tiles, blade counts) of the active tiles, in the solver's order."""
        info = self.lib.blade_sim_info(self.sim)
        tiles = np.empty(info["active_tiles"], np.int32)
        counts = np.empty(info["active_tiles"], np.int32)
        if len(tiles):
            self.lib.blade_sim_get_active(self.sim, tiles, counts)
        return tiles, counts

    def knots(self):
        """Current knots of the active blades, float32 (n*K*3)."""
        info = self.lib.blade_sim_info(self.sim)
        out = np.empty(info["active_blades"] * self.K * 3, np.float32)
        if len(out):
            self.lib.blade_sim_get_knots(self.sim, out)
        return out

    def ribbons(self, first, widths, sides, out):
        """Ribbon vertices of active blades first .. first + len(sides) / 3 into `out`
        (float32, 2 * K * 3 per blade), made in C straight from the solver's state: the
        bytes blades_expand gives on the same blades' knots(), without copying them out."""
        self.lib.blade_sim_ribbons(self.sim, first, widths, sides, out)

    def per_blade(self, tiles, what):
        """Concatenation of one rest array (0 widths, 1 sides, 2 blade rand, 3 roots) over
        `tiles`."""
        parts = [self.tiles[int(t)][what] for t in tiles]
        if parts:
            return np.concatenate(parts)
        return np.zeros((0, 3) if what == 3 else 0, np.float32)

    def step(self, frame, rows, fps, wind_at):
        """Steps from frame - 1 to `frame` with the collider rows of `frame` and the wind
        wind_at(frame, xyz (n, 3)) -> (n, 3) m/s."""
        steps = steps_per_frame(fps)
        lib, sim = self.lib, self.sim
        lib.blade_sim_set_colliders(sim, np.ascontiguousarray(rows, np.float32).ravel())
        self._provide_pending()
        dt = 1.0 / fps / steps
        wind, layout, n = self._wind(frame, wind_at)
        for _ in range(steps):
            if lib.blade_sim_info(sim)["active_blades"] != n:  # a step released a tile
                wind, layout, n = self._wind(frame, wind_at)
            lib.blade_sim_step(sim, dt, wind, layout)
        self.frame = frame

    def _wind(self, frame, wind_at):
        """(wind per blade root, its layout, active blades) for the active tiles now."""
        tiles, _ = self.active()
        key = tiles.tobytes()
        if self._roots[0] != key:
            self._roots = (key, self.per_blade(tiles, 3))
        roots = self._roots[1]
        if not len(roots):
            return None, 0, 0
        wind = np.ascontiguousarray(wind_at(frame, roots), np.float32).ravel()
        return wind, 2, len(roots)  # layout 2: one velocity per blade


class Playback:
    """The live simulation of one meadow object: its Runner, the collider rows recorded per
    frame as frames are played, and snapshots of the solver state."""

    def __init__(self, obj, scene, key):
        s = obj.tussock_meadow
        origin, size = build.area_of(obj, s)
        lib = native.require()
        patch = build.make_patch(s)
        meadow = build.make_meadow(s, origin, size)
        info = lib.meadow_info(meadow)
        n = info["chunk_instances"]
        self.instance_tile = np.empty(n, np.int32)
        lib.meadow_chunk_instances(meadow, None, None, self.instance_tile)
        blade_rand = np.empty(lib.patch_info(patch)["blade_count"], np.float32)
        lib.rand_fill(s.seed, build.BLADE_RAND_STREAM, blade_rand)
        k = lib.patch_info(patch)["knot_count"]
        self.chunk_blades = int(info["chunk_blades"])  # blades per chunk instance
        self.runner = Runner(patch, meadow,
                             sim_definition(s, info, k, wind_runtime.fps_of(scene)), blade_rand)
        # the dynamic meshes' fixed texture space: the meadow's ground, a metre high
        o, sz = np.asarray(origin, np.float64), np.asarray(size, np.float64)
        self.texture_space = (o, o + np.array([sz[0], sz[1], 1.0]))
        self.key = key
        self.frame_start = scene.frame_start
        self.colliders = {}  # frame -> collider rows recorded when it was played
        self.snapshots = {}  # frame -> (solver clone, bytes)
        self.every = SNAPSHOT_EVERY
        self.wind_key = None
        self.stale = False  # the solver's state used colliders that have changed since
        self.restored_from = None  # frame the last jump back resumed from (tests, panel)
        self.written = None  # active tiles last written into the dynamic mesh (bytes)
        self.steady = 0  # writes since the active tiles last changed
        self.held = None  # chunk index -> what its mesh holds: _COLLAPSED, or the room (in
                          # blades) this playback last wrote it with
        self.buf = None  # one chunk's vertex positions, float32; every chunk is written
                         # through it in turn (see _write_chunk)
        self.ribbon = None  # (widths, sides) of the written tiles, one row per blade
        self.rand = None  # colour value of each written blade
        self.hidden = None  # per instance: is its tile simulated
        self.viewport_key = None  # (seed, display, instances) the plan was made for
        self.plan = None  # per chunk object key: the part of the active blades it shows
        self.baked_hidden = None  # (bake layout digest, per instance: is its tile baked)
        self.stats = {}  # active tiles and blades last written (the meadow's properties)

    # -- snapshots ------------------------------------------------------------------------
    def snapshot_bytes(self):
        return sum(b for _, b in self.snapshots.values())

    def drop_snapshots(self, first=None):
        """Forgets the snapshots at `first` and later (all when None)."""
        for f in [f for f in self.snapshots if first is None or f >= first]:
            del self.snapshots[f]

    def _take_snapshot(self):
        r = self.runner
        if (r.frame - self.frame_start) % self.every or r.frame in self.snapshots:
            return
        lib = r.lib
        clone = lib.blade_sim_clone(r.sim)
        self.snapshots[r.frame] = (clone, lib.blade_sim_info(clone)["state_bytes"])
        while self.snapshot_bytes() > SNAPSHOT_BUDGET:
            if len(self.snapshots) <= 1:
                self.snapshots.clear()
                break
            self.every *= 2  # thin out: keep every other one, take them half as often
            for f in [f for f in self.snapshots if (f - self.frame_start) % self.every]:
                del self.snapshots[f]

    # -- stepping -------------------------------------------------------------------------
    def record(self, frame, rows):
        """Records the collider rows of `frame`; if they differ from those recorded before,
        the snapshots and state that used the old ones are out of date."""
        old = self.colliders.get(frame)
        if old is not None and old.tobytes() == rows.tobytes():
            return
        had = old is not None or any(f > frame for f in self.snapshots)
        self.colliders[frame] = rows
        self.drop_snapshots(frame)
        r = self.runner
        if r.frame is not None and r.frame >= frame and (had or r.frame > frame):
            self.stale = True

    def go_to(self, frame, fps, wind_at):
        r = self.runner
        back = r.sim is None or r.frame > frame or self.stale
        known = [f for f in self.snapshots if f <= frame]
        snap = max(known) if known else None
        if back or (snap is not None and snap > r.frame):
            if snap is not None:
                r.resume(self.snapshots[snap][0], snap)
            else:
                r.restart(self.frame_start)
            self.restored_from = r.frame
            self.stale = False
        try:
            while r.frame < frame:
                f = r.frame + 1
                r.step(f, self.colliders.get(f, NO_COLLIDERS), fps, wind_at)
                self._take_snapshot()
        except (native.Error, ValueError):
            # A refused step (bad colliders, time step...) must not count as simulated: the
            # solver may have taken part of it, so the next frame starts again from a
            # snapshot or rest, and the refused colliders are not replayed.
            self.stale = True
            self.colliders.pop(frame, None)
            raise


def layout_key(obj, scene):
    """What a meadow's simulated blades depend on besides colliders and wind: patch, area,
    layout and density settings, solver settings, the first frame and the frame rate."""
    s = obj.tussock_meadow
    origin, size = build.area_of(obj, s)
    image = s.density_image.name if s.density_image is not None else None
    return repr((build.patch_key(s), origin, size, sorted(sim_settings(s).items()),
                 s.density, round(s.noise_scale, 6), s.noise_octaves,
                 round(s.noise_threshold, 6), image, s.blades_per_tile, s.chunk_blades,
                 scene.frame_start, STEPS_PER_FRAME, s.sim_settle_time,
                 wind_runtime.fps_of(scene)))


def _playback(obj, scene):
    key = layout_key(obj, scene)
    which = identity.key(obj)
    pb = _cache.get(which)
    if pb is None or pb.key != key:
        s = obj.tussock_meadow
        if obj.library is None and obj.get("tussock_patch_key") != build.patch_key(s):
            build.rebuild(obj)  # models changed: the instances grow what the solver does
        _cache.pop(which, None)  # the old solver, patch and snapshots go before the new come
        pb = Playback(obj, scene, key)
        _cache[which] = pb
    return pb


def playback_of(obj):
    """The live simulation (Playback) of meadow object `obj`, or None."""
    return _cache.get(identity.key(obj))


def live_count():
    """Meadows with a live simulation (a native solver, patch and snapshots each)."""
    return len(_cache)


def simulate_to(obj, scene, frame, depsgraph=None):
    """Advances (or takes back) the meadow's simulation to `frame`; returns its Playback."""
    check_animation(obj)
    pb = _playback(obj, scene)
    pb.record(frame, colliders(scene, obj.tussock_meadow.colliders, depsgraph))
    wind_key = wind_runtime.settings_key(scene)
    if wind_key != pb.wind_key:  # other wind: every snapshot is out of date
        pb.drop_snapshots()
        pb.stale = pb.wind_key is not None
        pb.wind_key = wind_key
    pb.go_to(frame, wind_runtime.fps_of(scene),
             lambda f, xyz: wind_runtime.sample(scene, f, xyz))
    return pb


# -- the dynamic mesh -------------------------------------------------------------------------

def ribbon_topology(mesh, blades, k):
    """(Re)builds `mesh` for `blades` ribbons of k knots: one quad per segment (the same
    diagonal as the instanced blades' triangles when rendered), the point attributes tsk_v
    (knot / (k - 1): 0 at the root, 1 at the tip; the material reads it where instanced
    blades have their UV map's v, since a UV map, one value per face corner, would cost
    Blender about a tenth more work per frame) and tsk_blade_rand. Positions are set
    apart."""
    lib = native.require()
    mesh.clear_geometry()
    tris = np.empty(blades * 6 * (k - 1), np.int32)
    lib.blade_indices(k, blades, tris)
    # triangles (v, v+1, v+3), (v, v+3, v+2) -> quad (v, v+1, v+3, v+2)
    t = tris.reshape(-1, 6)
    quads = np.ascontiguousarray(np.stack([t[:, 0], t[:, 1], t[:, 2], t[:, 5]], axis=1)).ravel()
    mesh.vertices.add(blades * 2 * k)
    meshes.set_faces(mesh, quads.reshape(-1, 4))
    nq = quads.size // 4
    mesh.polygons.foreach_set("use_smooth", np.ones(nq, bool))
    v = np.repeat(np.arange(k, dtype=np.float32) / (k - 1), 2)
    mesh.attributes.new("tsk_v", "FLOAT", "POINT").data.foreach_set("value", np.tile(v, blades))
    mesh.attributes.new("tsk_blade_rand", "FLOAT", "POINT")
    grass = material.grass_material()  # (brought up to date if an older Tussock made it)
    if len(mesh.materials) == 0:
        mesh.materials.append(grass)
    mesh.update()


def set_blade_rand(mesh, rand, k):
    """Per-blade colour variation (one value per blade) onto the ribbon vertices."""
    vrand = np.zeros(len(mesh.vertices), np.float32)
    vrand[:len(rand) * 2 * k] = np.repeat(rand, 2 * k)
    mesh.attributes["tsk_blade_rand"].data.foreach_set("value", vrand)


_hidden_written = {}  # meadow key -> (points serial, the hidden array written)


def set_hidden(obj, hidden):
    """Sets the meadow's point attribute tsk_hidden (instances not drawn) if it differs.
    The same array already written into the same points (chunks.write_points counts them
    in tussock_points_serial) is not read back: that was a copy of every point per frame."""
    mesh = obj.data
    if mesh.library is not None:
        return  # a linked meadow's points are its library's: Blender ignores writes to them
    which = identity.key(obj)
    serial = mesh.get("tussock_points_serial")
    last = _hidden_written.get(which)
    if serial is not None and last is not None and last[0] == serial and last[1] is hidden:
        return
    attr = mesh.attributes.get("tsk_hidden")
    if attr is None or len(attr.data) != len(hidden):
        return
    current = np.empty(len(hidden), bool)
    attr.data.foreach_get("value", current)
    if not np.array_equal(current, hidden):
        attr.data.foreach_set("value", np.ascontiguousarray(hidden, bool))
        mesh.update()
    _hidden_written[which] = (serial, hidden)


def _in_the_way(name):
    return ValueError(f"an object named '{name}' that is not this meadow's simulated blades "
                      f"is in the way: rename it")


def _mesh_object(name, meadow, beside):
    """The mesh object `name`, made if missing in the local collections of object `beside`
    (else in the scene's); owned by the meadow (identity.OWNER). (users_collection walks
    every collection: only when made.)"""
    child = bpy.data.objects.get(name)
    made = child is None
    if made:
        child = bpy.data.objects.new(name, bpy.data.meshes.new(name))
        colls = [c for c in beside.users_collection if getattr(c, "library", None) is None]
        for coll in colls or [bpy.context.scene.collection]:
            coll.objects.link(child)
        child[identity.OWNER] = identity.key(meadow)
        child["tussock_meadow_name"] = meadow.name
    elif child.type != "MESH" or not identity.adopt(meadow, child,
                                                    child.get("tussock_meadow_name")):
        raise _in_the_way(name)  # someone else's object: never overwrite it
    return child, made


def base_name(obj):
    """What the names of a meadow's own objects start with: its name, and for a linked
    meadow its library's too (a local meadow may have the same name)."""
    return obj.name if obj.library is None else f"{obj.name} [{obj.library.name}]"


def chunk_name(obj, key):
    """Name of the meadow's chunk object `key`: i (0 the first, which a bake writes) for the
    chunks shown in the viewport, ("render", i) for the render chunks."""
    if isinstance(key, tuple):
        return f"{base_name(obj)} blades render {key[1] + 1}"
    return f"{base_name(obj)} blades" + (f" {key + 1}" if key else "")


def _role(child):
    """The chunk key (see chunk_name) of one of a meadow's simulated-blade objects."""
    if child.get("tussock_simulated_blades"):
        return 0
    if "tussock_blades_render_chunk" in child:
        return ("render", int(child["tussock_blades_render_chunk"]))
    return int(child.get("tussock_blades_chunk", -1))


def follow_name(obj):
    """Renames the meadow's simulated-blade objects (and their meshes) after the meadow, if
    it was renamed since they were named; returns the first chunk, or None if there is none.
    The blades objects are found by their owner (one walk over the file's objects, only
    when the first chunk is not found under the meadow's name)."""
    first = bpy.data.objects.get(chunk_name(obj, 0))
    if first is not None and identity.adopt(obj, first, first.get("tussock_meadow_name")):
        return first
    k = identity.key(obj)
    own = [o for o in bpy.data.objects if o.get(identity.OWNER) == k and _role(o) != -1]
    if not own:
        if first is not None:
            raise _in_the_way(first.name)
        return None
    wanted = {o: chunk_name(obj, _role(o)) for o in own}
    for o, name in wanted.items():
        other = bpy.data.objects.get(name)
        if other is not None and other not in wanted:
            raise _in_the_way(name)
    for o in own:  # first out of the way (names may swap among them), then the new names
        o.name = o.name + " (renamed)"
    for o, name in wanted.items():
        o.name = name
        o["tussock_meadow_name"] = obj.name
        if o.data is not None and o.data.users == 1:
            o.data.name = name
    if obj.library is None:
        build.follow_name(obj)  # and the patch collection with its chunk objects
    return next((o for o in own if _role(o) == 0), None)


def blades_object(obj):
    """The meadow's dynamic mesh of simulated blades (created once): its first chunk, the
    one a bake writes."""
    child = follow_name(obj)
    if child is not None:
        return child
    child, made = _mesh_object(chunk_name(obj, 0), obj, obj)
    if made:
        child["tussock_simulated_blades"] = True
    return child


def find_blades_object(obj):
    """The meadow's first chunk if it exists (after a rename too), else None; makes nothing."""
    return follow_name(obj)


def chunk_object(obj, i):
    """Chunk i of the meadow's simulated blades: 0 is blades_object(); the others are
    children of the first (the outliner groups them; the first stays at the origin), shown
    and rendered as it is."""
    first = blades_object(obj)
    if i == 0:
        return first
    child, made = _mesh_object(chunk_name(obj, i), obj, first)
    if made:
        child.parent = first
        child["tussock_blades_chunk"] = i
    for prop in ("hide_render", "hide_viewport"):
        if getattr(child, prop) != getattr(first, prop):
            setattr(child, prop, getattr(first, prop))
    return child


def render_chunk_object(obj, i):
    """Render chunk i of the meadow's simulated blades: a child of the first chunk that is
    disabled in the viewport (Blender does not evaluate it there) and rendered as the first
    chunk is; it holds blades the meadow's Viewport display leaves out."""
    first = blades_object(obj)
    child, made = _mesh_object(chunk_name(obj, ("render", i)), obj, first)
    if made:
        child.parent = first
        child["tussock_blades_render_chunk"] = i
    if not child.hide_viewport:
        child.hide_viewport = True
    if child.hide_render != first.hide_render:
        child.hide_render = first.hide_render
    return child


def render_chunks(obj):
    """The meadow's render chunk objects that exist, in order."""
    found = []
    while (child := bpy.data.objects.get(chunk_name(obj, ("render", len(found))))) is not None:
        found.append(child)
    return found


def ensure_chunks(obj):
    """Makes every chunk object of the meadow now (see CHUNKS: not during playback)."""
    for i in range(CHUNKS):
        chunk_object(obj, i)
        render_chunk_object(obj, i)


def extra_chunks(obj):
    """The meadow's chunk objects after the first, in order."""
    found = []
    i = 1
    while (child := bpy.data.objects.get(chunk_name(obj, i))) is not None:
        found.append(child)
        i += 1
    return found


_COLLAPSED = "collapsed"  # pb.held[i] of a chunk whose blades are all collapsed


def _collapse(child, pb=None, i=None):
    """Shows no blade in a chunk: every vertex at the origin (zero-area quads, which render
    nothing). Its topology stays: clearing a mesh to no vertices mid-playback makes
    Blender's rigid-body world take another path (test_sim's snapshot test)."""
    if pb is not None and pb.held is not None and pb.held.get(i) == _COLLAPSED:
        return  # already collapsed by this playback
    mesh = child.data
    n = len(mesh.vertices) * 3
    if n:
        co = np.empty(n, np.float32)
        compat.get_positions(mesh, co)
        if co.any():
            compat.set_positions(mesh, np.zeros(n, np.float32))
            mesh.update()
    if pb is not None and pb.held is not None:
        pb.held[i] = _COLLAPSED  # the next write sets this chunk's blades afresh


def empty_extra_chunks(obj):
    """Leaves only the first chunk with blades (a bake's layout lives there alone)."""
    pb = playback_of(obj)
    for i, child in enumerate(extra_chunks(obj), start=1):
        _collapse(child, pb, i)
    for i, child in enumerate(render_chunks(obj)):
        _collapse(child, pb, ("render", i))


def chunk_ranges(nb):
    """The active blades of each chunk, as ranges in order: nearly equal parts over as many
    chunks as have CHUNK_MIN_BLADES each (at least one), empty ranges for the rest."""
    used = max(1, min(CHUNKS, nb // CHUNK_MIN_BLADES))
    return [range(i * nb // used, (i + 1) * nb // used) if i < used else range(nb, nb)
            for i in range(CHUNKS)]


def active_ribbons(obj):
    """Ribbon vertex positions of the active simulated blades, in the solver's order, read
    back from the chunks that show them in the viewport and the render chunks (float32,
    2 * K * 3 per blade); each chunk's spare room must be zero."""
    pb = playback_of(obj)
    nb = int(pb.stats.get("tussock_active_blades", 0)) if pb is not None else 0
    if pb is None or nb == 0 or not pb.plan:
        return np.zeros(0, np.float32)
    per = 2 * pb.runner.K * 3
    out = np.zeros((nb, per), np.float32)
    got = np.zeros(nb, np.int32)
    for key, part in pb.plan.items():
        child = bpy.data.objects.get(chunk_name(obj, key))
        v = np.zeros(0, np.float32)
        if child is not None:
            v = np.empty(len(child.data.vertices) * 3, np.float32)
            compat.get_positions(child.data, v)
        n = len(part.index) * per
        if len(v) < n or v[n:].any():
            raise AssertionError(f"{key}: the chunk does not hold exactly its {len(part.index)} blades")
        out[part.index] = v[:n].reshape(-1, per)
        got[part.index] += 1
    if not np.all(got == 1):
        raise AssertionError("the chunks do not hold every active blade exactly once")
    return out.ravel()


def viewport_shown(pb, tiles, counts, viewport_off):
    """Per active blade (the solver's order): is it shown in the viewport, i.e. is its chunk
    instance (tsk_meadow_chunk_instances: tile by tile, a tile's blades C at a time) one
    that the viewport shows."""
    c = pb.chunk_blades
    per_tile = counts // c
    first = np.searchsorted(pb.instance_tile, tiles)  # each active tile's first instance
    instance = (np.repeat(first - (np.cumsum(per_tile) - per_tile), per_tile)
                + np.arange(int(per_tile.sum())))
    return np.repeat(~viewport_off[instance], c)


def _part(pb, index):
    """What a chunk object holds: the active blades `index` (ascending) as runs for
    blade_sim_ribbon_runs, with their widths, sides and colour values."""
    index = np.asarray(index, np.int64)
    if len(index):
        breaks = np.flatnonzero(np.diff(index) != 1) + 1
        starts = index[np.concatenate(([0], breaks))]
        ends = index[np.concatenate((breaks - 1, [len(index) - 1]))] + 1
    else:
        starts = ends = np.zeros(0, np.int64)
    return SimpleNamespace(index=index, starts=np.ascontiguousarray(starts),
                           counts=np.ascontiguousarray(ends - starts),
                           widths=np.ascontiguousarray(pb.ribbon[0][index]).ravel(),
                           sides=np.ascontiguousarray(pb.ribbon[1][index]).ravel(),
                           rand=pb.rand[index])


def make_plan(pb, shown):
    """Chunk object key -> part: the blades shown in the viewport shared evenly among the
    CHUNKS chunk objects (keys 0 ..), the others among as many render chunks (keys
    ("render", i)). With every blade shown, chunk i holds chunk_ranges(nb)[i]."""
    plan = {}
    for which, seq in ((None, np.flatnonzero(shown)), ("render", np.flatnonzero(~shown))):
        for i, r in enumerate(chunk_ranges(len(seq))):
            key = i if which is None else (which, i)
            if which is None or len(r):
                plan[key] = _part(pb, seq[r.start:r.stop])
    return plan


def chunk_capacity(capacity, nb, fit=False):
    """Room (in blades) of a chunk's mesh holding nb blades, given its room now: whole
    CAPACITY_BLOCKs, grown by half at least when too small, shrunk to fit when under a
    quarter full, and when `fit` (the active tiles have held FIT_AFTER_FRAMES) to fit if
    more than an eighth of it is unused."""
    def blocks(n):
        return max(1, -(-n // CAPACITY_BLOCK)) * CAPACITY_BLOCK
    if not capacity or nb > capacity:
        return blocks(max(nb, capacity * 3 // 2))
    if nb < capacity // 4 or (fit and blocks(nb) < capacity - capacity // 8):
        return blocks(nb)
    return capacity


def _write_chunk(child, pb, i, part, k, layout_changed, fit=False):
    """Writes the active blades of `part` (make_plan) into chunk `child` (pb.held key i);
    `fit`: see chunk_capacity."""
    mesh = child.data
    nb = len(part.index) if part is not None else 0
    if nb == 0 and mesh.get("tussock_layout") == "live":
        _collapse(child, pb, i)  # written once: an unchanged mesh costs Blender nothing
        return
    capacity = chunk_capacity(mesh.get("tussock_capacity") or 0, nb, fit)
    fresh = (mesh.get("tussock_layout") != "live" or mesh.get("tussock_capacity") != capacity
             or len(mesh.vertices) != capacity * 2 * k)
    if fresh:
        ribbon_topology(mesh, capacity, k)
        mesh["tussock_layout"] = "live"
        mesh["tussock_capacity"] = capacity
    if fresh or layout_changed or pb.held.get(i) != capacity:
        # (a new Playback, e.g. after the meadow's ground moved, brings its own box)
        meshes.fix_texture_space(mesh, *pb.texture_space)
        set_blade_rand(mesh, part.rand if nb else np.zeros(0, np.float32), k)
        pb.held[i] = capacity
    # The chunks share one buffer: it is still in the cache when the next chunk is written,
    # where a buffer per chunk comes back from memory every frame, since Blender's evaluation
    # of the meshes in between goes through far more memory than the cache holds
    # (docs/performance.md, session 8: about 1 ms of the write step at 20,480 blades).
    n, used = capacity * 2 * k * 3, nb * 2 * k * 3
    if pb.buf is None or len(pb.buf) < n:
        pb.buf = np.empty(n, np.float32)
    pos = pb.buf[:n]
    if nb:
        pb.runner.lib.blade_sim_ribbon_runs(pb.runner.sim, part.starts, part.counts,
                                            part.widths, part.sides, pos[:used])
    pos[used:] = 0.0  # the chunk's unused room: zero-area quads at the origin
    compat.set_positions(mesh, pos)
    mesh.update()


def write(obj, pb):
    """Writes the simulated blades into the meadow's dynamic meshes and hides the instances
    of their tiles. The blades the meadow's Viewport display shows are shared evenly among
    CHUNKS objects, which Blender evaluates in parallel; the others go into render chunks
    (see the module's docstring). Per frame only vertex positions change; a chunk's
    topology, the per-blade colour and the hidden instances change only when the set of
    active tiles, or the viewport's share, does. Unused blade slots collapse to zero-area
    quads."""
    r = pb.runner
    k = r.K
    s = obj.tussock_meadow
    tiles, counts = r.active()
    nb = int(counts.sum())
    layout = tiles.tobytes()
    layout_changed = pb.written != layout
    pb.steady = 0 if layout_changed else pb.steady + 1
    if layout_changed:
        pb.written = layout
        pb.hidden = np.isin(pb.instance_tile, tiles)
        pb.rand = r.per_blade(tiles, 2)
        pb.ribbon = tuple(np.ascontiguousarray(r.per_blade(tiles, w).reshape(nb, -1))
                          if nb else r.per_blade(tiles, w).reshape(0, k if w == 0 else 3)
                          for w in (0, 1))
    viewport_key = (s.seed, float(s.display), len(pb.instance_tile))
    if layout_changed or pb.viewport_key != viewport_key or pb.plan is None:
        off = build.viewport_off(s, len(pb.instance_tile))
        pb.plan = make_plan(pb, viewport_shown(pb, tiles, counts, off))
        pb.viewport_key = viewport_key
        layout_changed = True  # chunks hold other blades: their colours too
    if pb.held is None:
        pb.held = {}
    set_hidden(obj, pb.hidden)  # (checked every frame: rebuilding the meadow clears it)
    fit = pb.steady == FIT_AFTER_FRAMES
    for i in range(CHUNKS):
        _write_chunk(chunk_object(obj, i), pb, i, pb.plan.get(i), k, layout_changed, fit)
    made = len(render_chunks(obj))
    for i in range(max(CHUNKS, made)):
        part = pb.plan.get(("render", i))
        if part is None and i >= made:
            continue  # render chunks are made only when there is something to show
        child = render_chunk_object(obj, i)
        if i >= CHUNKS:
            _collapse(child, pb, ("render", i))  # of a larger CHUNKS: unused
        else:
            _write_chunk(child, pb, ("render", i), part, k, layout_changed, fit)
    for i, child in enumerate(extra_chunks(obj)[CHUNKS - 1:], start=CHUNKS):
        _collapse(child, pb, i)  # chunks of a larger CHUNKS: unused
    pb.stats = dict(tussock_active_tiles=len(tiles), tussock_active_blades=nb,
                    tussock_viewport_blades=int(sum(len(p.index) for key, p in pb.plan.items()
                                                    if not isinstance(key, tuple))))
    if obj.library is None:  # (a linked meadow's properties are its library's)
        for name, value in pb.stats.items():
            obj[name] = value


def on_frame(scene, depsgraph=None):
    if suspended:
        return
    sync()
    from . import baking
    for obj in scene.objects:  # one simulation per meadow object
        s = compat.settings_of(obj, "tussock_meadow")
        if s is None or not s.is_meadow or not s.use_simulation:
            continue
        try:
            if baking.show_baked(obj, scene, scene.frame_current):
                # the bake's Mesh Cache shows this frame; the colliders are still recorded
                # for live frames after the baked range
                _playback(obj, scene).record(
                    scene.frame_current, colliders(scene, s.colliders, depsgraph))
                continue
            pb = simulate_to(obj, scene, scene.frame_current, depsgraph)
            write(obj, pb)
            s.last_error = ""
        except (native.Error, ValueError) as exc:
            s.last_error = str(exc)


def forget(obj=None):
    """Frees the live simulation of meadow object `obj`, or of every meadow."""
    if obj is None:
        _cache.clear()
        _hidden_written.clear()
        _followed.clear()
        identity.forget()
    else:
        _cache.pop(identity.key(obj), None)
        _hidden_written.pop(identity.key(obj), None)


def sync(force=False):
    """After objects were made or removed: gives duplicated meadows their own ids (and so
    their own simulation and blades objects), and frees the simulations of meadows that are
    gone (deleted, or their file closed)."""
    live = identity.scan(force)
    if live is None:
        return
    for which in [k for k in _cache if k not in live]:
        del _cache[which]  # the native solver, patch and snapshots go with it
    for which in [k for k in _hidden_written if k not in live]:
        del _hidden_written[which]
    _tidy_owned(live)


_OWN_TAGS = (identity.OWNER, "tussock_meadow_name", "tussock_simulated_blades",
             "tussock_blades_chunk", "tussock_blades_render_chunk")


def _tidy_owned(live):
    """What meadows owned outlives them otherwise, frozen in the scene: the simulated-blade
    objects of a deleted meadow (identity.gone: one that was there, not one being made by
    Add Meadow) are removed, with its patch once nothing instances it. Copies
    of blade objects (Shift+D of a meadow with its blades) go to the meadow copied with them,
    one copy per chunk, renamed after it at the next frame; copies of blades alone (or
    sharing their mesh, Alt+D) become the artist's plain meshes, which Tussock never writes.
    Runs when objects were made or removed (one walk over the file's objects)."""
    groups = {}
    for o in bpy.data.objects:
        k = o.get(identity.OWNER)
        if k is not None and o.library is None and (role := _role(o)) != -1:
            groups.setdefault((k, role), []).append(o)
    heirs = {}
    for fresh, old in identity.born.items():
        heirs.setdefault(old, []).append(fresh)
    taken = set(groups)
    for (k, role), objs in groups.items():
        if k not in live:
            if k in identity.gone:
                for o in objs:
                    meshes.remove_object(o)
            continue
        if len(objs) == 1:
            continue
        meadow = identity.find(k)
        name = chunk_name(meadow, role) if meadow is not None else None
        objs.sort(key=lambda o: (o.name != name, o.name))  # the original holds the name
        for o in objs[1:]:
            heir = next((h for h in sorted(heirs.get(k, ()))
                         if (h, role) not in taken), None)
            if heir is not None and o.data is not None and o.data.users == 1:
                o[identity.OWNER] = heir
                taken.add((heir, role))
            else:
                for tag in _OWN_TAGS:
                    if tag in o:
                        del o[tag]
    for coll in list(bpy.data.collections):
        k = coll.get(identity.OWNER)
        if k in identity.gone and coll.users == 0 and coll.library is None:
            for o in list(coll.objects):
                if len(o.users_collection) == 1:
                    meshes.remove_object(o)
            bpy.data.collections.remove(coll)


_followed = {}  # meadow key -> the name its objects were last renamed after


def _follow_renames(depsgraph):
    """The simulated-blade objects and patch collections of renamed meadows take the new
    names (a rename updates the depsgraph, so this runs right after it)."""
    for update in depsgraph.updates:  # the data-blocks changed: a handful
        obj = update.id.original if hasattr(update.id, "original") else update.id
        if not isinstance(obj, bpy.types.Object) or obj.library is not None:
            continue
        s = compat.settings_of(obj, "tussock_meadow")
        if s is None or not s.is_meadow or obj.get(identity.ID) is None:
            continue
        which = identity.key(obj)
        if _followed.get(which) == obj.name:
            continue  # not renamed (a move, a setting): nothing to look for
        _followed[which] = obj.name
        try:
            follow_name(obj)
            build.follow_name(obj)
        except ValueError as exc:  # a name in the way: the panel says which
            if s.last_error != str(exc):  # (each write is one more depsgraph update)
                s.last_error = str(exc)


@bpy.app.handlers.persistent
def _on_frame_change(scene, depsgraph=None):
    if native.available():
        on_frame(scene, depsgraph)


@bpy.app.handlers.persistent
def _on_load(*_args):
    forget()


SYNC_EVERY = 0.5  # seconds between looks for meadows gone without an update (see _sync_later)


def _sync_later():
    """Delete in a window frees the object after the last depsgraph update it causes, and a
    script may remove one with none at all: this look, twice a second, finds such a meadow
    gone and frees what it owned (it costs a count of the file's objects while none is made
    or removed)."""
    if native.available() and not suspended:
        sync()
    return SYNC_EVERY


@bpy.app.handlers.persistent
def _on_depsgraph_update(scene, depsgraph=None):
    if suspended:
        return
    sync()
    if depsgraph is not None:
        build.models_edited(depsgraph)
        _follow_renames(depsgraph)


classes = ()


@bpy.app.handlers.persistent
def _on_undo(*_args):
    _hidden_written.clear()  # undo may bring back an older tsk_hidden with the same serial


def register_extra():
    handlers.add("frame_change_post", _on_frame_change)
    handlers.add("load_post", _on_load)
    handlers.add("depsgraph_update_post", _on_depsgraph_update)
    handlers.add_timer(_sync_later, SYNC_EVERY, persistent=True)
    handlers.add("undo_post", _on_undo)
    handlers.add("redo_post", _on_undo)
