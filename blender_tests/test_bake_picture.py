"""Bakes of animated pictures for farms: the baked OpenEXR files hold exactly the UV passes,
plate and layers Tussock computes live, and the compositor reads them through stock Image
nodes; a bake split over two `blender -b` processes gives the same bytes as one; the baked
.blend renders the same frame with Tussock disabled as with it enabled (and that frame is
Tussock's own composite, and it moves); a bake killed with SIGKILL resumes to the same
files; a cache of another version, a missing frame, a frame-range or settings change are
reported and the live frame is shown instead, never a wrong one; a read-only folder and a
full disk are reported with the scene unchanged; Free Bake restores the live wiring."""

import os
import shutil
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import expect_cancel, test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from farm import assert_same_caches, bake_killed, bake_refused_in, blender, cache_files, mount_tmpfs  # noqa: E402,F401,E501

harness.enable_addon()
from tussock import bake, cache, compat, native  # noqa: E402
from tussock.picture import baking as picture_baking  # noqa: E402
from tussock.picture import frames  # noqa: E402
from tussock.wind import runtime as wind_runtime  # noqa: E402

lib = native.require()
TMP = os.environ.get("TSK_TEST_TMP", "/tmp")
FRAMES = 8
TOL = 1e-5  # a rendered frame against Tussock's composite (Map UV's EWA re-implemented)


