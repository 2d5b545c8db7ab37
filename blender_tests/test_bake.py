"""Bakes for farms, of trees and of simulated meadows: the .pc2 holds exactly the live
poses and Blender's Mesh Cache plays them; a bake split over two `blender -b` processes
gives the same bytes as one; a .blend renders the same with Tussock disabled; a bake killed
with SIGKILL resumes; a cache of another version, a missing frame, a changed frame range, a
full disk and a read-only folder are reported, never silently rendered wrong; freeing a
meadow's bake brings its live simulation back."""

import os
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import expect_cancel, test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from farm import assert_same_caches, bake_killed, bake_refused_in, blender, cache_files, mount_tmpfs  # noqa: E402,F401,E501

harness.enable_addon()
from tussock import bake, cache, native  # noqa: E402
from tussock.meadow import baked, simulate, writer  # noqa: E402

lib = native.require()
TMP = os.environ.get("TSK_TEST_TMP", "/tmp")
FRAMES = 8


def save_small_render_scene(scene, folder, cam_location, cam_rotation):
    """Adds a camera and a sun, sets a 64x48 one-sample Cycles render with a fixed seed, and
    saves the scene as folder/scene.blend; returns its path."""
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(cam)
    cam.location, cam.rotation_euler = cam_location, cam_rotation
    scene.camera = cam
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.seed = 0
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    scene.render.resolution_percentage = 100
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    scene.collection.objects.link(sun)
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "scene.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    return path


def make_scene(folder, frames=FRAMES, preset="quaking_aspen"):
    """A saved .blend with a swaying tree and a small Cycles camera; returns its path."""
    scene = harness.empty_scene(frames)
    w = scene.tussock_wind
    w.base_speed = 4.0
    wave = w.waves.add()
    wave.amplitude, wave.wavelength, wave.speed = 3.0, 5.0, 6.0
    assert bpy.ops.tussock.add_tree(preset=preset, seed=2, leaves=False) == {"FINISHED"}
    scene.render.film_transparent = True  # alpha shows where the tree is
    return save_small_render_scene(scene, folder, (0.0, -25.0, 6.0), (1.45, 0.0, 0.0))


@test
def test_pc2_holds_live_poses_and_mesh_cache_plays_them():
    path = make_scene(os.path.join(TMP, "live"))
    obj = bpy.data.objects[[o.name for o in bpy.context.scene.objects if o.type == "MESH"][0]]
    scene = bpy.context.scene
    live = {}
    for f in range(1, FRAMES + 1):
        scene.frame_set(f)
        co = np.empty(len(obj.data.vertices) * 3, np.float32)
        obj.data.vertices.foreach_get("co", co)
        live[f] = co
    assert bpy.ops.tussock.bake() == {"FINISHED"}
    pc2 = os.path.join(os.path.dirname(path), "tussock_cache", cache.safe_name(obj.name) + ".pc2")
    info = lib.pc2_info(pc2)
    assert info["samples"] == FRAMES and info["start_frame"] == 1.0
    out = np.empty(info["points"] * 3, np.float32)
    for f in range(1, FRAMES + 1):
        lib.pc2_read_sample(pc2, f - 1, out)
        assert np.array_equal(out, live[f]), f  # the cache is the live pose, bit for bit
    # Blender's own Mesh Cache modifier plays the right frame
    for f in (1, 4, FRAMES):
        scene.frame_set(f)
        ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
        co = np.empty(len(ev.vertices) * 3, np.float32)
        ev.vertices.foreach_get("co", co)
        assert np.allclose(co, live[f], atol=1e-6), f


