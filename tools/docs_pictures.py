"""Renders the pictures of docs/ with Tussock itself, in background Blender:
  blender_run.py tools/docs_pictures.py -- OUT_DIR [FEATURE...]
Features: capture, refine, meadow, trees, picture, wind, simulation, walk, farm,
farm_meadow, farm_picture, reliability. Each writes PNGs named <feature>_<view>.png
into OUT_DIR."""

import math
import os
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import picture_sample_scene  # noqa: E402
import walker  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
OUT = os.path.abspath(ARGS[0] if ARGS else "docs/images")
WANT = ARGS[1:]


def reset():
    import addon_utils
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("tussock", default_set=True)


def sky_and_sun(strength=1.0, sun_angle=(0.9, 0.15, 0.8)):
    scene = bpy.context.scene
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.55, 0.7, 0.95, 1.0)
    bg.inputs["Strength"].default_value = strength
    scene.world = world
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.5
    sun.data.angle = 0.05
    sun.rotation_euler = sun_angle
    scene.collection.objects.link(sun)


def camera(location, rotation, lens=35.0):
    scene = bpy.context.scene
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = lens
    cam.data.clip_end = 1000.0
    cam.location, cam.rotation_euler = location, rotation
    scene.collection.objects.link(cam)
    scene.camera = cam
    return cam


def soil(obj):
    mat = bpy.data.materials.new("Soil")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.10, 0.07, 0.04, 1)
    obj.data.materials.append(mat)


def render(name, res=(640, 360), samples=24):
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False  # Debian's Blender has no OpenImageDenoise
    scene.render.resolution_x, scene.render.resolution_y = res
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = os.path.join(OUT, name + ".png")
    t = time.time()
    bpy.ops.render.render(write_still=True)
    print(f"[pictures] {scene.render.filepath} ({time.time() - t:.1f} s)", flush=True)


def meadow():
    reset()
    bpy.ops.mesh.primitive_plane_add(size=1.0)
    ground = bpy.context.active_object
    ground.scale = (40.0, 40.0, 1.0)
    soil(ground)
    bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=96, chunk_blades=16,
                               noise_scale=6.0, seed=2, display=1.0, patch_blades=16384)
    sky_and_sun()
    camera((0.0, -19.2, 0.35), (math.radians(84), 0, 0), lens=40.0)
    render("meadow_closeup")
    camera((-22.0, -22.0, 18.0), (math.radians(58), 0, math.radians(-45)), lens=30.0)
    render("meadow_birdseye")


SAMPLE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "samples",
                      "blades", "depth_####.png")


def save_rgba(name, rgba, crop=None, zoom=1):
    """Writes an (h, w, 4) float image, top row first, as an 8-bit PNG; `crop` is
    (top, bottom, left, right) and `zoom` an integer enlargement (nearest pixel)."""
    import numpy as np
    if crop is not None:
        t, b, l, r = crop
        rgba = rgba[t:b, l:r]
    if zoom > 1:
        rgba = np.repeat(np.repeat(rgba, zoom, axis=0), zoom, axis=1)
    h, w, _ = rgba.shape
    img = bpy.data.images.new(name, w, h, alpha=False)
    img.pixels.foreach_set(np.ascontiguousarray(rgba[::-1], np.float32).ravel())
    img.filepath_raw = os.path.join(OUT, name + ".png")
    img.file_format = "PNG"
    img.save()
    print(f"[pictures] {img.filepath_raw}", flush=True)


