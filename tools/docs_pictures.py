"""Renders the pictures of docs/ with Tussock itself, in background Blender:
  blender_run.py tools/docs_pictures.py -- OUT_DIR [FEATURE...]
Features: meadow. Each writes PNGs named <feature>_<view>.png into OUT_DIR."""

import math
import os
import sys
import time

import bpy

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
    mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.10, 0.07, 0.04, 1)
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


FEATURES = {"meadow": meadow}

os.makedirs(OUT, exist_ok=True)
for name, fn in FEATURES.items():
    if not WANT or name in WANT:
        fn()