def paint(w, h):
    """Sky with texture, grass along the bottom (layer 1), a round crown (layer 2):
    straight RGBA top-first and the two masks."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    img = np.zeros((h, w, 4), np.float32)
    img[..., 0] = 0.45 + 0.3 * np.sin(x / 6.0) * np.cos(y / 9.0)
    img[..., 1] = 0.6 + 0.2 * np.cos(y / 5.0)
    img[..., 2], img[..., 3] = 0.85, 1.0
    grass = y > 0.65 * h + 8 * np.sin(x / 9.0) + 4 * np.sin(x * 1.3)
    img[grass, 0] = 0.12 + 0.1 * np.sin(x[grass] * 1.7)
    img[grass, 1] = 0.45 + 0.2 * np.sin(x[grass] * 0.9 + y[grass] * 0.3)
    img[grass, 2] = 0.08
    crown = (x - 0.75 * w) ** 2 + (y - 0.27 * h) ** 2 < (0.15 * h) ** 2
    img[crown, 0] = 0.2
    img[crown, 1] = 0.35 + 0.3 * np.sin(x[crown] * 2.1) * np.sin(y[crown] * 1.9)
    img[crown, 2] = 0.15
    return np.clip(img, 0, 1), grass, crown


def save_png(path, rgba):
    h, w = rgba.shape[:2]
    im = bpy.data.images.new("tmp_png", w, h, alpha=True)
    im.pixels.foreach_set(np.ascontiguousarray(rgba[::-1], np.float32).ravel())
    im.filepath_raw = path
    im.file_format = "PNG"
    im.save()
    bpy.data.images.remove(im)


def mask_rgba(m):
    out = np.zeros(m.shape + (4,), np.float32)
    out[m] = 1.0
    out[..., 3] = 1.0
    return out


def make_scene(folder, frames_=FRAMES, size=(160, 120), loop=0):
    """A saved .blend in `folder` animating a two-layer picture (files beside it, relative
    paths), rendering to 32-bit EXR; returns its path."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    wind_runtime.clear()
    frames.forget()
    os.makedirs(folder, exist_ok=True)
    w, h = size
    img, grass, crown = paint(w, h)
    save_png(os.path.join(folder, "picture.png"), img)
    save_png(os.path.join(folder, "grass.png"), mask_rgba(grass))
    save_png(os.path.join(folder, "crown.png"), mask_rgba(crown))
    path = os.path.join(folder, "scene.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)  # so that '//' paths resolve
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, frames_
    s = scene.tussock_picture
    s.filepath, s.loop_frames = "//picture.png", loop
    layer = s.layers.add()
    layer.name, layer.mask_path, layer.lambda_x, layer.lambda_y = "Grass", "//grass.png", 60.0, 20.0
    layer = s.layers.add()
    layer.name, layer.mask_path, layer.root = "Crown", "//crown.png", "NONE"
    layer.lambda_x, layer.lambda_y, layer.cell_x, layer.cell_y = 40.0, 40.0, 8, 8
    assert bpy.ops.tussock.animate_picture() == {"FINISHED"}
    for obj in scene.objects:
        if obj.tussock_wind_source.is_source:
            obj.tussock_wind_source.strength = 0.9
    st = scene.render.image_settings
    st.file_format, st.color_depth, st.color_mode = "OPEN_EXR", "32", "RGBA"
    bpy.ops.wm.save_mainfile()
    return path


def read_exr(path):
    pic = lib.picture_load(path)
    w, h = lib.picture_size(pic)
    out = np.empty((h, w, 4), np.float32)
    lib.picture_read_rgba(pic, out)
    return out


def render(scene, frame, name):
    """Frame `frame` rendered through the compositor in this Blender; RGBA top-first."""
    scene.frame_set(frame)
    scene.render.filepath = os.path.join(TMP, f"{name}_{frame}.exr")
    bpy.ops.render.render(write_still=True)
    return read_exr(scene.render.filepath)


def render_in(blend, frame, out, addon):
    """Frame `frame` of a .blend rendered by another background Blender, with or without
    Tussock installed; RGBA top-first."""
    blender(blend, f"bpy.context.scene.render.filepath = {out!r}\n"
                   f"bpy.context.scene.frame_set({frame})\n"
                   "bpy.ops.render.render(write_still=True)", addon=addon)
    return read_exr(out)


def uv_path(scene, i, frame):
    stem = picture_baking.uv_name(scene, i)
    return os.path.join(cache.cache_root(), stem, picture_baking.uv_file(stem, frame))


def uv_path_in(folder, scene, i, frame):
    stem = picture_baking.uv_name(scene, i)
    return os.path.join(TMP, folder, "tussock_cache", stem, picture_baking.uv_file(stem, frame))


def node_image(scene, name):
    return compat.compositor_tree(scene, create=False).nodes[name].image


@test
def test_baked_files_hold_the_live_passes_and_render_the_live_frames():
    make_scene(os.path.join(TMP, "live"))
    scene = bpy.context.scene
    s = scene.tussock_picture
    b = frames.built(scene)
    w, h = b.width, b.height
    live_uv = {f: [uv.reshape(h, w, 4)[::-1].copy() for uv, _ in frames.layer_frames(scene, f)]
               for f in range(1, FRAMES + 1)}
    live_render = render(scene, 6, "live")
    assert bpy.ops.tussock.bake() == {"FINISHED"}
    for f in range(1, FRAMES + 1):  # every baked UV pass is the live one, bit for bit
        for i in (1, 2):
            got = read_exr(uv_path(scene, i, f))
            assert np.array_equal(got, live_uv[f][i - 1]), (f, i)
    moved = np.abs(live_uv[FRAMES][0] - live_uv[1][0])[..., :2].max()
    assert moved * w > 0.5, moved  # more than half a pixel: the bake holds motion
    folder = os.path.join(cache.cache_root(), picture_baking.base_name(scene))
    buf = np.empty((h, w, 4), np.float32)
    lib.picture_read_background(b.handle, buf)
    assert np.array_equal(read_exr(os.path.join(folder, "background.exr")), buf)
    for i in (0, 1):
        lib.picture_read_layer(b.handle, i, buf)
        assert np.array_equal(read_exr(os.path.join(folder, f"layer_{i + 1}.exr")), buf)
    # stock Image nodes read the files: the UV passes as sequences numbered by frame
    uv = node_image(scene, "Tussock UV 1")
    assert uv.source == "SEQUENCE" and uv.filepath.startswith("//tussock_cache/")
    assert node_image(scene, "Tussock Background").filepath.endswith("background.exr")
    assert uv != s.images[0].uv_image
    # the worker part runs off the main thread (as in an interactive bake) and writes
    # the same bytes
    job = picture_baking.jobs(scene, cache.cache_root())[0]
    old = {f: open(uv_path(scene, 1, f), "rb").read() for f in (1, 6)}
    for f in (1, 6):
        os.remove(uv_path(scene, 1, f))
    done, errors = [], []

    def work():
        try:
            job.bake_frames(job.frames((1, FRAMES)), lambda: done.append(1), lambda: False)
        except Exception as exc:  # noqa: BLE001 - reported below
            errors.append(exc)
    worker = threading.Thread(target=work)
    worker.start()
    worker.join()
    assert not errors and len(done) == FRAMES, (errors, len(done))
    assert all(open(uv_path(scene, 1, f), "rb").read() == old[f] for f in (1, 6))
    baked = render(scene, 6, "baked")
    assert node_image(scene, "Tussock UV 1") == uv  # rendered from the files
    assert np.array_equal(baked, live_render)
    err = float(np.max(np.abs(baked - frames.native_composite(scene, 6))))
    assert err < TOL, err


@test
def test_split_bake_equals_single_bake_and_renders_without_tussock():
    one = make_scene(os.path.join(TMP, "one"))
    expected = frames.native_composite(bpy.context.scene, 6)
    still = frames.native_composite(bpy.context.scene, 1)
    assert np.abs(expected - still).max() > 0.05  # frame 6 has moved
    two_dir = os.path.join(TMP, "two")
    os.makedirs(two_dir, exist_ok=True)
    for name in ("scene.blend", "picture.png", "grass.png", "crown.png"):
        shutil.copyfile(os.path.join(TMP, "one", name), os.path.join(two_dir, name))
    two = os.path.join(two_dir, "scene.blend")
    blender(one, "bpy.ops.tussock.bake(save=True)")
    blender(two, "bpy.ops.tussock.bake(frame_start=1, frame_end=3, save=True)")
    blender(two, "bpy.ops.tussock.bake(frame_start=4, frame_end=8, save=True)")
    a, b = cache_files(os.path.dirname(one)), cache_files(two_dir)
    assert a == b and sum(x.endswith(".exr") for x in a) == 3 + 2 * FRAMES, (a, b)
    assert_same_caches(os.path.dirname(one), two_dir)
    # frame 6 rendered from the baked .blend with Tussock, without it, and from the split
    # bake without it; the pictures and masks are gone for the Blenders without Tussock
    with_tussock = render_in(one, 6, os.path.join(TMP, "one", "with.exr"), True)
    for folder in (os.path.dirname(one), two_dir):
        for name in ("picture.png", "grass.png", "crown.png"):
            os.remove(os.path.join(folder, name))
    without = render_in(one, 6, os.path.join(TMP, "one", "without.exr"), False)
    split = render_in(two, 6, os.path.join(two_dir, "without.exr"), False)
    assert np.array_equal(with_tussock, without) and np.array_equal(without, split)
    err = float(np.max(np.abs(without - expected)))
    assert err < TOL, err
    # frame 1 without Tussock is the picture at rest: the sequence plays by frame number
    first = render_in(one, 1, os.path.join(TMP, "one", "first.exr"), False)
    assert float(np.max(np.abs(first - still))) < TOL


@test
def test_a_worker_removes_only_its_own_or_stale_temporary_files():
    # A split bake's workers share the folders: one must not remove the temporary file
    # another is writing (found by the farm run on an artist's machine: a worker's
    # UV frame vanished before its rename). Its own frames' leftovers, and a plate's that
    # no one has touched for long, are a killed bake's and go.
    make_scene(os.path.join(TMP, "workers"))
    scene = bpy.context.scene
    job = picture_baking.jobs(scene, cache.cache_root())[0]
    for folder in [job.folder] + job.uv_folders:
        os.makedirs(folder, exist_ok=True)
    stem = job.uv_stems[0]
    other = os.path.join(job.uv_folders[0], picture_baking.uv_file(stem, 6) + ".tmp99999.exr")
    own = os.path.join(job.uv_folders[0], picture_baking.uv_file(stem, 2) + ".tmp99999.exr")
    plate = os.path.join(job.folder, "background.exr.tmp99998.exr")
    stale = os.path.join(job.folder, "layer_1.exr.tmp99997.exr")
    # a sidecar is written to `<file>.tski.tmp<pid>` after its EXR is renamed: a bake killed
    # there left one that its resumed bake kept (CI, Blender 4.3: one file too many)
    own_sidecar, other_sidecar = (
        os.path.join(job.uv_folders[0], picture_baking.uv_file(stem, f) + ".tski.tmp99999")
        for f in (3, 7))
    for path in (other, own, plate, stale, own_sidecar, other_sidecar):
        with open(path, "wb") as f:
            f.write(b"being written")
    old = time.time() - 2 * picture_baking.STALE_TEMPORARY_S
    os.utime(stale, (old, old))
    for _ in job.steps([1, 2, 3, 4], lambda: None):
        pass
    assert os.path.isfile(other) and os.path.isfile(plate) and os.path.isfile(other_sidecar), \
        "another worker's file was removed"
    assert not os.path.exists(own) and not os.path.exists(stale)
    assert not os.path.exists(own_sidecar)
    assert all(os.path.isfile(uv_path(scene, 1, f)) for f in (1, 2, 3, 4))
    assert not os.path.exists(uv_path(scene, 1, 6))


def count_sidecars(folder):
    return sum(f.endswith(".tski") for _, _, fs in os.walk(folder) for f in fs)


@test
def test_killed_bake_resumes_to_the_same_files():
    n = 40
    ref = make_scene(os.path.join(TMP, "ref"), frames_=n, size=(480, 360), loop=12)
    killed_dir = os.path.join(TMP, "killed")
    os.makedirs(killed_dir, exist_ok=True)
    for name in ("scene.blend", "picture.png", "grass.png", "crown.png"):
        shutil.copyfile(os.path.join(TMP, "ref", name), os.path.join(killed_dir, name))
    killed = os.path.join(killed_dir, "scene.blend")
    start = time.time()
    blender(ref, "bpy.ops.tussock.bake()")
    print(f"    {n} frames of 480x360 with 2 layers baked in {time.time() - start:.1f} s "
          "(Blender start included)")
    # the loop's frames (made from wind frames out of order) are the live ones
    scene = bpy.context.scene
    w, h = 480, 360
    for f in (1, 7, 13, n):
        live = frames.layer_frames(scene, f)
        for i in (1, 2):
            got = read_exr(os.path.join(TMP, "ref", "tussock_cache",
                                        picture_baking.uv_name(scene, i),
                                        picture_baking.uv_file(
                                            picture_baking.uv_name(scene, i), f)))
            assert np.array_equal(got, live[i - 1][0].reshape(h, w, 4)[::-1]), (f, i)
    assert np.array_equal(read_exr(uv_path_in("ref", scene, 1, 1)),
                          read_exr(uv_path_in("ref", scene, 1, 13)))  # the loop closes
    folder = os.path.join(killed_dir, "tussock_cache")
    total = 3 + 2 * n
    bake_killed(killed, lambda: count_sidecars(folder) >= 3 + 2 * 5, 120)
    done = count_sidecars(folder)
    print(f"    killed after {done} of {total} files")
    assert 3 + 2 * 5 <= done < total, done  # killed part-way
    blender(killed, "bpy.ops.tussock.bake()")  # resumes
    assert count_sidecars(folder) == total
    assert_same_caches(os.path.dirname(ref), killed_dir)


class _Layout:
    """Stands in for the Bake panel's layout and keeps the labels it shows."""

    def __init__(self, labels):
        self.labels = labels

    def __getattr__(self, name):
        return lambda *a, **k: _Layout(self.labels)

    def label(self, text="", **kw):
        self.labels.append(text)


def panel_labels():
    labels = []
    me = type("P", (), {"layout": _Layout(labels)})()
    bpy.types.TUSSOCK_PT_bake.draw(me, bpy.context)
    return labels


def shows_live(scene):
    return node_image(scene, "Tussock UV 1") == scene.tussock_picture.images[0].uv_image


@test
def test_version_missing_frame_and_range_change_are_reported_and_shown_live():
    make_scene(os.path.join(TMP, "errors"))
    scene = bpy.context.scene
    expected = {f: frames.native_composite(scene, f) for f in (3, 5, FRAMES + 2)}
    assert bpy.ops.tussock.bake() == {"FINISHED"}
    assert panel_labels() == [f"Picture: frames 1-{FRAMES}"]
    # a frame from another format version: never shown, and a bake refuses to build on it
    f3 = uv_path(scene, 2, 3)
    with open(f3 + ".tski", "r+b") as f:
        f.seek(8)
        f.write(bytes([9, 0, 0, 0]))
    why = picture_baking.frame_problem(scene, 3)
    assert why and "another Tussock" in why and os.path.basename(f3) in why, why
    assert float(np.max(np.abs(render(scene, 3, "version") - expected[3]))) < TOL
    assert shows_live(scene)
    expect_cancel(bpy.ops.tussock.bake, "another Tussock")
    # a missing frame: reported with its file, the live frame is rendered, a bake rewrites it
    os.remove(f3)
    os.remove(f3 + ".tski")
    f5 = uv_path(scene, 1, 5)
    os.remove(f5)
    why = picture_baking.frame_problem(scene, 5)
    assert why and "frame 5" in why and os.path.basename(f5) in why, why
    assert float(np.max(np.abs(render(scene, 5, "missing") - expected[5]))) < TOL
    assert shows_live(scene)
    assert bpy.ops.tussock.bake() == {"FINISHED"}
    assert os.path.exists(f5) and os.path.exists(f3)
    scene.frame_set(5)
    assert not shows_live(scene) and picture_baking.frame_problem(scene, 5) is None
    # the frame range grows after baking: frames beyond it are live, never a held frame
    scene.frame_end = FRAMES + 4
    why = picture_baking.frame_problem(scene, FRAMES + 2)
    assert why and f"outside the baked frames 1-{FRAMES}" in why, why
    got = render(scene, FRAMES + 2, "beyond")
    assert shows_live(scene) and float(np.max(np.abs(got - expected[FRAMES + 2]))) < TOL
    scene.frame_set(2)
    assert not shows_live(scene)
    # the first frame moves: the wind starts elsewhere, every baked frame is out of date
    scene.frame_start = 2
    scene.frame_set(3)
    why = picture_baking.frame_problem(scene, 3)
    assert shows_live(scene) and why and "out of date" in why, why
    assert panel_labels() == ["Picture: bake out of date, bake again"]
    scene.frame_start, scene.frame_end = 1, FRAMES
    scene.frame_set(3)
    assert not shows_live(scene)
    # a motion setting changes: out of date too
    scene.tussock_picture.layers[0].lambda_x *= 2
    assert "out of date" in picture_baking.frame_problem(scene, 3)
    scene.tussock_picture.layers[0].lambda_x /= 2
    assert picture_baking.frame_problem(scene, 3) is None
    # a keyframed wind source changes: the check at every frame does not see it (it is
    # documented), but a new bake does and writes the frames again
    before = open(uv_path(scene, 1, FRAMES), "rb").read()
    src = [o for o in scene.objects if o.tussock_wind_source.is_source][0]
    src.tussock_wind_source.strength = 0.2
    src.keyframe_insert("tussock_wind_source.strength", frame=4)
    src.tussock_wind_source.strength = 1.0
    src.keyframe_insert("tussock_wind_source.strength", frame=5)
    assert bpy.ops.tussock.bake() == {"FINISHED"}
    after = open(uv_path(scene, 1, FRAMES), "rb").read()
    assert after != before
    live = frames.layer_frames(scene, FRAMES)[0][0].reshape(120, 160, 4)[::-1]
    assert np.array_equal(read_exr(uv_path(scene, 1, FRAMES)), live)
    # Free Bake: files and baked images gone, the live images wired again
    names = list(scene[picture_baking.RECORD]["images"])
    assert bpy.ops.tussock.free_bake() == {"FINISHED"}
    assert shows_live(scene) and picture_baking.RECORD not in scene
    assert not any(bpy.data.images.get(n) for n in names)
    assert cache_files(os.path.join(TMP, "errors")) == []
    assert float(np.max(np.abs(render(scene, 3, "freed") -
                               frames.native_composite(scene, 3)))) < TOL


@test
def test_bad_input_cancels_with_the_scene_unchanged():
    folder = os.path.join(TMP, "bad")
    make_scene(folder)
    scene = bpy.context.scene
    # the picture file is gone and this Blender has not built it yet (a file just opened)
    frames.forget()
    os.rename(os.path.join(folder, "picture.png"), os.path.join(folder, "moved.png"))
    expect_cancel(bpy.ops.tussock.bake, "picture.png")
    os.rename(os.path.join(folder, "moved.png"), os.path.join(folder, "picture.png"))
    # the compositor's Tussock nodes were deleted
    tree = compat.compositor_tree(scene, create=False)
    node = tree.nodes["Tussock UV 2"]
    tree.nodes.remove(node)
    expect_cancel(bpy.ops.tussock.bake, "Tussock UV 2")
    assert cache_files(folder) == []
    # an unsaved file has no place for caches
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    s = bpy.context.scene.tussock_picture
    s.filepath = os.path.join(folder, "picture.png")
    layer = s.layers.add()
    layer.mask_path = os.path.join(folder, "grass.png")
    assert bpy.ops.tussock.animate_picture() == {"FINISHED"}
    expect_cancel(bpy.ops.tussock.bake, "save the .blend first")
    assert picture_baking.RECORD not in bpy.context.scene


@test
def test_read_only_folder_and_full_disk_are_reported_with_the_scene_unchanged():
    make_scene(os.path.join(TMP, "disk"), size=(320, 240))
    scene = bpy.context.scene
    ro, full = os.path.join(TMP, "pic_ro"), os.path.join(TMP, "pic_full")
    if os.geteuid() == 0 and mount_tmpfs(ro, "ro,size=64k"):
        bake_refused_in(ro, "Read-only file system", unmount=True)
        # the cache's folders exist but the disk became read-only: the frame writer says so
        assert mount_tmpfs(ro, "size=64k")
        for sub in (picture_baking.base_name(scene), picture_baking.uv_name(scene, 1),
                    picture_baking.uv_name(scene, 2)):
            os.makedirs(os.path.join(ro, "tussock_cache", sub))
        # as an earlier bake of this scene left them, with the record of its files
        bake.record_outputs(scene, os.path.join(ro, "tussock_cache"),
                            picture_baking.PictureJob(scene, os.path.join(ro, "tussock_cache"))
                            .outputs())
        subprocess.run(["mount", "-o", "remount,ro", ro], check=True)
        bake_refused_in(ro, "background.exr': Read-only file system", unmount=True)
        # a disk that fills during the bake: one 320x240 float frame is ~1 MB
        assert mount_tmpfs(full, "size=2m")
        os.makedirs(os.path.join(full, "tussock_cache"))

        def no_temporary_file_left():
            left = [f for _, _, fs in os.walk(full) for f in fs if ".tmp" in f]
            assert left == [], left

        bake_refused_in(full, "No space left on device", unmount=True,
                        after=no_temporary_file_left)
    else:  # not root: a folder without write permission
        os.makedirs(ro, exist_ok=True)
        os.chmod(ro, 0o555)
        bake_refused_in(ro, "Permission denied")
    assert shows_live(scene) and picture_baking.RECORD not in scene


harness.main()
