"""The binding inside Blender: numpy float32 buffers go into C and back, results checked
against numpy; bad buffers raise tussock.Error naming the argument and Blender goes on."""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import test  # noqa: E402

import numpy as np  # noqa: E402

harness.enable_addon()
from tussock import native  # noqa: E402

lib = native.require()

M64 = np.uint64(0xFFFFFFFFFFFFFFFF)


def _mix(z):
    with np.errstate(over="ignore"):
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return z ^ (z >> np.uint64(31))


def numpy_rand01(seed, stream, n):
    """The counter-based generator written again in numpy, from its definition."""
    with np.errstate(over="ignore"):
        i = np.arange(n, dtype=np.uint64)
        h = _mix(np.full(n, np.uint64(seed) ^ np.uint64(0x9E3779B97F4A7C15)))
        h = _mix(h + np.uint64(stream))
        h = _mix(h + i + np.uint64(0x632BE59BD9B4E019))
        h = _mix(h + np.uint64(0) + np.uint64(0x8CB92BA72F3D8DD7))
    return ((h >> np.uint64(40)).astype(np.float64) / 16777216.0).astype(np.float32)


@test
def test_vec3_lengths_match_numpy():
    rng = np.random.default_rng(5)
    xyz = rng.normal(size=(10000, 3)).astype(np.float32)
    out = np.empty(10000, np.float32)
    lib.vec3_lengths(xyz, out)
    ref = np.linalg.norm(xyz.astype(np.float64), axis=1)
    assert np.max(np.abs(out - ref)) < 1e-6 * np.max(ref), np.max(np.abs(out - ref))


@test
def test_rand_fill_matches_numpy_definition():
    out = np.empty(50000, np.float32)
    lib.rand_fill(1234, 7, out)
    ref = numpy_rand01(1234, 7, 50000)
    assert np.array_equal(out, ref), np.flatnonzero(out != ref)[:5]


@test
def test_rand_fill_same_bytes_with_1_and_2_threads():
    a = np.empty(100003, np.float32)
    b = np.empty(100003, np.float32)
    lib.set_threads(1)
    lib.rand_fill(9, 1, a)
    lib.set_threads(2)
    lib.rand_fill(9, 1, b)
    lib.set_threads(0)
    assert a.tobytes() == b.tobytes()


def expect_error(fn, needle):
    try:
        fn()
    except lib.Error as exc:
        assert needle in str(exc), f"message {exc!r} lacks {needle!r}"
        assert isinstance(exc, RuntimeError)
        return
    raise AssertionError(f"no tussock.Error for {needle}")


@test
def test_wrong_dtype_raises_naming_argument():
    expect_error(lambda: lib.vec3_lengths(np.zeros(9, np.float64), np.zeros(3, np.float32)),
                 "xyz: must have dtype float32")
    expect_error(lambda: lib.vec3_lengths(np.zeros(9, np.float32), np.zeros(3, np.int32)),
                 "out: must have dtype float32")


@test
def test_non_contiguous_raises_naming_argument():
    xyz = np.zeros((6, 3), np.float32)[::2]
    expect_error(lambda: lib.vec3_lengths(xyz, np.zeros(3, np.float32)),
                 "xyz: must be C-contiguous")


@test
def test_too_short_raises_naming_argument():
    expect_error(lambda: lib.vec3_lengths(np.zeros(8, np.float32), np.zeros(3, np.float32)),
                 "xyz: must have exactly 9 elements, got 8")


@test
def test_read_only_output_raises_naming_argument():
    out = np.zeros(3, np.float32)
    out.setflags(write=False)
    expect_error(lambda: lib.vec3_lengths(np.zeros(9, np.float32), out), "out: must be writable")


@test
def test_not_a_buffer_raises_naming_argument():
    expect_error(lambda: lib.rand_fill(1, 2, [0.0, 1.0]), "out: expected a float32 array")


@test
def test_nan_input_reports_index():
    xyz = np.zeros(9, np.float32)
    xyz[4] = np.nan
    expect_error(lambda: lib.vec3_lengths(xyz, np.zeros(3, np.float32)), "vector 1 is not finite")