@test
def test_split_bake_equals_single_bake_and_renders_without_tussock():
    one = make_scene(os.path.join(TMP, "one"))
    two = os.path.join(TMP, "two", "scene.blend")
    os.makedirs(os.path.dirname(two), exist_ok=True)
    shutil.copyfile(one, two)
    blender(one, "bpy.ops.tussock.bake(save=True)")
    blender(two, "bpy.ops.tussock.bake(frame_start=1, frame_end=3, save=True)")
    blender(two, "bpy.ops.tussock.bake(frame_start=4, frame_end=8, save=True)")
    a, b = cache_files(os.path.dirname(one)), cache_files(os.path.dirname(two))
    assert a == b and any(x.endswith(".pc2") for x in a), (a, b)
    assert_same_caches(os.path.dirname(one), os.path.dirname(two))
    # frame 6 rendered from the baked .blend: Tussock enabled, disabled, and the split bake
    renders = []
    for blend, addon in ((one, True), (one, False), (two, False)):
        out = os.path.join(os.path.dirname(blend), f"r_{addon}_")
        blender(blend, f"bpy.context.scene.render.filepath = {out!r}\n"
                       "bpy.context.scene.frame_set(6)\n"
                       "bpy.ops.render.render(write_still=True)", addon=addon)
        img = bpy.data.images.load(out + ".png")
        px = np.empty(64 * 48 * 4, np.float32)
        img.pixels.foreach_get(px)
        renders.append(px)
    assert np.array_equal(renders[0], renders[1]) and np.array_equal(renders[1], renders[2])
    alpha = renders[0].reshape(-1, 4)[:, 3]
    assert 0.02 < (alpha > 0.5).mean() < 0.9, (alpha > 0.5).mean()  # the tree is in the picture


def assert_killed_bake_resumes(ref, killed_dir, timeout):
    """`ref` is baked completely; a copy of it in `killed_dir` is baked, killed with SIGKILL
    after 3 of its 24 frame files, then baked again: it ends with the bytes of `ref`'s cache."""
    killed = os.path.join(killed_dir, "scene.blend")
    os.makedirs(killed_dir, exist_ok=True)
    shutil.copyfile(ref, killed)
    blender(ref, "bpy.ops.tussock.bake()")
    folder = os.path.join(killed_dir, "tussock_cache")

    def frame_files():
        return [f for _, _, fs in os.walk(folder) for f in fs if f.endswith(".tskf")]

    bake_killed(killed, lambda: len(frame_files()) >= 3, timeout)
    done = frame_files()
    assert 3 <= len(done) < 24, len(done)  # killed part-way
    assert not any(f.endswith(".pc2") for f in os.listdir(folder))
    blender(killed, "bpy.ops.tussock.bake()")  # resumes
    assert_same_caches(os.path.dirname(ref), os.path.dirname(killed))


@test
def test_killed_bake_resumes_to_the_same_cache():
    ref = make_scene(os.path.join(TMP, "ref"), frames=24, preset="black_tupelo")
    assert_killed_bake_resumes(ref, os.path.join(TMP, "killed"), timeout=120)


@test
def test_version_missing_frame_and_range_change_are_reported():
    path = make_scene(os.path.join(TMP, "errors"))
    scene = bpy.context.scene
    obj = [o for o in scene.objects if o.type == "MESH"][0]
    assert bpy.ops.tussock.bake() == {"FINISHED"}
    folder = os.path.join(os.path.dirname(path), "tussock_cache", cache.safe_name(obj.name))
    # a frame from another format version: refused with its path, nothing baked over it
    f3 = cache.frame_path(folder, 3)
    with open(f3, "r+b") as f:
        f.seek(8)
        f.write(bytes([9, 0, 0, 0]))
    expect_cancel(bpy.ops.tussock.bake, "another Tussock")
    # a missing frame: the bake writes it again; assembling without it is refused
    os.remove(f3)
    try:
        lib.bake_assemble_pc2(os.path.join(TMP, "x.pc2"),
                              [cache.frame_path(folder, f) for f in range(1, FRAMES + 1)], 1.0, 1.0)
    except lib.Error as exc:
        assert "frame_000003" in str(exc)
    else:
        raise AssertionError("a missing frame was assembled")
    assert bpy.ops.tussock.bake() == {"FINISHED"} and os.path.exists(f3)
    # the frame range grows after baking: frames beyond the cache show the live tree,
    # never the cache's held last frame
    mod = obj.modifiers[cache.MODIFIER]
    scene.frame_end = FRAMES + 4
    scene.frame_set(FRAMES + 2)
    assert not mod.show_render and bake.cached_range(obj, scene) == (1, FRAMES)
    scene.frame_set(2)
    assert mod.show_render
    # the first frame moves: wind time starts elsewhere, every cached pose is out of date
    scene.frame_start = 2
    scene.frame_set(3)
    assert not mod.show_render and bake.cached_range(obj, scene) is None
    scene.frame_start, scene.frame_end = 1, FRAMES
    scene.frame_set(3)
    assert mod.show_render
    # a changed setting (the tree's wind response) makes the cache out of date too
    obj.tussock_tree.wind_strength *= 2
    assert bake.cached_range(obj, scene) is None
    # ... and baking again (without freeing) rewrites every frame from the new inputs: no
    # frame file of the old setting is taken for a finished frame
    scene.frame_set(4)
    assert not mod.show_render
    live4 = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", live4)
    assert bpy.ops.tussock.bake() == {"FINISHED"}
    assert bake.cached_range(obj, scene) == (1, FRAMES)
    pc2 = os.path.join(os.path.dirname(folder), cache.safe_name(obj.name) + ".pc2")
    got = np.empty(lib.pc2_info(pc2)["points"] * 3, np.float32)
    lib.pc2_read_sample(pc2, 3, got)
    assert np.array_equal(got, live4)
    # free: caches gone, live animation back
    assert bpy.ops.tussock.free_bake() == {"FINISHED"}
    assert cache.MODIFIER not in obj.modifiers and not os.path.exists(folder)


