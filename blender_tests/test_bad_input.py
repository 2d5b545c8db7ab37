"""Every operator x every class of bad input that applies to it (issue 11): missing file,
corrupt file, wrong format, extreme size, NaN / negative / huge parameters, empty or wrong
selection, missing device, read-only output, and work over the memory budget. Each must
report an error, return CANCELLED and leave the scene as it was (harness.expect_cancel
compares harness.scene_fingerprint before and after).

Blender clamps operator properties to their min/max (NaN passes through a FloatProperty's
clamp unchanged), so NaN is tried wherever a FloatProperty takes it and out-of-range values
are tried at the limits Blender lets through.

Not covered yet (the operators do not exist): simulation, bake caches, picture operators.
Add their rows here when they land."""

import json
import os
import struct
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


def select_only(objs):
    for o in bpy.context.scene.objects:
        o.select_set(False)
    for o in objs:
        o.select_set(True)
    if objs:
        bpy.context.view_layer.objects.active = objs[0]


@test
def test_refine_bad_selection_and_parameters_cancel():
    blades = captured_blades()
    assert blades, "the sample capture gave no blades"
    op = ops.refine_blades
    select_only([])                                            # empty selection
    expect_cancel(op, "select one or more Tussock blades")
    cube = bpy.data.objects.new("Not a blade", bpy.data.meshes.new("Not a blade"))
    bpy.context.scene.collection.objects.link(cube)
    select_only([cube])                                        # wrong selection
    expect_cancel(op, "select one or more Tussock blades")
    select_only(blades[:1])
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
        select_only([obj])
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
        ("blade_count", dict(patch_blades=2 ** 31 - 1)),
        ("blade_count", dict(patch_blades=0)),
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
    select_only([ground])
    expect_cancel(op, "", patch_blades=256)
    select_only([])
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


harness.main()
