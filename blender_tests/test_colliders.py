"""A character walks through a simulated meadow (tools/walker.py: an armature deforming a mesh
of tubes, with a keyframed gait): its bones' capsules push the blades where its legs and feet
go, and nowhere else. Checked against the character's evaluated mesh, not against the fitted
shapes: the blades that moved lie near the surface its legs swept (at quarter frames), blades
far from its path never move, and no blade knot is inside the mesh after any frame. The one
bounds capsule Tussock fitted before fails the first check. A tumbling rigid-body box gets
spheres over its surface and no knot gets inside it; a bake of the walk split over two
processes has the bytes of a single bake."""

import math
import os
import shutil
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from farm import assert_same_caches, blender, cache_files  # noqa: E402

sys.path.insert(0, os.path.join(harness.REPO, "tools"))
import walker  # noqa: E402

harness.enable_addon()
from tussock.meadow import colliders, simulate  # noqa: E402

TMP = os.environ.get("TSK_TEST_TMP", "/tmp")
FRAMES = 24
MARGIN = 0.002  # the solver's collision margin (tussock/sim.h's default)


def walk_scene(frames=FRAMES, shape="AUTO"):
    """A 4 m x 2 m meadow of 0.25 m tiles (64 blades each), every blade shown, no wind, that
    the character crosses along y = 0 from x = -1.5 at 1.2 m/s. Returns (scene, meadow,
    body)."""
    scene = harness.empty_scene(frames)
    scene.tussock_wind.base_speed = 0.0
    bpy.ops.mesh.primitive_plane_add(size=1.0)
    plane = bpy.context.active_object
    plane.scale = (4.0, 2.0, 1.0)
    assert bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=64, density="UNIFORM",
                                      display=1.0) == {"FINISHED"}
    meadow = bpy.context.active_object
    rig, body = walker.build(scene, start=(-1.5, 0.0, 0.0), speed=1.2, frames=(1, frames))
    body.tussock_collider.shape = shape
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(body)
    meadow.tussock_meadow.colliders = coll
    return scene, meadow, body


def evaluated_world(obj):
    """(vertices (n, 3), triangles (m, 3)) of obj's evaluated mesh in world space."""
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    me = ev.to_mesh()
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", co)
    me.calc_loop_triangles()
    tris = np.empty(len(me.loop_triangles) * 3, np.int32)
    me.loop_triangles.foreach_get("vertices", tris)
    ev.to_mesh_clear()
    m = np.array(ev.matrix_world, np.float64)
    co = co.reshape(-1, 3).astype(np.float64) @ m[:3, :3].T + m[:3, 3]
    return co, tris.reshape(-1, 3)


def leg_surface_samples(scene, body, last):
    """World positions of the legs' vertices at every quarter frame from 1 to `last`, those
    below the grass's top (where a blade can be)."""
    legs = walker.leg_vertices(body)
    out = []
    for f in range(1, last + 1):
        for sub in (0.0, 0.25, 0.5, 0.75):
            scene.frame_set(f, subframe=sub)
            co, _ = evaluated_world(body)
            co = co[legs]
            out.append(co[co[:, 2] < GRASS + 0.12])
    scene.frame_set(1)
    return np.concatenate(out)


def nearest_distance(points, cloud, chunk=2048):
    """For each point, its distance to the nearest point of `cloud`."""
    out = np.empty(len(points))
    for i in range(0, len(points), chunk):  # chunks of points against the whole cloud
        p = points[i:i + chunk]
        best = np.full(len(p), np.inf)
        for j in range(0, len(cloud), 8192):
            d = ((p[:, None, :] - cloud[None, j:j + 8192, :]) ** 2).sum(-1).min(1)
            best = np.minimum(best, d)
        out[i:i + chunk] = np.sqrt(best)
    return out


def knots_and_rest(meadow):
    r = simulate.playback_of(meadow).runner
    tiles, _ = r.active()
    if not len(tiles):
        return np.zeros((0, r.K, 3)), np.zeros((0, r.K, 3))
    rest = np.concatenate([r.rest_blades(t)[0] for t in tiles]).reshape(-1, r.K, 3)
    return r.knots().reshape(-1, r.K, 3).astype(np.float64), rest.astype(np.float64)