# ---- simulated meadows ------------------------------------------------------------------------

def make_meadow_scene(folder, frames=FRAMES):
    """A saved .blend with a small simulated meadow that a keyframed ball crosses, in a
    breeze, and a small Cycles camera looking at the ball's path; returns its path."""
    scene = harness.empty_scene(frames)
    scene.tussock_wind.base_speed = 3.0
    meadow, ball = harness.meadow_crossed_by_ball(frames)
    ball.hide_render = True  # the picture shows the blades it pushed
    return save_small_render_scene(scene, folder, (0.0, -1.6, 0.9), (1.05, 0.0, 0.0))


@test
def test_meadow_pc2_holds_the_live_ribbons_and_rest_elsewhere():
    path = make_meadow_scene(os.path.join(TMP, "meadow_live"))
    scene = bpy.context.scene
    meadow = bpy.data.objects["Meadow"]
    k = 16
    live = {}
    for f in range(1, FRAMES + 1):  # the live simulation, frame by frame
        scene.frame_set(f)
        pb = simulate.playback_of(meadow)
        tiles, counts = pb.runner.active()
        live[f] = (tiles.copy(), counts.copy(), writer.active_ribbons(meadow))
    assert any(len(v[0]) for v in live.values())
    assert bpy.ops.tussock.bake() == {"FINISHED"}
    child = bpy.data.objects["Meadow blades"]
    baked_tiles = np.array(child["tussock_baked_tiles"], np.int32)
    union = np.unique(np.concatenate([v[0] for v in live.values()]))
    assert np.array_equal(baked_tiles, union), (baked_tiles, union)
    pc2 = os.path.join(os.path.dirname(path), "tussock_cache", "Meadow_blades.pc2")
    info = lib.pc2_info(pc2)
    assert info["samples"] == FRAMES and info["points"] == len(child.data.vertices)
    # per tile: its slot in the baked mesh, and its blades at rest
    runner = simulate.playback_of(meadow).runner
    rest = baked.rest_layout(runner, baked_tiles)
    offset = np.concatenate([[0], np.cumsum(rest["counts"])]) * 2 * k * 3
    out = np.empty(info["points"] * 3, np.float32)
    for f in range(1, FRAMES + 1):
        lib.pc2_read_sample(pc2, f - 1, out)
        tiles, counts, ribbons = live[f]
        start = np.concatenate([[0], np.cumsum(counts)]) * 2 * k * 3
        for i, t in enumerate(baked_tiles):  # one comparison per tile of the bake
            got = out[offset[i]:offset[i + 1]]
            where = np.flatnonzero(tiles == t)
            if len(where):  # simulated in this frame: the live ribbons, bit for bit
                j = where[0]
                assert np.array_equal(got, ribbons[start[j]:start[j + 1]]), (f, t)
            else:  # asleep: exactly its rest ribbons
                assert np.array_equal(got, rest["rest"][offset[i]:offset[i + 1]]), (f, t)
    # the instances of every baked tile stay hidden, the others are shown
    hidden = np.empty(len(meadow.data.vertices), bool)
    meadow.data.attributes["tsk_hidden"].data.foreach_get("value", hidden)
    instance_tile = simulate.playback_of(meadow).instance_tile
    assert np.array_equal(hidden, np.isin(instance_tile, baked_tiles))
    # Blender's own Mesh Cache plays the frames
    for f in (2, FRAMES):
        scene.frame_set(f)
        lib.pc2_read_sample(pc2, f - 1, out)
        ev = child.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
        co = np.empty(len(ev.vertices) * 3, np.float32)
        ev.vertices.foreach_get("co", co)
        assert np.allclose(co, out, atol=1e-6), f
        child.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh_clear()


