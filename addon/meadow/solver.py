"""The blade solver's driver, with no Blender data (seed 000 §4.5 with Han & Harada's solver):
Runner steps one meadow's simulation from frame to frame with the colliders and wind of each
frame, giving tiles their rest blades as colliders wake them up. Playback (playback.py) and
the bake (baking.py) both use it, so a frame has the same bytes either way; it imports no bpy,
so tests run it under plain Python (tests/test_runner.py). The collider fitting is here too:
pure numpy on bounds that the caller reads from Blender."""

import math

import numpy as np

from .. import native

STEPS_PER_FRAME = 2  # solver steps per frame, more at low frame rates (steps_per_frame)
MAX_STEP_SECONDS = 1.0 / 20.0  # a step is never longer
MAX_STEPS_PER_FRAME = 240  # below 1/12 fps a frame would take more: refused with a message
TSK_MAX_COLLIDERS = 4096  # TSK_BLADE_SIM_MAX_COLLIDERS (tussock/sim.h)
NO_COLLIDERS = np.zeros((0, 8), np.float32)


def sim_settings(s):
    return dict(iterations=s.sim_iterations, damping=s.sim_damping,
                global_stiffness_root=s.sim_stiffness, local_stiffness=s.sim_local_stiffness)


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


def fit_collider(matrix, corners, sphere):
    """One collider row (kind, radius, a xyz, b xyz) fitted to an object's bounds: `corners`
    (8, 3) in object space, placed by `matrix` (4, 4): a sphere when `sphere` (a sphere
    rigid body) or the bounds are round, else a capsule along the longest axis. None for
    bounds without extent (an empty, camera, light, empty mesh); NaN bounds give a row,
    which the native check reports."""
    m = np.asarray(matrix, np.float64)
    corners = np.asarray(corners, np.float64)
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    centre = m[:3, :3] @ ((lo + hi) / 2) + m[:3, 3]
    axes = m[:3, :3] * ((hi - lo) / 2)[None, :]  # columns: half-extent vectors
    half = np.linalg.norm(axes, axis=0)
    if half.max() == 0.0:
        return None
    order = np.argsort(half)
    if sphere or half[order[2]] < 1.5 * half[order[1]]:
        return (0, half.max(), *centre, *centre)
    r = half[order[1]]
    d = axes[:, order[2]] / half[order[2]] * max(half[order[2]] - r, 0.0)
    return (1, r, *(centre - d), *(centre + d))


def collider_rows(rows):
    """float32 (n, 8) from fit_collider's rows (None ones left out)."""
    return np.array([r for r in rows if r is not None], np.float32).reshape(-1, 8)


MAX_SWEEP_COPIES = 16  # in-between copies of one capsule in one solver step


def substep_rows(before, rows, steps):
    """The collider rows of each of a frame's `steps` solver steps, swept from `before` (the
    rows of the frame before, or None) to `rows`: a foot that moves farther than its own
    size in a frame must still push every blade on its way, not jump over them. Step i
    holds the shapes where they are at the end of the step (moved linearly) together with
    the volume they swept during it: a moving sphere becomes the capsule between its two
    centres (exactly the volume it sweeps), and a capsule that moves more than its radius
    gets copies at in-between positions, at most its radius apart (so no point of its path
    is farther than half a radius from a copy's axis). Rows whose kind changed between the
    frames, or all of them when the count changed, are not swept. Elementwise float64
    arithmetic rounded to float32 once: the same bytes on every machine."""
    rows = np.asarray(rows, np.float32).reshape(-1, 8)
    if before is None or len(rows) == 0 or np.shape(before) != rows.shape:
        return [rows] * steps
    b = np.asarray(before, np.float64)
    r = rows.astype(np.float64)
    same = b[:, 0] == r[:, 0]
    b[~same] = r[~same]
    out = []
    for i in range(steps):  # a few solver steps per frame
        p0 = b + (r - b) * (i / steps)
        p1 = b + (r - b) * ((i + 1) / steps)
        p1[:, 0] = r[:, 0]
        move = np.linalg.norm(p1[:, 2:5] - p0[:, 2:5], axis=1)  # (a sphere's b is unused)
        move = np.where(r[:, 0] == 0, move,
                        np.maximum(move, np.linalg.norm(p1[:, 5:8] - p0[:, 5:8], axis=1)))
        now = p1.copy()
        sphere = (r[:, 0] == 0) & (move > 0)
        now[sphere, 0] = 1  # sphere -> capsule from its centre before to its centre now
        now[sphere, 2:5] = p0[sphere, 2:5]
        now[sphere, 5:8] = p1[sphere, 2:5]
        capsule = r[:, 0] == 1
        copies = np.zeros(len(r), np.int64)
        with np.errstate(divide="ignore", invalid="ignore"):
            need = np.ceil(move / p1[:, 1]) - 1
        copies[capsule] = np.clip(np.nan_to_num(need[capsule], nan=0.0, posinf=0.0), 0,
                                  MAX_SWEEP_COPIES)
        if copies.sum() + len(r) > TSK_MAX_COLLIDERS:
            copies[:] = 0  # too many shapes to sweep them all: none is swept
        idx = np.repeat(np.arange(len(r)), copies)
        if len(idx):
            first = np.repeat(np.cumsum(copies) - copies, copies)
            j = np.arange(len(idx)) - first + 1  # 1..copies for each swept row
            f = (j / (copies[idx] + 1.0))[:, None]
            extra = p0[idx] + (p1[idx] - p0[idx]) * f
            extra[:, 0] = 1
            now = np.concatenate([now, extra])
        out.append(now.astype(np.float32))
    return out


class Runner:
    """One meadow's simulation without any Blender data: the native patch and meadow layout
    give the rest blades of tiles as they wake up, and the solver steps them with the
    colliders and wind of each frame. Wind is sampled once per blade, at its root (the wind
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

    def snapshot(self):
        """(a clone of the solver now, its state's bytes): what resume() continues from."""
        clone = self.lib.blade_sim_clone(self.sim)
        return clone, self.lib.blade_sim_info(clone)["state_bytes"]

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

    def step(self, frame, rows, fps, wind_at, before=None):
        """Steps from frame - 1 to `frame` with the collider rows of `frame`, swept from
        `before`, those of frame - 1 (substep_rows; None: not swept), and the wind
        wind_at(frame, xyz (n, 3)) -> (n, 3) m/s."""
        steps = steps_per_frame(fps)
        lib, sim = self.lib, self.sim
        dt = 1.0 / fps / steps
        n = None
        for sub in substep_rows(before, rows, steps):
            lib.blade_sim_set_colliders(sim, np.ascontiguousarray(sub).ravel())
            self._provide_pending()
            if lib.blade_sim_info(sim)["active_blades"] != n:  # tiles woke up or were released
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
