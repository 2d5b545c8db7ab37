"""Tussock's demo, run by `./build.sh demo` in background Blender: builds a scene from
what Tussock can do today, renders it with Cycles and saves the .blend, all into out/.
Each step prints what it made and how long it took."""

import os
import sys
import time

import bpy
import numpy as np

OUT = os.path.abspath(sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else "out")
os.makedirs(OUT, exist_ok=True)

import addon_utils  # noqa: E402

addon_utils.enable("tussock", default_set=True)
from tussock import native  # noqa: E402

lib = native.require()
_t0 = time.time()


def step(msg):
    global _t0
    now = time.time()
    print(f"[demo] {msg} ({now - _t0:.2f} s)", flush=True)
    _t0 = now


def reset_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("tussock", default_set=True)


def tuft_mesh(count, seed, size=2.0):
    """A field of simple blades scattered by the native counter-based generator: every
    blade's position, turn, height and lean come from (seed, stream, blade), so the same
    seed gives the same field on every machine. Built with numpy, no Python loop."""
    r = np.empty(count * 5, np.float32)
    lib.rand_fill(seed, 1, r)
    r = r.reshape(5, count)
    x, y = (r[0] - 0.5) * size, (r[1] - 0.5) * size
    turn = r[2] * 2.0 * np.pi
    h = 0.12 + 0.18 * r[3]
    lean = 0.35 * r[4]
    w = 0.012
    # three vertices per blade: two at the root, one at the tip
    cx, cy = np.cos(turn), np.sin(turn)
    verts = np.empty((count, 3, 3), np.float32)
    verts[:, 0] = np.stack([x - cx * w, y - cy * w, np.zeros(count)], axis=1)
    verts[:, 1] = np.stack([x + cx * w, y + cy * w, np.zeros(count)], axis=1)
    verts[:, 2] = np.stack([x - cy * lean * h, y + cx * lean * h, h], axis=1)
    mesh = bpy.data.meshes.new("Demo tufts")
    mesh.vertices.add(count * 3)
    mesh.vertices.foreach_set("co", verts.ravel())
    mesh.loops.add(count * 3)
    mesh.loops.foreach_set("vertex_index", np.arange(count * 3, dtype=np.int32))
    mesh.polygons.add(count)
    mesh.polygons.foreach_set("loop_start", np.arange(0, count * 3, 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(count, 3, np.int32))
    mesh.update()
    mesh.validate()
    return mesh


def grass_material():
    mat = bpy.data.materials.new("Demo grass")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.09, 0.32, 0.05, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.6
    return mat


def render(path, res=(480, 270), samples=16):
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False  # Debian's Blender is built without OpenImageDenoise
    scene.render.resolution_x, scene.render.resolution_y = res
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)


def main():
    reset_scene()
    step(f"Tussock {native.version()} in Blender {bpy.app.version_string}, "
         f"{lib.get_threads()} threads")
    mesh = tuft_mesh(20000, seed=7)
    mesh.materials.append(grass_material())
    obj = bpy.data.objects.new("Demo tufts", mesh)
    bpy.context.scene.collection.objects.link(obj)
    step(f"scattered {len(mesh.polygons)} blades with the native counter-based generator")

    bpy.ops.mesh.primitive_plane_add(size=2.2)
    ground = bpy.context.active_object
    gm = bpy.data.materials.new("Demo soil")
    gm.use_nodes = True
    gm.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.12, 0.08, 0.05, 1)
    ground.data.materials.append(gm)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    bpy.context.scene.collection.objects.link(cam)
    cam.location = (0.0, -2.2, 0.9)
    cam.rotation_euler = (1.25, 0.0, 0.0)
    bpy.context.scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.7, 0.2, 0.5)
    bpy.context.scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.5, 0.65, 0.9, 1)
    bpy.context.scene.world = world

    blend = os.path.join(OUT, "demo.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    step(f"saved {blend}")
    png = os.path.join(OUT, "demo_field.png")
    render(png)
    step(f"rendered {png}")
    print(f"[demo] outputs in {OUT}")


main()
