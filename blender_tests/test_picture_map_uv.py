"""The UV pass through Blender's own compositor: a layer image and the native UV pass fed to
a Map UV node render (to an EXR) exactly what the native warp computes with the sampling of
this Blender's Map UV node (compat.map_uv_sampling: 'map_uv' before 5.0, 'map_uv_5' from
5.0) within 1e-5, far inside 1/255, in both compositor execution modes where there are two;
and at rest the render is the layer itself. This pins the UV convention (origin bottom-left,
pixel centres at (i + 0.5) / W, blue = alpha) and Map UV's EWA filter against real Blender.
The compositor runs on the CPU: Blender's GPU compositor (the default from 5.0, in
background Blender too when a driver is found) samples through the driver's anisotropic
texture filter, which no native sampling reproduces."""

import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

harness.enable_addon()
from tussock import compat, native  # noqa: E402

lib = native.require()

W, H = 96, 64  # not square: the EWA ellipse mixes width and height


def _layer_picture(seed):
    rng = np.random.default_rng(seed)
    img = np.empty((H, W, 4), np.float32)
    img[..., :3] = rng.random((H, W, 3), dtype=np.float32)
    img[..., 3] = 1.0
    pic = lib.picture_create(W, H, img)
    mask = np.zeros((H, W), np.uint8)
    mask[24:60, 16:80] = 255
    lib.picture_add_layer(pic, mask)
    lib.picture_build(pic)
    return pic


def _float_image(name, pixels_bottom_up):
    im = bpy.data.images.new(name, W, H, alpha=True, float_buffer=True)
    im.colorspace_settings.name = "Non-Color"
    im.alpha_mode = "PREMUL"
    im.pixels.foreach_set(pixels_bottom_up.ravel())
    return im


def _render_map_uv(layer_bottom_up, uv_bottom_up, mode, background_bottom_up=None):
    """Map UV of the layer image by the UV image (Alpha Over the background when given),
    rendered to EXR, read back top-first."""
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.render.resolution_percentage = 100
    compat.compositor_on_cpu(scene)
    tree = compat.compositor_tree(scene)
    if hasattr(tree, "execution_mode"):
        tree.execution_mode = mode
    tree.nodes.clear()
    n_layer = tree.nodes.new("CompositorNodeImage")
    n_layer.image = _float_image("tsk_layer", layer_bottom_up)
    n_uv = tree.nodes.new("CompositorNodeImage")
    n_uv.image = _float_image("tsk_uv", uv_bottom_up)
    map_uv = tree.nodes.new("CompositorNodeMapUV")
    compat.map_uv_like_ewa(map_uv)
    out = compat.compositor_output(tree)
    tree.links.new(n_layer.outputs["Image"], map_uv.inputs["Image"])
    tree.links.new(n_uv.outputs["Image"], map_uv.inputs["UV"])
    if background_bottom_up is None:
        tree.links.new(map_uv.outputs["Image"], out.inputs["Image"])
    else:
        n_bg = tree.nodes.new("CompositorNodeImage")
        n_bg.image = _float_image("tsk_background", background_bottom_up)
        over = tree.nodes.new("CompositorNodeAlphaOver")
        compat.alpha_over_premultiplied(over)  # the layer is premultiplied already
        back, front = compat.alpha_over_inputs(over)
        tree.links.new(n_bg.outputs["Image"], back)
        tree.links.new(map_uv.outputs["Image"], front)
        tree.links.new(over.outputs["Image"], out.inputs["Image"])
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR"
    settings.color_depth = "32"
    settings.color_mode = "RGBA"
    with tempfile.TemporaryDirectory() as tmp:
        scene.render.filepath = os.path.join(tmp, "map_uv.exr")
        bpy.ops.render.render(write_still=True)
        result = lib.picture_load(scene.render.filepath)
        pixels = np.empty((H, W, 4), np.float32)
        lib.picture_read_rgba(result, pixels)
    return pixels


def _frame(pic, amplitude, sampling):
    a = np.arange(64, dtype=np.float32)
    vx = (amplitude * np.sin(0.7 * a)).astype(np.float32)
    vy = (0.3 * amplitude * np.cos(0.4 * a)).astype(np.float32)
    rgba = np.empty((H, W, 4), np.float32)
    uv = np.empty((H, W, 4), np.float32)
    lib.picture_layer_frame(pic, 0, vx, vy, 8, 8, rgba=rgba, uv=uv, lambda_x=8.0,
                            lambda_y=8.0, sampling=sampling)
    return rgba, uv


@test
def test_compositor_map_uv_equals_native_warp():
    pic = _layer_picture(1)
    layer = np.empty((H, W, 4), np.float32)
    lib.picture_read_layer(pic, 0, layer, bottom_up=True)
    for amplitude in (0.0, 0.9, 3.0):
        native_rgba, uv = _frame(pic, amplitude, compat.map_uv_sampling())
        for mode in ("TILED", "FULL_FRAME"):
            rendered = _render_map_uv(layer, uv, mode)
            err = float(np.max(np.abs(rendered - native_rgba)))
            print(f"    amplitude {amplitude} {mode}: max |compositor - native| = {err:.3g}")
            assert err < 1e-5, (amplitude, mode, err)
    # the bilinear warp is a different filter: it differs from the compositor visibly
    bilinear, uv = _frame(pic, 0.9, "bilinear")
    rendered = _render_map_uv(layer, uv, "TILED")
    assert np.max(np.abs(rendered - bilinear)) > 1.0 / 255.0


@test
def test_compositor_alpha_over_equals_native_composite():
    pic = _layer_picture(2)
    layer = np.empty((H, W, 4), np.float32)
    lib.picture_read_layer(pic, 0, layer, bottom_up=True)
    background = np.empty((H, W, 4), np.float32)
    lib.picture_read_background(pic, background, bottom_up=True)
    native_layer, uv = _frame(pic, 1.5, compat.map_uv_sampling())
    native = np.empty((H, W, 4), np.float32)
    lib.picture_composite(pic, [native_layer], native)
    rendered = _render_map_uv(layer, uv, "TILED", background)
    err = float(np.max(np.abs(rendered - native)))
    print(f"    Map UV + Alpha Over vs native composite: max difference {err:.3g}")
    assert err < 1e-5, err


harness.main()