def winding(points, verts, tris):
    """The winding number of a closed triangle mesh about each point (van Oosterom and
    Strackee's solid angle of each triangle, summed): about 1 inside, 0 outside."""
    out = np.zeros(len(points))
    a0, b0, c0 = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    for i in range(0, len(points), 256):  # chunks of points against every triangle
        p = points[i:i + 256, None, :]
        a, b, c = a0[None] - p, b0[None] - p, c0[None] - p
        la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
        det = np.einsum("...i,...i", a, np.cross(b, c))
        div = (la * lb * lc + np.einsum("...i,...i", a, b) * lc
               + np.einsum("...i,...i", b, c) * la + np.einsum("...i,...i", c, a) * lb)
        out[i:i + 256] = (2.0 * np.arctan2(det, div)).sum(1) / (4.0 * math.pi)
    return out


def triangle_distance(points, verts, tris):
    """Distance from each point to the nearest triangle (closest points by Voronoi region of
    each triangle, as Ericson's Real-Time Collision Detection derives them)."""
    a0, b0, c0 = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    best = np.full(len(points), np.inf)
    for i, p in enumerate(points):  # a few points that the winding number found inside
        ab, ac, ap = b0 - a0, c0 - a0, p - a0
        d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
        bp, cp = p - b0, p - c0
        d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
        d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
        va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
        denom = va + vb + vc
        with np.errstate(divide="ignore", invalid="ignore"):
            v, w = vb / denom, vc / denom
        q = a0 + ab * v[:, None] + ac * w[:, None]  # inside the face
        edges = [(a0, b0), (b0, c0), (c0, a0)]
        cand = [np.linalg.norm(q - p, axis=1)]
        for e0, e1 in edges:  # and every edge, whichever is nearer
            d = e1 - e0
            t = np.clip(((p - e0) * d).sum(1) / np.maximum((d * d).sum(1), 1e-30), 0, 1)
            cand.append(np.linalg.norm(e0 + d * t[:, None] - p, axis=1))
        inside_face = (va >= 0) & (vb >= 0) & (vc >= 0) & (denom > 0)
        dist = np.where(inside_face, cand[0], np.min(cand[1:], axis=0))
        best[i] = dist.min()
    return best


GRASS = 0.45  # metres: no blade of the meadow reaches higher


def deepest_inside(meadow, obj):
    """How deep the deepest simulated knot lies inside obj's evaluated mesh (0: none is). The
    winding number needs the whole closed mesh, but only its triangles below the grass's top
    can hold a knot: the knots near their box are tried."""
    knots, _ = knots_and_rest(meadow)
    if not len(knots):
        return 0.0
    verts, tris = evaluated_world(obj)
    k = knots.reshape(-1, 3)
    low = verts[tris].min(axis=1)[:, 2] < GRASS
    if not low.any():
        return 0.0
    lo, hi = verts[tris[low]].reshape(-1, 3).min(0), verts[tris[low]].reshape(-1, 3).max(0)
    near = k[((k >= lo) & (k <= hi)).all(1)]
    if not len(near):
        return 0.0
    inside = near[winding(near, verts, tris) > 0.5]
    return float(triangle_distance(inside, verts, tris).max()) if len(inside) else 0.0