@test
def test_tree_mesh_edges_buffers_are_checked():
    """tree_mesh_edges writes 2 edges' worth per corner at most and one edge per corner:
    buffers of another size, type or a read-only one are refused by name."""
    tree = lib.tree_create(lib.tree_preset("quaking_aspen"))
    _, nq = lib.tree_mesh_count(tree, leaves=True)
    ok_e, ok_c = np.empty(nq * 8, np.int32), np.empty(nq * 4, np.int32)
    assert 0 < lib.tree_mesh_edges(tree, ok_e, ok_c, leaves=True) <= nq * 4
    expect_error(lambda: lib.tree_mesh_edges(tree, np.empty(nq * 8 - 1, np.int32), ok_c),
                 "edges: must have exactly")
    expect_error(lambda: lib.tree_mesh_edges(tree, ok_e, np.empty(nq * 4, np.float32)),
                 "corner_edges: must have dtype int32")
    ro = np.empty(nq * 4, np.int32)
    ro.setflags(write=False)
    expect_error(lambda: lib.tree_mesh_edges(tree, ok_e, ro), "corner_edges: must be writable")
    expect_error(lambda: lib.tree_mesh_edges(tree, ok_e, ok_c, around=[2, 3, 3, 3]),
                 "around")
    expect_error(lambda: lib.tree_mesh_edges("a tree", ok_e, ok_c), "tree")


@test
def test_ribbon_runs_buffers_are_checked():
    """blade_sim_ribbon_runs: int64 runs whose blades add up to the sides given; anything
    else is refused by name, and good runs give blade_sim_ribbons' bytes run by run."""
    K = 4
    sim = lib.blade_sim_create(tiles_x=2, tiles_y=1, knot_count=K, tile_size=1.0)
    lib.blade_sim_activate_tile(sim, 0)
    n = 40
    u = np.linspace(0.0, 0.3, K, dtype=np.float32)
    knots = np.zeros((n, K, 3), np.float32)
    knots[:, :, 0] = (np.arange(n, dtype=np.float32) / n)[:, None]
    knots[:, :, 1] = 0.5
    knots[:, :, 2] = u[None, :]
    widths = np.full(n * K, 0.01, np.float32)
    sides = np.tile(np.array([0.0, 1.0, 0.0], np.float32), n)
    lib.blade_sim_provide_tile(sim, 0, knots.ravel(), widths, sides)
    lib.blade_sim_step(sim, 1.0 / 48.0)
    every = np.empty(n * 2 * K * 3, np.float32)
    lib.blade_sim_ribbons(sim, 0, widths, sides, every)
    per = 2 * K * 3
    starts, counts = np.array([30, 2], np.int64), np.array([5, 3], np.int64)
    rows = np.r_[30:35, 2:5]
    out = np.empty(8 * per, np.float32)
    lib.blade_sim_ribbon_runs(sim, starts, counts, widths[:8 * K], sides[:8 * 3], out)
    assert np.array_equal(out.reshape(8, per), every.reshape(n, per)[rows])
    expect_error(lambda: lib.blade_sim_ribbon_runs(sim, starts.astype(np.int32), counts,
                                                   widths[:8 * K], sides[:24], out),
                 "starts: must have dtype int64")
    expect_error(lambda: lib.blade_sim_ribbon_runs(sim, starts, counts[:1], widths[:8 * K],
                                                   sides[:24], out), "counts: must have exactly 2")
    expect_error(lambda: lib.blade_sim_ribbon_runs(sim, starts, counts, widths[:8 * K],
                                                   sides[:21], out),
                 "counts: the runs' blades must add up to the 7 blades of sides")
    expect_error(lambda: lib.blade_sim_ribbon_runs(sim, starts, counts, widths[:9 * K],
                                                   sides[:27], out),
                 "counts: the runs hold 8 blades; sides has 9")
    expect_error(lambda: lib.blade_sim_ribbon_runs(sim, starts, np.array([5, -1], np.int64),
                                                   widths[:8 * K], sides[:24], out), "counts")
    expect_error(lambda: lib.blade_sim_ribbon_runs(sim, np.array([38, 2], np.int64), counts,
                                                   widths[:8 * K], sides[:24], out),
                 "run 0: 5 blades from blade 38 on")
    expect_error(lambda: lib.blade_sim_ribbon_runs(sim, starts, counts, widths[:8 * K],
                                                   sides[:24], out[:-1]), "positions")


@test
def test_blender_keeps_running_after_errors():
    import bpy
    for _ in range(100):
        try:
            lib.vec3_lengths(np.zeros(2, np.float64), np.zeros(1, np.float32))
        except lib.Error:
            pass
    bpy.ops.mesh.primitive_cube_add()
    assert bpy.context.active_object is not None
    assert lib.allocated_bytes() == 0


harness.main()