def capture():
    import numpy as np
    from tussock import native
    from tussock.capture import pipeline, preview
    reset()
    lib = native.require()
    src = lib.depth_open_files(SAMPLE)
    info = lib.depth_info(src)
    w, h = info["width"], info["height"]
    depth = np.empty(w * h, np.float32)
    lib.depth_read(src, depth)
    lib.depth_close(src)
    r = pipeline.process(depth, w, h, 0.0, 0.0, info["fx"], info["fy"], info["cx"], info["cy"], 150)
    im = r["images"]
    blank = np.zeros_like(im["DEPTH"])
    rows, cols = np.nonzero(im["MASK"])
    crop = (max(rows.min() - 12, 0), rows.max() + 12, max(cols.min() - 12, 0), cols.max() + 12)
    views = {
        "capture_depth": (im["DEPTH"], blank, blank, blank),
        "capture_mask": (im["DEPTH"], im["MASK"], blank, blank),
        "capture_partition": (im["DEPTH"], im["MASK"], im["LABELS"], blank),
        "capture_skeletons": (im["DEPTH"], im["MASK"], im["LABELS"], im["OVERLAY"]),
    }
    for name, layers in views.items():
        save_rgba(name, preview.compose(*layers), crop=crop, zoom=2)
    bpy.ops.tussock.capture_blades(source="FILES", filepath=SAMPLE)
    sky_and_sun(sun_angle=(1.2, 0.0, 0.4))
    camera((0.0, -0.55, 0.07), (math.radians(88), 0, 0), lens=50.0)
    render("capture_blades", res=(480, 360), samples=16)


def refine():
    reset()
    bpy.ops.tussock.capture_blades(source="FILES", filepath=SAMPLE)
    coll = bpy.data.collections["Tussock Blades"]
    originals = sorted(coll.objects, key=lambda o: o.name)
    # four copies of the cluster side by side: full, 32, 16 and 8 knots (seed Fig. 6)
    for column, knots in enumerate((0, 32, 16, 8)):
        copies = []
        for o in originals:
            c = o if column == 0 else o.copy()
            if column:
                c.data = o.data.copy()
                coll.objects.link(c)
            c.location.x += 0.3 * column
            copies.append(c)
        if knots:
            for o in coll.objects:
                o.select_set(o in copies)
            bpy.ops.tussock.refine_blades(knots=str(knots), movement="TRACKED", frames=12)
    sky_and_sun(sun_angle=(1.2, 0.0, 0.4))
    camera((0.45, -1.6, 0.07), (math.radians(88), 0, 0), lens=50.0)
    render("refine_levels", res=(720, 300), samples=16)


def _tree_row(names, gap=2.0):
    """Adds one tree per preset in a row along x; returns (objects, width, height)."""
    objs, x = [], 0.0
    for name in names:
        bpy.ops.tussock.add_tree(preset=name, seed=1, leaves=True)
        obj = bpy.context.active_object
        xs = [c[0] for c in obj.bound_box]
        obj.location.x = x - min(xs)
        x += max(xs) - min(xs) + gap
        objs.append(obj)
    height = max(max(c[2] for c in o.bound_box) for o in objs)
    return objs, x - gap, height


def _ortho_camera(width, height, aspect, margin=1.08):
    cam = camera((width / 2, -200.0, height / 2), (math.radians(90), 0, 0))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = margin * max(width, height * aspect)
    return cam


def _ground(size):
    bpy.ops.mesh.primitive_plane_add(size=size, location=(size / 4, 0, 0))
    soil(bpy.context.active_object)


def trees():
    from tussock import native
    names = list(native.require().tree_presets())
    # the presets side by side, at their true sizes
    reset()
    objs, width, height = _tree_row(names)
    _ground(4 * width)
    sky_and_sun(sun_angle=(0.8, 0.1, 0.6))
    res = (1200, 400)
    _ortho_camera(width, height, res[0] / res[1])
    bpy.context.scene.camera.location.z = height * 0.5
    render("trees_presets", res=res, samples=12)
    # a frame strip of one tree in a steady wind with waves and gusts: every 12th frame
    import numpy as np
    reset()
    scene = bpy.context.scene
    w = scene.tussock_wind
    w.base_speed = 2.0
    w.gust_strength, w.gust_interval, w.gust_duration = 6.0, 2.0, 1.2
    wave = w.waves.add()
    wave.amplitude, wave.wavelength, wave.speed = 4.0, 10.0, 5.0
    objs, width, height = _tree_row(["ca_black_oak"])
    _ground(6 * max(width, height))
    sky_and_sun(sun_angle=(0.8, 0.1, 0.6))
    frame_res = (260, 320)
    _ortho_camera(width, height, frame_res[0] / frame_res[1], margin=1.25)
    bpy.context.scene.camera.location.z = height * 0.55
    frames = (1, 13, 25, 37, 49)
    tiles = []
    for f in frames:
        scene.frame_set(f)
        render(f"trees_wind_f{f}", res=frame_res, samples=10)
        img = bpy.data.images.load(scene.render.filepath)
        px = np.empty(frame_res[0] * frame_res[1] * 4, np.float32)
        img.pixels.foreach_get(px)
        tiles.append(px.reshape(frame_res[1], frame_res[0], 4)[::-1])  # top row first
        bpy.data.images.remove(img)
        os.remove(scene.render.filepath)
    sep = np.ones((frame_res[1], 4, 4), np.float32)
    row = []
    for t in tiles:
        row += [t, sep]
    save_rgba("trees_wind_strip", np.concatenate(row[:-1], axis=1))


