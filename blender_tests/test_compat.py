"""addon/compat.py against the Blender that runs it: each helper is checked by its effect
(what Blender evaluates, renders or writes), not by which branch it took, so that a branch
removed or wrong for this version (3.4, 4.3 or 5.x in the suite) fails here."""

import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

harness.enable_addon()
from tussock import compat, native  # noqa: E402


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()


def _offset_group():
    """A geometry-node group that moves every point by its float input "Lift" along z."""
    group = bpy.data.node_groups.new("tsk lift", "GeometryNodeTree")
    compat.node_group_add_socket(group, "INPUT", "NodeSocketGeometry", "Geometry")
    compat.node_group_add_socket(group, "INPUT", "NodeSocketFloat", "Lift")
    compat.node_group_add_socket(group, "OUTPUT", "NodeSocketGeometry", "Geometry")
    gin = group.nodes.new("NodeGroupInput")
    gout = group.nodes.new("NodeGroupOutput")
    combine = group.nodes.new("ShaderNodeCombineXYZ")
    setpos = group.nodes.new("GeometryNodeSetPosition")
    group.links.new(gin.outputs["Geometry"], setpos.inputs["Geometry"])
    group.links.new(gin.outputs["Lift"], combine.inputs["Z"])
    group.links.new(combine.outputs["Vector"], setpos.inputs["Offset"])
    group.links.new(setpos.outputs["Geometry"], gout.inputs["Geometry"])
    return group


@test
def test_modifier_input_reaches_the_evaluated_mesh():
    fresh()
    mesh = bpy.data.meshes.new("m")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    obj = bpy.data.objects.new("o", mesh)
    bpy.context.scene.collection.objects.link(obj)
    mod = obj.modifiers.new("lift", "NODES")
    mod.node_group = _offset_group()
    assert compat.node_group_socket_names(mod.node_group, "INPUT") == ["Geometry", "Lift"]
    for lift in (0.75, -2.5):
        compat.set_modifier_input(mod, "Lift", lift)
        assert abs(compat.get_modifier_input(mod, "Lift") - lift) < 1e-7
        depsgraph = bpy.context.evaluated_depsgraph_get()  # evaluates what was tagged
        ev = obj.evaluated_get(depsgraph).to_mesh()
        z = np.empty(len(ev.vertices) * 3, np.float32)
        ev.vertices.foreach_get("co", z)
        obj.evaluated_get(depsgraph).to_mesh_clear()
        assert np.allclose(z[2::3], lift), (lift, z[2::3])


@test
def test_settings_of_sees_set_groups_and_creates_none():
    fresh()
    a = bpy.data.objects.new("a", None)
    b = bpy.data.objects.new("b", None)
    assert compat.settings_of(a, "tussock_tree") is None
    assert not a.is_property_set("tussock_tree"), "looking created the group"
    b.tussock_tree.is_tree = True
    s = compat.settings_of(b, "tussock_tree")
    assert s is not None and s.is_tree
    assert compat.settings_of(None, "tussock_tree") is None


@test
def test_fcurve_reads_the_keyed_values():
    fresh()
    obj = bpy.data.objects.new("keyed", None)
    bpy.context.scene.collection.objects.link(obj)
    for frame, x in ((1, 0.0), (11, 5.0)):
        obj.location.x = x
        obj.keyframe_insert("location", index=0, frame=frame)
    assert compat.fcurve(obj.animation_data, "location", 1) is None  # y is not keyed
    fc = compat.fcurve(obj.animation_data, "location", 0)
    assert fc is not None and abs(fc.evaluate(11) - 5.0) < 1e-6 and abs(fc.evaluate(1)) < 1e-6
    assert [c.data_path for c in compat.fcurves(obj.animation_data)] == ["location"]
    assert len(compat.fcurves(bpy.data.objects.new("still", None).animation_data)) == 0


@test
def test_compositor_math_and_file_output_write_the_value():
    """A compositor tree with no Render Layers: an image through a Math node to a File
    Output node, rendered; the written EXR holds the computed value."""
    fresh()
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 8, 4
    scene.render.resolution_percentage = 100
    scene.render.use_compositing = True
    tree = compat.compositor_tree(scene)
    assert compat.compositor_tree(scene, create=False) == tree
    tree.nodes.clear()
    image = bpy.data.images.new("grey", 8, 4, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    image.pixels.foreach_set(np.full(8 * 4 * 4, 0.25, np.float32))
    value = tree.nodes.new("CompositorNodeImage")
    value.image = image
    times = compat.compositor_math(tree, "MULTIPLY")
    times.inputs[1].default_value = 3.0
    tree.links.new(value.outputs[0], times.inputs[0])
    with tempfile.TemporaryDirectory() as tmp:
        node, socket = compat.file_output(tree, tmp, "val_", "OPEN_EXR")
        node.format.color_depth = "32"
        tree.links.new(times.outputs[0], socket)
        out = compat.compositor_output(tree)
        tree.links.new(value.outputs[0], out.inputs["Image"])
        scene.frame_set(3)
        bpy.ops.render.render(write_still=False)
        path = os.path.join(tmp, "val_0003.exr")
        assert os.path.isfile(path), os.listdir(tmp)
        lib = native.require()
        pic = lib.picture_load(path)
        px = np.empty((4, 8, 4), np.float32)
        lib.picture_read_rgba(pic, px)
    assert np.allclose(px[..., 0], 0.75, atol=1e-6), px[..., 0]


@test
def test_map_uv_filter_is_anisotropic():
    fresh()
    tree = compat.compositor_tree(bpy.context.scene)
    node = tree.nodes.new("CompositorNodeMapUV")
    compat.map_uv_like_ewa(node)
    if hasattr(node, "filter_type"):
        assert node.filter_type == "ANISOTROPIC"
    elif "Interpolation" in node.inputs:
        assert node.inputs["Interpolation"].default_value == "Anisotropic"
    else:
        assert bpy.app.version < (4, 0, 0), "a Map UV node with no filter setting"
    assert compat.map_uv_sampling() == ("map_uv_5" if bpy.app.version >= (5, 0, 0) else "map_uv")


@test
def test_video_format_and_sequencer_strips():
    fresh()
    scene = bpy.context.scene
    compat.set_file_format(scene.render.image_settings, "FFMPEG")
    assert scene.render.image_settings.file_format == "FFMPEG"
    compat.set_file_format(scene.render.image_settings, "PNG")
    assert scene.render.image_settings.file_format == "PNG"
    editor = scene.sequence_editor_create()
    png = os.path.join(harness.REPO, "samples", "picture", "meadow.png")
    strip = compat.sequencer_strips(editor).new_image("s", png, 1, 1)
    assert len(compat.sequencer_strips(editor)) == 1 and strip.frame_final_duration == 1


@test
def test_file_paths_keep_blend_relative_paths():
    fresh()
    s = bpy.context.scene.tussock_picture
    s.filepath = "//pictures/meadow.png"
    assert s.filepath == "//pictures/meadow.png"
    prop = type(s).bl_rna.properties["filepath"]
    if hasattr(prop, "is_path_supports_blend_relative"):  # 4.5+
        assert prop.is_path_supports_blend_relative


@test
def test_user_data_dir_of_a_legacy_addon_is_in_the_user_scripts():
    assert compat.ADDON_PACKAGE == "tussock"  # the suite links the add-on as a legacy one
    d = compat.user_data_dir("tussock_trees")
    assert os.path.realpath(d).startswith(os.path.realpath(bpy.utils.script_path_user())), d


harness.main()
