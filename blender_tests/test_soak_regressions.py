"""Failures the soak tester (tools/soak.py, issue 42) found, each kept as the short sequence
it shrank to: the steps an artist took, and the invariant they broke."""

import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import expect_cancel, test  # noqa: E402

import bpy  # noqa: E402

harness.enable_addon()

TMP = os.environ.get("TSK_TEST_TMP", "/tmp")
PICTURE = os.path.join(harness.REPO, "samples", "picture")


def saved_scene(name, frames=6):
    scene = harness.empty_scene(frames)
    folder = os.path.join(TMP, f"soak_{name}")
    os.makedirs(folder, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(folder, "soak.blend"))
    return scene, folder


def record_and_disk(folder):
    """(paths tussock_written.json lists, names in the cache folder)"""
    root = os.path.join(folder, "tussock_cache")
    try:
        with open(os.path.join(root, "tussock_written.json")) as f:
            listed = {p for paths in json.load(f).values() for p in paths}
    except FileNotFoundError:
        listed = set()
    disk = set(os.listdir(root)) - {"tussock_written.json"} if os.path.isdir(root) else set()
    return listed, disk


@test
def test_bake_of_a_meadow_nothing_touches_records_no_files_it_never_writes():
    # soak seed 101, shrunk to: save; add a simulated meadow whose colliders are an empty
    # collection; bake. The bake finished with nothing to write for the meadow, yet
    # tussock_written.json listed its folder, .pc2 and .layout.json.
    scene, folder = saved_scene("untouched_meadow")
    assert bpy.ops.tussock.add_meadow(size=(1.2, 2.8), blades_per_tile=32, patch_blades=1024,
                                      chunk_blades=16, density="NOISE") == {"FINISHED"}
    meadow = bpy.context.active_object
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    assert bpy.ops.tussock.add_tree(preset="quaking_aspen", leaves=False) == {"FINISHED"}
    assert bpy.ops.tussock.bake() == {"FINISHED"}
    listed, disk = record_and_disk(folder)
    assert listed == disk and disk, (sorted(listed), sorted(disk))
    assert not any(p.startswith("Meadow") for p in listed), sorted(listed)
    assert bpy.ops.tussock.free_bake() == {"FINISHED"}
    assert record_and_disk(folder) == (set(), set())


@test
def test_a_huge_picture_loop_is_limited_and_does_not_freeze_blender():
    # soak seed 102, shrunk to: animate the sample picture; set its Loop to 2**31 - 1 (at
    # the property's limit: it had none). The update stepped the wind 2**32 frames ahead of
    # the first frame, and Blender never came back.
    from tussock.picture.props import LOOP_FRAMES_MAX
    scene = harness.empty_scene(6)
    p = scene.tussock_picture
    p.filepath = os.path.join(PICTURE, "meadow.png")
    layer = p.layers.add()
    layer.name, layer.mask_path = "grass", os.path.join(PICTURE, "grass_mask.png")
    layer.cell_x = layer.cell_y = 32
    assert bpy.ops.tussock.animate_picture() == {"FINISHED"}
    scene.frame_set(3)
    t0 = time.monotonic()
    p.loop_frames = 2 ** 31 - 1
    secs = time.monotonic() - t0
    assert p.loop_frames == LOOP_FRAMES_MAX == 10000, p.loop_frames
    assert not p.last_error, p.last_error
    assert secs < 120, f"setting the loop took {secs:.0f} s"


@test
def test_a_meadow_from_blades_one_of_which_is_in_edit_mode_says_so():
    # soak seed 21 (in a window), shrunk to: capture blades; Tab into Edit Mode on one of
    # them; add a tree (now the active object, in Object Mode); add a meadow. Its blade
    # models were read from the mesh in Edit Mode, whose attributes read as empty: "Tussock
    # failed unexpectedly (RuntimeError: internal error setting the array)".
    harness.empty_scene(6)
    depth = os.path.join(harness.REPO, "samples", "blades", "depth_0001.png")
    assert bpy.ops.tussock.capture_blades(source="FILES", filepath=depth) == {"FINISHED"}
    blade = bpy.data.collections["Tussock Blades"].objects[1]
    harness.select_objects([blade])
    bpy.ops.object.mode_set(mode="EDIT")
    assert bpy.ops.tussock.add_tree(preset="weeping_willow", leaves=False) == {"FINISHED"}
    assert blade.data.is_editmode and bpy.context.mode == "OBJECT"
    expect_cancel(bpy.ops.tussock.add_meadow, f"'{blade.name}' is in Edit Mode",
                  size=(2.7, 3.5), blades_per_tile=32, patch_blades=1024, chunk_blades=16)
    harness.select_objects([blade])
    bpy.ops.object.mode_set(mode="OBJECT")
    harness.select_objects([])
    assert bpy.ops.tussock.add_meadow(size=(2.7, 3.5), blades_per_tile=32, patch_blades=1024,
                                      chunk_blades=16) == {"FINISHED"}


@test
def test_a_preset_that_cannot_be_posed_leaves_the_tree_as_it_was():
    # soak seed 200, shrunk to: a tree; a wind wave whose phase is at its limit (3.4e38,
    # which the native wind refuses); Apply Preset. The operator cancelled with the wind's
    # message, but the tree's parameters were already the preset's.
    scene = harness.empty_scene(6)
    assert bpy.ops.tussock.add_tree(preset="european_larch", seed=137,
                                    leaves=False) == {"FINISHED"}
    wave = scene.tussock_wind.waves.add()
    wave.phase = 3.4e38
    expect_cancel(bpy.ops.tussock.tree_apply_preset, "phase", preset="lombardy_poplar")
    wave.phase = 0.0
    assert bpy.ops.tussock.tree_apply_preset(preset="lombardy_poplar") == {"FINISHED"}


harness.main()