PICTURE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "samples",
                       "picture")


def picture():
    """samples/picture/ animated by tussock.animate_picture and rendered by the compositor:
    the picture, its layers and background plate, and a strip of rendered frames."""
    import tempfile
    import numpy as np
    from tussock import native
    reset()
    lib = native.require()
    scene = bpy.context.scene
    s = scene.tussock_picture
    grass, crown = picture_sample_scene.describe(s, PICTURE)
    bpy.ops.tussock.animate_picture()
    w, h = scene.render.resolution_x, scene.render.resolution_y

    def read(path):
        p = lib.picture_load(path)
        out = np.empty((h, w, 4), np.float32)
        lib.picture_read_rgba(p, out)
        return out

    original = read(s.filepath)
    save_rgba("picture_sample", original)
    # layers tinted over the picture | the background plate with the layers taken out
    tinted = original.copy()
    for path, tint in ((grass.mask_path, (0.2, 0.4, 1.0)), (crown.mask_path, (1.0, 0.5, 0.1))):
        m = read(path)[..., 0] >= 0.5
        tinted[m, :3] = 0.45 * tinted[m, :3] + 0.55 * np.array(tint, np.float32)
    plate = np.empty(w * h * 4, np.float32)
    s.background_image.pixels.foreach_get(plate)
    plate = plate.reshape(h, w, 4)[::-1]
    gap = np.ones((h, 8, 4), np.float32)
    save_rgba("picture_layers", np.concatenate([tinted, gap, plate], axis=1))
    # frames rendered by Blender's compositor, cropped around the tree and the horizon
    st = scene.render.image_settings
    st.file_format, st.color_mode, st.color_depth = "PNG", "RGBA", "8"
    tiles = []
    with tempfile.TemporaryDirectory() as tmp:
        for frame in (1, 36, 48, 60):
            scene.frame_set(frame)
            scene.render.filepath = os.path.join(tmp, f"frame_{frame}.png")
            t = time.time()
            bpy.ops.render.render(write_still=True)
            print(f"[pictures] frame {frame} rendered ({time.time() - t:.2f} s)", flush=True)
            tile = read(scene.render.filepath)[0:140, 215:345]  # the crown and the horizon
            tiles.append(np.repeat(np.repeat(tile, 2, axis=0), 2, axis=1))
            tiles.append(np.ones((280, 8, 4), np.float32))
    save_rgba("picture_frames", np.concatenate(tiles[:-1], axis=1))


def wind():
    """The wind field of two keyframed sources in the fluid grid, as the debug image
    shows it (hue: direction, brightness: speed), at three frames."""
    import numpy as np
    from tussock.wind import operators as wind_ops
    reset()
    scene = bpy.context.scene
    w = scene.tussock_wind
    w.base_speed = 0.0
    w.use_fluid, w.fluid_resolution, w.fluid_size = True, 96, 20.0
    for loc, rot, interval in (((-7.0, -3.0, 0.0), (0.0, 1.5708, 0.3), 0.0),
                               ((5.0, 6.0, 0.0), (0.0, 1.5708, -2.2), 1.0)):
        scene.cursor.location = loc
        bpy.ops.tussock.add_wind_source(strength=1.0, radius=2.0, interval=interval)
        bpy.context.active_object.rotation_euler = rot
    tiles = []
    for frame in (12, 36, 72):
        rgba, _ = wind_ops.field_image(scene, frame, size=192)
        tiles += [rgba, np.ones((192, 6, 4), np.float32)]
    save_rgba("wind_field", np.concatenate(tiles[:-1], axis=1))


