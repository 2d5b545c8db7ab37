"""The live simulation of each meadow as frames are played: a Runner (solver.py), the collider
rows recorded per frame, and snapshots of the solver state.

Going back in time (or jumping ahead) resumes from the nearest snapshot of the solver state
at or before the frame, else from rest, and steps on with the collider positions recorded
when those frames were played. Snapshots are taken every SNAPSHOT_EVERY frames while
playing, within SNAPSHOT_BUDGET bytes per meadow: when that is full, every other snapshot
is dropped and they are taken half as often, so they keep covering the whole timeline."""

import numpy as np

from .. import compat, native
from ..wind import runtime as wind_runtime
from . import build, identity, solver
from . import colliders as collider_shapes

SNAPSHOT_EVERY = 10  # frames between snapshots of the solver state (counted from frame_start)
SNAPSHOT_BUDGET = 256 << 20  # bytes of snapshots kept per meadow
# meadow key (identity.key: survives renames, tells linked meadows apart) -> Playback
_playbacks = identity.PerMeadow()  # the native solver, patch and snapshots go with an entry
suspended = False  # True while the bake plays frames only to read collider positions

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


def colliders(scene, coll, depsgraph=None):
    """float32 (n, 8) collider rows (kind, radius, a xyz, b xyz) of the objects in `coll`,
    fitted to their true shapes (collider_shapes.rows). Objects without extent (empties,
    cameras, lights) are skipped."""
    return collider_shapes.rows(scene, coll, depsgraph)


class Playback:
    """The live simulation of one meadow object: its Runner, the collider rows recorded per
    frame as frames are played, and snapshots of the solver state. `output` belongs to the
    mesh writer (writer.py), which makes it at the first write; it goes with the Playback."""

    def __init__(self, obj, scene, key):
        s = obj.tussock_meadow
        origin, size = build.area_of(obj, s)
        lib = native.require()
        patch = build.make_patch(s)
        meadow = build.make_meadow(s, origin, size)
        info = lib.meadow_info(meadow)
        self.instance_tile = np.empty(info["chunk_instances"], np.int32)  # tile of each
        lib.meadow_chunk_instances(meadow, None, None, self.instance_tile)  # chunk instance
        self.chunk_blades = int(info["chunk_blades"])  # blades per chunk instance
        self.area = (np.asarray(origin, np.float64), np.asarray(size, np.float64))
        blade_rand = np.empty(lib.patch_info(patch)["blade_count"], np.float32)
        lib.rand_fill(s.seed, build.BLADE_RAND_STREAM, blade_rand)
        k = lib.patch_info(patch)["knot_count"]
        self.runner = solver.Runner(
            patch, meadow, solver.sim_definition(s, info, k, wind_runtime.fps_of(scene)),
            blade_rand)
        self.key = key
        self.frame_start = scene.frame_start
        self.colliders = {}  # frame -> collider rows recorded when it was played
        self.snapshots = {}  # frame -> (solver clone, bytes)
        self.every = SNAPSHOT_EVERY
        self.wind_key = None
        self.stale = False  # the solver's state used colliders that have changed since
        self.restored_from = None  # frame the last jump back resumed from (tests, panel)
        self.output = None  # the mesh writer's state (writer.Output)

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
        self.snapshots[r.frame] = r.snapshot()
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
                r.step(f, self.colliders.get(f, solver.NO_COLLIDERS), fps, wind_at,
                       self.colliders.get(f - 1))
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
    return repr((build.patch_key(s), origin, size, sorted(solver.sim_settings(s).items()),
                 s.density, round(s.noise_scale, 6), s.noise_octaves,
                 round(s.noise_threshold, 6), image, s.blades_per_tile, s.chunk_blades,
                 scene.frame_start, solver.STEPS_PER_FRAME, s.sim_settle_time,
                 wind_runtime.fps_of(scene)))


def playback(obj, scene):
    """The meadow's live simulation, made (or made again, when its layout_key changed)."""
    key = layout_key(obj, scene)
    which = identity.key(obj)
    pb = _playbacks.get(which)
    if pb is None or pb.key != key:
        s = obj.tussock_meadow
        if obj.library is None and obj.get("tussock_patch_key") != build.patch_key(s):
            build.rebuild(obj)  # models changed: the instances grow what the solver does
        _playbacks.pop(which, None)  # the old solver, patch and snapshots go before the new come
        pb = Playback(obj, scene, key)
        _playbacks[which] = pb
    return pb


def playback_of(obj):
    """The live simulation (Playback) of meadow object `obj`, or None."""
    return _playbacks.get(identity.key(obj))


def live_count():
    """Meadows with a live simulation (a native solver, patch and snapshots each)."""
    return len(_playbacks)


forget = _playbacks.forget  # (obj=None): frees the live simulation of `obj`, or of every meadow
keep_only = _playbacks.keep_only  # (live): frees those of meadows whose keys are not in `live`


def simulate_to(obj, scene, frame, depsgraph=None):
    """Advances (or takes back) the meadow's simulation to `frame`; returns its Playback."""
    check_animation(obj)
    pb = playback(obj, scene)
    pb.record(frame, colliders(scene, obj.tussock_meadow.colliders, depsgraph))
    wind_key = wind_runtime.settings_key(scene)
    if wind_key != pb.wind_key:  # other wind: every snapshot is out of date
        pb.drop_snapshots()
        pb.stale = pb.wind_key is not None
        pb.wind_key = wind_key
    pb.go_to(frame, wind_runtime.fps_of(scene),
             lambda f, xyz: wind_runtime.sample(scene, f, xyz))
    return pb
