"""The picture binding inside Blender: pictures as handles, layers, frames into numpy float32
buffers; the UV pass sampled the way Map UV samples reproduces the native warp; bad buffers
and parameters raise tussock.Error naming the argument."""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import test  # noqa: E402

import numpy as np  # noqa: E402

harness.enable_addon()
from tussock import native  # noqa: E402

lib = native.require()

W, H = 96, 64


def _picture():
    y, x = np.mgrid[0:H, 0:W].astype(np.float32)
    img = np.empty((H, W, 4), np.float32)
    img[..., 0] = 0.5 + 0.3 * np.sin(0.2 * x)
    img[..., 1] = 0.5 + 0.3 * np.cos(0.15 * y)
    img[..., 2] = 0.4
    img[..., 3] = 1.0
    pic = lib.picture_create(W, H, img)
    mask = np.zeros((H, W), np.uint8)
    mask[24:60, 16:80] = 255
    assert lib.picture_add_layer(pic, mask) == 0
    lib.picture_build(pic)
    return pic, img


def _bilinear_map_uv(img_bottom_up, uv):
    """Map UV with bilinear interpolation: origin bottom-left, centres at (i + 0.5) / W."""
    h, w = img_bottom_up.shape[:2]
    x = uv[..., 0].astype(np.float64) * w - 0.5
    y = uv[..., 1].astype(np.float64) * h - 0.5
    x0 = np.floor(x).astype(int)
    y0 = np.floor(y).astype(int)
    tx = (x - x0)[..., None]
    ty = (y - y0)[..., None]
    x1 = np.minimum(x0 + 1, w - 1)
    y1 = np.minimum(y0 + 1, h - 1)
    im = img_bottom_up.astype(np.float64)
    return ((1 - ty) * ((1 - tx) * im[y0, x0] + tx * im[y0, x1]) +
            ty * ((1 - tx) * im[y1, x0] + tx * im[y1, x1]))


@test
def test_zero_wind_uv_pass_is_pixel_centres():
    pic, _ = _picture()
    z = np.zeros(64, np.float32)
    uv = np.empty((H, W, 4), np.float32)
    lib.picture_layer_frame(pic, 0, z, z, 8, 8, uv=uv)
    u = (np.arange(W, dtype=np.float32) + np.float32(0.5)) / np.float32(W)
    v = (np.arange(H, dtype=np.float32) + np.float32(0.5)) / np.float32(H)
    assert np.array_equal(uv[..., 0], np.broadcast_to(u, (H, W)))
    assert np.array_equal(uv[..., 1], np.broadcast_to(v[:, None], (H, W)))


@test
def test_uv_pass_sampled_like_map_uv_equals_native_warp():
    pic, _ = _picture()
    a = np.arange(64, dtype=np.float32)
    vx = (0.9 * np.sin(0.7 * a)).astype(np.float32)
    vy = (0.3 * np.cos(0.4 * a)).astype(np.float32)
    rgba = np.empty((H, W, 4), np.float32)
    uv = np.empty((H, W, 4), np.float32)
    lib.picture_layer_frame(pic, 0, vx, vy, 8, 8, rgba=rgba, uv=uv, lambda_x=8.0, lambda_y=8.0)
    layer = np.empty((H, W, 4), np.float32)
    lib.picture_read_layer(pic, 0, layer, bottom_up=True)
    sampled = _bilinear_map_uv(layer, uv)          # bottom-up rows, like uv
    err = np.max(np.abs(sampled[::-1] - rgba))     # rgba is top-first
    assert err < 1e-4, err
    assert np.max(np.abs(uv[..., 0] * W - (np.arange(W) + 0.5))) > 1.0


@test
def test_bad_arguments_raise_tussock_error_naming_them():
    pic, img = _picture()
    vx = np.zeros(64, np.float32)
    uv = np.empty((H, W, 4), np.float32)
    cases = [
        (lambda: lib.picture_add_layer(pic, np.zeros((H, W), np.float64)), "mask"),
        (lambda: lib.picture_add_layer(pic, np.zeros(10, np.uint8)), "mask"),
        (lambda: lib.picture_layer_frame(pic, 0, vx, vx, 8, 8, uv=uv, lambda_x=float("nan")),
         "lambda_x"),
        (lambda: lib.picture_layer_frame(pic, 0, vx, vx, 8, 8, uv=uv, cell_x=-1), "cell_x"),
        (lambda: lib.picture_layer_frame(pic, 0, vx, vx, 8, 8, uv=uv.astype(np.float64)), "uv"),
        (lambda: lib.picture_create(W, H, (img * 255).astype(np.uint8)), "rgba"),
        (lambda: lib.picture_create(30000, 30000, img), "width"),
        (lambda: lib.picture_load("/nonexistent/picture.png"), "path"),
        (lambda: lib.picture_size(3), "picture"),
    ]
    for fn, name in cases:
        try:
            fn()
        except native.Error as exc:
            assert name in str(exc), (name, str(exc))
        else:
            raise AssertionError(f"no error for {name}")


@test
def test_handles_free_their_memory():
    before = lib.allocated_bytes()
    pic, _ = _picture()
    assert lib.allocated_bytes() > before
    del pic
    assert lib.allocated_bytes() == before


harness.main()
