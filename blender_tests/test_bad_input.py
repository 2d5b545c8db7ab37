"""Every operator x every class of bad input that applies to it (issue 11): missing file,
corrupt file, wrong format, extreme size, NaN / negative / huge parameters, empty or wrong
selection, missing device, read-only output, and work over the memory budget. Each must
report an error, return CANCELLED and leave the scene as it was (harness.expect_cancel
compares harness.scene_fingerprint before and after).

Blender clamps operator properties to their min/max (NaN passes through a FloatProperty's
clamp unchanged), so NaN is tried wherever a FloatProperty takes it and out-of-range values
are tried at the limits Blender lets through.

The blade simulation is not an operator: it runs on every frame change for meadows with
"Simulate touched blades" on. Its rows check the same promise in that setting: the error is
shown in the meadow's panel (`last_error`), nothing is created or moved, and the next frame
with good settings works again."""

import json
import os
import struct
import subprocess
import sys
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import expect_cancel, test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

TMP = os.path.join(os.environ.get("TSK_TEST_TMP", "/tmp"), f"tsk_bad_input_{os.getpid()}")
os.makedirs(TMP, exist_ok=True)
NAN = float("nan")
INF = float("inf")
PNG = os.path.join(harness.REPO, "samples", "blades", "depth_0001.png")
EXR = os.path.join(harness.REPO, "samples", "blades", "cluster.exr")
# an OpenEXR header whose first dataWindow says 272 bytes (reliability.md, finding 16)
BAD_EXR = os.path.join(harness.REPO, "native", "fuzz", "corpus", "depth_files",
                       "regression-exr-datawindow-of-272-bytes")

harness.enable_addon()
from tussock import native  # noqa: E402

lib = native.require()
ops = bpy.ops.tussock


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    lib.set_memory_budget(0)


def tmp(name, data=None):
    path = os.path.join(TMP, name)
    if data is not None:
        with open(path, "wb") as f:
            f.write(data)
    return path


def png_bytes(width, height, bit_depth=16, colour=0, rows=None):
    """A PNG; rows None = zero pixels. Written by hand so the header can lie."""
    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xffffffff))
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, colour, 0, 0, 0)
    if rows is None:
        bpp = max(1, bit_depth // 8) * {0: 1, 2: 3, 4: 2, 6: 4}[colour]
        rows = b"".join(b"\0" + bytes(width * bpp) for _ in range(min(height, 4096)))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows))
            + chunk(b"IEND", b""))


class budget:
    """Lowers the native memory budget for a block (the library refuses larger requests)."""
    def __init__(self, nbytes):
        self.nbytes = nbytes

    def __enter__(self):
        lib.set_memory_budget(self.nbytes)

    def __exit__(self, *exc):
        lib.set_memory_budget(0)


# ---- capture ---------------------------------------------------------------------------------

@test
def test_capture_bad_files_cancel():
    fresh()
    op = ops.capture_blades
    good = open(PNG, "rb").read()
    cases = [
        ("filepath", dict(filepath="")),                                         # no file
        ("missing.png", dict(filepath=tmp("missing.png"))),                      # missing
        ("missing.exr", dict(filepath=tmp("missing.exr"))),
        ("truncated", dict(filepath=tmp("truncated.png", good[:200]))),          # corrupt
        ("", dict(filepath=tmp("garbage.png", b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 8))),
        ("", dict(filepath=tmp("garbage.exr", b"v/1\x01" + bytes(4000)))),
        ("", dict(filepath=tmp("empty.png", b""))),                              # empty file
        ("16-bit", dict(filepath=tmp("eight.png", png_bytes(64, 48, 8)))),      # wrong format
        ("colour PNG", dict(filepath=tmp("rgb.png", png_bytes(64, 48, 16, 2)))),
        ("", dict(filepath=tmp("text.exr", b"not an image at all\n" * 50))),
        ("malformed OpenEXR", dict(filepath=tmp("finding16.exr", open(BAD_EXR, "rb").read()))),
        ("8192", dict(filepath=tmp("huge.png", png_bytes(100000, 100000)))),    # extreme size
        ("", dict(filepath=tmp("zero.png", png_bytes(0, 0)))),
        ("all-zero", dict(filepath=tmp("zeros.png", png_bytes(64, 48)))),        # no data
        ("", dict(filepath=TMP)),                                                # a folder
    ]
    for needle, kw in cases:
        expect_cancel(op, needle, source="FILES", **kw)
    # ONI recordings: missing, corrupt, another format under the .oni name
    expect_cancel(op, "", source="ONI", filepath=tmp("missing.oni"))
    expect_cancel(op, "", source="ONI", filepath=tmp("garbage.oni", bytes(range(256)) * 16))
    expect_cancel(op, "", source="ONI", filepath=tmp("png.oni", good))
    # a recording that crashes OpenNI2's own player: its reader process crashes, not Blender
    crash = os.path.join(harness.REPO, "native", "fuzz", "crashes", "oni-segv-libOniFile.oni")
    expect_cancel(op, "recording reader crashed", source="ONI", filepath=crash)
    expect_cancel(op, "", source="ONI", filepath="")