def simulation():
    """A ball rolled by Blender's rigid bodies through a meadow: the blades it touches are
    simulated and pushed aside; the rest stay instanced."""
    reset()
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=6.0)
    ground = bpy.context.active_object
    soil(ground)
    bpy.ops.rigidbody.object_add(type="PASSIVE")
    bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=96, density="UNIFORM",
                               display=1.0, scale_min=0.7, scale_max=1.1)
    meadow = bpy.context.active_object
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.22, location=(-2.4, 0.0, 0.22))
    ball = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    red = bpy.data.materials.new("Ball")
    red.use_nodes = True
    red.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.6, 0.05, 0.03, 1)
    ball.data.materials.append(red)
    bpy.ops.rigidbody.object_add(type="ACTIVE")
    ball.rigid_body.collision_shape = "SPHERE"
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(ball)
    scene.gravity = (4.0, 0.0, -9.81)
    scene.tussock_wind.base_speed = 0.5
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    for f in range(1, 31):
        scene.frame_set(f)
    sky_and_sun(sun_angle=(0.8, 0.2, -0.6))
    camera((-0.4, -2.3, 2.3), (math.radians(48), 0, 0), lens=35.0)
    render("simulation_ball", res=(560, 315), samples=16)


def walk():
    """A character walking through a simulated meadow, seen from behind and above: each bone
    pushes the grass with its own capsule, and the legs leave a track."""
    reset()
    scene = bpy.context.scene
    scene.render.fps = 24
    scene.frame_start, scene.frame_end = 1, 40
    scene.tussock_wind.base_speed = 0.5
    ground, meadow, rig, body = walker.through_meadow(
        scene, (4.0, 2.0), start=(-1.6, 0.0, 0.0), speed=1.2, frames=(1, 40),
        blades_per_tile=96)
    soil(ground)
    blue = bpy.data.materials.new("Body")
    blue.use_nodes = True
    blue.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (
        0.15, 0.25, 0.55, 1)
    body.data.materials.append(blue)
    for f in range(1, 41):
        scene.frame_set(f)
    sky_and_sun(sun_angle=(0.8, 0.2, -0.6))
    camera((1.3, -1.2, 1.3), (math.radians(58), 0, math.radians(40)), lens=35.0)
    render("simulation_walk", res=(560, 315), samples=16)


def split_bake_with_without(frame, name):
    """Saves the scene (frames 1-24), bakes it in two halves by two background Blenders as
    two farm workers would, renders `frame` by a Blender with Tussock and by one without it,
    and saves both side by side as `name`."""
    import tempfile
    import numpy as np
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import blender_env
    w, h = bpy.context.scene.render.resolution_x, bpy.context.scene.render.resolution_y
    tiles = []
    with tempfile.TemporaryDirectory() as tmp:
        blend = os.path.join(tmp, "farm.blend")
        bpy.ops.wm.save_as_mainfile(filepath=blend)
        for part in ("frame_start=1, frame_end=12", "frame_start=13, frame_end=24"):
            blender_env.run_worker(blend, f"bpy.ops.tussock.bake({part}, save=True)")
        for addon in (True, False):
            out = os.path.join(tmp, f"r{int(addon)}")
            blender_env.run_worker(blend, f"bpy.context.scene.render.filepath = {out!r}\n"
                                   f"bpy.context.scene.frame_set({frame})\n"
                                   "bpy.ops.render.render(write_still=True)", addon=addon)
            img = bpy.data.images.load(out + ".png")
            px = np.empty(w * h * 4, np.float32)
            img.pixels.foreach_get(px)
            tiles += [px.reshape(h, w, 4)[::-1], np.ones((h, 8, 4), np.float32)]
        same = np.array_equal(tiles[0], tiles[2])
        print(f"[pictures] with and without Tussock identical: {same}", flush=True)
    save_rgba(name, np.concatenate(tiles[:-1], axis=1))


