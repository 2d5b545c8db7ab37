"""What artists do to a scene (issue 32): operator arguments out of the stored settings'
limits are refused, never built with one value and stored with another; Tussock objects in
Edit Mode and pictures whose file went missing give a message, not a traceback or black
frames; property update callbacks report any exception."""

import os
import shutil
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import expect_cancel, test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

harness.enable_addon()
from tussock import native  # noqa: E402
from tussock.meadow import build as meadow_build  # noqa: E402
from tussock.meadow.operators import SETTINGS as MEADOW_SETTINGS  # noqa: E402
from tussock.meadow.props import TussockMeadowSettings  # noqa: E402
from tussock.trees.props import TussockTreeSettings  # noqa: E402
from tussock.wind.props import TussockWindSource  # noqa: E402

from tussock import meshes  # noqa: E402
from tussock.picture import frames as picture_frames  # noqa: E402
from tussock.trees import build as tree_build  # noqa: E402

lib = native.require()
ops = bpy.ops.tussock
TMP = tempfile.mkdtemp(prefix="tsk_artist_", dir=os.environ.get("TSK_TEST_TMP"))
DEPTH = os.path.join(harness.REPO, "samples", "blades", "depth_0001.png")
PICTURES = os.path.join(harness.REPO, "samples", "picture")
SMALL_MEADOW = dict(size=(2.0, 2.0), patch_blades=256, chunk_blades=16)


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    lib.set_memory_budget(0)


def outside(group_cls, name):
    """Values just outside the stored property's hard limits (those that are not the type's
    own), each with which limit it breaks."""
    p = group_cls.bl_rna.properties[name]
    out = []
    if p.type == "INT":
        if p.hard_min > -2 ** 31:
            out.append(p.hard_min - 1)
        if p.hard_max < 2 ** 31 - 1:
            out.append(p.hard_max + 1)
    else:
        if p.hard_min > -3e38:
            out.append(p.hard_min - max(abs(p.hard_min) * 0.5, 1e-3))
        if p.hard_max < 3e38:
            out.append(p.hard_max + max(abs(p.hard_max) * 0.5, 1e-3))
    return out


def bounded(group_cls, names):
    return [n for n in names if group_cls.bl_rna.properties[n].type in ("INT", "FLOAT")
            and outside(group_cls, n)]


# ---- 1. operator arguments are the stored settings, or refused -----------------------------

@test
def test_meadow_arguments_out_of_the_stored_range_are_refused():
    fresh()
    names = bounded(TussockMeadowSettings, MEADOW_SETTINGS)
    # every bounded meadow setting is tried (the three among them)
    assert {"tile_size", "scale_max", "noise_threshold", "patch_blades"} <= set(names), names
    tried = 0
    for name in names:
        for v in outside(TussockMeadowSettings, name):
            kw = dict(SMALL_MEADOW)
            kw[name] = v
            expect_cancel(ops.add_meadow, name, **kw)
            tried += 1
    assert tried >= 15, tried
    # the example, with the range in the message
    try:
        ops.add_meadow(tile_size=0.005, **SMALL_MEADOW)
    except RuntimeError as exc:
        assert "Tile size (tile_size) must be from 0.01 to 100, got 0.005" in str(exc), exc
    assert not any(o.get("tussock_meadow_object") for o in bpy.data.objects)


@test
def test_meadow_in_range_arguments_are_stored_as_built():
    fresh()
    values = dict(tile_size=0.37, blades_per_tile=48, patch_blades=512, chunk_blades=16,
                  scale_min=0.6, scale_max=1.7, noise_scale=3.5, noise_octaves=4,
                  noise_threshold=0.45, seed=7, display=0.5)
    assert ops.add_meadow(size=(4.0, 3.0), **values) == {"FINISHED"}
    obj = bpy.context.active_object
    s = obj.tussock_meadow
    for name, v in values.items():
        stored = getattr(s, name)
        assert stored == np.float32(v) if isinstance(v, float) else stored == v, \
            (name, stored, v)
    # what the operator built is what the stored settings build
    built = (obj["tussock_blades"], obj["tussock_tiles"], obj["tussock_instances"])
    co = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co)
    assert built[0] > 1000, built
    meadow_build.rebuild(obj)
    again = (obj["tussock_blades"], obj["tussock_tiles"], obj["tussock_instances"])
    co2 = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co2)
    assert built == again, (built, again)
    assert np.array_equal(co, co2)


