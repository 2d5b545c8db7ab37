"""Refining in Blender: captured blades refined with tracked and simulated movement keep
root and tip, get exactly m knots that each stand for a contiguous run of the original
knots, keep positive widths, can be refined again from the full mesh, and bad input
cancels with the scene unchanged."""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import expect_cancel, test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

harness.enable_addon()
from tussock.capture import blades  # noqa: E402

SAMPLE = os.path.join(harness.REPO, "samples", "blades", "depth_####.png")


def captured():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    assert bpy.ops.tussock.capture_blades(source="FILES", filepath=SAMPLE) == {"FINISHED"}
    objs = sorted(bpy.data.collections["Tussock Blades"].objects, key=lambda o: o.name)
    full = {}
    for o in objs:
        n = len(o.data.vertices)
        co = np.empty(n * 3, np.float32)
        o.data.vertices.foreach_get("co", co)
        full[o.name] = co.reshape(-1, 3)
    return objs, full


def read(obj, name, width=3, dtype=np.float32):
    n = len(obj.data.vertices)
    a = np.empty(n * width, dtype)
    attr = obj.data.attributes[name]
    attr.data.foreach_get("vector" if width == 3 else "value", a)
    return a.reshape(-1, width) if width > 1 else a


def check_refined(objs, full, m):
    for o in objs:
        assert len(o.data.vertices) == m, (o.name, len(o.data.vertices))
        co = np.empty(m * 3, np.float32)
        o.data.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        src = full[o.name]
        assert np.allclose(co[0], src[0], atol=1e-6), (co[0], src[0])      # root kept
        assert np.allclose(co[-1], src[-1], atol=1e-5), (co[-1], src[-1])  # tip kept
        w = read(o, "width", 1)
        assert np.all(w > 0)
        first = read(o, "source_first", 1, np.int32)
        count = read(o, "source_count", 1, np.int32)
        # contiguous runs that partition the original knots: only adjacent knots merged
        assert first[0] == 0 and np.all(first[1:] == first[:-1] + count[:-1])
        assert first[-1] + count[-1] == len(src) and np.all(count >= 1)
        assert o.modifiers.get("Tussock Ribbon") is not None


@test
def test_tracked_refine_keeps_root_tip_and_partitions_knots():
    objs, full = captured()
    assert bpy.ops.tussock.refine_blades(knots="16", movement="TRACKED", frames=12) == {"FINISHED"}
    check_refined(objs, full, 16)
    assert all(o["tussock_refine_movement"] == "TRACKED" for o in objs)
    # camera_co stays the rigid image of the local knots
    for o in objs:
        cam = read(o, "camera_co")
        co = np.empty(len(o.data.vertices) * 3, np.float32)
        o.data.vertices.foreach_get("co", co)
        back = (cam - cam[0]) @ blades.CAMERA_TO_WORLD.T
        assert np.allclose(back, co.reshape(-1, 3), atol=1e-5)


@test
def test_simulated_refine_and_refine_again_from_full_mesh():
    objs, full = captured()
    target = objs[:2]
    for o in objs:
        o.select_set(o in target)
    assert bpy.ops.tussock.refine_blades(knots="8", movement="SIMULATED", frames=6) == {"FINISHED"}
    check_refined(target, full, 8)
    # refining again to more knots starts from the full-resolution mesh
    assert bpy.ops.tussock.refine_blades(custom_knots=20, movement="TRACKED",
                                         frames=4) == {"FINISHED"}
    check_refined(target, full, 20)
    assert all(len(o.data.vertices) > 20 for o in objs[2:])  # unselected ones untouched


@test
def test_uniform_method_spaces_knots_evenly():
    objs, full = captured()
    assert bpy.ops.tussock.refine_blades(knots="8", method="UNIFORM") == {"FINISHED"}
    for o in objs:
        co = np.empty(8 * 3, np.float32)
        o.data.vertices.foreach_get("co", co)
        seg = np.linalg.norm(np.diff(co.reshape(-1, 3), axis=0), axis=1)
        src = full[o.name]
        length = np.linalg.norm(np.diff(src, axis=0), axis=1).sum()
        assert np.allclose(co.reshape(-1, 3)[[0, -1]], src[[0, -1]], atol=1e-5)
        # evenly spaced along the arc: chords within 2 % of length / 7
        assert np.all(np.abs(seg - length / 7) < 0.02 * length / 7), (seg, length / 7)
        assert o["tussock_refine_method"] == "UNIFORM" and "source_first" not in o.data.attributes


@test
def test_bad_input_cancels_with_scene_unchanged():
    objs, _ = captured()
    op = bpy.ops.tussock.refine_blades
    for o in objs:
        o.select_set(False)
    expect_cancel(op, "select one or more Tussock blades")
    cube = bpy.data.objects.new("cube", bpy.data.meshes.new("cube"))
    bpy.context.scene.collection.objects.link(cube)
    cube.select_set(True)
    expect_cancel(op, "select one or more Tussock blades")
    cube.select_set(False)
    objs[0].select_set(True)
    expect_cancel(op, "target_knots", custom_knots=1)
    expect_cancel(op, "frames", movement="TRACKED", frames=500)
    # a blade made by hand has no capture to track
    mesh = blades.blade_mesh("hand", np.array([[0, 0, 0], [0, 0, 0.1], [0, 0, 0.2]], np.float32),
                             np.array([0.01, 0.008, 0.002], np.float32),
                             np.zeros((3, 3), np.float32))
    hand = bpy.data.objects.new("hand", mesh)
    bpy.context.scene.collection.objects.link(hand)
    objs[0].select_set(False)
    hand.select_set(True)
    expect_cancel(op, "not captured", movement="TRACKED")
    # duplicate knots: the native check names them
    mesh2 = blades.blade_mesh("dup", np.array([[0, 0, 0], [0, 0, 0], [0, 0, 0.2]], np.float32),
                              np.array([0.01, 0.008, 0.002], np.float32),
                              np.zeros((3, 3), np.float32))
    dup = bpy.data.objects.new("dup", mesh2)
    bpy.context.scene.collection.objects.link(dup)
    hand.select_set(False)
    dup.select_set(True)
    expect_cancel(op, "duplicate knot", movement="SIMULATED", custom_knots=2, frames=2)


harness.main()