def farm():
    """A tree baked in two halves by two background Blenders (as farm workers would), then
    frame 12 rendered by a Blender with Tussock and by one without it: the same picture."""
    reset()
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 24
    scene.tussock_wind.base_speed = 5.0
    wave = scene.tussock_wind.waves.add()
    wave.amplitude, wave.wavelength, wave.speed = 4.0, 8.0, 6.0
    bpy.ops.tussock.add_tree(preset="quaking_aspen", seed=3)
    sky_and_sun()
    camera((0.0, -26.0, 7.0), (math.radians(84), 0, 0), lens=45.0)
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.use_denoising = 12, False
    scene.render.resolution_x, scene.render.resolution_y = 240, 300
    split_bake_with_without(12, "farm_with_without")


def farm_picture():
    """The sample picture animated, baked in two halves by two background Blenders, then
    frame 48 rendered by a Blender without Tussock and by one with it (cropped around the
    crown, enlarged twice), and the crown layer's baked UV pass read from its EXR file:
    how far each pixel takes its colour from (red: sideways, green: up and down)."""
    import shutil
    import tempfile
    import numpy as np
    from tussock import native
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import blender_env
    reset()
    lib = native.require()
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 60
    tiles = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in picture_sample_scene.FILES:
            shutil.copyfile(os.path.join(PICTURE, name), os.path.join(tmp, name))
        blend = os.path.join(tmp, "picture.blend")
        bpy.ops.wm.save_as_mainfile(filepath=blend)
        picture_sample_scene.describe(scene.tussock_picture, "//")
        bpy.ops.tussock.animate_picture()
        w, h = scene.render.resolution_x, scene.render.resolution_y
        st = scene.render.image_settings
        st.file_format, st.color_mode, st.color_depth = "OPEN_EXR", "RGBA", "32"
        bpy.ops.wm.save_mainfile()

        def run(expr, addon=True):
            blender_env.run_worker(blend, expr, addon)

        def read(path):
            p = lib.picture_load(path)
            out = np.empty((h, w, 4), np.float32)
            lib.picture_read_rgba(p, out)
            return out

        t = time.time()
        run("bpy.ops.tussock.bake(frame_start=1, frame_end=30, save=True)")
        run("bpy.ops.tussock.bake(frame_start=31, frame_end=60, save=True)")
        print(f"[pictures] 60 frames baked by two Blenders in {time.time() - t:.1f} s",
              flush=True)
        crop = (slice(0, 140), slice(215, 345))
        renders = []
        for addon in (False, True):
            out = os.path.join(tmp, f"r{int(addon)}.exr")
            run(f"bpy.context.scene.render.filepath = {out!r}\nbpy.context.scene.frame_set(48)\n"
                "bpy.ops.render.render(write_still=True)", addon=addon)
            renders.append(read(out))
            tiles += [renders[-1][crop], np.ones((140, 4, 4), np.float32)]
        print(f"[pictures] with and without Tussock identical: "
              f"{np.array_equal(renders[0], renders[1])}", flush=True)
        uv = read(os.path.join(tmp, "tussock_cache", "Scene_picture_uv2",
                               "Scene_picture_uv2_0048.exr"))
        rest_u = (np.arange(w, dtype=np.float32) + 0.5) / w
        rest_v = (h - np.arange(h, dtype=np.float32) - 0.5) / h  # rows top-first
        du, dv = (uv[..., 0] - rest_u[None, :]) * w, (uv[..., 1] - rest_v[:, None]) * h
        scale = max(float(np.abs(du).max()), float(np.abs(dv).max()), 1e-6)
        vis = np.ones((h, w, 4), np.float32)
        vis[..., 0], vis[..., 1], vis[..., 2] = 0.5 + 0.5 * du / scale, 0.5 + 0.5 * dv / scale, 0.5
        print(f"[pictures] crown UV pass at frame 48: up to {scale:.1f} px", flush=True)
        tiles.append(vis[crop])
    save_rgba("farm_picture", np.concatenate(tiles, axis=1), zoom=2)