@test
def test_tree_arguments_out_of_the_stored_range_are_refused():
    fresh()
    preset = lib.tree_presets()[0]
    names = bounded(TussockTreeSettings, ("seed", "smooth_levels"))
    assert names == ["seed", "smooth_levels"], names
    for name in names:
        for v in outside(TussockTreeSettings, name):
            expect_cancel(ops.add_tree, name, preset=preset, **{name: v})
    try:
        ops.add_tree(preset=preset, smooth_levels=4)
    except RuntimeError as exc:
        assert "Smooth (smooth_levels) must be from 0 to 3, got 4" in str(exc), exc
    assert ops.add_tree(preset=preset, seed=11, smooth_levels=1, leaves=False) == {"FINISHED"}
    s = bpy.context.active_object.tussock_tree
    assert (s.seed, s.smooth_levels, s.leaves) == (11, 1, False)


@test
def test_wind_source_arguments_out_of_the_stored_range_are_refused():
    fresh()
    names = bounded(TussockWindSource, ("strength", "radius", "interval"))
    assert names == ["strength", "radius", "interval"], names
    for name in names:
        for v in outside(TussockWindSource, name):
            expect_cancel(ops.add_wind_source, name, **{name: v})
    # 0.0005 was clamped to 0.001 before; now the operator says why
    expect_cancel(ops.add_wind_source, "Radius (radius) must be from 0.001 to 1e+06",
                  radius=0.0005)
    assert ops.add_wind_source(strength=0.3, radius=0.25, interval=2.0) == {"FINISHED"}
    s = bpy.context.active_object.tussock_wind_source
    assert (s.strength, s.radius, s.interval) == (np.float32(0.3), np.float32(0.25), 2.0)


# ---- 2. errors where the artist sees them -----------------------------------------------------

def enter_edit_mode(obj):
    harness.select_objects([obj])
    bpy.ops.object.mode_set(mode="EDIT")
    assert obj.data.is_editmode


def leave_edit_mode():
    bpy.ops.object.mode_set(mode="OBJECT")
    meshes._poll_edit_mode()  # the timer's work (timers do not run in a background script)


def vertex_digest(obj):
    co = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co)
    return len(co) // 3, float(np.abs(co).sum())


def edit_mode_scene():
    """Captured blades, a tree and a meadow of them, as an artist has them."""
    fresh()
    assert ops.capture_blades(source="FILES", filepath=DEPTH) == {"FINISHED"}
    blades = list(bpy.context.selected_objects)
    assert len(blades) >= 3, blades
    assert ops.add_tree(preset=lib.tree_presets()[0]) == {"FINISHED"}
    tree = bpy.context.active_object
    assert ops.add_meadow(**SMALL_MEADOW) == {"FINISHED"}
    meadow = bpy.context.active_object
    return blades, tree, meadow


@test
def test_a_tree_in_edit_mode_keeps_its_mesh_and_says_why_until_it_leaves():
    blades, tree, meadow = edit_mode_scene()
    s = tree.tussock_tree
    rest = vertex_digest(tree)
    branches = tree["tussock_branches"]
    assert rest[0] > 10000, rest
    enter_edit_mode(tree)
    s.seed = 5                                    # the panel's rebuild
    assert "Edit Mode" in s.last_error and "Tab" in s.last_error, s.last_error
    bpy.context.scene.frame_set(4)                # the frame handler
    assert "Edit Mode" in s.last_error, s.last_error
    expect_cancel(ops.tree_apply_preset, "Edit Mode", preset=lib.tree_presets()[1])
    # adding objects works meanwhile, and leaves the tree's mesh alone
    for op, kw in ((ops.add_tree, dict(preset=lib.tree_presets()[0])),
                   (ops.add_meadow, SMALL_MEADOW), (ops.add_wind_source, {}),
                   (ops.capture_blades, dict(source="FILES", filepath=DEPTH))):
        assert op(**kw) == {"FINISHED"}, op
    harness.select_objects([tree])
    bpy.ops.object.mode_set(mode="OBJECT")
    assert vertex_digest(tree)[0] == rest[0], (vertex_digest(tree), rest)  # never emptied
    meshes._poll_edit_mode()
    # out of Edit Mode, the seed set meanwhile takes effect and the message goes
    assert s.last_error == "", s.last_error
    assert tree["tussock_branches"] != branches or vertex_digest(tree) != rest
    again = vertex_digest(tree)
    tree_build.forget(tree.name)
    bpy.context.scene.frame_set(4)
    assert vertex_digest(tree)[0] == again[0] and s.last_error == ""


