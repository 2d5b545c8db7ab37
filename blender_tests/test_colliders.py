"""A character walks through a simulated meadow (tools/walker.py: an armature deforming a mesh
of tubes, with a keyframed gait): its bones' capsules push the blades where its legs and feet
go, and nowhere else. Checked against the character's evaluated mesh, not against the fitted
shapes: the blades that moved lie near the surface its legs swept (at quarter frames), blades
far from its path never move, and no blade knot is inside the mesh after any frame. The one
bounds capsule Tussock fitted before fails the first check. A tumbling rigid-body box gets
spheres over its surface and no knot gets inside it by more than the margin (its contact set
for a close shot, so that Bullet keeps it on the ground). No blade
crosses a cloth-like sheet (a baked, deforming open mesh) that drops onto the grass. A bake of
the walk split over two processes has the bytes of a single bake."""

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


def inside_depths(meadow, obj):
    """(knots inside obj's evaluated mesh (n, 3), how deep each lies). The winding number
    needs the whole closed mesh, but only its triangles below the grass's top can hold a
    knot: the knots near their box are tried."""
    none = np.zeros((0, 3)), np.zeros(0)
    knots, _ = knots_and_rest(meadow)
    if not len(knots):
        return none
    verts, tris = evaluated_world(obj)
    k = knots.reshape(-1, 3)
    low = verts[tris].min(axis=1)[:, 2] < GRASS
    if not low.any():
        return none
    lo, hi = verts[tris[low]].reshape(-1, 3).min(0), verts[tris[low]].reshape(-1, 3).max(0)
    near = k[((k >= lo) & (k <= hi)).all(1)]
    if not len(near):
        return none
    inside = near[winding(near, verts, tris) > 0.5]
    return inside, triangle_distance(inside, verts, tris)


def deepest_inside(meadow, obj):
    """How deep the deepest simulated knot lies inside obj's evaluated mesh (0: none is)."""
    _, depth = inside_depths(meadow, obj)
    return float(depth.max()) if len(depth) else 0.0


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
    ground = bpy.context.active_object
    bpy.ops.rigidbody.object_add(type="PASSIVE")
    assert bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=96, density="UNIFORM",
                                      display=1.0) == {"FINISHED"}
    meadow = bpy.context.active_object
    bpy.ops.mesh.primitive_cube_add(size=0.4, location=(-1.0, 0.0, 0.5),
                                    rotation=(0.3, 0.5, 0.2))
    box = bpy.context.active_object
    bpy.ops.rigidbody.object_add(type="ACTIVE")
    box.rigid_body.collision_shape = "BOX"
    # Contact set up as for a close shot (Rigid Body > Collisions > Margin 1 mm, the world's
    # Substeps 30 and Iterations 20): with Blender's defaults (4 cm margins, 10 and 10)
    # Bullet sinks the box 17-23 mm into the ground, and a blade root under it, held at the
    # ground, is then inside it by as much; with these it stays on the ground
    for body in (ground, box):
        body.rigid_body.use_margin, body.rigid_body.collision_margin = True, 0.001
    scene.rigidbody_world.substeps_per_frame = 30
    scene.rigidbody_world.solver_iterations = 20
    scene.gravity = (6.0, 0.0, -9.81)  # a slope's pull: Bullet tumbles the box along +x
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(box)
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    deepest, deepest_off_ground, sunk, start = 0.0, 0.0, 0.0, None
    for f in range(1, FRAMES + 1):
        scene.frame_set(f)
        start = start if start is not None else box.matrix_world.translation.copy()
        sunk = max(sunk, -min(0.0, float(evaluated_world(box)[0][:, 2].min())))
        knots, depth = inside_depths(meadow, box)
        if not len(depth):
            continue
        deepest = max(deepest, float(depth.max()))
        assert depth.max() <= MARGIN + 1e-4, (f, depth.max(), sunk)
        off = knots[:, 2] > 1e-3  # (the ground is z = 0)
        if off.any():
            deepest_off_ground = max(deepest_off_ground, float(depth[off].max()))
    assert sunk <= 1e-3, sunk  # (the premise: Bullet kept the box on the ground)
    shape, rows = colliders.shown(box)
    assert shape == "SPHERES" and 8 <= len(rows) <= 32, (shape, len(rows))
    travelled = (box.matrix_world.translation - start).length
    assert travelled > 0.5, travelled  # it went through the grass
    knots, rest = knots_and_rest(meadow)
    assert (np.linalg.norm(knots - rest, axis=2) > 0.02).any()
    print(f"  box: {len(rows)} spheres, deepest knot inside it {deepest * 1e3:.2f} mm (the box "
          f"sank {sunk * 1e3:.1f} mm into the ground), off the ground "
          f"{deepest_off_ground * 1e3:.2f} mm")
    assert deepest_off_ground <= MARGIN, deepest_off_ground


def sheet_cache(path, grid, frames):
    """A cloth-like sheet's vertex positions for frames 1..frames, written as a .pc2 (what a
    baked cloth simulation gives Blender's Mesh Cache modifier): the grid's vertices drop
    from 0.6 m to 0.12 m over the first two thirds of the shot while a wave of 4 cm runs
    across it. (Dragged sideways into standing grass, a sheet's edge can fold blades over
    itself: a sphere set has no sides; docs/simulation.md.)"""
    xy = grid[:, :2].astype(np.float64)
    out = np.empty((frames, len(grid), 3), np.float32)
    for i in range(frames):
        t = i / 24.0
        fall = min(1.0, i / (frames * 2 / 3))
        z0 = 0.6 - (0.6 - 0.12) * (3 * fall ** 2 - 2 * fall ** 3)  # eased, as cloth settles
        out[i, :, 0] = xy[:, 0]
        out[i, :, 1] = xy[:, 1] + 0.01 * np.sin(5.0 * xy[:, 0])
        out[i, :, 2] = z0 + 0.04 * np.sin(2 * math.pi * (xy[:, 0] / 0.6 - 1.5 * t)) \
            * np.cos(math.pi * xy[:, 1] / 1.2)
    with open(path, "wb") as f:
        f.write(b"POINTCACHE2\0" + np.array([1, len(grid)], "<i4").tobytes()
                + np.array([1.0, 1.0], "<f4").tobytes() + np.array([frames], "<i4").tobytes())
        f.write(out.astype("<f4").tobytes())


