"""Meadows in Blender: instance and blade counts follow the density map, seeds are
reproducible, widths follow the models, and bad input cancels with the scene unchanged."""

import hashlib
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import expect_cancel, test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

harness.enable_addon()
from tussock import native  # noqa: E402

lib = native.require()


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()


def add_meadow(**kw):
    kw.setdefault("size", (4.0, 3.0))
    kw.setdefault("display", 1.0)
    assert bpy.ops.tussock.add_meadow(**kw) == {"FINISHED"}
    return bpy.context.active_object


def render_instances(obj):
    """(chunk object names, matrices) of the meadow's instances as a render sees them."""
    dg = bpy.context.evaluated_depsgraph_get()
    names, mats = [], []
    for inst in dg.object_instances:
        if inst.is_instance and inst.parent is not None and inst.parent.original == obj:
            names.append(inst.object.original.name)
            mats.append(np.array(inst.matrix_world, np.float64))
    return names, np.array(mats)


@test
def test_instance_count_follows_density_map():
    fresh()
    obj = add_meadow(tile_size=0.25, blades_per_tile=64, chunk_blades=16, seed=3)
    s = obj.tussock_meadow
    origin, size = tuple(obj["tussock_origin"]), tuple(obj["tussock_size"])
    # the density of every tile, then the count formula applied here in numpy
    m = lib.meadow_create(origin=origin, size=size, tile_size=s.tile_size,
                          blades_per_tile=s.blades_per_tile, patch_blades=s.patch_blades,
                          chunk_blades=s.chunk_blades, seed=s.seed, density="noise",
                          noise_scale=s.noise_scale, noise_octaves=s.noise_octaves,
                          noise_threshold=s.noise_threshold)
    info = lib.meadow_info(m)
    density = np.empty(info["tile_count"], np.float32)
    lib.meadow_tiles(m, None, None, density)
    c = s.chunk_blades
    expected = c * np.minimum(np.floor(s.blades_per_tile * density / c + 0.5),
                              s.blades_per_tile // c)
    names, _ = render_instances(obj)
    assert len(names) * c == int(expected.sum()) == obj["tussock_blades"], \
        (len(names) * c, expected.sum(), obj["tussock_blades"])
    assert 0 < obj["tussock_blades"] < info["tile_count"] * 64  # noise leaves bare ground
    # every instanced chunk holds exactly C blades of 2(K-1) triangles
    tri = sum(len(bpy.data.objects[n].data.polygons) for n in set(names))
    per_chunk = {len(bpy.data.objects[n].data.polygons) for n in set(names)}
    assert per_chunk == {c * 2 * 15}, per_chunk  # default blade: 16 knots
    assert tri > 0


def geometry_digest(obj):
    names, mats = render_instances(obj)
    h = hashlib.sha256()
    h.update("|".join(n.split(" chunk ")[1] for n in names).encode())
    h.update(np.round(mats, 6).tobytes())
    coll = bpy.data.collections[f"{obj.name} patch"]
    for o in sorted(coll.objects, key=lambda o: o.name):
        co = np.empty(len(o.data.vertices) * 3, np.float32)
        o.data.vertices.foreach_get("co", co)
        h.update(co.tobytes())
    return h.hexdigest()


@test
def test_same_seed_same_geometry_other_seed_differs():
    fresh()
    a = geometry_digest(add_meadow(seed=11))
    fresh()
    b = geometry_digest(add_meadow(seed=11))
    fresh()
    c = geometry_digest(add_meadow(seed=12))
    assert a == b
    assert a != c


@test
def test_tile_offsets_same_with_1_and_2_threads():
    out = []
    for threads in (1, 2):
        lib.set_threads(threads)
        m = lib.meadow_create(origin=(0, 0, 0), size=(30.0, 20.0), tile_size=0.5, seed=4)
        n = lib.meadow_info(m)["tile_count"]
        counts, offsets = np.empty(n, np.int32), np.empty(n, np.int32)
        lib.meadow_tiles(m, counts, offsets)
        out.append((counts.tobytes(), offsets.tobytes()))
    lib.set_threads(0)
    assert out[0] == out[1]


@test
def test_expansion_widths_equal_model_widths_times_scale():
    fresh()
    # one captured-style blade model in 'Tussock Blades': 8 knots, known widths
    from tussock.capture import blades
    k = 8
    co = np.zeros((k, 3), np.float32)
    co[:, 2] = np.linspace(0, 0.2, k)
    co[:, 0] = 0.02 * np.linspace(0, 1, k) ** 2
    widths = np.linspace(0.01, 0.002, k).astype(np.float32)
    mesh = blades.blade_mesh("Model", co, widths, co)
    model = bpy.data.objects.new("Model", mesh)
    blades.blade_collection(bpy.context.scene).objects.link(model)
    obj = add_meadow(patch_blades=256, chunk_blades=16, blades_per_tile=16, scale_min=0.5,
                     scale_max=2.0)
    patch = lib.patch_create(knots=co.ravel(), widths=widths, knot_counts=np.array([k], np.int32),
                             blade_count=256, scale_min=0.5, scale_max=2.0, seed=1)
    scale = np.empty(256, np.float32)
    lib.patch_blades(patch, None, None, scale, None)
    coll = bpy.data.collections[f"{obj.name} patch"]
    chunks = sorted(coll.objects, key=lambda o: o.name)
    co_all = []
    for o in chunks:
        v = np.empty(len(o.data.vertices) * 3, np.float32)
        o.data.vertices.foreach_get("co", v)
        co_all.append(v.reshape(-1, 3))
    v = np.concatenate(co_all).reshape(256, k, 2, 3)
    measured = np.linalg.norm(v[:, :, 1] - v[:, :, 0], axis=2)
    expected = widths[None, :] * scale[:, None]
    assert np.max(np.abs(measured - expected)) < 1e-6, np.max(np.abs(measured - expected))


@test
def test_a_whole_captured_blade_of_many_knots_grows_as_a_64_knot_model():
    """A blade fresh from capture (here 150 knots along a bent blade 0.3 m long) needs no
    refining first: the meadow takes it resampled evenly to 64 knots, root and tip kept,
    its length within 0.5 %."""
    fresh()
    from tussock.capture import blades
    k = 150
    t = np.linspace(0.0, 1.0, k)
    co = np.zeros((k, 3), np.float32)
    co[:, 0] = 0.08 * t ** 2
    co[:, 2] = 0.29 * t
    widths = (0.008 * (1.0 - t) + 0.001).astype(np.float32)
    model = bpy.data.objects.new("Whole blade", blades.blade_mesh("Whole blade", co, widths, co))
    blades.blade_collection(bpy.context.scene).objects.link(model)
    obj = add_meadow(patch_blades=64, chunk_blades=16, blades_per_tile=16, scale_min=1.0,
                     scale_max=1.0)
    assert obj["tussock_blades"] > 0
    coll = bpy.data.collections[f"{obj.name} patch"]
    first = sorted(coll.objects, key=lambda o: o.name)[0]
    v = np.empty(len(first.data.vertices) * 3, np.float32)
    first.data.vertices.foreach_get("co", v)
    ribbon = v.reshape(-1, 64, 2, 3)  # blades x knots x (left, right) edge
    spine = ribbon[0].mean(axis=1)
    length = np.linalg.norm(np.diff(spine, axis=0), axis=1).sum()
    true_length = np.linalg.norm(np.diff(co.astype(np.float64), axis=0), axis=1).sum()
    assert abs(length / true_length - 1.0) < 0.005, (length, true_length)


@test
def test_bad_input_cancels_with_scene_unchanged():
    fresh()
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    ground = bpy.context.active_object
    op = bpy.ops.tussock.add_meadow
    expect_cancel(op, "tile_size", tile_size=0.0)
    expect_cancel(op, "tile_size", tile_size=5.0)          # tile larger than the 2 m ground
    expect_cancel(op, "blades_per_tile", blades_per_tile=0)
    expect_cancel(op, "Patch size (patch_blades) must be from 16", patch_blades=0)
    expect_cancel(op, "blade", tile_size=0.01, blades_per_tile=65536, patch_blades=65536,
                  chunk_blades=65536)                     # 2.6 G blades: over the limit
    ground.select_set(False)
    expect_cancel(op, "size", size=(0.0, 5.0))
    # a non-blade object in Tussock Blades
    from tussock.capture import blades
    cube = bpy.data.objects.new("Not a blade", bpy.data.meshes.new("cube"))
    blades.blade_collection(bpy.context.scene).objects.link(cube)
    ground.select_set(True)
    bpy.context.view_layer.objects.active = ground
    expect_cancel(op, "not a Tussock blade")


@test
def test_settings_change_rebuilds_and_bad_change_keeps_last_meadow():
    fresh()
    obj = add_meadow(blades_per_tile=64, density="UNIFORM", tile_size=0.5, size=(2.0, 2.0))
    assert obj["tussock_blades"] == 16 * 64
    obj.tussock_meadow.blades_per_tile = 32
    assert obj["tussock_blades"] == 16 * 32
    assert obj.tussock_meadow.last_error == ""
    obj.tussock_meadow.chunk_blades = 7  # does not divide the patch: refused, meadow kept
    assert obj["tussock_blades"] == 16 * 32
    assert "chunk_blades" in obj.tussock_meadow.last_error


harness.main()
