"""Tussock's demo, run by `./build.sh demo` in background Blender: from the sample depth
recording it captures the blades, refines them to 16 knots, grows a meadow of over a
million blades from them, rolls a rigid-body ball through it (every touched blade
simulated), grows a Weber-Penn tree beside it that sways in the same wind, bakes, saves
the .blend and renders a short Cycles animation (frames and an MP4) into out/; then it
brings the sample picture to life through the compositor into a second clip, and walks a
character through a simulated meadow into a third (each bone pushes the grass). Each step
prints what it made and how long it took, as "[demo k/STEPS] ...", and the frames it
renders or encodes next as "[demo] rendering N frames ..." (for tools/demo_run.py).
TSK_DEMO_CLIP=walk renders the third clip alone."""

import math
import os
import sys
import time

import bpy

OUT = os.path.abspath(sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else "out")
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLE = os.path.join(REPO, "samples", "blades", "depth_####.png")
FRAMES = int(os.environ.get("TSK_DEMO_FRAMES", "24"))
os.makedirs(OUT, exist_ok=True)

import addon_utils  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import picture_sample_scene  # noqa: E402
import walker  # noqa: E402

STEPS = 16  # the step() calls of a run (tests/test_demo_run.py counts them)
_t0 = time.time()
_start = _t0
_done = 0


def step(msg):
    global _t0, _done
    now = time.time()
    _done += 1
    print(f"[demo {_done}/{STEPS}] {msg} ({now - _t0:.1f} s)", flush=True)
    _t0 = now


def frames_next(what, frames):
    """Says that the step under way now renders or encodes `frames` frames (`what`:
    "rendering" or "encoding"), so tools/demo_run.py shows how far it is."""
    print(f"[demo] {what} {frames} frames ...", flush=True)


def paint(obj, name, rgba):
    """A new material `name` of base colour `rgba` on `obj`."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = rgba
    obj.data.materials.append(mat)


def camera_sun_sky(scene, location, rotation, sun_rotation):
    """The shot's camera (24 mm), a sun and a blue sky."""
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location, cam.rotation_euler = location, rotation
    cam.data.lens = 24.0
    cam.data.clip_end = 300.0
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.5
    sun.rotation_euler = sun_rotation
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.55, 0.7, 0.95, 1)
    scene.world = world


def cycles_frames(scene, folder, prefix):
    """Cycles on the CPU, 8 samples, 480x270 PNG frames into OUT/folder/prefix####.png."""
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 8
    scene.cycles.use_denoising = False  # Debian's Blender has no OpenImageDenoise
    scene.render.resolution_x, scene.render.resolution_y = 480, 270
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = os.path.join(OUT, folder, prefix)


def reset_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("tussock", default_set=True)