@test
def test_capture_bad_parameters_cancel():
    fresh()
    op = ops.capture_blades
    for needle, kw in [
        ("near_m", dict(near=NAN, far=1.0)),
        ("near_m", dict(near=0.5, far=NAN)),
        ("_m", dict(near=INF, far=INF)),                     # Blender makes inf FLT_MAX
        ("far_m", dict(near=0.5, far=0.4)),                   # far before near
        ("far_m", dict(near=0.1, far=3e38)),                  # huge
        ("band", dict(near=30.0, far=40.0)),                  # selects nothing
        ("", dict(fx=NAN, fy=NAN, cx=320.0, cy=240.0)),
        ("", dict(fx=1e-30, fy=1e-30, cx=320.0, cy=240.0)),   # tiny focal length
        ("", dict(fx=500.0, fy=500.0, cx=3e38, cy=240.0)),    # huge principal point
        ("", dict(fx=500.0)),                                 # incomplete intrinsics
        ("min_area", dict(min_area=2 ** 31 - 1)),             # huge
        ("frame", dict(frame=2 ** 31 - 1)),                   # past the end
    ]:
        expect_cancel(op, needle, source="FILES", filepath=PNG, **kw)


@test
def test_capture_missing_device_cancels():
    fresh()
    expect_cancel(ops.capture_blades, "uri", source="DEVICE", device_uri="no-such-device://0")
    expect_cancel(ops.capture_blades, "", source="DEVICE", device_uri="\x7f" * 300)


@test
def test_capture_preview_bad_source_fails_before_starting():
    """The live preview's invoke needs a window: in background Blender does not run it
    (PASS_THROUGH, nothing changes). Its only failure point before the modal loop is
    pipeline.open_source, the same call capture_blades makes: each bad source raises there."""
    fresh()
    from tussock.capture import pipeline
    before = harness.scene_fingerprint()
    assert ops.capture_preview("INVOKE_DEFAULT") in ({"PASS_THROUGH"}, {"CANCELLED"})
    for source, path, uri in (("FILES", tmp("missing.png"), ""),
                              ("FILES", tmp("truncated.png"), ""),
                              ("FILES", tmp("huge.png"), ""),
                              ("ONI", tmp("garbage.oni"), ""),
                              ("DEVICE", "", "no-such-device://0")):
        try:
            src = pipeline.open_source(source, path, uri)
        except (native.Error, ValueError, OSError):
            continue
        lib.depth_close(src)
        raise AssertionError(f"{source} {path or uri} opened")
    assert harness.scene_fingerprint() == before


@test
def test_capture_over_memory_budget_cancels():
    fresh()
    with budget(1 << 20):  # a 640x480 frame needs ~17 MiB
        expect_cancel(ops.capture_blades, "memory budget", source="FILES", filepath=PNG)
        expect_cancel(ops.capture_blades, "memory budget", source="FILES", filepath=EXR)


# ---- refine ----------------------------------------------------------------------------------

def captured_blades():
    fresh()
    bpy.ops.tussock.capture_blades(source="FILES", filepath=PNG)
    return [o for o in bpy.context.selected_objects]


