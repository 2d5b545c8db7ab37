#!/usr/bin/python3
"""Makes docs/images/picture_strip.png: a cartoon meadow the script paints itself (so the
picture is free to ship), its grass layer taken out with a mask, the background inpainted,
and four frames of the layer swaying under a travelling wave, side by side after the
original. Runs outside Blender:  PYTHONPATH=build/release /usr/bin/python3 tools/picture_strip.py"""

import os
import struct
import sys
import zlib

import numpy as np

import _tussock as t

W, H = 360, 240
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def paint():
    """Sky, a hill, and a band of grass blades with a jagged top (straight RGBA)."""
    rng = np.random.default_rng(4)
    y, x = np.mgrid[0:H, 0:W].astype(np.float32)
    img = np.zeros((H, W, 4), np.float32)
    img[..., 0] = 0.55 + 0.25 * y / H
    img[..., 1] = 0.75 + 0.15 * y / H
    img[..., 2] = 0.95
    hill = y > 120 + 25 * np.sin(x / 70.0)
    img[hill, :3] = [0.45, 0.55, 0.25]
    # grass: each 3-px column is a blade whose tip height varies
    tips = 150 + 40 * rng.random(W // 3 + 1).astype(np.float32)
    tip = np.repeat(tips, 3)[:W][None, :] - 12 * np.sin(x / 23.0)
    grass = y > tip
    shade = 0.75 + 0.25 * np.sin(x * 2.1)  # blade-to-blade shading
    img[grass, 0] = (0.15 * shade)[grass]
    img[grass, 1] = (0.45 + 0.25 * (y - tip) / H * -1.0 + 0.2 * shade)[grass]
    img[grass, 2] = (0.08 * shade)[grass]
    img[..., 3] = 1.0
    return np.clip(img, 0, 1), grass


def write_png(path, rgb):
    """8-bit RGB PNG with zlib (no image library needed)."""
    h, w, _ = rgb.shape
    raw = (np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8)
    rows = b"".join(b"\x00" + raw[j].tobytes() for j in range(h))

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data +
                struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def main():
    img, grass = paint()
    pic = t.picture_create(W, H, img)
    t.picture_add_layer(pic, (grass * 255).astype(np.uint8))
    t.picture_build(pic, feather=3.0)
    fw, fh = 32, 32
    a, b = np.meshgrid(np.arange(fw, dtype=np.float32), np.arange(fh, dtype=np.float32))
    frames = [img[..., :3]]
    for k in range(4):
        phase = k * 1.3
        vx = (1.0 * np.sin(0.45 * a - phase) + 0.3).astype(np.float32).ravel()
        vy = (0.15 * np.cos(0.3 * a - phase)).astype(np.float32).ravel()
        layer = np.empty((H, W, 4), np.float32)
        t.picture_layer_frame(pic, 0, vx, vy, fw, fh, rgba=layer, cell_x=12, cell_y=12,
                              lambda_x=30.0, lambda_y=30.0, rigidity=1.5, root="bottom")
        out = np.empty((H, W, 4), np.float32)
        t.picture_composite(pic, [layer], out)
        frames.append(out[..., :3])
    gap = np.ones((H, 6, 3), np.float32)
    strip = np.concatenate(sum(([f, gap] for f in frames), [])[:-1], axis=1)
    path = os.path.join(REPO, "docs", "images", "picture_strip.png")
    write_png(path, strip)
    background = np.empty((H, W, 4), np.float32)
    t.picture_read_background(pic, background)
    write_png(os.path.join(REPO, "docs", "images", "picture_background.png"), background[..., :3])
    print("wrote", path)


if __name__ == "__main__":
    sys.exit(main())