def render_png(blend, frame, addon, name):
    out = os.path.join(os.path.dirname(blend), name)
    blender(blend, f"bpy.context.scene.render.filepath = {out!r}\n"
                   f"bpy.context.scene.frame_set({frame})\n"
                   "bpy.ops.render.render(write_still=True)", addon=addon)
    img = bpy.data.images.load(out + ".png")
    px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px


@test
def test_meadow_split_bake_equals_single_bake_and_renders_without_tussock():
    one = make_meadow_scene(os.path.join(TMP, "meadow_one"))
    two = os.path.join(TMP, "meadow_two", "scene.blend")
    os.makedirs(os.path.dirname(two), exist_ok=True)
    shutil.copyfile(one, two)
    blender(one, "bpy.ops.tussock.bake(save=True)")
    blender(two, "bpy.ops.tussock.bake(frame_start=1, frame_end=3, save=True)")
    blender(two, "bpy.ops.tussock.bake(frame_start=4, frame_end=8, save=True)")
    a, b = cache_files(os.path.dirname(one)), cache_files(os.path.dirname(two))
    assert a == b and "Meadow_blades.pc2" in a and "Meadow_blades.layout.json" in a, (a, b)
    assert_same_caches(os.path.dirname(one), os.path.dirname(two))
    renders = [render_png(one, 6, True, "with"), render_png(one, 6, False, "without"),
               render_png(two, 6, False, "split_without")]
    assert np.array_equal(renders[0], renders[1]) and np.array_equal(renders[1], renders[2])
    rgb = renders[0].reshape(-1, 4)[:, :3]
    assert (rgb.max(axis=1) > 0.01).mean() > 0.5  # the meadow fills the picture


@test
def test_meadow_killed_bake_resumes_to_the_same_cache():
    ref = make_meadow_scene(os.path.join(TMP, "meadow_ref"), frames=24)
    assert_killed_bake_resumes(ref, os.path.join(TMP, "meadow_killed"), timeout=180)


@test
def test_meadow_range_change_is_reported_and_free_bake_restores_the_live_simulation():
    path = make_meadow_scene(os.path.join(TMP, "meadow_range"))
    scene = bpy.context.scene
    meadow = bpy.data.objects["Meadow"]
    scene.frame_set(1)
    live = {}
    for f in range(1, FRAMES + 1):  # ribbons of the simulated blades (the rest of the
        scene.frame_set(f)           # dynamic mesh is spare room, all zero)
        live[f] = writer.active_ribbons(meadow)
    assert bpy.ops.tussock.bake() == {"FINISHED"}
    child = bpy.data.objects["Meadow blades"]
    mod = child.modifiers[cache.MODIFIER]
    baked_count = len(child.data.vertices)
    # the range grows: baking again is refused with what to do; the baked frames still
    # play from the cache, the new ones live
    scene.frame_end = FRAMES + 4
    scene.frame_set(FRAMES)
    expect_cancel(bpy.ops.tussock.bake, f"was baked for frames 1–{FRAMES}")
    scene.frame_set(FRAMES + 2)
    assert not mod.show_render and child.data.get("tussock_layout") == "live"
    assert meadow.get("tussock_active_blades", 0) > 0
    # saved while a live frame shows: the file is saved with the cache on and its layout,
    # so that a farm without Tussock renders the baked frames
    bpy.ops.wm.save_mainfile()
    assert mod.show_render and len(child.data.vertices) == baked_count
    scene.frame_set(FRAMES + 3)
    assert not mod.show_render
    scene.frame_set(5)
    assert mod.show_render and len(child.data.vertices) == baked_count
    assert child.data["tussock_layout"].startswith("baked:")
    hidden = np.empty(len(meadow.data.vertices), bool)
    meadow.data.attributes["tsk_hidden"].data.foreach_get("value", hidden)
    baked_hidden = np.isin(simulate.playback_of(meadow).instance_tile, child["tussock_baked_tiles"])
    assert hidden.sum() > 0 and np.array_equal(hidden, baked_hidden)
    meadow.tussock_meadow.display = 0.5  # rebuilds the instances: tsk_hidden cleared ...
    scene.frame_set(6)
    meadow.data.attributes["tsk_hidden"].data.foreach_get("value", hidden)
    assert np.array_equal(hidden, baked_hidden)  # ... and hidden again on the next frame
    # the first frame moves: every cached frame is out of date, the live simulation shows
    scene.frame_start = 2
    scene.frame_set(5)
    assert not mod.show_render and bake.cached_range(child, scene) is None
    scene.frame_start, scene.frame_end = 1, FRAMES
    scene.frame_set(5)
    assert mod.show_render
    # free: caches gone, and the live simulation is back with the live frames' bytes
    assert bpy.ops.tussock.free_bake() == {"FINISHED"}
    root = os.path.join(os.path.dirname(path), "tussock_cache")
    assert cache.MODIFIER not in child.modifiers and not os.listdir(root), os.listdir(root)
    for f in (1, 2, 3, 4, 5, 6):
        scene.frame_set(f)
        assert child.data.get("tussock_layout") == "live"
        assert np.array_equal(writer.active_ribbons(meadow), live[f]), f
    assert bpy.ops.tussock.bake() == {"FINISHED"}  # and it bakes again after the free


