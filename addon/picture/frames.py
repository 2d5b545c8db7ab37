"""Frames of an animated picture: the scene's shared wind mapped over the picture, and per
layer the UV pass of a frame (computed in C) written into the layer's UV image.

Mapping (docs/picture.md): the picture lies on the ground plane, centred on the wind
grid's centre, its longer side spanning the grid's side (Scene > Tussock wind > Size); its
top edge is towards +Y. So a wind source empty placed over the picture's image empty
pushes the vegetation under it. The picture samples the wind's wave continuum Vp (seed 004,
eq. 3-4) at the centres of a field with the wind grid's cell density, aligned to the
picture; that field drives the warp grid (eq. 5-7). Without the fluid grid or the
continuum there is no Vp and the picture stays still.

Frame N is the same whatever order frames are visited in: the wind steps from the first
frame (wind/runtime.py) and the sampled fields are kept per frame."""

import json

import numpy as np

from .. import compat, native
from ..wind import runtime as wind_runtime
from . import layers

_pictures = {}    # scene name -> {"key": applied JSON, "built": layers.Built}
_fields = {}      # scene name -> {"key", "frames": {frame: (vx, vy)}, "sources": {frame: bytes}}
_written = {}     # scene name -> key of the frame last written into the UV images
FIELD_CACHE_BYTES = 256 << 20

ROOTS = {"BOTTOM": "bottom", "TOP": "top", "NONE": "none"}


# ---- the description of a picture ---------------------------------------------------------

def layer_spec(layer):
    """What of a layer the build needs (the mask and the scale map), as plain values.
    Paths stay as the artist wrote them ('//' = next to the .blend), so that a file moved
    with its pictures, to a farm for instance, still finds them."""
    return {"mask_mode": layer.mask_mode, "mask_path": layer.mask_path,
            "mask_image": layer.mask_image, "rect": [int(v) for v in layer.rect],
            "strokes_path": layer.strokes_path,
            "grabcut_iterations": layer.grabcut_iterations,
            "grabcut_max_side": layer.grabcut_max_side,
            "scale_map_path": layer.scale_map_path}


def spec(settings, filepath, layer_list):
    return {"filepath": filepath,
            "layers": [layer_spec(x) for x in layer_list],
            "inpaint": settings.inpaint, "inpaint_radius": settings.inpaint_radius,
            "grow": settings.grow, "feather": settings.feather}


def dumps(d):
    return json.dumps(d, sort_keys=True)


def abspath(path):
    """A path of the spec made absolute ('//' = the .blend's folder)."""
    import bpy
    return bpy.path.abspath(path) if path else ""


