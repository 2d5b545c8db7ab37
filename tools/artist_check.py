"""An artist's session with Tussock, for checking an installed build: run inside
Blender with Tussock installed (the 4.2+ extension bl_ext.user_default.tussock, or the
add-on `tussock`):

    blender -b --factory-startup --python-exit-code 1 --python tools/artist_check.py -- \\
        OUT_JSON WORKDIR SAMPLES_DIR ONI_FILE

(in this checkout: /usr/bin/python3 tools/blender_run.py tools/artist_check.py -- ...).
WORKDIR must be new or empty; ONI_FILE is the recording that native/tools/png_to_oni made
of SAMPLES_DIR/blades (build/release/png_to_oni ONI_FILE SAMPLES_DIR/blades/depth_####.png).

In one fresh scene, through Tussock's operators, it captures blades from the sample depth
images and from the recording, refines the blades of the images, grows a meadow of them
with a keyframed sphere (a kinematic rigid body) rolling through it, grows a tree in a
windy scene, animates the sample picture with its two masks, plays frames 1..FRAMES, saves
the .blend into WORKDIR, bakes (caches in WORKDIR/tussock_cache) and renders one small
Cycles frame (WORKDIR/frame.png). OUT_JSON gets the Blender and Tussock versions, counts,
and sha256 hashes of what each step made (see HASHES), so that runs of two builds can be
compared key by key. Any failure prints its traceback and exits with code 1 (OUT_JSON then
holds "ok": false and the traceback).

What a hash covers:
- captured and refined skeletons: blades sorted by object name; per blade its vertex
  positions (knots, float32 x, y, z) then its `width` attribute (float32), concatenated;
- solver: at the last frame, the active tiles and their blade counts (int32), the solver's
  knots of the simulated blades (float32, the runner's order) and the ribbon vertices the
  add-on wrote for them into the meadow's chunk meshes (writer.active_ribbons), each its own
  hash;
- tree: the evaluated mesh's vertex positions (float32) at the last frame;
- caches: every file under WORKDIR/tussock_cache, path relative to WORKDIR -> sha256 of its
  bytes. No cache file holds a time or an absolute path: the picture and its masks are
  copied beside the .blend and used by relative paths (//), because the picture bake's
  inputs key, written into every .tski sidecar, digests the picture's path as given;
- render: whether WORKDIR/frame.png exists, its size and (for information: Cycles may
  differ between Blender versions and builds) a hash of its decoded pixels. Its bytes are not
  hashed: Cycles writes its render times into the PNG (text chunks cycles.*.total_time...),
  which no setting turns off. Blender's own metadata stamps (date, time, file name, host...)
  are turned off, so the size does not depend on when or where it ran (Cycles' times have a
  fixed width)."""

import hashlib
import importlib
import json
import math
import os
import platform
import shutil
import sys
import time
import traceback

import bpy
import numpy as np

FRAMES = 12  # frames played and baked
TREE_PRESET = "quaking_aspen"
HASHES = ("capture_files", "capture_oni", "refined", "sim_tiles", "sim_knots", "sim_ribbons",
          "tree_mesh")

result = {"ok": False, "seconds": {}}
_t0 = [time.time()]


def step(key, msg):
    """Ends step `key` (its time goes into result["seconds"]) and prints what it made."""
    now = time.time()
    result["seconds"][key] = round(now - _t0[0], 2)
    _t0[0] = now
    print(f"[artist_check] {msg} ({result['seconds'][key]:.1f} s)", flush=True)


def sha(*arrays):
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def call(op, **kw):
    """Runs an operator; anything but FINISHED is a failure (its report is in the log)."""
    got = op(**kw)
    if got != {"FINISHED"}:
        raise RuntimeError(f"bpy.ops.{op.idname_py()}({kw}) returned {got}")
    return got


# ---- Tussock: found, enabled --------------------------------------------------------------

def tussock_name():
    """The module name of the installed Tussock: the one enabled, else the one installed
    (bl_ext.<repo>.tussock before the legacy add-on `tussock`)."""
    import addon_utils
    enabled = [m for m in bpy.context.preferences.addons.keys()
               if m == "tussock" or m.endswith(".tussock")]
    if enabled:
        return enabled[0]
    names = sorted((m.__name__ for m in addon_utils.modules()
                    if m.__name__ == "tussock" or m.__name__.endswith(".tussock")),
                   key=lambda n: (not n.startswith("bl_ext."), n))
    if not names:
        raise RuntimeError("Tussock is not installed: no add-on or extension named tussock")
    return names[0]


