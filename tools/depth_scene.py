"""Ground truth for capture: analytic grass blades as Blender meshes, and exact depth
images of them rendered by Cycles (planar depth along the camera axis, the convention of
depth cameras), written as 32-bit OpenEXR in metres and 16-bit PNG in millimetres.

Runs inside Blender. The camera sits at the world origin looking along +Y with x to the
right and z up, and has the intrinsics of a 640x480 structured-light sensor
(fx = fy = 570.3 px, cx = 319.5, cy = 239.5), so a point (X, Y, Z) in the world is
(X, -Z, Y) in the OpenCV camera frame (x right, y down, z forward)."""

import math
import os

import bpy
import numpy as np

WIDTH, HEIGHT = 640, 480
FX = 570.3
SENSOR_MM = 36.0


def world_to_camera(p):
    """World points (N, 3) to the OpenCV camera frame of the ground-truth camera."""
    p = np.asarray(p, np.float64)
    return np.stack([p[:, 0], -p[:, 2], p[:, 1]], axis=1)


def blade_centreline(root, length, angle, bend, knots=200):
    """An analytic blade: a circular-arc-like centreline in the x-z plane at depth root[1]
    starting at `root`, leaning by `angle` (radians from vertical, + to the right) and
    curving by `bend` (radians turned over its length). Returns (knots, 3) world points
    and the arc-length parameter s in [0, 1]."""
    s = np.linspace(0.0, 1.0, knots)
    heading = angle + bend * s  # direction of the tangent from vertical
    ds = length / (knots - 1)
    dx = np.sin(heading) * ds
    dz = np.cos(heading) * ds
    x = root[0] + np.concatenate([[0.0], np.cumsum(0.5 * (dx[1:] + dx[:-1]))])
    z = root[2] + np.concatenate([[0.0], np.cumsum(0.5 * (dz[1:] + dz[:-1]))])
    y = np.full_like(s, root[1])
    return np.stack([x, y, z], axis=1), s


def blade_width(s, base_width, tip=0.25):
    """Full width (m) along the blade: widest near the base, tapering to a point.
    w(s) = base_width * (1 - s^2)^(1/2) * (1 - tip*s): smooth and zero at the tip."""
    s = np.asarray(s, np.float64)
    return base_width * np.sqrt(np.clip(1.0 - s * s, 0.0, 1.0)) * (1.0 - tip * s)


