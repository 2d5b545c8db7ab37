"""Builds a native picture from a plain description (no bpy here): the picture file, one
mask per layer (a mask file, a painted image's pixels, or a GrabCut proposal), then the
inpainted background and the layer mattes. Every array is handled by numpy or C; errors
name the layer and the file so that the operator's message says what to fix."""

import math
import os

import numpy as np

from .. import native


class Built:
    """A built native picture with what the frames need besides it."""

    def __init__(self, handle, width, height, scale_maps):
        self.handle = handle
        self.width = width
        self.height = height
        self.scale_maps = scale_maps  # per layer: float32 W*H top-first, or None


def _load(lib, path, what):
    if not path:
        raise ValueError(f"{what}: no file given")
    if not os.path.isfile(path):
        raise ValueError(f"{what}: file not found: {path}")
    try:
        return lib.picture_load(path)
    except native.Error as exc:
        raise native.Error(f"{what}: {exc}") from None


def _read_same_size(lib, path, what, width, height):
    """Straight RGBA (H, W, 4) top-first of an image file that must match the picture."""
    p = _load(lib, path, what)
    w, h = lib.picture_size(p)
    if (w, h) != (width, height):
        raise ValueError(f"{what}: {os.path.basename(path)} is {w}x{h} pixels, the picture "
                         f"is {width}x{height}")
    rgba = np.empty((h, w, 4), np.float32)
    lib.picture_read_rgba(p, rgba)
    return rgba


def _grey(rgba):
    """Mask value of straight RGBA: mean of r, g, b times alpha (a mask painted on a
    transparent image counts only where painted)."""
    return np.ascontiguousarray(rgba[..., :3].mean(axis=2) * rgba[..., 3], np.float32)


def _strokes(rgba):
    """Stroke map from an image: red strokes force vegetation (1), blue strokes force
    background (2), everything else (black, white, transparent) is free (0)."""
    r, b, a = rgba[..., 0], rgba[..., 2], rgba[..., 3]
    s = np.zeros(r.shape, np.uint8)
    s[(a >= 0.5) & (r >= 0.5) & (b < 0.5)] = 1
    s[(a >= 0.5) & (b >= 0.5) & (r < 0.5)] = 2
    return s