def above_sheet(knots, verts, tris):
    """For each knot, how far above the sheet it lies where the sheet is over it (its height
    minus the sheet's at its x, y, from the triangle under it), or -inf where no triangle
    is over it (no part of the sheet)."""
    out = np.full(len(knots), -np.inf)
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    lo, hi = verts[:, :2].min(0), verts[:, :2].max(0)
    idx = np.nonzero(((knots[:, :2] >= lo) & (knots[:, :2] <= hi)).all(1))[0]
    for i in range(0, len(idx), 512):  # chunks of knots against every triangle, in x, y
        k = knots[idx[i:i + 512]]
        p = k[:, None, :2]
        v0, v1, v2 = (b - a)[None, :, :2], (c - a)[None, :, :2], p - a[None, :, :2]
        d = v0[..., 0] * v1[..., 1] - v0[..., 1] * v1[..., 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = (v2[..., 0] * v1[..., 1] - v2[..., 1] * v1[..., 0]) / d
            w = (v0[..., 0] * v2[..., 1] - v0[..., 1] * v2[..., 0]) / d
        under = (u >= 0) & (w >= 0) & (u + w <= 1) & (np.abs(d) > 1e-12)
        z = a[None, :, 2] + u * (b - a)[None, :, 2] + w * (c - a)[None, :, 2]
        z = np.where(under, z, np.nan)
        with np.errstate(invalid="ignore"):
            top = np.nanmax(z, axis=1)
        got = ~np.isnan(top)
        out[idx[i:i + 512][got]] = k[got, 2] - top[got]
    return out


@test
def test_a_cloth_like_sheet_pressing_the_grass_is_never_crossed_by_a_blade():
    """An open sheet has no inside: the check is that no blade crosses it, on every frame as
    it drops onto the meadow and ripples there."""
    frames = 18
    scene = harness.empty_scene(frames)
    scene.tussock_wind.base_speed = 0.0
    bpy.ops.mesh.primitive_plane_add(size=1.0)
    bpy.context.active_object.scale = (1.8, 1.8, 1.0)  # the sheet and a blade beyond its edges
    assert bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=64, density="UNIFORM",
                                      display=1.0) == {"FINISHED"}
    meadow = bpy.context.active_object
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=31, y_subdivisions=31, size=1.2)
    sheet = bpy.context.active_object
    grid = np.empty(len(sheet.data.vertices) * 3, np.float32)
    sheet.data.vertices.foreach_get("co", grid)
    path = os.path.join(TMP, "sheet.pc2")
    sheet_cache(path, grid.reshape(-1, 3), frames)
    mod = sheet.modifiers.new("Cloth cache", "MESH_CACHE")
    mod.cache_format, mod.filepath, mod.frame_start = "PC2", path, 1.0
    sheet.tussock_collider.max_spheres = 256
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(sheet)
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    worst, crossings, gaps = -np.inf, 0, []
    for f in range(1, frames + 1):
        scene.frame_set(f)
        verts, tris = evaluated_world(sheet)
        knots, _ = knots_and_rest(meadow)
        if not len(knots):
            continue
        h = above_sheet(knots.reshape(-1, 3), verts, tris).reshape(len(knots), -1)
        # no blade's segment goes from under the sheet to above it. A blade pressed out past
        # an edge may rise there and lean back over the sheet (round the edge, not through
        # it); one rooted further in than a blade's length stays under it
        lo, hi = verts[:, :2].min(0) + GRASS, verts[:, :2].max(0) - GRASS
        under = ((knots[:, 0, :2] > lo) & (knots[:, 0, :2] < hi)).all(1)
        if under.any():
            worst = max(worst, float(h[under].max()))
        a, b = h[:, :-1], h[:, 1:]
        crossings += int(((np.isfinite(a) & np.isfinite(b)) & ((a < 0) != (b < 0))).sum())
        if f == frames:  # how far under the sheet the tips it holds down lie
            gaps = -h[under, -1][np.isfinite(h[under, -1])]
    assert abs(float(verts[:, 2].mean()) - 0.12) < 0.01, verts[:, 2].mean()  # it settled
    shape, rows = colliders.shown(sheet)
    assert shape == "SPHERES" and len(rows) > 32, (shape, len(rows))
    radius = max(r[1] for r in rows)
    print(f"  sheet: {len(rows)} spheres (largest {radius * 1e3:.0f} mm); highest knot of a "
          f"blade rooted a blade's length inside its edges {worst * 1e3:+.2f} mm from it; "
          f"{crossings} segments cross it; tips under it {np.median(gaps) * 1e3:.0f} mm below "
          f"it (median, {len(gaps)})")
    assert len(gaps) > 50, len(gaps)  # the blades under the sheet were held down
    assert crossings == 0, crossings
    assert worst < 0.0, worst
    # the spheres bulge below the sheet: the blades it holds lie at most a sphere's radius
    # below it
    assert np.median(gaps) <= radius + 0.01, (np.median(gaps), radius)


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
