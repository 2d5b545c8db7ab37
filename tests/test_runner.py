"""The meadow's solver driver (addon/meadow/solver.py) under plain Python, without Blender:
numpy and the built addon/_tussock.abi3.so only. Run by ./build.sh test, or alone:
    /usr/bin/python3 tests/test_runner.py [NAME...]"""

import math
import os
import sys
import types

import numpy as np

ADDON = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "addon")
# the add-on's package without its __init__ (which registers with Blender)
_pkg = types.ModuleType("tussock")
_pkg.__path__ = [os.path.abspath(ADDON)]
sys.modules.setdefault("tussock", _pkg)

from tussock import native  # noqa: E402
from tussock.meadow import solver  # noqa: E402
import harness  # noqa: E402

FPS = 24.0
FRAMES = 24
# a meadow's default solver settings (addon/meadow/props.py)
SETTINGS = types.SimpleNamespace(sim_iterations=4, sim_damping=4.0, sim_stiffness=30.0,
                                 sim_local_stiffness=120.0, sim_settle_time=2.5)


def make_runner():
    """A 3 m x 2 m meadow of 0.25 m tiles, 64 blades each, of a 4,096-blade patch."""
    lib = native.require()
    patch = lib.patch_create(blade_count=4096, scale_min=0.8, scale_max=1.2, seed=1)
    meadow = lib.meadow_create(origin=(0.0, 0.0, 0.0), size=(3.0, 2.0), tile_size=0.25,
                               blades_per_tile=64, patch_blades=4096, chunk_blades=16, seed=1,
                               density="uniform", noise_scale=8.0, noise_octaves=3,
                               noise_threshold=0.2, image=None, image_width=0, image_height=0)
    info = lib.meadow_info(meadow)
    k = lib.patch_info(patch)["knot_count"]
    rand = np.empty(lib.patch_info(patch)["blade_count"], np.float32)
    lib.rand_fill(1, 0x636F6C6F72, rand)
    return solver.Runner(patch, meadow, solver.sim_definition(SETTINGS, info, k, FPS), rand)


def ball(frame):
    """A 0.3 m ball rolling along x (at y = 1 m) through the meadow, half sunk into the
    blades."""
    x = 0.2 + 2.6 * (frame - 1) / (FRAMES - 1)
    return np.array([[0, 0.3, x, 1.0, 0.2, x, 1.0, 0.2]], np.float32)


def breeze(frame, xyz):
    return np.tile(np.array([1.5, 0.5 * math.sin(frame / 4.0), 0.0], np.float32), (len(xyz), 1))


def play(runner, first, last):
    for f in range(first + 1, last + 1):
        runner.step(f, ball(f), FPS, breeze)


def test_runner_steps_each_frame_in_steps_per_frame_solver_steps():
    """A frame of the Runner is STEPS_PER_FRAME native steps of 1 / (fps * steps) seconds
    with the wind at each active blade's root: a solver driven so by hand gives the same
    bytes, and one driven with one step more per frame does not."""
    runner = make_runner()
    runner.restart(1)
    play(runner, 1, 12)
    got = runner.knots()
    tiles, counts = runner.active()
    assert len(tiles) >= 4 and counts.sum() >= 4 * 64, (tiles, counts)

    def by_hand(steps):
        lib = native.require()
        ref = make_runner()
        sim = lib.blade_sim_create(**ref.definition)
        for f in range(2, 13):
            lib.blade_sim_set_colliders(sim, ball(f).ravel())
            n = lib.blade_sim_pending(sim)
            pending = np.empty(n, np.int32)
            if n:
                lib.blade_sim_pending(sim, pending)
            for t in pending:
                knots, widths, sides, _ = ref.rest_blades(int(t))
                lib.blade_sim_provide_tile(sim, int(t), knots, widths, sides)
                ref.tiles[int(t)] = (None, None, None,
                                     knots.reshape(-1, ref.K, 3)[:, 0, :].copy())
            for _ in range(steps):
                info = lib.blade_sim_info(sim)
                active = np.empty(info["active_tiles"], np.int32)
                if len(active):
                    lib.blade_sim_get_active(sim, active, np.empty(len(active), np.int32))
                roots = ref.per_blade(active, 3)
                wind = np.ascontiguousarray(breeze(f, roots), np.float32).ravel() \
                    if len(roots) else None
                lib.blade_sim_step(sim, 1.0 / FPS / steps, wind, 2 if len(roots) else 0)
        out = np.empty(lib.blade_sim_info(sim)["active_blades"] * ref.K * 3, np.float32)
        lib.blade_sim_get_knots(sim, out)
        return out

    assert solver.steps_per_frame(FPS) == solver.STEPS_PER_FRAME == 2
    assert got.tobytes() == by_hand(2).tobytes()
    other = by_hand(3)
    assert other.shape != got.shape or np.abs(other - got).max() > 1e-6