def _shrink(img, f):
    """Block mean by an integer factor f, edges repeated to fill the last block."""
    h, w = img.shape[:2]
    hh, ww = -(-h // f) * f, -(-w // f) * f
    pad = [(0, hh - h), (0, ww - w)] + [(0, 0)] * (img.ndim - 2)
    img = np.pad(img, pad, mode="edge")
    return img.reshape(hh // f, f, ww // f, f, *img.shape[2:]).mean(axis=(1, 3))


def _grabcut(lib, pic, width, height, layer, index):
    try:
        return _grabcut_mask(lib, pic, width, height, layer, index)
    except native.Error as exc:
        raise native.Error(f"layer {index} GrabCut: {exc}") from None


def _grabcut_mask(lib, pic, width, height, layer, index):
    x, y, w, h = (int(v) for v in layer["rect"])
    strokes = None
    if layer.get("strokes_path"):
        strokes = _strokes(_read_same_size(lib, layer["strokes_path"], f"layer {index} strokes",
                                           width, height))
    iterations = int(layer.get("grabcut_iterations", 5))
    max_side = int(layer.get("grabcut_max_side", 0))
    if max_side < 0:
        raise ValueError(f"layer {index}: proposal size must be >= 0, got {max_side}")
    f = math.ceil(max(width, height) / max_side) if max_side else 1
    if f <= 1:
        mask = np.empty(width * height, np.uint8)
        lib.picture_propose_mask(pic, (x, y, w, h), mask,
                                 strokes=None if strokes is None else strokes.ravel(),
                                 iterations=iterations)
        return mask
    # Propose on a copy shrunk by f (block means), then enlarge the mask by repeating
    # each pixel f x f: the cut is as good as GrabCut's on the small copy, and the mask
    # edge follows blocks of f pixels (the matte's feather softens it).
    rgba = np.empty((height, width, 4), np.float32)
    lib.picture_read_rgba(pic, rgba)
    small = np.ascontiguousarray(_shrink(rgba, f), np.float32)
    sh, sw = small.shape[:2]
    small_pic = lib.picture_create(sw, sh, small.ravel())
    sx, sy = x // f, y // f
    rect = (sx, sy, max(1, -(-(x + w) // f) - sx), max(1, -(-(y + h) // f) - sy))
    small_strokes = None
    if strokes is not None:
        fg = _shrink((strokes == 1).astype(np.float32), f) > 0
        bg = _shrink((strokes == 2).astype(np.float32), f) > 0
        small_strokes = np.zeros((sh, sw), np.uint8)
        small_strokes[bg] = 2
        small_strokes[fg] = 1
        small_strokes = small_strokes.ravel()
    small_mask = np.empty(sw * sh, np.uint8)
    lib.picture_propose_mask(small_pic, rect, small_mask, strokes=small_strokes,
                             iterations=iterations)
    big = np.repeat(np.repeat(small_mask.reshape(sh, sw), f, axis=0), f, axis=1)
    return np.ascontiguousarray(big[:height, :width]).ravel()


def _mask(lib, pic, width, height, layer, index, image_pixels):
    mode = layer.get("mask_mode", "FILE")
    if mode == "FILE":
        return _grey(_read_same_size(lib, layer.get("mask_path", ""), f"layer {index} mask",
                                     width, height)).ravel()
    if mode == "IMAGE":
        name = layer.get("mask_image", "")
        got = image_pixels(name) if name else None
        if got is None:
            raise ValueError(f"layer {index} mask: no image named '{name}'")
        w, h, rgba = got
        if (w, h) != (width, height):
            raise ValueError(f"layer {index} mask: image '{name}' is {w}x{h} pixels, the "
                             f"picture is {width}x{height}")
        return _grey(rgba).ravel()
    if mode == "GRABCUT":
        return _grabcut(lib, pic, width, height, layer, index)
    raise ValueError(f"layer {index}: unknown mask mode {mode!r}")


def build(spec, image_pixels=lambda name: None, abspath=lambda path: path):
    """Loads spec['filepath'], adds spec['layers'] back to front and separates them.
    `image_pixels(name)` returns (width, height, straight RGBA (H, W, 4) top-first) of a
    Blender image for painted masks, or None; `abspath` resolves the spec's paths.
    Raises native.Error or ValueError."""
    lib = native.require()
    spec = dict(spec, filepath=abspath(spec.get("filepath", "")),
                layers=[dict(x, **{k: abspath(x.get(k, "")) for k in
                                   ("mask_path", "strokes_path", "scale_map_path")})
                        for x in spec.get("layers", [])])
    layers = spec.get("layers", [])
    if not layers:
        raise ValueError("add at least one vegetation layer")
    pic = _load(lib, spec.get("filepath", ""), "picture")
    width, height = lib.picture_size(pic)
    scale_maps = []
    for i, layer in enumerate(layers, 1):
        mask = _mask(lib, pic, width, height, layer, i, image_pixels)
        try:
            lib.picture_add_layer(pic, mask)
        except native.Error as exc:
            raise native.Error(f"layer {i}: {exc}") from None
        scale = None
        if layer.get("scale_map_path"):
            scale = _grey(_read_same_size(lib, layer["scale_map_path"], f"layer {i} scale map",
                                          width, height)).ravel()
        scale_maps.append(scale)
    lib.picture_build(pic, method=spec.get("inpaint", "TELEA").lower(),
                      radius=float(spec.get("inpaint_radius", 5.0)),
                      grow=float(spec.get("grow", 3.0)), feather=float(spec.get("feather", 4.0)))
    return Built(pic, width, height, scale_maps)