def farm_meadow():
    """A ball crossing a simulated meadow, baked in two halves by two background Blenders,
    then frame 18 rendered by a Blender with Tussock and by one without it."""
    reset()
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 24
    bpy.ops.mesh.primitive_plane_add(size=4.0)
    soil(bpy.context.active_object)
    bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=96, density="UNIFORM",
                               display=1.0, scale_min=0.7, scale_max=1.1)
    meadow = bpy.context.active_object
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.2, location=(-1.6, 0.1, 0.12))
    ball = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    red = bpy.data.materials.new("Ball")
    red.use_nodes = True
    red.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.6, 0.05, 0.03, 1)
    ball.data.materials.append(red)
    ball.keyframe_insert("location", frame=1)
    ball.location = (1.0, -0.1, 0.12)
    ball.keyframe_insert("location", frame=24)
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(ball)
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    sky_and_sun(sun_angle=(0.8, 0.2, -0.6))
    camera((-0.6, -2.1, 1.7), (math.radians(52), 0, math.radians(-8)), lens=35.0)
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.use_denoising = 12, False
    w, h = 320, 220
    scene.render.resolution_x, scene.render.resolution_y = w, h
    split_bake_with_without(18, "farm_meadow")


def reliability():
    """The sample depth frame corrupted on purpose — heavy noise, 10 % dropout and bursts of
    missing pixels — and what the capture still makes of it."""
    import numpy as np
    from tussock import native
    from tussock.capture import pipeline, preview
    reset()
    lib = native.require()
    src = lib.depth_open_files(SAMPLE)
    info = lib.depth_info(src)
    w, h = info["width"], info["height"]
    depth = np.empty(w * h, np.float32)
    lib.depth_read(src, depth)
    lib.depth_close(src)
    rng = np.random.default_rng(11)
    d = depth.reshape(h, w).copy()
    valid = d > 0
    d[valid] += rng.normal(0.0, 4e-3, valid.sum()).astype(np.float32)  # 2.7x the sensor noise
    d[rng.random(d.shape) < 0.10] = 0.0                                # 10 % dropout
    for _ in range(40):                                                # bursts of lost pixels
        y, x = rng.integers(0, h - 6), rng.integers(0, w - 6)
        d[y:y + 5, x:x + 5] = 0.0
    r = pipeline.process(np.ascontiguousarray(d.ravel()), w, h, 0.0, 0.0, info["fx"], info["fy"],
                         info["cx"], info["cy"], 150)
    im = r["images"]
    rows, cols = np.nonzero(im["MASK"])
    crop = (max(rows.min() - 12, 0), rows.max() + 12, max(cols.min() - 12, 0), cols.max() + 12)
    blank = np.zeros_like(im["DEPTH"])
    raw = preview.compose(im["DEPTH"], blank, blank, blank)
    found = preview.compose(im["DEPTH"], im["MASK"], im["LABELS"], im["OVERLAY"])
    t, b, l, rr = crop
    gap = np.ones((b - t, 6, 4), np.float32)
    save_rgba("reliability_capture",
              np.concatenate([raw[t:b, l:rr], gap, found[t:b, l:rr]], axis=1),
              zoom=2)
    print(f"[pictures] corrupted frame: {r['summary']['message']}", flush=True)


FEATURES = {"capture": capture, "refine": refine, "meadow": meadow, "trees": trees,
            "wind": wind, "simulation": simulation, "walk": walk, "farm": farm,
            "farm_picture": farm_picture, "farm_meadow": farm_meadow,
            "reliability": reliability, "picture": picture}

os.makedirs(OUT, exist_ok=True)
for name, fn in FEATURES.items():
    if not WANT or name in WANT:
        fn()