def test_resumed_snapshot_gives_the_same_bytes():
    """Frames 10..24 played again from a snapshot of frame 10 (as playback does when the
    artist jumps back) are the bytes of the run that went through without stopping; the
    snapshot itself stays as it was taken."""
    runner = make_runner()
    runner.restart(1)
    play(runner, 1, 10)
    snap, size = runner.snapshot()
    at_10 = runner.knots()
    assert size > at_10.nbytes, size  # the state holds more than the knots
    play(runner, 10, FRAMES)
    straight = runner.knots()
    assert len(straight) != len(at_10) or np.abs(straight - at_10).max() > 1e-3

    runner.resume(snap, 10)
    assert runner.frame == 10 and runner.knots().tobytes() == at_10.tobytes()
    play(runner, 10, FRAMES)
    assert runner.knots().tobytes() == straight.tobytes()
    runner.resume(snap, 10)  # the snapshot was not stepped by the run resumed from it
    assert runner.knots().tobytes() == at_10.tobytes()


def test_blades_the_ball_passed_differ_from_rest_and_far_ones_sleep():
    """Halfway, the awake tiles lie along the ball's path so far (y = 1 m, x up to about
    1.5 m), and their blades are bent away from their rest knots."""
    runner = make_runner()
    runner.restart(1)
    play(runner, 1, 12)
    tiles, counts = runner.active()
    tx, ty = tiles % 12, tiles // 12  # 12 tiles across 3 m, 8 along 2 m
    assert 8 <= len(tiles) < 48, tiles
    assert (ty.min() * 0.25 > 1.0 - 0.3 - 0.25 - 1e-6
            and (ty.max() + 1) * 0.25 < 1.0 + 0.3 + 0.25 + 1e-6), ty
    assert tx.max() * 0.25 < 0.2 + 2.6 * 11 / 23 + 0.3 + 0.25 + 1e-6, tx  # none far ahead
    rest = np.concatenate([runner.rest_blades(t)[0] for t in tiles])
    moved = np.abs(runner.knots() - rest).reshape(-1, runner.K, 3)[:, -1, :].max(axis=1)
    assert (moved > 0.01).mean() > 0.2, (moved > 0.01).mean()  # tips bent a centimetre on


def test_colliders_fit_spheres_and_capsules():
    """Round bounds and sphere rigid bodies give spheres of the largest half-extent; long
    bounds a capsule along the longest axis, of the middle half-extent; no extent, none."""
    cube = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
    move = np.identity(4)
    move[:3, 3] = (2.0, 3.0, 0.5)
    row = solver.fit_collider(move, cube * 0.5, False)
    assert row[0] == 0 and math.isclose(row[1], 0.5) and row[2:5] == (2.0, 3.0, 0.5)
    stick = cube * np.array([2.0, 0.25, 0.1])  # 4 m long along x, 0.5 m wide
    turn = np.identity(4)
    turn[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]  # x becomes y
    row = solver.fit_collider(turn, stick, False)
    assert row[0] == 1 and math.isclose(row[1], 0.25)
    assert np.allclose(row[2:5], (0, -1.75, 0)) and np.allclose(row[5:8], (0, 1.75, 0))
    row = solver.fit_collider(turn, stick, True)  # a sphere rigid body
    assert row[0] == 0 and math.isclose(row[1], 2.0)
    assert solver.fit_collider(move, np.zeros((8, 3)), False) is None
    rows = solver.collider_rows([None, solver.fit_collider(move, cube, False)])
    assert rows.shape == (1, 8) and rows.dtype == np.float32


def dash(frame):
    """A 0.1 m ball rolling 0.5 m a frame (12 m/s) along y = 1 m, sunk into the blades."""
    x = 0.25 + 0.5 * (frame - 1)
    return np.array([[0, 0.1, x, 1.0, 0.08, x, 1.0, 0.08]], np.float32)


