"""Touched blades in Blender: a rigid-body ball rolls through a meadow (Blender's Bullet
world moves it), the blades under its path bend, none enters the ball, the instances of
simulated tiles are hidden, going back in time or jumping ahead resumes from a snapshot
and gives the same bytes as playing straight through, snapshots stay within their memory
budget and are not used once the colliders they saw have changed, and bad settings are
reported without harm."""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

harness.enable_addon()
from tussock import compat, native  # noqa: E402
from tussock.meadow import blade_objects, identity, playback, simulate, solver, writer  # noqa: E402

RADIUS = 0.2


def rolling_ball_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    simulate.forget()
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=4.0)
    bpy.ops.rigidbody.object_add(type="PASSIVE")
    assert bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=32, density="UNIFORM",
                                      display=1.0) == {"FINISHED"}
    meadow = bpy.context.active_object
    bpy.ops.mesh.primitive_uv_sphere_add(radius=RADIUS, location=(-1.6, 0.0, RADIUS))
    ball = bpy.context.active_object
    bpy.ops.rigidbody.object_add(type="ACTIVE")
    ball.rigid_body.collision_shape = "SPHERE"
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(ball)
    scene.gravity = (3.0, 0.0, -9.81)  # a slope's pull: Bullet rolls the ball along +x
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    return scene, meadow, ball


def blade_knots(meadow):
    r = simulate.playback_of(meadow).runner
    return r.knots().reshape(-1, r.K, 3)


def instance_count(meadow):
    dg = bpy.context.evaluated_depsgraph_get()
    return sum(1 for i in dg.object_instances
               if i.is_instance and i.parent is not None and i.parent.original == meadow)


@test
def test_rolling_ball_bends_blades_on_its_path():
    scene, meadow, ball = rolling_ball_scene()
    total_instances = instance_count(meadow)
    start_x = None
    bent = 0.0
    frames = {}
    for f in range(1, 31):
        scene.frame_set(f)
        centre = np.array(ball.matrix_world.translation)
        if start_x is None:
            start_x = centre[0]
        knots = blade_knots(meadow)
        if len(knots):
            # no knot inside the ball (collision is a hard constraint)
            d = np.linalg.norm(knots - centre[None, None, :], axis=2)
            assert d.min() > RADIUS - 1e-3, (f, d.min())
            bent = max(bent, float(np.abs(knots[:, -1, :2] - knots[:, 0, :2]).max()))
        frames[f] = ribbons(meadow)
    assert np.array(ball.matrix_world.translation)[0] > start_x + 0.8  # Bullet rolled it
    assert meadow["tussock_active_tiles"] > 0 and meadow["tussock_active_blades"] > 0
    assert bent > 0.05, bent  # tips pushed well away from above their roots
    hidden = np.empty(len(meadow.data.vertices), bool)
    meadow.data.attributes["tsk_hidden"].data.foreach_get("value", hidden)
    assert hidden.sum() > 0 and instance_count(meadow) == total_instances - hidden.sum()
    # back in time: resumed with the recorded ball positions, same bytes
    scene.frame_set(12)
    assert ribbons(meadow) == frames[12]
    # rebuilding the meadow's instances (a viewport setting) clears tsk_hidden; the next
    # frame hides the simulated tiles' instances again
    meadow.tussock_meadow.display = 0.5
    meadow.data.attributes["tsk_hidden"].data.foreach_get("value", hidden)
    assert hidden.sum() == 0
    scene.frame_set(13)
    meadow.data.attributes["tsk_hidden"].data.foreach_get("value", hidden)
    pb = simulate.playback_of(meadow)
    assert hidden.sum() > 0
    assert np.array_equal(hidden, np.isin(pb.instance_tile, pb.runner.active()[0]))


def rest_knots(meadow):
    """Rest knots of the active blades, in the simulation's order, from the meadow."""
    r = simulate.playback_of(meadow).runner
    lib = native.lib
    tiles, _ = r.active()
    out = []
    for t in tiles:
        t = int(t)
        n = lib.meadow_blade_count(r.meadow, t, t + 1)
        k = np.empty(n * r.K * 3, np.float32)
        lib.meadow_realise_knots(r.meadow, r.patch, t, t + 1, k, None, None)
        out.append(k.reshape(n, r.K, 3))
    return np.concatenate(out) if out else np.zeros((0, r.K, 3), np.float32)


