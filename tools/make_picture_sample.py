"""Makes samples/picture/: a still picture of vegetation that Tussock renders itself (so it
ships under the project's licence) and the masks of its two layers, for tussock.animate_picture:
  /usr/bin/python3 tools/blender_run.py tools/make_picture_sample.py -- OUT_DIR
Writes meadow.png (Cycles: a Tussock meadow, a Tussock tree, sky and sun), grass_mask.png
(the meadow: its blades and the soil seen between them) and crown_mask.png (the tree's
leaves, closed by 4 px so that the gaps between leaves belong to the crown; the trunk stays
in the background, as seed 004 advises), all 480x270. The masks are the same view drawn
flat by Workbench: white where the layer's material is, black elsewhere."""

import math
import os
import sys
import time

import bpy

ARGS = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
OUT = os.path.abspath(ARGS[0] if ARGS else "samples/picture")
RES = (480, 270)


def setup():
    import addon_utils
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("tussock", default_set=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=1.0)
    ground = bpy.context.active_object
    ground.scale = (40.0, 40.0, 1.0)
    soil = bpy.data.materials.new("Soil")
    soil.use_nodes = True
    bsdf = soil.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.10, 0.07, 0.04, 1)
    ground.data.materials.append(soil)
    bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=64, chunk_blades=16,
                               density="UNIFORM", seed=3, display=1.0, patch_blades=16384)
    meadow = bpy.context.active_object
    scene.cursor.location = (5.0, 40.0, 0.0)
    bpy.ops.tussock.add_tree(preset="quaking_aspen", seed=4)
    tree = bpy.context.active_object
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.55, 0.7, 0.95, 1.0)
    scene.world = world
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.5
    sun.data.angle = 0.05
    sun.rotation_euler = (0.9, 0.15, 0.8)
    scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = 32.0
    cam.location, cam.rotation_euler = (0.0, -12.0, 0.9), (math.radians(89), 0, 0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y = RES
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    return scene, meadow, tree


def render(scene, name):
    scene.render.filepath = os.path.join(OUT, name + ".png")
    t = time.time()
    bpy.ops.render.render(write_still=True)
    print(f"[sample] {scene.render.filepath} ({time.time() - t:.1f} s)", flush=True)


def _grow(m, steps, value):
    """`steps` 3x3 dilations (value True) or erosions (value False) of a bool mask."""
    import numpy as np
    for _ in range(steps):
        p = np.pad(m, 1, constant_values=not value)
        views = [p[1 + dy:p.shape[0] - 1 + dy, 1 + dx:p.shape[1] - 1 + dx]
                 for dy in (-1, 0, 1) for dx in (-1, 0, 1)]
        m = np.logical_or.reduce(views) if value else np.logical_and.reduce(views)
    return m


def close_mask(path, steps=4):
    """Closes a mask (dilate, then erode, by `steps` px): the gaps between leaves, where
    branches and sky show through, become part of the crown, so that the crown moves as
    one piece and the background plate never shows through it."""
    import numpy as np
    img = bpy.data.images.load(path)
    w, h = img.size
    px = np.empty(w * h * 4, np.float32)
    img.pixels.foreach_get(px)  # 8-bit PNG: stored values, as the operator reads them
    m = px.reshape(h, w, 4)[..., 0] >= 0.5
    m = _grow(_grow(m, steps, True), steps, False)
    out = np.zeros((h, w, 4), np.float32)
    out[m, :3] = 1.0
    out[..., 3] = 1.0
    img.pixels.foreach_set(out.ravel())
    img.save()
    bpy.data.images.remove(img)


def main():
    os.makedirs(OUT, exist_ok=True)
    scene, meadow, tree = setup()
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 32
    scene.cycles.use_denoising = False  # Debian's Blender has no OpenImageDenoise
    render(scene, "meadow")
    # the masks: flat colours, white = the layer's material
    scene.render.engine = "BLENDER_WORKBENCH"
    shading = scene.display.shading
    shading.light, shading.color_type = "FLAT", "MATERIAL"
    scene.view_settings.view_transform = "Standard"
    scene.world.color = (0.0, 0.0, 0.0)
    bark, leaf = tree.material_slots[0].material, tree.material_slots[1].material
    blade = [m for m in bpy.data.materials if m not in (bark, leaf) and m.name != "Soil"]
    print("[sample] blade materials:", [m.name for m in blade], flush=True)
    soil = bpy.data.materials["Soil"]  # seen only between blades: part of the grass layer
    for name, white in (("grass_mask", blade + [soil]), ("crown_mask", [leaf])):
        for m in bpy.data.materials:
            m.diffuse_color = (1.0, 1.0, 1.0, 1.0) if m in white else (0.0, 0.0, 0.0, 1.0)
        render(scene, name)
    close_mask(os.path.join(OUT, "crown_mask.png"))


main()
