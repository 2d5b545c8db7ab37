"""Bakes of animated pictures for farms: the baked OpenEXR files hold exactly the UV passes,
plate and layers Tussock computes live, and the compositor reads them through stock Image
nodes; a bake split over two `blender -b` processes gives the same bytes as one; the baked
.blend renders the same frame with Tussock disabled as with it enabled (and that frame is
Tussock's own composite, and it moves); a bake killed with SIGKILL resumes to the same
files; a cache of another version, a missing frame, a frame-range or settings change are
reported and the live frame is shown instead, never a wrong one; a read-only folder and a
full disk are reported with the scene unchanged; Free Bake restores the live wiring."""

import filecmp
import os
import shutil
import signal
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import expect_cancel, test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(harness.REPO, "tools"))
import blender_env  # noqa: E402

harness.enable_addon()
from tussock import bake, native  # noqa: E402
from tussock.picture import bake as picture_bake  # noqa: E402
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


def blender(blend, expr, addon=True):
    """Runs background Blender on a .blend with a python expression (a farm worker)."""
    with blender_env.BlenderUser() as user:
        if not addon:
            os.unlink(os.path.join(user.root, "scripts", "addons", "tussock"))
        script = os.path.join(user.tmp, "run.py")
        with open(script, "w") as f:
            f.write("import bpy, addon_utils, sys\n")
            if addon:
                f.write("addon_utils.enable('tussock', default_set=True)\n")
            f.write(expr + "\n")
        proc = subprocess.run(blender_env.command(script, blend=blend), env=user.env,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        assert proc.returncode == 0, proc.stdout[-3000:]
        return proc.stdout


def render_in(blend, frame, out, addon):
    """Frame `frame` of a .blend rendered by another background Blender, with or without
    Tussock installed; RGBA top-first."""
    blender(blend, f"bpy.context.scene.render.filepath = {out!r}\n"
                   f"bpy.context.scene.frame_set({frame})\n"
                   "bpy.ops.render.render(write_still=True)", addon=addon)
    return read_exr(out)


def cache_files(folder):
    root = os.path.join(folder, "tussock_cache")
    out = []
    for dirpath, _, files in os.walk(root):
        out += [os.path.relpath(os.path.join(dirpath, f), root) for f in files]
    return sorted(out)


def uv_path(scene, i, frame):
    stem = picture_bake.uv_name(scene, i)
    return os.path.join(bake.cache_root(), stem, picture_bake.uv_file(stem, frame))


def node_image(scene, name):
    return scene.node_tree.nodes[name].image


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
    folder = os.path.join(bake.cache_root(), picture_bake.base_name(scene))
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
    baked = render(scene, 6, "baked")
    assert np.array_equal(baked, live_render)
    err = float(np.max(np.abs(baked - frames.native_composite(scene, 6))))
    assert err < TOL, err


harness.main()