def image_pixels(name):
    """(width, height, straight RGBA top-first) of a Blender image, or None."""
    import bpy
    img = bpy.data.images.get(name)
    if img is None or img.size[0] == 0:
        return None
    w, h = img.size
    px = np.empty(w * h * img.channels, np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(h, w, img.channels)[::-1]
    if img.channels != 4:
        px = np.concatenate([px[..., :1].repeat(3, 2) if img.channels < 3 else px[..., :3],
                             np.ones((h, w, 1), np.float32)], axis=2)
    return w, h, np.ascontiguousarray(px)


# ---- the built picture --------------------------------------------------------------------

def install(scene, applied, built):
    """Keeps a picture the operator just built for the scene's frames."""
    _pictures[scene.name] = {"key": applied, "built": built}
    _written.pop(scene.name, None)


def built(scene):
    """The scene's native picture, built again from its applied description when this
    Blender has none (after opening the .blend) or the description changed."""
    settings = scene.tussock_picture
    entry = _pictures.get(scene.name)
    if entry is None or entry["key"] != settings.applied:
        try:
            b = layers.build(json.loads(settings.applied), image_pixels, abspath)
        except Exception:
            show_missing(scene)
            raise
        entry = {"key": settings.applied, "built": b}
        _pictures[scene.name] = entry
        _written.pop(scene.name, None)
        write_rest_images(scene, b)
    return entry["built"]


def _check_images(scene, b):
    """Tussock's images must have the picture's size (a picture file replaced by one of
    another size since Animate Picture would not fit them)."""
    s = scene.tussock_picture
    imgs = [s.background_image] + [x for out in s.images for x in (out.layer_image, out.uv_image)]
    for img in imgs:
        if img is not None and tuple(img.size) != (b.width, b.height):
            raise ValueError(f"image '{img.name}' is {img.size[0]}x{img.size[1]}, the picture "
                             f"is now {b.width}x{b.height}: run Animate Picture again")


MISSING = (1.0, 0.0, 1.0, 1.0)  # Blender's colour of a missing image


def show_missing(scene):
    """Fills the picture's images so that the compositor shows Blender's missing-image
    magenta, not the black of empty images, while the picture cannot be built (its file or
    a mask went missing or changed): a frame rendered or drawn then shows it.
    The next successful build writes the images again (built())."""
    settings = scene.tussock_picture
    _written.pop(scene.name, None)
    fills = [(settings.background_image, MISSING)]
    fills += [(img, (0.0, 0.0, 0.0, 0.0)) for out in settings.images
              for img in (out.layer_image, out.uv_image)]
    for img, rgba in fills:
        if img is not None and img.size[0] * img.size[1] > 0:
            img.pixels.foreach_set(np.tile(np.asarray(rgba, np.float32),
                                           img.size[0] * img.size[1]))
            img.update()


def write_rest_images(scene, b):
    """Writes the background plate and the layers at rest into their images."""
    lib = native.require()
    settings = scene.tussock_picture
    _check_images(scene, b)
    buf = np.empty(b.width * b.height * 4, np.float32)
    if settings.background_image is not None:
        lib.picture_read_background(b.handle, buf, bottom_up=True)
        settings.background_image.pixels.foreach_set(buf)
        settings.background_image.update()
    for i, out in enumerate(settings.images):
        if out.layer_image is not None and i < lib.picture_layer_count(b.handle):
            lib.picture_read_layer(b.handle, i, buf, bottom_up=True)
            out.layer_image.pixels.foreach_set(buf)
            out.layer_image.update()


# ---- the wind over the picture ------------------------------------------------------------

def picture_rect(scene, width, height):
    """(x0, y0, metres per pixel): the picture's bottom-left corner on the ground plane."""
    w = scene.tussock_wind
    px = w.fluid_size / max(width, height)
    return (w.fluid_center[0] - 0.5 * width * px, w.fluid_center[1] - 0.5 * height * px, px)


def field_shape(scene, width, height):
    """Columns and rows of the field sampled over the picture: the wind grid's density."""
    n = scene.tussock_wind.fluid_resolution
    side = max(width, height)
    return (max(1, min(4096, round(n * width / side))),
            max(1, min(4096, round(n * height / side))))


def wind_placement(scene):
    """(centre x, centre y, size, resolution) of the wind grid: all that places the
    picture's field (plain values, for a bake worker)."""
    w = scene.tussock_wind
    return (w.fluid_center[0], w.fluid_center[1], w.fluid_size, w.fluid_resolution)


def _points(scene, width, height):
    return sample_points(wind_placement(scene), width, height)


def sample_points(placement, width, height):
    """(xs, ys, columns, rows): where the field over a width x height picture samples the
    wind, row 0 at the bottom; `placement` from wind_placement. Pure."""
    cx, cy, size, n = placement
    px = size / max(width, height)
    x0, y0 = cx - 0.5 * width * px, cy - 0.5 * height * px
    side = max(width, height)
    fw = max(1, min(4096, round(n * width / side)))
    fh = max(1, min(4096, round(n * height / side)))
    xs = x0 + (np.arange(fw, dtype=np.float64) + 0.5) * (width * px / fw)
    ys = y0 + (np.arange(fh, dtype=np.float64) + 0.5) * (height * px / fh)
    gx, gy = np.meshgrid(xs, ys)  # row 0 = bottom (field_y_up)
    return (np.ascontiguousarray(gx.ravel(), np.float32),
            np.ascontiguousarray(gy.ravel(), np.float32), fw, fh)


def _field_key(scene, width, height):
    return (wind_runtime._key(scene), picture_rect(scene, width, height),
            field_shape(scene, width, height),
            wind_runtime.sources(scene, scene.frame_start).tobytes())


def _sample(scene, frame, xs, ys):
    lib = native.require()
    handle, t = wind_runtime.wind_at(scene, frame)
    n = len(xs)
    vx, vy = np.empty(n, np.float32), np.empty(n, np.float32)
    sx, sy = np.empty(n, np.float32), np.empty(n, np.float32)
    lib.wind_sample(handle, t, xs, ys, vx, vy, sx, sy)
    return sx, sy


def field(scene, frame, width, height):
    """(vx, vy, columns, rows): the continuum Vp over the picture at `frame`, row 0 at the
    bottom. Frames from the scene's first frame on are kept, so going back costs nothing
    and going forward steps the wind only over frames not seen yet."""
    frame = int(frame)
    key = _field_key(scene, width, height)
    cache = _fields.get(scene.name)
    if cache is None or cache["key"] != key:
        cache = {"key": key, "frames": {}, "sources": {}, "bytes": 0}
        _fields[scene.name] = cache
    xs, ys, fw, fh = _points(scene, width, height)
    if frame <= scene.frame_start:  # the continuum is at rest until the first step
        z = np.zeros(fw * fh, np.float32)
        return z, z, fw, fh
    got = cache["frames"].get(frame)
    if got is not None and cache["sources"][frame] == wind_runtime.sources(scene, frame).tobytes():
        return got[0], got[1], fw, fh
    if got is not None:  # a wind source changed since: start the wind again
        cache["frames"].clear()
        cache["sources"].clear()
        cache["bytes"] = 0
        wind_runtime.forget(scene)
    if cache["bytes"] > FIELD_CACHE_BYTES:
        cache["frames"].clear()
        cache["sources"].clear()
        cache["bytes"] = 0
    # fill forward from the last frame kept, so that the shared wind only steps forward
    first = frame
    while first - 1 > scene.frame_start and (first - 1) not in cache["frames"]:
        first -= 1
    for f in range(first, frame + 1):
        sx, sy = _sample(scene, f, xs, ys)
        cache["frames"][f] = (sx, sy)
        cache["sources"][f] = wind_runtime.sources(scene, f).tobytes()
        cache["bytes"] += sx.nbytes + sy.nbytes
    sx, sy = cache["frames"][frame]
    return sx, sy, fw, fh


def loop_field(scene, frame, width, height):
    """The field of `frame`, made a seamless loop of N = loop_frames frames when N > 0:
    with k = (frame - first) mod N and a = k / N, Vp = (1 - a) Vp(k + 2N) + a Vp(k + N),
    so frame first + N equals frame first and nothing jumps in between; the warp is
    linear in Vp, so this is a cross-fade of the motion, not of the colours. The wind
    runs N frames before the loop is taken, to settle."""
    n = scene.tussock_picture.loop_frames
    if n <= 0:
        return field(scene, frame, width, height)
    (f1, _), (f0, a) = loop_frames_of(frame, scene.frame_start, n)
    vx1, vy1, fw, fh = field(scene, f1, width, height)
    vx0, vy0, _, _ = field(scene, f0, width, height)
    vx, vy = loop_mix(vx1, vy1, vx0, vy0, a)
    return vx, vy, fw, fh


def loop_frames_of(frame, first, n):
    """The wind frames whose fields make `frame` of a loop of n frames from `first`:
    ((first + k + 2n, 1 - a), (first + k + n, a)). Pure."""
    k = (int(frame) - first) % n
    a = k / n
    return (first + k + 2 * n, 1.0 - a), (first + k + n, a)


def loop_mix(vx1, vy1, vx0, vy0, a):
    """(1 - a) Vp1 + a Vp0 as float32 (seed 004's motion cross-faded, see loop_field)."""
    return (((1.0 - a) * vx1 + a * vx0).astype(np.float32),
            ((1.0 - a) * vy1 + a * vy0).astype(np.float32))


# ---- per-layer frames ---------------------------------------------------------------------

def warp_kwargs(scene, layer, height):
    """Keyword arguments of picture_layer_frame for a layer's motion settings."""
    return layer_kwargs(layer, scene.render.fps_base / scene.render.fps, height)


def layer_kwargs(layer, dt, height):
    """warp_kwargs from a layer's settings (any object with its attributes) and the frame
    step dt (seconds). Pure."""
    kw = dict(cell_x=layer.cell_x, cell_y=layer.cell_y, lambda_x=layer.lambda_x,
              lambda_y=layer.lambda_y, dt=dt, rigidity=layer.rigidity, root=ROOTS[layer.root])
    if not layer.root_auto and layer.root != "NONE":
        kw.update(root_y=height - layer.root_line, height=layer.root_height)
    return kw


def _motion_key(scene, frame):
    """What the UV passes of `frame` depend on: the picture, the layers' motion, the wind
    settings and the wind sources at the wind frames used (so that editing a source while
    staying on a frame redraws it)."""
    s = scene.tussock_picture
    motion = [tuple(warp_kwargs(scene, x, 0).items()) for x in s.layers]
    wind_frames = [int(frame)] if s.loop_frames <= 0 else \
        [f for f, _ in loop_frames_of(frame, scene.frame_start, s.loop_frames)]
    winds = tuple(wind_runtime.sources(scene, f).tobytes() for f in wind_frames)
    return (s.applied, int(frame), s.loop_frames, repr(motion),
            tuple(x.uv_image.name if x.uv_image else "" for x in s.images),
            wind_runtime._key(scene), winds)


def layer_frames(scene, frame, rgba=False, sampling="bilinear"):
    """Per layer (uv, rgba): the UV pass (bottom row first, ready for Image.pixels) and,
    when asked, the warped premultiplied layer (top row first) with `sampling`."""
    lib = native.require()
    settings = scene.tussock_picture
    b = built(scene)
    vx, vy, fw, fh = loop_field(scene, frame, b.width, b.height)
    out = []
    for i, layer in enumerate(settings.layers[:lib.picture_layer_count(b.handle)]):
        uv = np.empty(b.width * b.height * 4, np.float32)
        img = np.empty(b.width * b.height * 4, np.float32) if rgba else None
        kw = warp_kwargs(scene, layer, b.height)
        if b.scale_maps[i] is not None:
            kw["scale_map"] = b.scale_maps[i]
        try:
            lib.picture_layer_frame(b.handle, i, vx, vy, fw, fh, rgba=img, uv=uv,
                                    field_y_up=True, uv_bottom_up=True, sampling=sampling,
                                    **kw)
        except native.Error as exc:
            raise native.Error(f"layer {i + 1}: {exc}") from None
        out.append((uv, img))
    return out


def update(scene, frame=None):
    """Writes every layer's UV pass of `frame` (default: the current frame) into its UV
    image. Does nothing when that frame is already there."""
    settings = scene.tussock_picture
    if not settings.applied:
        return
    frame = scene.frame_current if frame is None else frame
    key = _motion_key(scene, frame)
    if _written.get(scene.name) == key:
        return
    _check_images(scene, built(scene))
    for out, (uv, _) in zip(settings.images, layer_frames(scene, frame)):
        if out.uv_image is not None:
            out.uv_image.pixels.foreach_set(uv)
            out.uv_image.update()
    _written[scene.name] = key


def native_composite(scene, frame, sampling=None):
    """The frame as Tussock computes it (premultiplied RGBA (H, W, 4), top row first):
    every layer warped with `sampling` and laid over the background plate. By default the
    sampling of this Blender's Map UV node (compat.map_uv_sampling), so that it is what
    the compositor renders."""
    lib = native.require()
    sampling = sampling or compat.map_uv_sampling()
    b = built(scene)
    frames = layer_frames(scene, frame, rgba=True, sampling=sampling)
    out = np.empty((b.height, b.width, 4), np.float32)
    lib.picture_composite(b.handle, [img for _, img in frames], out)
    return out


def forget(scene_name=None):
    for d in (_pictures, _fields, _written):
        if scene_name is None:
            d.clear()
        else:
            d.pop(scene_name, None)
