"""The memory budget counts what Blender will hold, not only Tussock's buffers (issue 32,
item 3): a tree mesh or a meadow whose estimate (Tussock's and Blender's, addon/budget.py)
exceeds what one object may take (half the budget) is refused with a message, in well under
a second's native work, before OpenSubdiv or Blender start on it, and the scene stays as it
was."""

import os
import sys
import time
import types

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import expect_cancel, test  # noqa: E402

import bpy  # noqa: E402

harness.enable_addon()
from tussock import budget, native  # noqa: E402

lib = native.require()
ops = bpy.ops.tussock
GIB = 1 << 30
# 250 m x 250 m of 0.25 m tiles, 64 blades each in chunks of 16: 64,000,000 blades in
# 4,000,000 instances (the meadow of issue 32, whose 32x32 render peaked at 5 GB)
MEADOW_64M = dict(size=(250.0, 250.0), tile_size=0.25, blades_per_tile=64, chunk_blades=16,
                  density="UNIFORM")


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    lib.set_memory_budget(0)  # the default: half of the machine's memory


def timed(fn, *args, **kwargs):
    t = time.perf_counter()
    fn(*args, **kwargs)
    return time.perf_counter() - t


@test
def test_the_willow_at_smooth_3_is_refused_at_once_with_the_default_budget():
    fresh()
    assert 8 * GIB < lib.memory_budget() <= 16 * GIB, lib.memory_budget()  # a 24 GiB machine
    try:
        ops.add_tree(preset="weeping_willow", smooth_levels=3)
    except RuntimeError as exc:
        msg = str(exc)
    else:
        raise AssertionError("the willow at Smooth 3 was built")
    assert "memory budget" in msg and "Blender" in msg and "lower Smooth" in msg, msg
    secs = timed(expect_cancel, ops.add_tree, "memory budget", preset="weeping_willow",
                 smooth_levels=3)
    assert secs < 3.0, secs  # it froze Blender for 43 s and more before


@test
def test_a_tree_set_to_smooth_3_keeps_its_mesh_and_says_why():
    fresh()
    assert ops.add_tree(preset="weeping_willow", smooth_levels=0) == {"FINISHED"}
    tree = bpy.context.active_object
    s = tree.tussock_tree
    vertices = len(tree.data.vertices)
    assert vertices > 1_900_000, vertices
    t = time.perf_counter()
    s.smooth_levels = 3  # the panel's setting
    secs = time.perf_counter() - t
    assert "memory budget" in s.last_error, s.last_error
    assert len(tree.data.vertices) == vertices
    assert secs < 3.0, secs


@test
def test_ordinary_trees_and_meadows_are_accepted_with_the_default_budget():
    fresh()
    for preset, smooth in (("quaking_aspen", 2), ("weeping_willow", 0)):
        assert ops.add_tree(preset=preset, smooth_levels=smooth) == {"FINISHED"}, preset
    assert ops.add_meadow(size=(10.0, 10.0)) == {"FINISHED"}
    assert ops.add_meadow(size=(60.0, 60.0), density="UNIFORM") == {"FINISHED"}
    assert bpy.context.active_object["tussock_instances"] == 230400


@test
def test_the_64M_blade_meadow_counts_what_blender_holds_for_it():
    fresh()
    # the estimate: Blender's ~1.7 KB per instance dwarfs Tussock's own ~45 B
    tussock = 1_000_000 * budget.TUSSOCK_PER_TILE + 4_000_000 * budget.TUSSOCK_PER_INSTANCE
    blender = 4_000_000 * budget.BLENDER_PER_INSTANCE
    assert tussock < 256 << 20 and blender > 6 * GIB, (tussock, blender)
    # under a budget that Tussock's buffers alone fit in many times over (an 8 GiB machine),
    # the meadow is refused with both parts named, at once, the scene unchanged
    lib.set_memory_budget(4 * GIB)
    try:
        secs = timed(expect_cancel, ops.add_meadow, "memory budget", **MEADOW_64M)
        try:
            ops.add_meadow(**MEADOW_64M)
        except RuntimeError as exc:
            assert "64,000,000 blades in 4,000,000 instances" in str(exc), exc
            assert "Blender" in str(exc) and "cover less ground" in str(exc), exc
    finally:
        lib.set_memory_budget(0)
    assert secs < 5.0, secs
    assert not any(o.get("tussock_meadow_object") for o in bpy.data.objects)
    # and with this machine's default budget (a 6 GiB share for one object on 24 GiB) too
    assert lib.memory_budget() * budget.OBJECT_SHARE < tussock + blender
    secs = timed(expect_cancel, ops.add_meadow, "one object may take", **MEADOW_64M)
    assert secs < 5.0, secs
    assert not any(o.get("tussock_meadow_object") for o in bpy.data.objects)
    # a quarter of it (16M blades) fits, but not silently: Add Meadow's report says how
    # much memory it will hold
    from tussock.meadow import build
    size = (125.0, 125.0)
    settings = types.SimpleNamespace(ground=None, models=None, density_image=None,
                                     **{k: v for k, v in MEADOW_64M.items() if k != "size"},
                                     patch_blades=16384, scale_min=0.8, scale_max=1.2,
                                     noise_scale=8.0, noise_octaves=3,
                                     noise_threshold=0.2, seed=1, display=0.25)
    layout = build.compute_layout(settings, (0.0, 0.0, 0.0), size)
    assert layout["info"]["blade_count"] == 16_000_000
    note = budget.note(layout["memory"])
    assert "it will hold about 2,0" in note and "% of what one object may take" in note, note


@test
def test_a_meadow_grown_over_the_budget_by_a_setting_keeps_its_instances():
    fresh()
    assert ops.add_meadow(size=(20.0, 20.0), density="UNIFORM") == {"FINISHED"}
    meadow = bpy.context.active_object
    s = meadow.tussock_meadow
    instances = meadow["tussock_instances"]
    lib.set_memory_budget(64 << 20)
    try:
        # 4x the instances (chunks of 1 would be more chunk objects than a meadow may have):
        # over a 64 MiB budget with Blender's part
        s.chunk_blades = 4
    finally:
        lib.set_memory_budget(0)
    assert "memory budget" in s.last_error and "Blender" in s.last_error, s.last_error
    assert meadow["tussock_instances"] == instances
    assert len(meadow.data.vertices) == instances


if __name__ == "__main__":
    harness.main()