def blade_object(name, co, widths):
    """A mesh that looks like a Tussock blade (a 'width' point attribute) with given knots."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(c) for c in co], [(i, i + 1) for i in range(len(co) - 1)], [])
    attr = mesh.attributes.new("width", "FLOAT", "POINT")
    attr.data.foreach_set("value", np.asarray(widths, np.float32))
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


@test
def test_refine_bad_selection_and_parameters_cancel():
    blades = captured_blades()
    assert blades, "the sample capture gave no blades"
    op = ops.refine_blades
    harness.select_objects([])                                            # empty selection
    expect_cancel(op, "select one or more Tussock blades")
    cube = bpy.data.objects.new("Not a blade", bpy.data.meshes.new("Not a blade"))
    bpy.context.scene.collection.objects.link(cube)
    harness.select_objects([cube])                                        # wrong selection
    expect_cancel(op, "select one or more Tussock blades")
    harness.select_objects(blades[:1])
    expect_cancel(op, "mu", mu=NAN)                            # NaN parameter
    expect_cancel(op, "target_knots", custom_knots=1)          # below the minimum
    n = len(blades[0].data.vertices)
    if n < 64:                                                 # more knots than the blade has
        expect_cancel(op, "target_knots", custom_knots=64)
    expect_cancel(op, "frames", movement="TRACKED", frames=10000)  # huge: no such sequence


@test
def test_refine_corrupt_blades_cancel():
    fresh()
    op = ops.refine_blades
    k = np.zeros((8, 3), np.float32)
    k[:, 2] = np.linspace(0, 0.2, 8)
    for name, co, w in [
        ("nan knot", np.where(np.arange(24).reshape(8, 3) == 13, np.nan, k), [0.01] * 8),
        ("inf knot", np.where(np.arange(24).reshape(8, 3) == 5, np.inf, k), [0.01] * 8),
        ("negative width", k, [0.01] * 7 + [-1.0]),
        ("nan width", k, [np.nan] * 8),
        ("one knot", k[:1], [0.01]),
        ("zero length", np.zeros((8, 3)), [0.01] * 8),
    ]:
        obj = blade_object(name, co, w)
        harness.select_objects([obj])
        for method in ("SIMILARITY", "UNIFORM"):
            expect_cancel(op, "", method=method, custom_knots=4)


# ---- meadow ----------------------------------------------------------------------------------

@test
def test_meadow_bad_parameters_cancel():
    fresh()
    op = ops.add_meadow
    small = dict(size=(2.0, 2.0), patch_blades=256, chunk_blades=16)
    for needle, kw in [
        ("tile_size", dict(tile_size=NAN)),
        ("tile_size", dict(tile_size=INF)),
        ("tile_size", dict(tile_size=0.0)),                     # at Blender's min
        ("size", dict(size=(NAN, 2.0))),
        ("size", dict(size=(0.0, 2.0))),
        ("", dict(size=(3e38, 3e38))),                          # huge area
        ("blades_per_tile", dict(blades_per_tile=0)),
        ("blades_per_tile", dict(blades_per_tile=2 ** 31 - 1)),
        ("patch_blades", dict(patch_blades=2 ** 31 - 1)),
        ("patch_blades", dict(patch_blades=0)),
        ("chunk", dict(chunk_blades=0)),
        ("chunk", dict(chunk_blades=100)),                      # does not divide the patch
        ("scale_min", dict(scale_min=NAN)),
        ("scale_min", dict(scale_min=-1.0)),
        ("scale_max", dict(scale_max=0.5)),                     # below scale_min
        ("scale_max", dict(scale_max=INF)),
        ("noise_scale", dict(noise_scale=NAN)),
        ("noise_scale", dict(noise_scale=-8.0)),
        ("noise_octaves", dict(noise_octaves=-3)),
        ("noise_octaves", dict(noise_octaves=2 ** 31 - 1)),
        ("noise_threshold", dict(noise_threshold=NAN)),
        ("noise_threshold", dict(noise_threshold=1.0)),
    ]:
        args = dict(small)
        args.update(kw)
        expect_cancel(op, needle, **args)


@test
def test_meadow_bad_ground_and_density_cancel():
    fresh()
    op = ops.add_meadow
    # a selected ground that is a mesh without area: a single vertex
    mesh = bpy.data.meshes.new("Point")
    mesh.from_pydata([(0, 0, 0)], [], [])
    ground = bpy.data.objects.new("Point", mesh)
    bpy.context.scene.collection.objects.link(ground)
    harness.select_objects([ground])
    expect_cancel(op, "", patch_blades=256)
    harness.select_objects([])
    # painted density without an image
    expect_cancel(op, "density image", size=(2.0, 2.0), density="IMAGE", patch_blades=256)


@test
def test_meadow_over_memory_budget_cancels():
    fresh()
    with budget(1 << 20):
        expect_cancel(ops.add_meadow, "memory budget", size=(2.0, 2.0))


# ---- trees -----------------------------------------------------------------------------------

def user_preset(name, content):
    from tussock.trees import presets
    d = presets.user_dir(create=True)
    path = os.path.join(d, name + ".json")
    with open(path, "w") as f:
        f.write(content if isinstance(content, str) else json.dumps(content))
    return "user:" + name


@test
def test_tree_bad_presets_cancel():
    fresh()
    op = ops.add_tree
    good = lib.tree_default_def()
    nan_def = json.loads(json.dumps(good))
    nan_def["scale"] = NAN                                       # json writes NaN
    huge = json.loads(json.dumps(good))
    huge["levels"] = 4
    for lv in huge["level"]:
        lv["branches"] = 10000
    cases = [
        ("cannot read", user_preset("corrupt", "{ not json")),            # corrupt
        ("does not hold", user_preset("list", "[1, 2, 3]")),              # wrong format
        ("scale", user_preset("nan", json.dumps(nan_def))),               # NaN
        ("scale", user_preset("string", {"scale": "big"})),               # wrong type
        ("levels", user_preset("float_int", {"levels": 2.5})),
        ("levels", user_preset("overflow", {"levels": 10 ** 20})),
        ("level", user_preset("five_levels", {"level": [{}] * 5})),
        ("level[0]", user_preset("level_not_dict", {"level": [3]})),
        ("not a tree parameter", user_preset("unknown", {"colour": 1.0})),
        ("max_branches", user_preset("huge", huge)),                      # extreme size
        ("", user_preset("negative", dict(good, scale=-10.0, ratio=-1.0))),
    ]
    for needle, preset in cases:
        expect_cancel(op, needle, preset=preset)
    # a preset that cannot be read (a folder named like one: root reads every file)
    from tussock.trees import presets
    os.makedirs(os.path.join(presets.user_dir(), "unreadable.json"), exist_ok=True)
    expect_cancel(op, "cannot read", preset="user:unreadable")


@test
def test_tree_apply_and_remove_presets_cancel():
    fresh()
    bpy.ops.tussock.add_tree(preset=lib.tree_presets()[0])
    tree = bpy.context.active_object
    assert tree.tussock_tree.is_tree
    for preset in ("user:corrupt", "user:nan", "user:string", "user:huge", "user:unknown"):
        expect_cancel(ops.tree_apply_preset, "", preset=preset)
    expect_cancel(ops.tree_preset_remove, "", preset="user:unreadable")  # not a file
    expect_cancel(ops.tree_preset_remove, "built-in", preset=lib.tree_presets()[0])


@test
def test_tree_preset_save_to_unwritable_place_cancels():
    fresh()
    bpy.ops.tussock.add_tree(preset=lib.tree_presets()[0])
    from tussock.trees import presets
    d = presets.user_dir(create=True)
    # read-only output: the file to write is in the way as a folder (works as root too)
    os.makedirs(os.path.join(d, "Blocked.json.tmp"), exist_ok=True)
    expect_cancel(ops.tree_preset_add, "", name="Blocked")
    expect_cancel(ops.tree_preset_add, "name", name="///")            # no usable name
    expect_cancel(ops.tree_preset_add, "name", name="")
    if os.getuid() != 0:  # permissions do not stop root
        os.chmod(d, 0o500)
        try:
            expect_cancel(ops.tree_preset_add, "", name="Readonly")
        finally:
            os.chmod(d, 0o700)


@test
def test_tree_over_memory_budget_cancels():
    fresh()
    with budget(4096):
        expect_cancel(ops.add_tree, "memory budget", preset=lib.tree_presets()[0])


# ---- wind ------------------------------------------------------------------------------------

@test
def test_wind_source_bad_parameters_cancel():
    fresh()
    op = ops.add_wind_source
    for needle, kw in [("strength", dict(strength=NAN)), ("radius", dict(radius=NAN)),
                       ("radius", dict(radius=INF)), ("radius", dict(radius=3e38)),
                       ("interval", dict(interval=NAN)), ("interval", dict(interval=INF))]:
        expect_cancel(op, needle, **kw)


@test
def test_wind_waves_and_debug_image_bad_input_cancel():
    fresh()
    w = bpy.context.scene.tussock_wind
    expect_cancel(ops.wind_wave_remove, "no wave", index=0)                # nothing to remove
    expect_cancel(ops.wind_wave_remove, "no wave", index=2 ** 31 - 1)
    while len(w.waves) < 8:
        bpy.ops.tussock.wind_wave_add()
    expect_cancel(ops.wind_wave_add, "at most 8")                          # extreme count
    # a NaN wave and a NaN breeze in the scene's settings: the debug image refuses them
    for setting in ("wavelength", "amplitude", "speed", "phase", "power"):
        old = getattr(w.waves[0], setting)
        setattr(w.waves[0], setting, NAN)
        if getattr(w.waves[0], setting) == getattr(w.waves[0], setting):
            setattr(w.waves[0], setting, old)   # Blender refused NaN itself: nothing to test
            continue
        expect_cancel(ops.wind_debug_image, "", size=8)
        setattr(w.waves[0], setting, old)
    w.fluid_center = (NAN, 0.0)
    if w.fluid_center[0] != w.fluid_center[0]:
        w.use_fluid = True
        expect_cancel(ops.wind_debug_image, "", size=8)
    w.fluid_center = (0.0, 0.0)


@test
def test_wind_over_memory_budget_cancels():
    fresh()
    w = bpy.context.scene.tussock_wind
    w.use_fluid = True
    with budget(64 << 10):  # the fluid grid needs more
        expect_cancel(ops.wind_debug_image, "memory budget", size=8)


# ---- blade simulation (meadow settings, run by the frame-change handler) ---------------------

def sim_scene():
    """A small simulated meadow with a ball resting in it (a collider touching tiles)."""
    fresh()
    from tussock.meadow import simulate
    simulate.forget()
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    assert ops.add_meadow(tile_size=0.25, blades_per_tile=16, density="UNIFORM",
                          patch_blades=256, chunk_blades=16) == {"FINISHED"}
    meadow = bpy.context.active_object
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.2, location=(0.0, 0.0, 0.2))
    ball = bpy.context.active_object
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(ball)
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    return scene, meadow, ball, coll


def expect_sim_error(scene, meadow, needle):
    """Plays the next frame: the meadow reports an error containing `needle` and nothing
    else changes (no blades object, nothing hidden, no datablock or setting touched but
    the error text and the frame)."""
    s = meadow.tussock_meadow
    frame, error = scene.frame_current, s.last_error
    bpy.context.view_layer.update()  # transforms the test just set, evaluated
    before = harness.scene_description()
    scene.frame_set(frame + 1)
    got = s.last_error
    s.last_error = error        # the two things the frame may change, put back without
    scene.frame_current = frame  # running the handlers again
    after = harness.scene_description()
    assert got and needle in got, f"error {got!r} lacks {needle!r}"
    if before != after:
        gone = [x[:300] for x in before if x not in after][:3]
        new = [x[:300] for x in after if x not in before][:3]
        raise AssertionError(f"a frame with a bad simulation setting ({needle}) changed the "
                             f"scene: before {gone}, after {new}")


@test
def test_simulation_bad_settings_are_reported_and_change_nothing():
    scene, meadow, ball, coll = sim_scene()
    s = meadow.tussock_meadow
    # NaN passes a FloatProperty's clamp; ID properties (scripts, old files, overrides)
    # bypass min/max entirely
    for prop, value, needle in [
        ("sim_damping", NAN, "damping"),
        ("sim_stiffness", NAN, "global_stiffness_root"),
        ("sim_local_stiffness", NAN, "local_stiffness"),
        ("sim_damping", -5.0, "damping"),
        ("sim_stiffness", -1.0, "global_stiffness_root"),
        ("sim_local_stiffness", -1e30, "local_stiffness"),
        ("sim_iterations", 0, "iterations"),
        ("sim_iterations", -7, "iterations"),
        ("sim_iterations", 1000, "iterations"),
        ("sim_iterations", 2 ** 31 - 1, "iterations"),
        ("sim_settle_time", NAN, "Settle after"),
        ("sim_settle_time", -1.0, "Settle after"),
    ]:
        old = getattr(s, prop)
        if value != value:
            setattr(s, prop, value)
        else:
            s[prop] = value
        assert value != value or np.float32(getattr(s, prop)) == np.float32(value), \
            (prop, getattr(s, prop))
        expect_sim_error(scene, meadow, needle)
        setattr(s, prop, old)
    # the time step: at least two steps per frame, none longer than 1/20 s; below 1/12 fps
    # a frame would take more than 240 steps, refused with the lowest usable rate
    scene.render.fps, scene.render.fps_base = 1, 20.0
    expect_sim_error(scene, meadow, "use at least 0.0833 fps")
    scene.render.fps, scene.render.fps_base = 24, 1.0
    # colliders: huge (beyond 1000 km) or NaN-sized objects
    ball.scale = (1e30, 1e30, 1e30)
    expect_sim_error(scene, meadow, "within 1e+06 m")
    ball.scale = (NAN, NAN, NAN)
    expect_sim_error(scene, meadow, "radius")
    ball.scale = (1.0, 1.0, 1.0)
    ball.location = (3e38, 0.0, 0.2)
    expect_sim_error(scene, meadow, "colliders")
    ball.location = (0.0, 0.0, 0.2)
    # good settings again: the next frame simulates, without an error
    scene.frame_set(scene.frame_current + 1)
    assert s.last_error == "", s.last_error
    assert meadow["tussock_active_blades"] > 0


@test
def test_simulation_colliders_empty_or_without_geometry_simulate_nothing():
    """An empty collection and objects without extent (an empty, a camera, a light) touch
    no blade: no error, no simulated blade; a mesh collider beside them still works."""
    scene, meadow, ball, coll = sim_scene()
    s = meadow.tussock_meadow
    s.colliders = bpy.data.collections.new("Nothing")
    scene.frame_set(2)
    assert s.last_error == "" and meadow["tussock_active_blades"] == 0
    s.colliders = coll
    empty = bpy.data.objects.new("Empty", None)
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    light = bpy.data.objects.new("Light", bpy.data.lights.new("Light", "POINT"))
    for obj in (empty, cam, light):
        coll.objects.link(obj)
    coll.objects.unlink(ball)
    scene.frame_set(3)
    assert s.last_error == "", s.last_error
    assert meadow["tussock_active_blades"] == 0
    coll.objects.link(ball)
    scene.frame_set(4)
    assert s.last_error == "", s.last_error
    assert meadow["tussock_active_blades"] > 0


# ---- bake caches ------------------------------------------------------------------------------

def bake_scene(folder, tree=True, frames=3):
    fresh()
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, frames
    if tree:
        assert ops.add_tree(preset=lib.tree_presets()[0], leaves=False) == {"FINISHED"}
    os.makedirs(folder, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(folder, "scene.blend"))
    return scene


def mount_tmpfs(where, options):
    os.makedirs(where, exist_ok=True)
    return subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", where],
                          stderr=subprocess.DEVNULL).returncode == 0


@test
def test_bake_bad_input_cancels():
    from tussock import cache
    fresh()
    assert ops.add_tree(preset=lib.tree_presets()[0], leaves=False) == {"FINISHED"}
    expect_cancel(ops.bake, "save the .blend first")              # unsaved .blend
    expect_cancel(ops.free_bake, "save the .blend first")
    bake_scene(tmp("bake_nothing"), tree=False)
    expect_cancel(ops.bake, "nothing to bake")                    # nothing to bake
    bake_scene(tmp("bake_bad"))
    expect_cancel(ops.bake, "after frame_end", frame_start=3, frame_end=2)  # end < start
    expect_cancel(ops.bake, "after frame_end", frame_start=-1, frame_end=-5)
    expect_cancel(ops.bake, "after frame_end", frame_start=2 ** 31 - 1, frame_end=-2 ** 31)
    expect_cancel(ops.bake, "no frame of the scene", frame_start=1000, frame_end=2000)
    expect_cancel(ops.bake, "no frame of the scene", frame_start=-20, frame_end=-10)
    # read-only output: sysfs refuses new folders even to root; a file in the folder's way
    for where, needle in (("/sys/tussock_cache", ""), ("/proc/tussock_cache", ""),
                          (tmp("in_the_way", b"a file, not a folder"), "")):
        cache.CACHE_DIR_OVERRIDE = where
        try:
            expect_cancel(ops.bake, needle)
        finally:
            cache.CACHE_DIR_OVERRIDE = None
    # a cache of another format version is refused, not used
    assert ops.bake() == {"FINISHED"}
    tree = next(o for o in bpy.context.scene.objects if o.modifiers.get(cache.MODIFIER))
    frame = cache.frame_path(os.path.join(cache.cache_root(), cache.safe_name(tree.name)), 2)
    with open(frame, "r+b") as f:
        f.seek(8)
        f.write(struct.pack("<I", 99))
    expect_cancel(ops.bake, "another Tussock")


@test
def test_bake_cache_read_only_or_forged_is_refused():
    """free_bake on a cache it cannot delete: CANCELLED, every modifier kept. A .pc2 whose
    header is forged (NaN start frame) is not used: the live tree shows, no traceback."""
    from tussock import bake, cache
    scene = bake_scene(tmp("bake_forged"))
    assert ops.add_tree(preset=lib.tree_presets()[0], leaves=False) == {"FINISHED"}
    bpy.ops.wm.save_mainfile()
    assert ops.bake() == {"FINISHED"}
    trees = [o for o in scene.objects if o.modifiers.get(cache.MODIFIER)]
    assert len(trees) == 2
    root = cache.cache_root()
    # the second tree's folder becomes read-only (root: a read-only tmpfs over it holding
    # the same files; otherwise: no write permission), so the first could be freed alone
    second = os.path.join(root, cache.safe_name(trees[1].name))
    saved = {n: open(os.path.join(second, n), "rb").read() for n in os.listdir(second)}
    mounted = False
    if os.geteuid() == 0 and mount_tmpfs(second, "size=4m"):
        mounted = True
        for n, data in saved.items():
            with open(os.path.join(second, n), "wb") as f:
                f.write(data)
        subprocess.run(["mount", "-o", "remount,ro", second], check=True)
    elif os.geteuid() != 0:
        os.chmod(second, 0o555)
    try:
        if mounted or os.geteuid() != 0:
            expect_cancel(ops.free_bake, "")
            assert all(o.modifiers.get(cache.MODIFIER) for o in trees)
    finally:
        if mounted:
            subprocess.run(["umount", second])
        else:
            os.chmod(second, 0o755)
    # a forged .pc2: NaN start frame
    first = trees[0]
    pc2 = bpy.path.abspath(first.modifiers[cache.MODIFIER].filepath)
    with open(pc2, "r+b") as f:
        f.seek(20)
        f.write(struct.pack("<f", NAN))
    assert bake.cached_range(first, scene) is None
    assert cache.baked_frame(first, scene, 2, bake.cache_key) is False
    assert ops.free_bake() == {"FINISHED"}
    assert not any(o.modifiers.get(cache.MODIFIER) for o in scene.objects)


# ---- pictures ---------------------------------------------------------------------------------

def picture_png(name, width=64, height=48, bit_depth=8, colour=2, value=None):
    """A valid PNG: RGB (colour 2) or grey (0), 8 or 16 bits; `value(x, y)` in 0..1 per
    pixel (default a gradient), the same in every channel."""
    ch = {0: 1, 2: 3}[colour]
    nbytes = bit_depth // 8
    y, x = np.mgrid[0:height, 0:width]
    v = (x / max(1, width - 1) * 0.6 + y / max(1, height - 1) * 0.3) if value is None \
        else value(x, y)
    top = (1 << bit_depth) - 1
    q = np.repeat((np.clip(v, 0, 1) * top + 0.5).astype(">u2" if nbytes == 2 else "u1")[..., None],
                  ch, axis=2)
    rows = b"".join(b"\0" + q[r].tobytes() for r in range(height))
    return tmp(name, png_bytes(width, height, bit_depth, colour, rows))


@test
def test_picture_bad_input_cancels():
    fresh()
    op = ops.animate_picture
    s = bpy.context.scene.tussock_picture
    pic8 = picture_png("pic8.png")
    half = picture_png("mask_half.png", value=lambda x, y: (y > 30).astype(float))
    expect_cancel(op, "layer", filepath=pic8)                            # no layer yet
    expect_cancel(ops.picture_layer_remove, "poll")                      # nothing to remove
    layer = s.layers.add()
    layer.mask_path = half
    good = open(pic8, "rb").read()
    for needle, path in [
        ("no file given", ""),                                           # no file
        ("not found", tmp("missing_picture.png")),                       # missing
        ("not found", TMP),                                              # a folder
        ("picture", tmp("pic_truncated.png", good[:60])),                # corrupt
        ("picture", tmp("pic_garbage.png", b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 4)),
        ("picture", tmp("pic_text.exr", b"not an image\n" * 40)),        # wrong format
        ("malformed OpenEXR", tmp("pic_finding16.exr", open(BAD_EXR, "rb").read())),
        ("picture", tmp("pic_empty.png", b"")),
        ("", tmp("pic_huge.png", png_bytes(100000, 100000, 8, 2))),     # extreme size
        ("", tmp("pic_zero.png", png_bytes(0, 0, 8, 2))),
    ]:
        expect_cancel(op, needle, filepath=path)
    with budget(64 << 10):                                               # over the budget
        expect_cancel(op, "memory budget", filepath=pic8)
    # masks: missing, corrupt, empty (no vegetation), another size (8- and 16-bit)
    for needle, mask in [
        ("not found", tmp("missing_mask.png")),
        ("mask", tmp("mask_truncated.png", open(half, "rb").read()[:70])),
        ("mask", picture_png("mask_empty.png", value=lambda x, y: 0.0 * x)),
        ("32x24", picture_png("mask_small.png", 32, 24)),
        ("32x24", picture_png("mask_small16.png", 32, 24, 16, 0)),
    ]:
        layer.mask_path = mask
        expect_cancel(op, needle, filepath=pic8)
    layer.mask_path = half
    layer.mask_mode = "IMAGE"
    layer.mask_image = "no such image"
    expect_cancel(op, "no image named", filepath=pic8)
    layer.mask_mode = "GRABCUT"
    layer.rect = (0, 0, 0, 0)                                            # empty rectangle
    expect_cancel(op, "rect", filepath=pic8)
    layer.rect = (4, 4, 40, 30)
    layer.grabcut_max_side = -1                                          # clamped, as C's range
    assert layer.grabcut_max_side == 0
    layer.strokes_path = picture_png("strokes_small.png", 10, 10)
    expect_cancel(op, "10x10", filepath=pic8)
    layer.strokes_path = ""
    layer.mask_mode = "FILE"
    layer.scale_map_path = tmp("missing_scale.png")
    expect_cancel(op, "scale map", filepath=pic8)
    layer.scale_map_path = ""
    # NaN / negative / huge parameters of the layer and of the picture
    # out of range: clamped by the properties' hard limits, which are C's ranges
    for obj, prop, value, clamped in [
        (layer, "lambda_x", INF, 1e6), (layer, "rigidity", -1.0, 0.0), (layer, "cell_x", 0, 1),
        (layer, "cell_y", -4, 1), (layer, "cell_x", 2 ** 31 - 1, 4096),
        (s, "inpaint_radius", -1.0, 1.0), (s, "feather", INF, 256.0),
    ]:
        old = getattr(obj, prop)
        setattr(obj, prop, value)
        assert getattr(obj, prop) == clamped, (prop, value, getattr(obj, prop))
        setattr(obj, prop, old)
    # NaN gets past Blender's clamping: C refuses it
    for obj, prop, value, needle in [
        (layer, "lambda_x", NAN, "lambda"), (layer, "lambda_y", NAN, "lambda"),
        (layer, "rigidity", NAN, "rigidity"), (s, "inpaint_radius", NAN, "radius"),
        (s, "grow", NAN, "grow"), (s, "feather", NAN, "feather"),
        (s, "loop_frames", -3, "loop"),
    ]:
        old = getattr(obj, prop)
        setattr(obj, prop, value)
        try:
            expect_cancel(op, needle, filepath=pic8)
        except AssertionError as exc:
            raise AssertionError(f"{prop} = {value}: {exc}") from None
        setattr(obj, prop, old)
    layer.root_auto = False
    for prop, value in (("root_line", NAN), ("root_height", NAN)):
        old = getattr(layer, prop)
        setattr(layer, prop, value)
        expect_cancel(op, "", filepath=pic8)
        setattr(layer, prop, old)
    layer.root_height, layer.root_line = 0.0, 3e38  # clamped to what the warp takes
    assert layer.root_height == np.float32(0.01) and layer.root_line < 1e7, (
        layer.root_height, layer.root_line)
    layer.root_height, layer.root_line = 100.0, 0.0
    layer.root_auto = True


@test
def test_picture_8_and_16_bit_files_are_both_read():
    """Not bad input: an 8-bit and a 16-bit picture, masks of either depth, all animate
    (the cancel rows above would be meaningless if a depth were refused)."""
    for pic_depth, mask_depth in ((8, 16), (16, 8)):
        fresh()
        s = bpy.context.scene.tussock_picture
        layer = s.layers.add()
        layer.mask_path = picture_png(f"mask_{mask_depth}.png", bit_depth=mask_depth, colour=0,
                                      value=lambda x, y: (y > 30).astype(float))
        pic = picture_png(f"pic_{pic_depth}.png", bit_depth=pic_depth)
        assert ops.animate_picture(filepath=pic) == {"FINISHED"}
        img = bpy.data.images["Tussock Layer 1"]
        assert tuple(img.size) == (64, 48)
        assert s.last_error == ""


class _FailOnCall:
    """Replaces module.name for the duration of a `with`: its `nth` call raises `exc`
    (after the earlier calls went through), as a Blender API that behaves otherwise in a
    new version, or a bug, raises in the middle of an operator's work."""

    def __init__(self, module, name, exc, nth=1):
        self.module, self.name, self.exc, self.nth = module, name, exc, nth

    def __enter__(self):
        self.original = getattr(self.module, self.name)
        calls = [0]

        def failing(*args, **kwargs):
            calls[0] += 1
            if calls[0] >= self.nth:
                raise self.exc
            return self.original(*args, **kwargs)
        setattr(self.module, self.name, failing)
        return self

    def __exit__(self, *exc):
        setattr(self.module, self.name, self.original)