def test_a_fast_ball_pushes_every_blade_on_its_way():
    """A ball that moves five times its size per frame bends the blades between the places
    where the frames show it, as much as those at them: without the sweep (before=None)
    no blade between them moves, which is what the sweep is for."""
    def moved_on_the_way(sweep):
        runner = make_runner()
        runner.restart(1)
        for f in range(2, 7):
            runner.step(f, dash(f), FPS, lambda f, xyz: np.zeros_like(xyz),
                        dash(f - 1) if sweep else None)
        tiles, _ = runner.active()
        rest = np.concatenate([runner.rest_blades(t)[0] for t in tiles]).reshape(-1, runner.K, 3)
        moved = np.abs(runner.knots().reshape(-1, runner.K, 3) - rest).max(axis=(1, 2))
        roots = rest[:, 0, :]
        # rooted on the path (within half the ball's radius of its line), frames 1..6
        on_path = (np.abs(roots[:, 1] - 1.0) < 0.05) & (roots[:, 0] > 0.3) & (roots[:, 0] < 2.7)
        between = on_path & (np.abs((roots[:, 0] - 0.25) % 0.5 - 0.25) < 0.06)
        assert between.sum() >= 30, between.sum()
        return (moved[between] > 0.02).mean(), (moved[on_path & ~between] > 0.02).mean()

    between, at = moved_on_the_way(True)
    assert between > 0.7 and at > 0.7, (between, at)
    between, at = moved_on_the_way(False)
    assert between < 0.05, between


def test_swept_rows_cover_the_path_and_end_where_the_frame_is():
    """substep_rows: still shapes are the frame's rows in every step (the same bytes); a
    moving sphere is, in each step, the capsule between its centres at the step's start and
    end; a moving capsule gets copies at most its radius apart; the last step ends at the
    frame's rows; rows that change kind, or a changed count, are not swept."""
    still = np.array([[0, 0.2, 1, 1, 0.1, 1, 1, 0.1], [1, 0.1, 0, 0, 0, 0, 1, 0]], np.float32)
    for sub in solver.substep_rows(still, still, 2):
        assert sub.tobytes() == still.tobytes()
    after = still.copy()
    after[0, 2] += 1.0  # the sphere moves 1 m along x
    after[1, 2:8] += [0, 2.0, 0, 0, 2.0, 0]  # the capsule (radius 0.1) moves 2 m along y
    subs = solver.substep_rows(still, after, 2)
    assert len(subs) == 2
    s0, s1 = subs
    assert s0[0, 0] == 1 and s0[0, 2] == 1.0 and s0[0, 5] == 1.5  # capsule x 1 -> 1.5
    assert s1[0, 0] == 1 and s1[0, 2] == 1.5 and s1[0, 5] == 2.0
    assert s1[1].tobytes() == after[1].tobytes()  # the capsule where the frame has it
    for i, sub in enumerate(subs):  # copies at most a radius apart along its 1 m a step
        caps = sub[1:]
        assert len(caps) == 10 and (caps[:, 0] == 1).all(), len(caps)
        ys = np.sort(caps[:, 3])
        assert math.isclose(ys[0], i + 0.1, abs_tol=1e-6) and ys[-1] == i + 1.0, ys
        assert np.diff(ys).max() <= 0.1 + 1e-6, np.diff(ys)
    changed = after.copy()
    changed[0, 0] = 1  # the sphere became a capsule: not swept
    assert solver.substep_rows(still, changed, 2)[0][0].tobytes() == changed[0].tobytes()
    for sub in solver.substep_rows(still[:1], after, 2):  # a row more: nothing swept
        assert sub.tobytes() == after.tobytes()
    for sub in solver.substep_rows(None, after, 3):
        assert sub.tobytes() == after.tobytes()
    many = np.tile(still[1:], (3000, 1))  # 3,000 capsules that each need copies: too many
    moved = many.copy()
    moved[:, 3] += 1.0
    assert all(len(sub) == 3000 for sub in solver.substep_rows(many, moved, 2))


def test_steps_per_frame_follow_the_frame_rate():
    assert [solver.steps_per_frame(f) for f in (60, 24, 10, 5, 1)] == [2, 2, 2, 4, 20]
    for bad in (0.05, 0.0, float("nan"), -24.0):
        try:
            solver.steps_per_frame(bad)
        except ValueError as exc:
            assert "fps" in str(exc)
        else:
            raise AssertionError(bad)


if __name__ == "__main__":
    sys.exit(harness.run(globals()))
