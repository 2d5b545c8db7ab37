"""The live preview image of a capture ('Tussock Capture Preview'): depth in grey, the
mask tinted, each blade's region in its own colour, contours and skeletons on top.
Composed with numpy from the native debug images; written with foreach_set."""

import bpy
import numpy as np

IMAGE = "Tussock Capture Preview"

# 12 distinct colours for blades, then repeated
PALETTE = np.array([
    (0.90, 0.30, 0.25), (0.25, 0.60, 0.95), (0.95, 0.75, 0.20), (0.55, 0.85, 0.35),
    (0.75, 0.40, 0.90), (0.20, 0.85, 0.80), (0.95, 0.50, 0.70), (0.60, 0.45, 0.25),
    (0.40, 0.95, 0.55), (0.95, 0.60, 0.30), (0.45, 0.50, 0.95), (0.85, 0.85, 0.55),
], np.float32)


def compose(depth_u8, mask_u8, labels_u8, overlay_u8):
    """RGBA float32 (h, w, 4) from the four debug images (h, w) uint8, top row first."""
    h, w = depth_u8.shape
    rgb = np.repeat((depth_u8.astype(np.float32) / 255.0 * 0.6)[..., None], 3, axis=2)
    mask = mask_u8 > 0
    rgb[mask] = rgb[mask] * 0.5 + np.array([0.15, 0.35, 0.15], np.float32)
    blade = (labels_u8 > 0) & (labels_u8 < 255)
    colours = PALETTE[(labels_u8.astype(np.int32) - 1) % len(PALETTE)]
    rgb[blade] = rgb[blade] * 0.3 + colours[blade] * 0.7
    rgb[overlay_u8 == 128] = (1.0, 1.0, 1.0)
    rgb[overlay_u8 == 255] = (1.0, 0.1, 0.1)
    rgba = np.empty((h, w, 4), np.float32)
    rgba[..., :3] = rgb
    rgba[..., 3] = 1.0
    return rgba


def show(rgba):
    """Writes rgba (h, w, 4, top row first) into the preview image and shows it in every
    open Image Editor. Returns the image."""
    h, w, _ = rgba.shape
    img = bpy.data.images.get(IMAGE)
    if img is None or tuple(img.size) != (w, h):
        if img is not None:
            bpy.data.images.remove(img)
        img = bpy.data.images.new(IMAGE, w, h, alpha=True, float_buffer=True)
    img.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())  # Blender: bottom row first
    img.update()
    wm = bpy.context.window_manager
    for window in wm.windows if wm else ():
        for area in window.screen.areas:
            if area.type == "IMAGE_EDITOR":
                area.spaces.active.image = img
                area.tag_redraw()
    return img