@test
def test_a_meadow_and_blades_in_edit_mode_refuse_and_keep_their_mesh():
    blades, tree, meadow = edit_mode_scene()
    s = meadow.tussock_meadow
    tiles, points = meadow["tussock_tiles"], vertex_digest(meadow)
    enter_edit_mode(meadow)
    s.tile_size = 0.5
    assert "Edit Mode" in s.last_error, s.last_error
    s.use_simulation = True
    bpy.context.scene.frame_set(3)
    bpy.ops.object.mode_set(mode="OBJECT")
    assert vertex_digest(meadow) == points and meadow["tussock_tiles"] == tiles
    meshes._poll_edit_mode()
    assert s.last_error == "", s.last_error      # rebuilt with the new tile size
    assert meadow["tussock_tiles"] < tiles, (meadow["tussock_tiles"], tiles)
    # blades: refine refuses a blade in Edit Mode (it read an empty attribute before)
    counts = [len(b.data.vertices) for b in blades]
    enter_edit_mode(blades[0])
    for b in blades:
        b.select_set(True)
    expect_cancel(ops.refine_blades, "Edit Mode", knots="8")
    bpy.ops.object.mode_set(mode="OBJECT")
    assert [len(b.data.vertices) for b in blades] == counts
    assert ops.refine_blades(knots="8") == {"FINISHED"}