def main():
    reset_scene()
    from tussock import native
    lib = native.require()
    scene = bpy.context.scene
    step(f"Tussock {native.version()} in Blender {bpy.app.version_string}, "
         f"{lib.get_threads()} threads")

    # 1. capture the blades of the sample recording (4 frames averaged)
    bpy.ops.tussock.capture_blades(source="FILES", filepath=SAMPLE, frames=4)
    blades = list(bpy.data.collections["Tussock Blades"].objects)
    step(f"captured {len(blades)} blades from {SAMPLE}")

    # 2. refine them to 16 knots with their motion tracked through the recording
    for o in blades:
        o.select_set(True)
    bpy.ops.tussock.refine_blades(knots="16", movement="TRACKED", frames=12)
    step(f"refined them to {len(blades[0].data.vertices)} knots (seed 000 Algorithm 1)")
    # the captured cluster stands aside, out of the shot
    for o in blades:
        o.location.x += 100.0

    # 3. a meadow of those blades on a 46 m ground
    bpy.ops.mesh.primitive_plane_add(size=46.0)
    ground = bpy.context.active_object
    bpy.ops.rigidbody.object_add(type="PASSIVE")
    paint(ground, "Soil", (0.09, 0.06, 0.035, 1))
    bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=64, chunk_blades=16,
                               scale_min=1.2, scale_max=2.4, noise_scale=9.0,
                               noise_threshold=0.05, seed=3, display=0.1)
    meadow = bpy.context.active_object
    step(f"grew a meadow of {meadow['tussock_blades']:,} blades in "
         f"{meadow['tussock_tiles']:,} tiles ({meadow['tussock_instances']:,} instances)")

    # 4. a rigid-body ball rolls through it (Blender's Bullet world moves the ball; the
    #    tiles it touches are simulated blade by blade, the rest stay instanced)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.3, location=(-4.8, -8.0, 0.3))
    ball = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    paint(ball, "Ball", (0.6, 0.05, 0.03, 1))
    bpy.ops.rigidbody.object_add(type="ACTIVE")
    ball.rigid_body.collision_shape = "SPHERE"
    scene.gravity = (5.0, 0.6, -9.81)  # as on a gentle slope
    colliders = bpy.data.collections.new("Colliders")
    scene.collection.children.link(colliders)
    colliders.objects.link(ball)
    meadow.tussock_meadow.colliders = colliders
    meadow.tussock_meadow.use_simulation = True
    step("a rigid-body ball rolls through the meadow; touched blades are simulated")

    # 5. a tree beside it, swaying in the same wind
    w = scene.tussock_wind
    w.base_speed, w.base_direction = 3.0, math.radians(20)
    wave = w.waves.add()
    wave.amplitude, wave.wavelength, wave.speed, wave.power = 4.0, 12.0, 5.0, 2.0
    w.gust_strength = 2.0
    scene.cursor.location = (2.5, 6.0, 0.0)
    bpy.ops.tussock.add_tree(preset="black_tupelo", seed=2)
    tree = bpy.context.active_object
    tree.scale = (0.7, 0.7, 0.7)
    step(f"grew a Weber-Penn black tupelo: {tree['tussock_branches']:,} branches, "
         f"{tree['tussock_leaves']:,} leaves")

    camera_sun_sky(scene, (-5.0, -12.0, 1.5), (math.radians(86), 0.0, math.radians(-24)),
                   (math.radians(50), 0.0, math.radians(30)))

    scene.frame_start, scene.frame_end = 1, FRAMES
    scene.render.fps = 12
    scene.rigidbody_world.point_cache.frame_end = FRAMES
    blend = os.path.join(OUT, "demo.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    step(f"saved {blend}")

    # 6. bake the tree for any render farm, then render: frames, then an MP4 through
    #    Blender's own video output
    bpy.ops.tussock.bake(save=True)
    step(f"baked the tree into {os.path.join(OUT, 'tussock_cache')} (Mesh Cache .pc2)")
    cycles_frames(scene, "frames", "demo_")
    # play the frames once: Blender's rigid-body world fills its cache (the render reads
    # it) and the blade simulation records where the ball is in every frame
    for f in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(f)
    scene.frame_set(scene.frame_start)
    simulated = []  # blades simulated in each rendered frame

    def count(scene, depsgraph=None):
        simulated.append(meadow.get("tussock_active_blades", 0))
    bpy.app.handlers.frame_change_post.append(count)
    frames_next("rendering", FRAMES)
    bpy.ops.render.render(animation=True)
    bpy.app.handlers.frame_change_post.remove(count)
    step(f"rendered {FRAMES} frames into {os.path.join(OUT, 'frames')} "
         f"(up to {max(simulated, default=0):,} blades simulated in a frame)")
    mp4 = os.path.join(OUT, "demo.mp4")
    encode_video(os.path.join(OUT, "frames"), "demo_", FRAMES, mp4, scene.render.fps, (480, 270))
    step(f"wrote {mp4}")
    picture_clip()
    walk_clip()
    print(f"[demo] outputs in {OUT}; total {time.time() - _start:.0f} s", flush=True)


def picture_clip():
    """The sample picture (samples/picture/) brought to life through the compositor."""
    reset_scene()
    scene = bpy.context.scene
    s = scene.tussock_picture
    picture_sample_scene.describe(s)
    bpy.ops.tussock.animate_picture()
    step(f"animated the picture {s.filepath}: 2 layers (grass, crown), background inpainted, "
         "compositor tree built")
    frames = max(FRAMES, 24)
    scene.frame_start, scene.frame_end = 1, frames
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = os.path.join(OUT, "picture_frames", "picture_")
    frames_next("rendering", frames)
    bpy.ops.render.render(animation=True)
    step(f"rendered {frames} frames of the picture into {os.path.join(OUT, 'picture_frames')}")
    mp4 = os.path.join(OUT, "picture.mp4")
    encode_video(os.path.join(OUT, "picture_frames"), "picture_", frames, mp4, scene.render.fps,
                 (scene.render.resolution_x, scene.render.resolution_y))
    step(f"wrote {mp4}")


def walk_clip():
    """A character (tools/walker.py: an armature deforming a mesh) walks through a simulated
    meadow with every blade shown; its legs push the grass aside and leave a track."""
    reset_scene()
    scene = bpy.context.scene
    frames = max(FRAMES, 36)
    scene.render.fps = 24
    scene.frame_start, scene.frame_end = 1, frames
    scene.tussock_wind.base_speed = 1.0
    ground, meadow, rig, body = walker.through_meadow(
        scene, (5.0, 2.5), start=(-1.7, 0.0, 0.0), speed=1.2, frames=(1, frames))
    paint(ground, "Soil", (0.09, 0.06, 0.035, 1))
    paint(body, "Body", (0.15, 0.25, 0.55, 1))
    step(f"a character walks through a meadow of {meadow['tussock_blades']:,} blades, every "
         f"one shown; {len(walker.BONES)} bones push the grass")
    camera_sun_sky(scene, (-0.6, -3.2, 2.1), (math.radians(66), 0.0, 0.0),
                   (math.radians(50), 0.0, math.radians(-30)))
    cycles_frames(scene, "walk_frames", "walk_")
    frames_next("rendering", frames)
    bpy.ops.render.render(animation=True)
    step(f"rendered {frames} frames of the walk into {os.path.join(OUT, 'walk_frames')}")
    mp4 = os.path.join(OUT, "walk.mp4")
    encode_video(os.path.join(OUT, "walk_frames"), "walk_", frames, mp4, scene.render.fps,
                 (480, 270))
    step(f"wrote {mp4}")


def encode_video(folder, prefix, frames, path, fps, size):
    """Frames -> MP4 with Blender's sequencer and FFmpeg output (no extra tools)."""
    from tussock import compat  # the sequencer and video output differ in Blender 5
    vscene = bpy.data.scenes.new("Video")
    vscene.render.resolution_x, vscene.render.resolution_y = size
    vscene.render.resolution_percentage = 100
    vscene.render.fps = fps
    vscene.frame_start, vscene.frame_end = 1, frames
    seq = vscene.sequence_editor_create()
    files = sorted(f for f in os.listdir(folder) if f.startswith(prefix))
    strip = compat.sequencer_strips(seq).new_image("frames", os.path.join(folder, files[0]), 1, 1)
    for f in files[1:]:
        strip.elements.append(f)
    compat.set_file_format(vscene.render.image_settings, "FFMPEG")
    vscene.render.ffmpeg.format = "MPEG4"
    vscene.render.ffmpeg.codec = "H264"
    vscene.render.filepath = path
    vscene.render.use_file_extension = False
    windows = bpy.context.window_manager.windows
    windows[0].scene = vscene if windows else None
    frames_next("encoding", frames)
    bpy.ops.render.render(animation=True, scene=vscene.name)


if os.environ.get("TSK_DEMO_CLIP") == "walk":  # (the third clip alone)
    walk_clip()
else:
    main()