@test
def test_any_exception_mid_operator_cancels_with_the_scene_unchanged():
    """Not only tussock.Error: a TypeError, KeyError or AttributeError raised half-way
    through an operator's work (after it created and linked objects) is reported, and what
    the work created is removed (errors.run)."""
    from tussock.capture import blades
    from tussock.meadow import build as meadow_build
    from tussock.trees import build as tree_build
    fresh()
    # capture: the second blade fails after the first one joined the scene
    with _FailOnCall(blades, "blade_mesh", TypeError("bpy_struct[key] = val: no"), nth=2):
        expect_cancel(ops.capture_blades, "TypeError", source="FILES", filepath=PNG)
    assert "Tussock Blades" not in bpy.data.collections
    assert ops.capture_blades(source="FILES", filepath=PNG) == {"FINISHED"}
    fresh()  # the meadow and the tree in a scene of their own
    n = len(bpy.data.objects)
    with _FailOnCall(meadow_build, "write_steps", KeyError("Socket_3")):
        expect_cancel(ops.add_meadow, "KeyError", size=(2.0, 2.0))
    with _FailOnCall(tree_build, "write_posed", AttributeError("no fcurves")):
        expect_cancel(ops.add_tree, "AttributeError", preset="black_tupelo")
    assert len(bpy.data.objects) == n
    assert ops.add_tree(preset="black_tupelo") == {"FINISHED"}