@test
def test_blades_recover_after_the_ball_has_passed():
    scene, meadow, ball = rolling_ball_scene()
    scene.gravity = (0.0, 0.0, -9.81)
    scene.tussock_wind.base_speed = 0.0  # no breeze: the blades' shape at rest is the rest pose
    ball.rigid_body.kinematic = True  # pressed into the grass, then lifted away
    ball.location = (-0.5, 0.1, RADIUS)
    ball.keyframe_insert("location", frame=1)
    ball.location = (-0.5, 0.1, 5.0)
    ball.keyframe_insert("location", frame=10)
    for fc in compat.fcurves(ball.animation_data):
        for kp in fc.keyframe_points:
            kp.interpolation = "CONSTANT"
    for f in range(1, 10):
        scene.frame_set(f)
    pressed, rest = blade_knots(meadow), rest_knots(meadow)
    assert len(pressed) > 0
    length = np.linalg.norm(np.diff(rest, axis=1), axis=2).sum(axis=1)
    assert np.max(np.linalg.norm(pressed - rest, axis=2).max(axis=1) / length) > 0.05
    for f in range(10, 121):
        scene.frame_set(f)
        # a tile released by a frame's first step used to leave the second step with wind
        # for more blades than were active ("wind: must have exactly ... elements")
        assert meadow.tussock_meadow.last_error == "", (f, meadow.tussock_meadow.last_error)
    after, rest = blade_knots(meadow), rest_knots(meadow)
    if len(after):  # still simulated: within 1 % of the blade length of the rest shape
        length = np.linalg.norm(np.diff(rest, axis=1), axis=2).sum(axis=1)
        err = np.linalg.norm(after - rest, axis=2).max(axis=1) / length
        assert err.max() < 0.01, err.max()
    else:  # released: the instances are shown again
        hidden = np.empty(len(meadow.data.vertices), bool)
        meadow.data.attributes["tsk_hidden"].data.foreach_get("value", hidden)
        assert hidden.sum() == 0


def ribbons(meadow):
    """Positions of the simulated blades' ribbons in the dynamic meshes, as bytes; the rest
    of each chunk's mesh (room for more blades) must be all zero."""
    return writer.active_ribbons(meadow).tobytes()


def positions(obj):
    co = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co)
    return co


def play(scene, meadow, frames):
    """Plays `frames` in order; knots and ribbon positions of each, as bytes."""
    knots, co = {}, {}
    for f in frames:
        scene.frame_set(f)
        knots[f] = blade_knots(meadow).tobytes()
        co[f] = ribbons(meadow)
    return knots, co


def knots_and_co(scene, meadow, frame):
    scene.frame_set(frame)
    return blade_knots(meadow).tobytes(), ribbons(meadow)


@test
def test_jumps_resume_from_snapshots_with_the_bytes_of_a_straight_run():
    scene, meadow, ball = rolling_ball_scene()
    knots, co = play(scene, meadow, list(range(1, 31)))
    pb = simulate.playback_of(meadow)
    assert sorted(pb.snapshots) == [11, 21], sorted(pb.snapshots)  # every 10 from frame 1
    assert len(knots[12]) > 0 and knots[12] != knots[11]
    # back to 12: resumes from the snapshot of frame 11, not from rest
    assert knots_and_co(scene, meadow, 12) == (knots[12], co[12])
    assert pb.restored_from == 11, pb.restored_from
    # forward from 12 to 27: resumes from the snapshot of frame 21
    got = knots_and_co(scene, meadow, 27)
    assert got[0] == knots[27], "knots"
    assert got[1] == co[27], ("ribbons", len(got[1]), len(co[27]))
    assert pb.restored_from == 21, pb.restored_from
    # before the first snapshot: from rest
    assert knots_and_co(scene, meadow, 6) == (knots[6], co[6])
    assert pb.restored_from == 1, pb.restored_from
    # a bad handle is refused by the binding with a message
    try:
        native.lib.blade_sim_clone("not a simulation")
    except native.Error as exc:
        assert "sim" in str(exc)
    else:
        raise AssertionError("blade_sim_clone accepted a string")