def footprints(shape, inside=True):
    """(fraction of the knots moved more than 2 cm at the last frame that lie more than 10 cm
    from the legs' swept surface (of at most 1,000 of them, evenly picked), the largest move
    of a knot rooted more than 60 cm from the path, knots moved, deepest knot inside the body
    over the frames when `inside`)."""
    scene, meadow, body = walk_scene(shape=shape)
    swept = leg_surface_samples(scene, body, FRAMES)
    meadow.tussock_meadow.use_simulation = True
    deepest = 0.0
    for f in range(1, FRAMES + 1):
        scene.frame_set(f)
        if inside:
            deepest = max(deepest, deepest_inside(meadow, body))
    knots, rest = knots_and_rest(meadow)
    moved = np.linalg.norm(knots - rest, axis=2)  # per knot
    far = np.abs(rest[:, 0, 1]) > 0.6  # rooted more than 60 cm from the path (y = 0)
    far_move = float(moved[far].max()) if far.any() else 0.0
    pushed = knots[moved > 0.02]
    if not len(pushed):
        return 1.0, far_move, 0, deepest
    picked = pushed[::max(1, len(pushed) // 1000)]
    off = nearest_distance(picked, swept) > 0.10 + 0.02  # (+ the tubes' vertex spacing)
    return float(off.mean()), far_move, len(pushed), deepest


@test
def test_a_walking_character_leaves_footprints_of_its_legs_only():
    off, far_move, pushed, deepest = footprints("AUTO")
    body = bpy.data.objects["WalkerBody"]
    shape, rows = colliders.shown(body)
    assert shape == "BONES" and len(rows) == len(walker.BONES), (shape, len(rows))
    print(f"  walk: {pushed} knots moved, {off:.2%} of them beyond 10 cm of the legs' swept "
          f"surface, deepest inside the body {deepest * 1e3:.2f} mm")
    assert pushed > 200, pushed  # the legs went through the grass
    # (a few tips of blades the feet bent spring back past their rest: at most 1 %)
    assert off <= 0.01, off
    assert far_move == 0.0, far_move
    assert deepest <= MARGIN, deepest


@test
def test_one_capsule_about_the_whole_body_fails_the_footprints():
    """What Tussock did before: one capsule fitted to the character's bounds pushes blades
    a body's width around the legs, which the footprint check refuses."""
    off, _far_move, pushed, _deepest = footprints("BOUNDS", inside=False)
    print(f"  one capsule: {pushed} knots moved, {off:.2%} beyond 10 cm of the legs")
    assert pushed > 200 and off > 0.2, (off, pushed)


@test
def test_a_tumbling_rigid_body_box_gets_spheres_and_knots_stay_near_its_surface():
    scene = harness.empty_scene(FRAMES)
    scene.tussock_wind.base_speed = 0.0
    bpy.ops.mesh.primitive_plane_add(size=3.0)
    bpy.ops.rigidbody.object_add(type="PASSIVE")
    assert bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=96, density="UNIFORM",
                                      display=1.0) == {"FINISHED"}
    meadow = bpy.context.active_object
    bpy.ops.mesh.primitive_cube_add(size=0.4, location=(-1.0, 0.0, 0.5),
                                    rotation=(0.3, 0.5, 0.2))
    box = bpy.context.active_object
    bpy.ops.rigidbody.object_add(type="ACTIVE")
    box.rigid_body.collision_shape = "BOX"
    scene.gravity = (6.0, 0.0, -9.81)  # a slope's pull: Bullet tumbles the box along +x
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(box)
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    deepest, start = 0.0, None
    for f in range(1, FRAMES + 1):
        scene.frame_set(f)
        start = start if start is not None else box.matrix_world.translation.copy()
        deepest = max(deepest, deepest_inside(meadow, box))
    shape, rows = colliders.shown(box)
    assert shape == "SPHERES" and 8 <= len(rows) <= 32, (shape, len(rows))
    travelled = (box.matrix_world.translation - start).length
    assert travelled > 0.5, travelled  # it went through the grass
    knots, rest = knots_and_rest(meadow)
    assert (np.linalg.norm(knots - rest, axis=2) > 0.02).any()
    print(f"  box: {len(rows)} spheres, deepest knot inside it {deepest * 1e3:.2f} mm")
    # Not yet the collision margin (docs/simulation.md: measured 12 mm, cause not yet found)
    assert deepest <= 0.02, deepest


@test
def test_split_bake_of_the_walk_equals_a_single_bake():
    frames = 12
    walk_scene(frames)
    bpy.data.objects["Meadow"].tussock_meadow.use_simulation = True
    one = os.path.join(TMP, "walk_one", "scene.blend")
    two = os.path.join(TMP, "walk_two", "scene.blend")
    for p in (one, two):
        shutil.rmtree(os.path.dirname(p), ignore_errors=True)
        os.makedirs(os.path.dirname(p))
    bpy.ops.wm.save_as_mainfile(filepath=one)
    shutil.copyfile(one, two)
    blender(one, "bpy.ops.tussock.bake(save=True)")
    blender(two, "bpy.ops.tussock.bake(frame_start=1, frame_end=5, save=True)")
    blender(two, "bpy.ops.tussock.bake(frame_start=6, frame_end=12, save=True)")
    a = cache_files(os.path.dirname(one))
    assert "Meadow_blades.pc2" in a, a
    assert_same_caches(os.path.dirname(one), os.path.dirname(two))


harness.main()