@test
def test_capture_refuses_fifo_socket_and_device_within_a_second():
    """A FIFO with no writer, a socket and a character device given as depth input (a file,
    a numbered sequence, a recording): each is refused with a message within a second,
    where reading it would wait for ever or never end (issue 32)."""
    import signal
    import socket
    import time
    fresh()
    fifo = tmp("pipe_0001.png")
    if not os.path.exists(fifo):
        os.mkfifo(fifo)
    sock_path = tmp("sock.oni")
    if os.path.exists(sock_path):
        os.unlink(sock_path)
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.bind(sock_path)
    sock.listen(1)
    # a hang is the failure this test looks for: end the process rather than the suite
    signal.alarm(60)
    try:
        for source, path, needle in (("FILES", fifo, "a pipe (FIFO)"),
                                     ("FILES", tmp("pipe_####.png"), "a pipe (FIFO)"),
                                     ("ONI", fifo, "a pipe (FIFO)"),
                                     ("ONI", sock_path, "a socket"),
                                     ("FILES", "/dev/zero", "a character device"),
                                     ("ONI", "/dev/urandom", "a character device")):
            t0 = time.monotonic()
            expect_cancel(ops.capture_blades, needle, source=source, filepath=path)
            took = time.monotonic() - t0
            assert took < 1.0, (source, path, took)
    finally:
        signal.alarm(0)
        sock.close()


harness.main()