@test
def test_blades_shared_among_chunk_objects_give_the_same_ribbons():
    """The simulated blades are shared evenly among blade_objects.CHUNKS objects (children of the
    first, shown and rendered as it is): the same frames give the same ribbons as with one
    object, and chunks no longer needed show nothing. Fewer than CHUNK_MIN_BLADES per chunk
    use fewer chunks (lowered to 16 here to split a small scene). The objects are made when
    simulation is switched on, so Bullet's ball rolls the same path as with no simulation
    at all."""
    scene, meadow, ball = rolling_ball_scene()
    empty = [range(100, 100)] * (blade_objects.CHUNKS - 1)
    assert writer.chunk_ranges(100) == [range(0, 100)] + empty
    min_blades, writer.CHUNK_MIN_BLADES = writer.CHUNK_MIN_BLADES, 16
    assert [len(r) for r in writer.chunk_ranges(40)] == [20, 20] + [0] * (blade_objects.CHUNKS - 2)
    first = bpy.data.objects[f"{meadow.name} blades"]
    extras = blade_objects.extra_chunks(meadow)
    assert blade_objects.CHUNKS >= 2 and len(extras) == blade_objects.CHUNKS - 1
    assert all(o.parent == first and o.get("tussock_simulated_blades") is None for o in extras)
    path = []
    knots, co = {}, {}
    for f in range(1, 25):
        scene.frame_set(f)
        knots[f], co[f] = blade_knots(meadow).tobytes(), ribbons(meadow)
        path.append(tuple(ball.matrix_world.translation))
    nb = meadow["tussock_active_blades"]
    assert nb >= 16 * blade_objects.CHUNKS, nb  # every chunk in use
    assert all(len(o.data.vertices) >= 2 * 16 * (nb // blade_objects.CHUNKS) for o in extras)
    first.hide_render = True
    scene.frame_set(23)
    assert all(o.hide_render for o in extras)
    first.hide_render = False
    chunks = blade_objects.CHUNKS
    blade_objects.CHUNKS = 1
    try:
        simulate.forget()
        again_knots, again = play(scene, meadow, list(range(1, 25)))
        assert again_knots == knots and again == co
        assert all(not positions(o).any() for o in extras)  # unused: no blade shown
    finally:
        blade_objects.CHUNKS = chunks
        writer.CHUNK_MIN_BLADES = min_blades
        simulate.forget()
    # the ball's path with no simulation at all, from a fresh scene
    scene, meadow, ball = rolling_ball_scene()
    meadow.tussock_meadow.use_simulation = False
    alone = []
    for f in range(1, 25):
        scene.frame_set(f)
        alone.append(tuple(ball.matrix_world.translation))
    assert alone == path, next((f, a, b) for f, (a, b) in enumerate(zip(alone, path), 1)
                               if a != b)


@test
def test_viewport_shows_the_simulated_blades_of_the_instances_it_shows():
    """The meadow's Viewport display applies to simulated blades as to its instances: the
    viewport's chunk objects hold exactly the blades of the chunk instances that the
    viewport shows (tsk_viewport_off false), the render chunks (disabled in the viewport,
    rendered) hold the others, and together they hold every active blade's ribbon. The
    viewport's share of the instances is the Viewport display fraction; at 1 every blade
    shows in the viewport and the render chunks are empty."""
    scene, meadow, ball = rolling_ball_scene()
    lib = native.lib
    meadow.tussock_meadow.display = 0.25
    off = np.empty(len(meadow.data.vertices), bool)
    meadow.data.attributes["tsk_viewport_off"].data.foreach_get("value", off)
    assert abs((~off).mean() - 0.25) < 0.05, (~off).mean()  # 1,600 instances
    min_blades, writer.CHUNK_MIN_BLADES = writer.CHUNK_MIN_BLADES, 16
    try:
        for f in range(1, 21):
            scene.frame_set(f)
        pb = simulate.playback_of(meadow)
        r = pb.runner
        tiles, counts = r.active()
        nb = int(counts.sum())
        assert nb > 200, nb
        # which blades the viewport shows, worked out tile by tile from the instances
        c = pb.chunk_blades
        shown = []
        for t, n in zip(tiles, counts):
            inst = np.flatnonzero(pb.instance_tile == t)
            assert len(inst) * c == n
            shown.append(np.repeat(~off[inst], c))
        shown = np.concatenate(shown)
        assert 0 < shown.sum() < nb
        assert meadow["tussock_viewport_blades"] == int(shown.sum())
        per = 2 * r.K * 3
        every = np.empty(nb * per, np.float32)
        lib.blade_sim_ribbons(r.sim, 0, pb.output.ribbon[0].ravel(),
                              pb.output.ribbon[1].ravel(), every)
        every = every.reshape(nb, per)

        def held(objs):
            parts = []
            for o in objs:
                v = positions(o).reshape(-1, per)
                used = v.any(axis=1)  # a chunk's blades first, then its spare room, all zero
                assert used[:used.sum()].all(), o.name
                parts.append(v[used])
            return np.concatenate(parts) if parts else np.zeros((0, per), np.float32)

        view = [bpy.data.objects[f"{meadow.name} blades"]] + blade_objects.extra_chunks(meadow)
        render = blade_objects.render_chunks(meadow)
        assert len(render) == blade_objects.CHUNKS
        assert all(not o.hide_viewport for o in view) and all(o.hide_viewport for o in render)
        assert all(o.hide_render == view[0].hide_render for o in render)
        assert np.array_equal(held(view), every[shown])
        assert np.array_equal(held(render), every[~shown])
        assert np.array_equal(writer.active_ribbons(meadow), every.ravel())
        # the viewport draws the instances it shows and that are not simulated
        hidden = np.empty(len(off), bool)
        meadow.data.attributes["tsk_hidden"].data.foreach_get("value", hidden)
        assert instance_count(meadow) == int((~off & ~hidden).sum())
        # every blade in the viewport again
        meadow.tussock_meadow.display = 1.0
        scene.frame_set(21)
        nb = meadow["tussock_active_blades"]
        assert meadow["tussock_viewport_blades"] == nb
        assert all(not positions(o).any() for o in render)
        assert len(held(view)) == nb
    finally:
        writer.CHUNK_MIN_BLADES = min_blades


def check_evaluated_blades(meadow):
    """Blender's evaluated meshes of the viewport chunks hold, for every active blade once,
    a ribbon whose two vertices per knot are centred on the simulation's knot and as far
    apart as the blade's width there (within float rounding), then zeros. Read by
    MeshVertex.co, not the route the write takes. Returns the number of blades checked."""
    pb = simulate.playback_of(meadow)
    r = pb.runner
    knots = blade_knots(meadow)
    nb, k = len(knots), r.K
    widths = pb.output.ribbon[0].reshape(nb, k)
    dg = bpy.context.evaluated_depsgraph_get()
    seen = np.zeros(nb, np.int32)
    for key, part in pb.output.plan.items():
        assert not isinstance(key, tuple), key  # every blade shown: no render chunk in use
        me = bpy.data.objects[identity.chunk_name(meadow, key)].evaluated_get(dg).data
        v = np.empty(len(me.vertices) * 3, np.float32)
        me.vertices.foreach_get("co", v)
        v = v.reshape(-1, k, 2, 3).astype(np.float64)
        n = len(part.index)
        mid = (v[:n, :, 0] + v[:n, :, 1]) / 2
        want = knots[part.index]
        # float rounding: a few units in the last place of the largest coordinate
        tol = 1e-6 * max(1.0, float(np.abs(want).max()) if n else 1.0)
        err = np.abs(mid - want).max() if n else 0.0
        assert err <= tol, (key, err, tol)
        apart = np.linalg.norm(v[:n, :, 1] - v[:n, :, 0], axis=2)
        err = np.abs(apart - widths[part.index]).max() if n else 0.0
        assert err <= tol, (key, err, tol)
        assert not v[n:].any(), key  # the chunk's spare room
        seen[part.index] += 1
    assert np.all(seen == 1), np.bincount(seen)
    return nb


@test
def test_blender_evaluates_the_simulations_knots_and_the_write_is_one_copy():
    """After each frame change, jumps back and forth included, the dynamic meshes Blender
    evaluates show every active blade around the simulation's knots of that frame
    (check_evaluated_blades). Writing them costs little beside making the ribbons: in
    Blender 5.2 writing MeshVertex.co went vertex by vertex, 160 ns a vertex (5 ms here for
    896 blades, a hundred times the ribbons themselves; compat.set_positions)."""
    scene, meadow, ball = rolling_ball_scene()
    min_blades, writer.CHUNK_MIN_BLADES = writer.CHUNK_MIN_BLADES, 64
    try:
        counts = []
        for f in range(1, 25):
            scene.frame_set(f)
            if f in (8, 16, 24):
                counts.append(check_evaluated_blades(meadow))
        assert max(counts) >= 64 * blade_objects.CHUNKS, counts  # every chunk object in use
        pb = simulate.playback_of(meadow)
        r = pb.runner
        nb = len(blade_knots(meadow))
        out = np.empty(nb * 2 * r.K * 3, np.float32)
        widths, sides = pb.output.ribbon[0].ravel(), pb.output.ribbon[1].ravel()
        ribbons_alone = harness.best_of(
            lambda: r.lib.blade_sim_ribbons(r.sim, 0, widths, sides, out))
        write = harness.best_of(lambda: writer.write(meadow, pb))
        assert write < 4.0 * ribbons_alone + 0.002, (
            f"write {write * 1e3:.2f} ms, ribbons alone {ribbons_alone * 1e3:.2f} ms, "
            f"{nb} blades")
        for f in (13, 24, 6):  # back from snapshots, and forward again
            scene.frame_set(f)
            check_evaluated_blades(meadow)
    finally:
        writer.CHUNK_MIN_BLADES = min_blades


def alpha_coverage(scene, path):
    """Renders the scene's camera with Cycles to `path` and returns the image's mean alpha."""
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return float(px[3::4].mean())


@test
def test_renders_show_the_blades_the_viewport_leaves_out():
    """Render chunks are disabled in the viewport but rendered: with only the simulated blades
    renderable, the render chunks alone show blades, and a render with every chunk shows
    more blade than the viewport's chunks or the render chunks alone."""
    scene, meadow, ball = rolling_ball_scene()
    meadow.tussock_meadow.display = 0.25
    for f in range(1, 15):
        scene.frame_set(f)
    assert 0 < meadow["tussock_viewport_blades"] < meadow["tussock_active_blades"]
    for o in scene.objects:
        if not o.name.startswith(f"{meadow.name} blades"):
            o.hide_render = True  # the ground, the ball and the instances
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(cam)
    cam.location = (float(ball.matrix_world.translation[0]) - 0.6, 0.0, 2.5)
    scene.camera = cam
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.render.film_transparent = True
    scene.render.resolution_x = scene.render.resolution_y = 48
    scene.render.resolution_percentage = 100
    tmp = os.environ.get("TSK_TEST_TMP", "/tmp")
    both = alpha_coverage(scene, os.path.join(tmp, "both.png"))
    # a render runs the frame handler, which makes every chunk follow the first one's
    # visibility; suspended, the chunks can be left out one kind at a time
    playback.suspended = True
    try:
        render = blade_objects.render_chunks(meadow)
        for o in render:
            o.hide_render = True
        viewport_share = alpha_coverage(scene, os.path.join(tmp, "viewport_share.png"))
        for o in render:
            o.hide_render = False
        first = bpy.data.objects[f"{meadow.name} blades"]
        first.hide_render = True
        for o in blade_objects.extra_chunks(meadow):
            o.hide_render = True
        render_share = alpha_coverage(scene, os.path.join(tmp, "render_share.png"))
    finally:
        playback.suspended = False
    assert viewport_share > 0.005 and render_share > 0.005, (viewport_share, render_share)
    assert both > 1.2 * max(viewport_share, render_share), (both, viewport_share, render_share)


@test
def test_a_meadow_made_before_viewport_flags_gets_them():
    """A meadow from a file made before tsk_viewport_off existed gets the attribute (the
    node group now reads it) when any meadow is built: until then it shows every instance."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    assert bpy.ops.tussock.add_meadow(size=(2.0, 2.0), display=0.5) == {"FINISHED"}
    old = bpy.context.active_object
    want = np.empty(len(old.data.vertices), bool)
    old.data.attributes["tsk_viewport_off"].data.foreach_get("value", want)
    assert 0 < want.sum() < len(want)
    old.data.attributes.remove(old.data.attributes["tsk_viewport_off"])
    assert bpy.ops.tussock.add_meadow(size=(1.0, 1.0)) == {"FINISHED"}
    got = np.empty(len(old.data.vertices), bool)
    old.data.attributes["tsk_viewport_off"].data.foreach_get("value", got)
    assert np.array_equal(got, want)


@test
def test_snapshots_stay_within_their_budget_and_cover_the_timeline():
    scene, meadow, ball = rolling_ball_scene()
    knots, _ = play(scene, meadow, list(range(1, 61)))
    pb = simulate.playback_of(meadow)
    assert sorted(pb.snapshots) == [11, 21, 31, 41, 51]  # the default budget holds them all
    largest = max(b for _, b in pb.snapshots.values())
    budget = playback.SNAPSHOT_BUDGET
    playback.SNAPSHOT_BUDGET = int(2.5 * largest)  # room for about two of them
    try:
        simulate.forget()
        again, _ = play(scene, meadow, list(range(1, 61)))
        pb = simulate.playback_of(meadow)
        assert again == knots
        assert 0 < pb.snapshot_bytes() <= playback.SNAPSHOT_BUDGET, pb.snapshot_bytes()
        assert pb.every > playback.SNAPSHOT_EVERY  # thinned out ...
        assert all((f - 1) % pb.every == 0 for f in pb.snapshots), (pb.every, list(pb.snapshots))
        assert max(pb.snapshots) >= 60 - pb.every  # ... still reaching the recent frames
        for f in (58, 33, 14):
            assert knots_and_co(scene, meadow, f)[0] == knots[f], f
            assert pb.restored_from == max([1] + [g for g in pb.snapshots if g <= f])
    finally:
        playback.SNAPSHOT_BUDGET = budget


@test
def test_changed_collider_path_gives_a_fresh_run_not_a_stale_snapshot():
    scene, meadow, ball = rolling_ball_scene()
    ball.rigid_body.kinematic = True  # keyframed: its path can be edited
    ball.location = (-0.8, 0.0, RADIUS)
    ball.keyframe_insert("location", frame=1)
    ball.location = (0.8, 0.0, RADIUS)
    ball.keyframe_insert("location", frame=25)
    play(scene, meadow, list(range(1, 26)))
    pb = simulate.playback_of(meadow)
    assert 11 in pb.snapshots and 21 in pb.snapshots
    # the ball now runs another way from frame 1 on; played again in order ...
    fc = [c for c in compat.fcurves(ball.animation_data) if c.data_path == "location"]
    fc[1].keyframe_points[1].co.y = 0.6
    fc[1].update()
    edited, _ = play(scene, meadow, list(range(1, 26)))
    # ... it must equal a simulation that never saw the old path
    simulate.forget()
    fresh, _ = play(scene, meadow, list(range(1, 26)))
    assert edited == fresh
    assert edited[25] != b"" and len(edited[25]) > 0


@test
def test_bad_simulation_settings_are_reported():
    scene, meadow, ball = rolling_ball_scene()
    meadow.tussock_meadow.sim_damping = float("nan")
    scene.frame_set(2)
    assert "damping" in meadow.tussock_meadow.last_error, meadow.tussock_meadow.last_error
    meadow.tussock_meadow.sim_damping = 4.0
    scene.frame_set(3)
    assert meadow.tussock_meadow.last_error == ""


@test
def test_someone_elses_object_with_a_chunk_name_is_never_overwritten():
    """An object of the artist's that happens to be named like a chunk of the simulated
    blades: the meadow reports it and leaves it alone; renamed, the simulation runs."""
    scene, meadow, ball = rolling_ball_scene()
    meadow.tussock_meadow.use_simulation = False
    for name in [f"{meadow.name} blades {i}" for i in (2, 3, 4)]:
        if name in bpy.data.objects:
            bpy.data.objects.remove(bpy.data.objects[name])
    bpy.ops.mesh.primitive_cube_add(location=(5.0, 5.0, 0.0))
    cube = bpy.context.active_object
    cube.name = f"{meadow.name} blades 3"
    before = [tuple(v.co) for v in cube.data.vertices]
    meadow.tussock_meadow.use_simulation = True
    assert "rename it" in meadow.tussock_meadow.last_error, meadow.tussock_meadow.last_error
    for f in (1, 2, 3):
        scene.frame_set(f)
        assert "rename it" in meadow.tussock_meadow.last_error
    assert [tuple(v.co) for v in cube.data.vertices] == before and cube.parent is None
    cube.name = "My cube"
    scene.frame_set(4)
    assert meadow.tussock_meadow.last_error == "" and meadow["tussock_active_blades"] > 0
    assert [tuple(v.co) for v in cube.data.vertices] == before


@test
def test_settle_time_frees_tiles_that_wind_keeps_moving():
    """In the scene's steady breeze a tile the ball has left never gets still; with a short
    Settle after it is released behind the ball while the ball rolls on, with a long one the
    simulated tiles only accumulate."""
    counts = {}
    for settle in (0.25, 600.0):
        scene, meadow, ball = rolling_ball_scene()
        assert scene.tussock_wind.base_speed > 0.0
        meadow.tussock_meadow.sim_settle_time = settle
        seen = []
        for f in range(1, 49):
            scene.frame_set(f)
            assert meadow.tussock_meadow.last_error == "", meadow.tussock_meadow.last_error
            seen.append(meadow["tussock_active_tiles"])
        counts[settle] = seen
    short, long = counts[0.25], counts[600.0]
    assert all(b >= a for a, b in zip(long, long[1:])), long  # never released
    assert max(short) > 0 and short[-1] < max(short), short     # released behind the ball
    assert short[-1] < long[-1], (short[-1], long[-1])


@test
def test_chunk_meshes_fit_their_blades_once_the_tiles_hold_still():
    """A chunk's mesh grows by half at least, so it can be left with much unused room that
    Blender evaluates every frame. Once the active tiles have held FIT_AFTER_FRAMES frames,
    a chunk with more than an eighth of its room unused is rebuilt to fit, and the ribbons
    shown are the same bytes as with no fitting."""
    cap, block = writer.chunk_capacity, writer.CAPACITY_BLOCK
    assert cap(0, 10) == block and cap(block, block) == block
    assert cap(4 * block, 4 * block + 1) == 6 * block            # grows by half
    assert cap(4 * block, block - 1) == block                    # under a quarter: shrinks
    assert cap(8 * block, 6 * block) == 8 * block                # holds while tiles come and go
    assert cap(8 * block, 6 * block, fit=True) == 6 * block      # fits once they hold still
    assert cap(8 * block, 7 * block + 1, fit=True) == 8 * block  # an eighth unused: kept
    saved = writer.CAPACITY_BLOCK, writer.CHUNK_MIN_BLADES, writer.FIT_AFTER_FRAMES
    shown, rooms = {}, {}
    try:
        writer.CAPACITY_BLOCK, writer.CHUNK_MIN_BLADES = 8, 16  # a small scene's sizes
        for fit_after in (writer.FIT_AFTER_FRAMES, 10 ** 9):
            writer.FIT_AFTER_FRAMES = fit_after
            scene, meadow, ball = rolling_ball_scene()
            ball.rigid_body.type = "PASSIVE"  # keyframed instead: rolls in over 14 frames, stops
            ball.rigid_body.kinematic = True
            for f, x in ((1, -1.6), (14, -0.4)):
                ball.location.x = x
                ball.keyframe_insert("location", frame=f)
            chunks = ([bpy.data.objects[f"{meadow.name} blades"]]
                      + blade_objects.extra_chunks(meadow))
            shown[fit_after], rooms[fit_after] = [], []
            for f in range(1, 29):
                scene.frame_set(f)
                assert meadow.tussock_meadow.last_error == "", meadow.tussock_meadow.last_error
                shown[fit_after].append(ribbons(meadow))
                rooms[fit_after].append([len(o.data.vertices) for o in chunks])
            k = simulate.playback_of(meadow).runner.K
            ranges = writer.chunk_ranges(meadow["tussock_active_blades"])
            used = [-(-len(r) // 8) * 8 * 2 * k for r in ranges]
            simulate.forget()
        fitted, grown = rooms[saved[2]][-1], rooms[10 ** 9][-1]
        assert fitted != grown, (fitted, grown)  # growth had left room to fit
        for room, need, before in zip(fitted, used, grown):
            if need:  # a chunk in use: fitted unless an eighth or less was unused
                assert room == need or (room == before and need >= before - before // 8), \
                    (room, need, before)
        assert shown[saved[2]] == shown[10 ** 9]
    finally:
        writer.CAPACITY_BLOCK, writer.CHUNK_MIN_BLADES, writer.FIT_AFTER_FRAMES = saved
        simulate.forget()


@test
def test_dynamic_meshes_keep_the_meadows_texture_space():
    """The simulated blades' meshes have a fixed texture space, the meadow's ground and a
    metre above it, instead of one Blender recomputes from every vertex each frame (a whole
    pass over the vertices per frame)."""
    scene, meadow, ball = rolling_ball_scene()
    origin, size = meadow["tussock_origin"], meadow["tussock_size"]
    boxes = []
    for f in range(1, 13):
        scene.frame_set(f)
        assert meadow.tussock_meadow.last_error == "", meadow.tussock_meadow.last_error
        chunks = [bpy.data.objects[f"{meadow.name} blades"]] + blade_objects.extra_chunks(meadow)
        live = [o.data for o in chunks if o.data.get("tussock_layout") == "live"]
        boxes += [(tuple(m.texspace_location), tuple(m.texspace_size), m.use_auto_texspace)
                  for m in live]
    assert meadow["tussock_active_blades"] > 0 and boxes
    want_loc = (origin[0] + size[0] / 2, origin[1] + size[1] / 2, origin[2] + 0.5)
    want_size = (size[0] / 2, size[1] / 2, 0.5)
    for loc, half, auto in boxes:
        assert not auto
        assert np.allclose(loc, want_loc, atol=1e-5) and np.allclose(half, want_size, atol=1e-5), \
            (loc, half, want_loc, want_size)
    # a new Playback (as after the meadow's ground moved) sets it again, topology kept
    first = bpy.data.objects[f"{meadow.name} blades"].data
    first.texspace_location = (9.0, 9.0, 9.0)
    simulate.forget(meadow)
    scene.frame_set(13)
    assert np.allclose(tuple(first.texspace_location), want_loc, atol=1e-5)
    simulate.forget()


@test
def test_slow_motion_frame_rates_take_more_steps_not_an_error():
    """Two solver steps per frame at ordinary rates, more when a step would exceed 1/20 s
    (a 5 fps time-lapse takes 4), and the blades still bend under the ball."""
    assert [solver.steps_per_frame(f) for f in (60.0, 24.0, 10.0, 5.0, 1.0)] == [2, 2, 2, 4, 20]
    scene, meadow, ball = rolling_ball_scene()
    scene.render.fps = 5
    for f in (1, 2, 3):
        scene.frame_set(f)
        assert meadow.tussock_meadow.last_error == "", meadow.tussock_meadow.last_error
    assert meadow["tussock_active_blades"] > 0
    assert np.isfinite(blade_knots(meadow)).all()
    rest = rest_knots(meadow)
    assert np.abs(blade_knots(meadow).reshape(rest.shape) - rest).max() > 1e-3  # bent


harness.main()