def blade_mesh(name, centre, widths):
    """A flat ribbon facing the camera (-Y), from centreline points and full widths."""
    t = np.gradient(centre, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    view = np.array([0.0, -1.0, 0.0])
    side = np.cross(t, view)
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    left = centre - side * (widths[:, None] * 0.5)
    right = centre + side * (widths[:, None] * 0.5)
    n = len(centre)
    verts = np.empty((n, 2, 3), np.float32)
    verts[:, 0], verts[:, 1] = left, right
    quads = np.arange(n - 1, dtype=np.int32)[:, None] * 2 + np.array([0, 1, 3, 2], np.int32)
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(n * 2)
    mesh.vertices.foreach_set("co", verts.ravel())
    mesh.loops.add(quads.size)
    mesh.loops.foreach_set("vertex_index", quads.ravel())
    mesh.polygons.add(n - 1)
    from tussock import compat  # face sizes are read-only from Blender 3.6
    compat.set_face_corners(mesh.polygons, 4)
    mesh.update()
    mesh.validate()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def standard_cluster(depth=0.6, count=5, length=0.16, base_width=0.012, spread=0.55,
                     base_gap=0.012, sway=None):
    """A cluster of `count` blades fanning out from a common base at `depth` metres in front
    of the camera, like a tuft photographed from the side. `sway` (one value per blade,
    radians) adds to each blade's bend, as wind would. Returns a list of dicts with the
    world centreline, arc parameter and widths of each blade (the ground truth)."""
    blades = []
    for i in range(count):
        u = (i - (count - 1) / 2) / max(1, (count - 1) / 2)  # -1 .. 1
        root = (u * base_gap * (count - 1) / 2, depth + 0.004 * abs(u), -0.09)
        bend = 0.35 * u + (sway[i] if sway is not None else 0.0)
        centre, s = blade_centreline(root, length * (1.0 - 0.12 * abs(u)), u * spread, bend,
                                     knots=200)
        blades.append({"centre": centre, "s": s, "width": blade_width(s, base_width)})
    return blades


def setup_camera_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    cam = bpy.data.objects.new("Depth camera", bpy.data.cameras.new("Depth camera"))
    scene.collection.objects.link(cam)
    cam.location = (0.0, 0.0, 0.0)
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    cam.data.sensor_fit = "HORIZONTAL"
    cam.data.sensor_width = SENSOR_MM
    cam.data.lens = FX * SENSOR_MM / WIDTH
    cam.data.clip_start = 0.05
    cam.data.clip_end = 20.0
    scene.camera = cam
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 0.01  # one ray through each pixel centre: exact depth
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Raw"
    scene.view_settings.look = "None"
    scene.view_layers[0].use_pass_z = True
    return scene


def _file_output(tree, base, name, fmt, depth):
    from tussock import compat
    out, socket = compat.file_output(tree, base, name, fmt)
    # Blender 3.4 writes OpenEXR only as RGB(A); the three channels hold the same depth.
    out.format.color_mode = "BW" if fmt == "PNG" else "RGB"
    out.format.color_depth = depth
    if fmt == "OPEN_EXR":
        out.format.exr_codec = "ZIP"
    return socket


def render_depth(scene, directory, stem, frame=1, far=10.0):
    """Renders the current frame's depth and writes <stem>.exr (metres, float32, 0 where
    nothing was hit) and <stem>.png (uint16 millimetres, 0 = no data). Returns both paths."""
    from tussock import compat  # the compositor's API differs in Blender 5
    os.makedirs(directory, exist_ok=True)
    scene.frame_set(frame)
    scene.render.use_compositing = True
    tree = compat.compositor_tree(scene)
    for node in list(tree.nodes):
        tree.nodes.remove(node)
    rl = tree.nodes.new("CompositorNodeRLayers")
    # valid = depth < far; metres = depth * valid; png value = metres * 1000 / 65535
    less = compat.compositor_math(tree, "LESS_THAN")
    less.inputs[1].default_value = far
    tree.links.new(rl.outputs["Depth"], less.inputs[0])
    metres = compat.compositor_math(tree, "MULTIPLY")
    tree.links.new(rl.outputs["Depth"], metres.inputs[0])
    tree.links.new(less.outputs[0], metres.inputs[1])
    mm = compat.compositor_math(tree, "MULTIPLY")
    mm.inputs[1].default_value = 1000.0 / 65535.0
    tree.links.new(metres.outputs[0], mm.inputs[0])
    tmp = os.path.join(directory, ".render_tmp")
    exr = _file_output(tree, tmp, "exr_", "OPEN_EXR", "32")
    png = _file_output(tree, tmp, "png_", "PNG", "16")
    tree.links.new(metres.outputs[0], exr)
    tree.links.new(mm.outputs[0], png)
    bpy.ops.render.render(write_still=False)
    paths = []
    for prefix, ext in (("exr_", ".exr"), ("png_", ".png")):
        src = os.path.join(tmp, f"{prefix}{frame:04d}{ext}")
        dst = os.path.join(directory, stem + ext)
        os.replace(src, dst)
        paths.append(dst)
    os.rmdir(tmp)
    return tuple(paths)


# ---- tufts: fans of blades that share a base (issue 31) ------------------------------------

WIDTH_FAMILIES = ("grass", "lanceolate", "bamboo", "acuminate")


def family_width(family, s, max_width):
    """Full width (m) along a blade of a width family, at arc parameter s in [0, 1], with
    `max_width` its widest. Every family ends in a point at s = 1 and keeps some width at
    the base, where the blade attaches:
      grass       nearly parallel sides narrowing a little, a short pointed tip (last 15 %)
      lanceolate  widest at about a third of the length, tapering to both ends
      bamboo      a narrow stalk-like base widening fast, widest at 0.3, a long taper
      acuminate   widest at the base, concave sides running out into a long point"""
    s = np.clip(np.asarray(s, np.float64), 0.0, 1.0)
    dense = np.linspace(0.0, 1.0, 2001)
    return max_width * _family_shape(family, s) / _family_shape(family, dense).max()


def _family_shape(family, s):
    if family == "grass":
        return (1.0 - 0.3 * s) * np.sqrt(np.clip((1.0 - s) / 0.15, 0.0, 1.0))
    if family == "lanceolate":
        return (s + 0.12) ** 0.7 * (1.0 - s) ** 0.8
    if family == "bamboo":
        return (s + 0.05) ** 0.9 * (1.0 - s) ** 0.9
    if family == "acuminate":
        return (1.0 - s) ** 0.75 * (1.0 - 0.3 * s)
    raise ValueError(f"unknown width family {family!r}")


def tuft_fan(family, count, length, depth, max_width, overlap=0.2, cross=True, bend=0.3,
             base_v=455.0, knots=2001, seed=0):
    """A tuft of `count` blades of one width family sharing one base `depth` metres in front
    of the camera, its base at image row `base_v`. Neighbouring blades lean apart just fast
    enough that they cover each other over about their first `overlap` of length; with
    `cross`, each blade's root lies on the other side of the base from its lean, so
    neighbours cross just above the base. Blades alternate a few millimetres in depth, so
    the crossing ones occlude each other. Returns the ground truth: per blade a dict with
    the world centreline ("centre", knots x 3), arc parameter "s", full widths "width" (m)
    and "length" (m)."""
    rng = np.random.default_rng(seed)
    z_base = -(base_v - 239.5) * depth / FX  # world z of the base row at that depth
    lean_step = max_width / (overlap * length)
    blades = []
    for i in range(count):
        u = i - (count - 1) / 2.0
        lean = lean_step * u + rng.uniform(-0.03, 0.03)
        side = -1.0 if cross else 1.0
        root_x = side * 0.25 * max_width * u
        blade_depth = depth + 0.003 * ((i % 2) - 0.5) + 0.001 * rng.uniform(-1, 1)
        blade_len = length * (1.0 - 0.1 * abs(u) / max(1.0, (count - 1) / 2.0))
        curve = bend * np.sign(u) * min(1.0, abs(u)) + rng.uniform(-0.1, 0.1)
        centre, s = blade_centreline((root_x, blade_depth, z_base), blade_len, lean, curve,
                                     knots=knots)
        blades.append({"centre": centre, "s": s, "width": family_width(family, s, max_width),
                       "length": blade_len, "family": family})
    return blades


# Fans of the capture accuracy tests: every width family, 1-6 blades, 0.10-0.35 m long,
# 0.5-1.2 m away, overlapping over their first 10-30 %, most crossing above the base.
# (family, blades, length m, depth m, widest m, overlap, cross)
TEST_TUFTS = (
    ("grass", 5, 0.20, 0.60, 0.008, 0.20, True),
    ("lanceolate", 3, 0.14, 0.50, 0.016, 0.30, True),
    ("bamboo", 4, 0.28, 0.90, 0.022, 0.15, False),
    ("acuminate", 2, 0.12, 0.55, 0.014, 0.25, True),
    ("grass", 6, 0.35, 1.20, 0.012, 0.10, True),
    ("lanceolate", 1, 0.10, 0.70, 0.015, 0.20, False),
    ("acuminate", 4, 0.22, 0.80, 0.018, 0.15, True),
    ("grass", 6, 0.30, 0.70, 0.010, 0.30, True),
    ("bamboo", 5, 0.25, 1.00, 0.025, 0.30, True),
)


def render_tuft(scene, directory, stem, tuft, seed=0):
    """Builds one TEST_TUFTS entry (removing the previous blade meshes), renders its depth
    and returns (truth, exr path, png path)."""
    for obj in [o for o in scene.objects if o.type == "MESH"]:
        mesh = obj.data
        bpy.data.objects.remove(obj)
        bpy.data.meshes.remove(mesh)
    family, count, length, depth, width, overlap, cross = tuft
    truth = tuft_fan(family, count, length, depth, width, overlap=overlap, cross=cross,
                     seed=seed)
    for i, b in enumerate(truth):
        blade_mesh(f"{stem} {i}", b["centre"], b["width"])
    exr, png = render_depth(scene, directory, stem)
    return truth, exr, png


def sensor_noise(depth, seed):
    """Depth-camera noise on a depth map (metres, 0 = no data): Gaussian with sigma
    1.5 mm * (z / 1 m)^2, rounded to whole millimetres, and 2 % of the pixels zeroed."""
    rng = np.random.default_rng(seed)
    out = depth.astype(np.float64).copy()
    valid = out > 0
    out[valid] += rng.normal(0.0, 1.5e-3, valid.sum()) * out[valid] ** 2
    out = np.round(out * 1000.0) / 1000.0
    out[rng.random(out.shape) < 0.02] = 0.0
    return np.clip(out, 0.0, None).astype(np.float32)


def tuft_picture(out_path, tufts=(0, 1), zoom=2):
    """docs/images/capture_tuft.png: test tufts captured (depth, single blades, contour in
    white, skeletons in red) with the true centrelines in blue where the capture leaves them,
    side by side."""
    from tussock import native
    from tussock.capture import pipeline, preview
    lib = native.require()
    scene = setup_camera_scene()
    directory = os.path.dirname(os.path.abspath(out_path))
    panels = []
    for k in tufts:
        truth, exr, png = render_tuft(scene, directory, f".tuft{k}", TEST_TUFTS[k], seed=k)
        os.remove(png)
        src = lib.depth_open_files(exr)
        depth = np.empty(WIDTH * HEIGHT, np.float32)
        lib.depth_read(src, depth)
        lib.depth_close(src)
        os.remove(exr)
        r = pipeline.process(depth, WIDTH, HEIGHT, 0.0, 0.0, FX, FX, 319.5, 239.5, 150)
        im = r["images"]
        rgba = preview.compose(im["DEPTH"], im["MASK"], im["LABELS"], im["OVERLAY"])
        for b in truth:  # the true centreline, projected, under the captured one
            cam = world_to_camera(b["centre"])
            u = np.round(FX * cam[:, 0] / cam[:, 2] + 319.5).astype(int)
            v = np.round(FX * cam[:, 1] / cam[:, 2] + 239.5).astype(int)
            keep = (u >= 0) & (u < WIDTH) & (v >= 0) & (v < HEIGHT)
            u, v = u[keep], v[keep]
            free = im["OVERLAY"][v, u] != 255
            rgba[v[free], u[free], :3] = (0.2, 0.5, 1.0)
        rows, cols = np.nonzero(im["MASK"])
        t, bt = max(rows.min() - 10, 0), min(rows.max() + 10, HEIGHT)
        lf, rt = max(cols.min() - 10, 0), min(cols.max() + 10, WIDTH)
        panels.append(rgba[t:bt, lf:rt])
    h = max(p.shape[0] for p in panels)
    padded = [np.concatenate([np.zeros((h - p.shape[0],) + p.shape[1:], np.float32), p])
              for p in panels]
    for p in padded:
        p[..., 3] = 1.0
    rgba = np.concatenate(padded, axis=1)
    rgba = np.repeat(np.repeat(rgba, zoom, axis=0), zoom, axis=1)
    ph, pw, _ = rgba.shape
    img = bpy.data.images.new("tuft picture", pw, ph, alpha=False)
    img.pixels.foreach_set(np.ascontiguousarray(rgba[::-1], np.float32).ravel())
    img.filepath_raw = os.path.abspath(out_path)
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)


if __name__ == "__main__":
    # blender_run.py tools/depth_scene.py -- OUT.png : the picture of tuft_picture()
    import sys
    import addon_utils
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    addon_utils.enable("tussock", default_set=True)
    tuft_picture(args[0] if args else "docs/images/capture_tuft.png")