@test
def test_full_disk_and_read_only_folder_are_reported():
    make_scene(os.path.join(TMP, "disk"))
    expect_unsaved = bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    bpy.ops.tussock.add_tree(preset="quaking_aspen", leaves=False)
    expect_cancel(bpy.ops.tussock.bake, "save the .blend first")
    assert expect_unsaved == {"FINISHED"}
    full, ro = os.path.join(TMP, "full"), os.path.join(TMP, "ro")
    if os.geteuid() == 0 and mount_tmpfs(full, "size=96k"):
        try:
            bpy.ops.wm.save_as_mainfile(filepath=os.path.join(full, "scene.blend"), compress=True)
        except RuntimeError:
            pass  # the .blend itself may not fit; then save it outside and point the cache in
        if not bpy.data.filepath.startswith(full):
            bpy.ops.wm.save_as_mainfile(filepath=os.path.join(TMP, "scene_full.blend"))
            bake_refused_in(full, "No space left", unmount=True)
        assert mount_tmpfs(ro, "ro,size=64k")
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(TMP, "scene_ro.blend"))
        bake_refused_in(ro, "Read-only file system", unmount=True)
    else:  # not root: a folder without write permission, and a file-size quota
        os.makedirs(ro, exist_ok=True)
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(TMP, "scene_ro.blend"))
        os.chmod(ro, 0o555)
        bake_refused_in(ro, "Permission denied")


@test
def test_free_bake_removes_a_failed_bake_and_a_renamed_cache():
    """A disk too small for the bake is refused before any file is written; a disk that
    fills while the bake runs (another program writing: the check passes) fails the bake
    part-way, and Free Bake then removes every file it wrote; a tree renamed after its bake
    leaves no old folder behind Free Bake either."""
    blend = make_scene(os.path.join(TMP, "free"))
    tree = bpy.context.active_object  # make_scene's tree
    assert tree.tussock_tree.is_tree
    frame_bytes = len(tree.data.vertices) * 12 + 64
    small = os.path.join(TMP, "small")
    if os.geteuid() == 0 and mount_tmpfs(small, f"size={3 * frame_bytes + 8192}"):
        small_cache = os.path.join(small, "tussock_cache")
        try:
            bake_refused_in(small, "No space left for the bake: it needs about")
            assert cache_files(small) == [], cache_files(small)
            check = bake.check_free_space
            bake.check_free_space = lambda *args: None
            try:
                bake_refused_in(small, "No space left")
            finally:
                bake.check_free_space = check
            written = cache_files(small)
            assert any(f.endswith(".tskf") for f in written), written
            cache.CACHE_DIR_OVERRIDE = small_cache
            try:
                assert bpy.ops.tussock.free_bake() == {"FINISHED"}
            finally:
                cache.CACHE_DIR_OVERRIDE = None
            assert cache_files(small) == [], cache_files(small)
        finally:
            subprocess.run(["umount", small])
    assert bpy.ops.tussock.bake() == {"FINISHED"}
    folder = os.path.dirname(blend)
    assert any(f.endswith(".pc2") for f in cache_files(folder)), cache_files(folder)
    tree.name = "Renamed tree"
    assert bpy.ops.tussock.free_bake() == {"FINISHED"}
    assert cache_files(folder) == [], cache_files(folder)
    assert tree.modifiers.get(cache.MODIFIER) is None


harness.main()