def enable_tussock(name):
    """Enables Tussock unless it is enabled already; returns its module."""
    import addon_utils
    if not addon_utils.check(name)[1]:
        def fail(exc):
            raise exc
        if addon_utils.enable(name, default_set=True, handle_error=fail) is None:
            raise RuntimeError(f"{name} did not enable")
    return importlib.import_module(name)


def tussock_version(mod):
    """The add-on's version: its extension manifest's, else its bl_info's."""
    manifest = os.path.join(os.path.dirname(mod.__file__), "blender_manifest.toml")
    if os.path.isfile(manifest):
        import tomllib
        with open(manifest, "rb") as f:
            return str(tomllib.load(f).get("version", ""))
    return ".".join(map(str, getattr(mod, "bl_info", {}).get("version", ())))


def fresh_scene():
    """An empty factory scene with Tussock enabled. The preferences are kept (an artist's
    Blender may have enabled Tussock by them); only the scene data is factory."""
    name = tussock_name()
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    mod = enable_tussock(name)
    native = importlib.import_module(name + ".native")
    if not native.available():
        raise RuntimeError(f"Tussock's native library did not load: {native.error}")
    return name, mod, native


# ---- reading what Tussock made ------------------------------------------------------------

def blade_arrays(obj):
    mesh = obj.data
    n = len(mesh.vertices)
    co = np.empty(n * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    width = np.empty(n, np.float32)
    mesh.attributes["width"].data.foreach_get("value", width)
    return co, width


def skeletons(objects):
    """(sha256, blade count, knot count, per-blade arrays in name order) of blade objects."""
    arrays = [blade_arrays(o) for o in sorted(objects, key=lambda o: o.name)]
    flat = [a for pair in arrays for a in pair]
    return sha(*flat), len(arrays), sum(len(w) for _, w in arrays), arrays


def evaluated_positions(obj):
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = ev.to_mesh()
    try:
        co = np.empty(len(mesh.vertices) * 3, np.float32)
        mesh.vertices.foreach_get("co", co)
    finally:
        ev.to_mesh_clear()
    return co


def file_hashes(root, under):
    """{path relative to root: sha256} of every file below root/under, sorted."""
    out = {}
    for dirpath, dirs, files in os.walk(os.path.join(root, under)):
        dirs.sort()
        for f in sorted(files):  # one hash per file
            path = os.path.join(dirpath, f)
            h = hashlib.sha256()
            with open(path, "rb") as fh:
                for chunk in iter(lambda: fh.read(1 << 20), b""):
                    h.update(chunk)
            out[os.path.relpath(path, root)] = h.hexdigest()
    return dict(sorted(out.items()))


# ---- the session --------------------------------------------------------------------------

def main(out_json, work, samples, oni):
    if os.path.isdir(work) and os.listdir(work):
        raise RuntimeError(f"WORKDIR {work} is not empty: give a new or empty folder")
    os.makedirs(work, exist_ok=True)
    pattern = os.path.join(samples, "blades", "depth_####.png")
    for path in (os.path.join(samples, "blades", "depth_0001.png"), oni,
                 os.path.join(samples, "picture", "meadow.png")):
        if not os.path.isfile(path):
            raise RuntimeError(f"missing input: {path}")

    name, mod, native = fresh_scene()
    sub = {m: importlib.import_module(f"{name}.{m}")
           for m in ("meadow.playback", "meadow.writer", "capture.blades")}
    result.update(blender=bpy.app.version_string, blender_build_hash=bpy.app.build_hash.decode(
        "ascii", "replace"), python=platform.python_version(), tussock_module=name,
        tussock_version=tussock_version(mod), tussock_native_version=native.version(),
        tussock_folder=os.path.dirname(os.path.realpath(mod.__file__)), frames=FRAMES)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, FRAMES
    scene.frame_set(1)
    blend = os.path.join(work, "artist.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)  # relative paths (//) are beside it
    step("start", f"Tussock {result['tussock_version']} ({name}) in Blender "
         f"{bpy.app.version_string}")

    # 1. capture: the depth images, then the recording (4 frames averaged, as the demo)
    coll_name = sub["capture.blades"].COLLECTION
    counts = {}
    hashes = {}

    def capture(source, path):
        before = set(bpy.data.objects)
        call(bpy.ops.tussock.capture_blades, source=source, filepath=path, frames=4)
        new = [o for o in bpy.data.collections[coll_name].objects if o not in before]
        if not new:
            raise RuntimeError(f"the {source} capture made no blade")
        return new

    file_blades = capture("FILES", pattern)
    hashes["capture_files"], counts["blades_files"], counts["knots_files"], files_arr = \
        skeletons(file_blades)
    step("capture_files", f"captured {counts['blades_files']} blades "
         f"({counts['knots_files']} knots) from {pattern}")
    oni_blades = capture("ONI", oni)
    hashes["capture_oni"], counts["blades_oni"], counts["knots_oni"], oni_arr = \
        skeletons(oni_blades)
    # how far the recording's capture is from the images' (its intrinsics differ from the
    # images' in the last bits of fx: png_to_oni says by how much)
    same_shape = [len(a[1]) for a in files_arr] == [len(a[1]) for a in oni_arr]
    result["oni_vs_files"] = {
        "same_blade_and_knot_counts": same_shape,
        "identical": hashes["capture_oni"] == hashes["capture_files"],
        "max_knot_difference_m": float(max(np.abs(a[0] - b[0]).max() for a, b in
                                           zip(files_arr, oni_arr))) if same_shape else None,
        "max_width_difference_m": float(max(np.abs(a[1] - b[1]).max() for a, b in
                                            zip(files_arr, oni_arr))) if same_shape else None,
    }
    # the recording's blades are kept, in a collection of their own: the meadow grows
    # from the refined blades of the images alone
    kept = bpy.data.collections.new("ONI capture")
    scene.collection.children.link(kept)
    for o in oni_blades:  # one link per blade object
        kept.objects.link(o)
        bpy.data.collections[coll_name].objects.unlink(o)
        o.location.x -= 3.0  # aside, out of the meadow
        o.location.y += 0.6
    step("capture_oni", f"captured {counts['blades_oni']} blades ({counts['knots_oni']} "
         f"knots) from {oni}")

    # 2. refine the images' blades to 16 knots, their motion tracked through the sequence
    for o in scene.objects:
        o.select_set(o in file_blades)
    bpy.context.view_layer.objects.active = file_blades[0]
    call(bpy.ops.tussock.refine_blades, knots="16", movement="TRACKED", frames=FRAMES)
    hashes["refined"], counts["blades_refined"], counts["knots_refined"], _ = \
        skeletons(file_blades)
    for o in file_blades:  # the cluster stands aside, out of the meadow
        o.location.x -= 3.0
    step("refine", f"refined them to {counts['knots_refined']} knots in all")

    # 3. a meadow of them on a 4 m ground, a sphere rolling through it
    bpy.ops.mesh.primitive_plane_add(size=4.0)
    call(bpy.ops.tussock.add_meadow, tile_size=0.25, blades_per_tile=32, density="UNIFORM",
         seed=3, display=1.0)
    meadow = bpy.context.active_object
    counts["meadow_blades"] = int(meadow["tussock_blades"])
    counts["meadow_tiles"] = int(meadow["tussock_tiles"])
    radius = 0.25
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, location=(-1.5, -0.3, radius))
    ball = bpy.context.active_object
    ball.name = "Ball"
    bpy.ops.rigidbody.object_add(type="ACTIVE")
    ball.rigid_body.collision_shape = "SPHERE"
    ball.rigid_body.kinematic = True  # moved by its keyframes: no Bullet dynamics to differ
    ball.keyframe_insert("location", frame=1)
    ball.location = (0.5, 0.2, radius)
    ball.keyframe_insert("location", frame=FRAMES)
    colliders = bpy.data.collections.new("Colliders")
    scene.collection.children.link(colliders)
    colliders.objects.link(ball)
    meadow.tussock_meadow.colliders = colliders
    meadow.tussock_meadow.use_simulation = True
    step("meadow", f"meadow of {counts['meadow_blades']} blades in "
         f"{counts['meadow_tiles']} tiles, a sphere rolling through it")

    # 4. a tree beside it in a windy scene
    w = scene.tussock_wind
    w.base_speed, w.base_direction = 3.0, math.radians(20)
    wave = w.waves.add()
    wave.amplitude, wave.wavelength, wave.speed, wave.power = 4.0, 12.0, 5.0, 2.0
    w.gust_strength = 2.0
    scene.cursor.location = (3.5, 1.0, 0.0)
    call(bpy.ops.tussock.add_tree, preset=TREE_PRESET, seed=2)
    tree = bpy.context.active_object
    scene.cursor.location = (0.0, 0.0, 0.0)
    counts["tree_vertices"] = len(tree.data.vertices)
    counts["tree_branches"] = int(tree["tussock_branches"])
    step("tree", f"tree '{TREE_PRESET}': {counts['tree_branches']} branches, "
         f"{counts['tree_vertices']} vertices")

    # 5. the sample picture, its two layers (as tools/picture_sample_scene.py describes
    #    them), from copies beside the .blend
    for f in ("meadow.png", "grass_mask.png", "crown_mask.png"):
        shutil.copyfile(os.path.join(samples, "picture", f), os.path.join(work, f))
    s = scene.tussock_picture
    s.filepath = "//meadow.png"
    grass = s.layers.add()
    grass.name, grass.mask_path, grass.root = "Grass", "//grass_mask.png", "TOP"
    crown = s.layers.add()
    crown.name, crown.mask_path = "Crown", "//crown_mask.png"
    crown.lambda_x, crown.lambda_y = 48.0, 12.0
    call(bpy.ops.tussock.animate_picture)
    counts["picture_layers"] = len(s.layers)
    step("picture", "animated the sample picture (2 layers)")

    # 6. play the frames: the solver runs, the tree sways, the picture moves
    active = []
    for f in range(1, FRAMES + 1):  # one frame_set per frame
        scene.frame_set(f)
        if meadow.tussock_meadow.last_error:
            raise RuntimeError(f"frame {f}: meadow: {meadow.tussock_meadow.last_error}")
        if s.last_error:
            raise RuntimeError(f"frame {f}: picture: {s.last_error}")
        active.append(int(meadow.get("tussock_active_blades", 0)))
    pb = sub["meadow.playback"].playback_of(meadow)
    if pb is None:
        raise RuntimeError("the meadow has no live simulation")
    tiles, tile_blades = pb.runner.active()
    knots = pb.runner.knots()
    ribbons = sub["meadow.writer"].active_ribbons(meadow)
    counts["simulated_blades"] = int(meadow.get("tussock_active_blades", 0))
    counts["simulated_tiles"] = int(len(tiles))
    counts["simulated_blades_per_frame"] = active
    counts["solver_knots_per_blade"] = int(pb.runner.K)
    if counts["simulated_blades"] == 0 or len(knots) == 0:
        raise RuntimeError(f"no blade simulated at frame {FRAMES}: the sphere missed the "
                           f"meadow (simulated per frame: {active})")
    hashes["sim_tiles"] = sha(np.asarray(tiles, np.int32), np.asarray(tile_blades, np.int32))
    hashes["sim_knots"] = sha(np.asarray(knots, np.float32))
    hashes["sim_ribbons"] = sha(np.asarray(ribbons, np.float32))
    tree_live = evaluated_positions(tree)
    hashes["tree_mesh"] = sha(tree_live)
    counts["tree_evaluated_vertices"] = len(tree_live) // 3
    step("play", f"played frames 1-{FRAMES}: {counts['simulated_blades']} blades simulated in "
         f"{counts['simulated_tiles']} tiles at frame {FRAMES}")

    # 7. save and bake
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    call(bpy.ops.tussock.bake, save=True)
    caches = file_hashes(work, "tussock_cache")
    if not caches:
        raise RuntimeError("the bake wrote no cache file")
    counts["cache_files"] = len(caches)
    scene.frame_set(FRAMES)
    result["tree_baked_equals_live"] = bool(np.array_equal(evaluated_positions(tree), tree_live))
    step("bake", f"baked {len(caches)} cache files into {os.path.join(work, 'tussock_cache')}")

    # 8. render one small frame of the 3D scene (the picture's compositor tree, which has
    #    no Render Layers node, is turned off for it)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location = (1.2, -11.0, 3.0)  # the meadow, the sphere and the tree
    cam.rotation_euler = (math.radians(84), 0.0, math.radians(6))
    cam.data.lens = 22.0
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (math.radians(40), 0.0, math.radians(30))
    scene.collection.objects.link(sun)
    r = scene.render
    r.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 4
    scene.cycles.seed = 0
    scene.cycles.use_denoising = False
    r.resolution_x, r.resolution_y, r.resolution_percentage = 64, 48, 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.use_compositing = False
    scene.view_settings.view_transform = "Standard"
    r.image_settings.file_format = "PNG"
    for p in r.bl_rna.properties:  # no metadata that tells when or where it rendered
        if p.identifier.startswith("use_stamp") and not p.is_readonly:
            setattr(r, p.identifier, False)
    frame = os.path.join(work, "frame.png")
    r.filepath = frame
    r.use_file_extension = False
    scene.frame_set(FRAMES)
    bpy.ops.render.render(write_still=True)
    render = {"path": frame, "exists": os.path.isfile(frame),
              "size": os.path.getsize(frame) if os.path.isfile(frame) else 0}
    if render["exists"]:
        img = bpy.data.images.load(frame)
        px = np.empty(img.size[0] * img.size[1] * img.channels, np.float32)
        img.pixels.foreach_get(px)
        render["pixels_sha256"] = sha(px)
        render["width_height"] = list(img.size)
        bpy.data.images.remove(img)
    step("render", f"rendered {frame} ({render['size']} bytes)")

    # The EXR caches' pixels as Blender reads them (a writer of another OpenEXR version may
    # lay out the same pixels in other bytes): float32 RGBA, Non-Color, no conversion.
    images = {}
    for rel in caches:
        if rel.endswith(".exr"):
            img = bpy.data.images.load(os.path.join(work, rel))
            img.colorspace_settings.name = "Non-Color"
            px = np.empty(img.size[0] * img.size[1] * img.channels, np.float32)
            img.pixels.foreach_get(px)
            images[rel] = {"pixels_sha256": sha(px), "size": list(img.size)}
            if rel.endswith("_picture/background.exr"):
                # cv::inpaint fills it, and OpenCV versions fill differently: its pixels are
                # kept (float32 RGBA rows) for artist_compare.py to measure by how much
                name = rel.replace("/", "_") + ".f32"
                os.makedirs(os.path.dirname(out_json), exist_ok=True)
                px.tofile(os.path.join(os.path.dirname(out_json), name))
                images[rel]["pixels_file"] = name
            bpy.data.images.remove(img)

    if file_hashes(work, "tussock_cache") != caches:
        raise RuntimeError("the caches changed after the bake (while rendering)")
    # the shot as rendered (camera, light, small render settings), for a farm to bake and
    # render again (native/portable/artist_run.sh)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(work, "shot.blend"), copy=True)
    result.update(ok=True, counts=counts, hashes={k: hashes[k] for k in HASHES},
                  caches=caches, render=render, images=images,
                  hash_notes={
                      "skeletons": "blades sorted by object name; per blade float32 vertex "
                                   "co (x, y, z per knot) then float32 width per knot",
                      "sim": "frame %d: sim_tiles = int32 active tiles then int32 blades per "
                             "tile; sim_knots = float32 solver knots (runner order); "
                             "sim_ribbons = float32 ribbon vertices written to the meadow's "
                             "chunks" % FRAMES,
                      "tree_mesh": "float32 evaluated vertex co at frame %d, before the bake"
                                   % FRAMES,
                      "caches": "sha256 of the bytes of every file under tussock_cache; none "
                                "is special-cased",
                  })


def run():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 4:
        print("usage: blender -b --factory-startup --python-exit-code 1 --python "
              "tools/artist_check.py -- OUT_JSON WORKDIR SAMPLES_DIR ONI_FILE", file=sys.stderr)
        sys.exit(1)
    out_json, work, samples, oni = (os.path.abspath(a) for a in argv)
    start = time.time()
    code = 0
    try:
        main(out_json, work, samples, oni)
    except Exception:  # noqa: BLE001 - every failure is reported the same way
        result["error"] = traceback.format_exc()
        traceback.print_exc()
        code = 1
    result["seconds"]["total"] = round(time.time() - start, 1)
    os.makedirs(os.path.dirname(out_json), exist_ok=True)
    with open(out_json, "w") as f:
        json.dump(result, f, indent=1, sort_keys=True)
        f.write("\n")
    print(f"[artist_check] {'ok' if code == 0 else 'FAILED'}: {out_json} "
          f"({result['seconds']['total']} s)", flush=True)
    sys.stdout.flush()
    sys.stderr.flush()
    if code:
        sys.exit(code)


run()