def animated_picture(folder):
    """A saved .blend animating the sample meadow picture (grass layer), files beside it."""
    fresh()
    os.makedirs(folder, exist_ok=True)
    for name in ("meadow.png", "grass_mask.png"):
        shutil.copy(os.path.join(PICTURES, name), folder)
    blend = os.path.join(folder, "scene.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 3
    s = scene.tussock_picture
    s.filepath = "//meadow.png"
    s.layers.add().mask_path = "//grass_mask.png"
    assert ops.animate_picture() == {"FINISHED"}
    bpy.ops.wm.save_mainfile()
    return blend


def rendered_mean(scene, name):
    scene.render.filepath = os.path.join(TMP, name)
    scene.render.image_settings.file_format = "PNG"
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(scene.render.filepath)
    px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(-1, 4).mean(axis=0)


@test
def test_an_animated_picture_whose_file_went_missing_says_so_and_renders_magenta():
    folder = os.path.join(TMP, "missing")
    blend = animated_picture(folder)
    good = rendered_mean(bpy.context.scene, "good.png")
    assert good[1] > 0.2, good                   # a green meadow
    os.rename(os.path.join(folder, "meadow.png"), os.path.join(folder, "moved.png"))
    bpy.ops.wm.open_mainfile(filepath=blend)
    scene = bpy.context.scene
    s = scene.tussock_picture
    assert "not found" in s.last_error and "meadow.png" in s.last_error, s.last_error
    scene.frame_set(2)
    assert "not found" in s.last_error, s.last_error
    # a render shows Blender's missing-image magenta, not black
    mean = rendered_mean(scene, "missing.png")
    assert mean[0] > 0.9 and mean[1] < 0.1 and mean[2] > 0.9, mean
    # the bake refuses with the message (the farm bakes before it renders)
    expect_cancel(ops.bake, "not found")
    # and a farm worker's render of the frame fails, naming why, and writes nothing
    code, out, written = render_on_command_line(blend, 2)
    assert code == 1 and "frame 2 of scene 'Scene' is not rendered" in out \
        and "meadow.png" in out and not written, (code, out[-2000:], written)
    # the file back: the next frame shows the picture again and the message goes
    os.rename(os.path.join(folder, "moved.png"), os.path.join(folder, "meadow.png"))
    scene.frame_set(3)
    assert s.last_error == "", s.last_error
    back = rendered_mean(scene, "back.png")
    assert abs(back[1] - good[1]) < 0.05 and back[0] < 0.9, (back, good)
    code, out, written = render_on_command_line(blend, 2)
    assert code == 0 and written == ["f_0002.png"], (code, out[-2000:], written)


def render_on_command_line(blend, frame):
    """`blender -b scene.blend -o … -f N` with Tussock enabled, as a farm worker renders:
    (exit status, output, files written)."""
    import subprocess
    sys.path.insert(0, os.path.join(harness.REPO, "tools"))
    import blender_env
    out_dir = tempfile.mkdtemp(prefix="cli_render_", dir=TMP)
    with blender_env.BlenderUser() as user:
        script = os.path.join(user.tmp, "enable.py")
        with open(script, "w") as f:
            f.write("import addon_utils\naddon_utils.enable('tussock', default_set=True)\n")
        cmd = [os.environ.get("BLENDER", "blender"), "-b", blend, "--factory-startup",
               "-noaudio", "--python", script, "-o", os.path.join(out_dir, "f_####"),
               "-F", "PNG", "-f", str(frame)]
        proc = subprocess.run(cmd, env=user.env, text=True, errors="replace",
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=300)
    return proc.returncode, proc.stdout, sorted(os.listdir(out_dir))


class _Raising:
    """Replaces module.name by a function raising `exc` for a block."""
    def __init__(self, module, name, exc):
        self.module, self.name, self.exc = module, name, exc

    def __enter__(self):
        self.saved = getattr(self.module, self.name)

        def failing(*_args, **_kwargs):
            raise self.exc
        setattr(self.module, self.name, failing)

    def __exit__(self, *_exc):
        setattr(self.module, self.name, self.saved)


@test
def test_update_callbacks_report_any_exception_in_the_panel():
    from tussock.meadow import blade_objects
    blades, tree, meadow = edit_mode_scene()
    s = meadow.tussock_meadow
    points = vertex_digest(meadow)
    # a ValueError (density from an image, none given) was a console traceback before
    s.density = "IMAGE"
    assert "density image" in s.last_error, s.last_error
    assert vertex_digest(meadow) == points        # the last good meadow stays
    s.density = "NOISE"
    assert s.last_error == "" and vertex_digest(meadow) == points
    # any exception, in every update callback, reaches the panel
    with _Raising(meadow_build, "rebuild", KeyError("boom")):
        s.seed = 3
    assert "KeyError" in s.last_error and "unexpectedly" in s.last_error, s.last_error
    with _Raising(blade_objects, "ensure_chunks", RuntimeError("no chunks")):
        s.use_simulation = True
    assert "no chunks" in s.last_error, s.last_error
    t = tree.tussock_tree
    with _Raising(tree_build, "rebuild", TypeError("bad type")):
        t.leaves = False
    assert "TypeError" in t.last_error, t.last_error
    t.leaves = True
    assert t.last_error == ""
    with _Raising(tree_build, "pose", ZeroDivisionError("frame")):
        bpy.context.scene.frame_set(9)
    assert "ZeroDivisionError" in t.last_error, t.last_error
    blend = animated_picture(os.path.join(TMP, "callbacks"))
    assert blend
    p = bpy.context.scene.tussock_picture
    with _Raising(picture_frames, "update", IndexError("no layer")):
        p.layers[0].lambda_x = 30.0
    assert "IndexError" in p.last_error, p.last_error
    p.layers[0].lambda_x = 31.0
    assert p.last_error == "", p.last_error


if __name__ == "__main__":
    harness.main()
