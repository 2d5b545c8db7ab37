"""The few Blender API differences between 3.4, 4.x and 5.x live here and nowhere else."""

import os

import bpy
import numpy as np

VERSION = bpy.app.version


# Options of a file path property: from 4.5 (5.2 measured) a path that may start with "//"
# (relative to the .blend, as farms need) must say so, or Blender warns and takes it as is.
# Earlier versions do not know the option and refuse to register a property that names it.
PATH_OPTIONS = {"ANIMATABLE", "PATH_SUPPORTS_BLEND_RELATIVE"} \
    if "is_path_supports_blend_relative" in bpy.types.Property.bl_rna.properties \
    else {"ANIMATABLE"}


def mesh_indices(values):
    """Vertex and loop indices (loops' vertex_index, polygons' loop_start and loop_total,
    edges' vertices) as the array foreach_set copies in one go. These RNA properties are
    unsigned: a uint32 buffer matches them and takes the raw-array path, while an int32
    one is converted item by item (Blender 3.4: 1.4 ms against 159 ms for 400,000 corners).
    Where a version stores them otherwise, the values are the same and only speed differs.
    Indices are never negative, so a contiguous int32 array is the same bytes read as
    uint32: it is reinterpreted in place rather than copied (a 99,000-quad tree has 1.2 M
    such indices)."""
    a = np.asarray(values)
    if a.dtype == np.int32 and a.flags.c_contiguous:
        return a.reshape(-1).view(np.uint32)
    return np.ascontiguousarray(a, np.uint32).ravel()


def _position_data(mesh):
    """The collection whose foreach_set/foreach_get copy a mesh's vertex positions in one
    go, with the name of their float3 property. Blender 3.4 keeps positions in MeshVertex
    structs, whose `co` is copied as one raw array. From 3.5 positions are the generic
    point attribute "position", and MeshVertex.co reads and writes it through functions,
    one vertex at a time: in Blender 5.2.2, vertices.foreach_set("co") of a 323,256-vertex
    tree takes 51 ms (0.7 ms in 3.4) against 0.15 ms through the attribute."""
    attr = mesh.attributes.get("position") if VERSION >= (3, 5, 0) else None
    if attr is not None and attr.data_type == "FLOAT_VECTOR" and attr.domain == "POINT":
        return attr.data, "vector"
    return mesh.vertices, "co"


def set_positions(mesh, flat):
    """Writes every vertex position of `mesh` from a flat float32 array (3 per vertex).
    Call mesh.update() afterwards (it tags the positions changed: normals and bounds are
    recomputed from them)."""
    data, name = _position_data(mesh)
    data.foreach_set(name, flat)


def get_positions(mesh, out):
    """Reads every vertex position of `mesh` into `out`, a flat float32 array."""
    data, name = _position_data(mesh)
    data.foreach_get(name, out)


def set_face_corners(polygons, corners_per_face):
    """Each face's first corner (loop_start) for faces of `corners_per_face` corners each,
    after polygons.add(). Blender 3.4/3.5 also store each face's corner count (loop_total)
    and need it set; 3.6+ derives it from the starts and made it read-only."""
    nf, k = len(polygons), int(corners_per_face)
    polygons.foreach_set("loop_start", np.arange(0, nf * k, k, dtype=np.uint32))
    if not bpy.types.MeshPolygon.bl_rna.properties["loop_total"].is_readonly:
        polygons.foreach_set("loop_total", np.full(nf, k, np.uint32))


def shade_smooth(obj, by_operator=False):
    """Marks every face of `obj`'s mesh smooth.

    Blender 4.1+: Mesh.shade_smooth(), which drops the sharp_face attribute. Before that,
    MeshPolygon.use_smooth is a bit of each face's flags, which foreach_set writes face by
    face (Blender 3.4: 2.8 ms for 99,000 faces). The Shade Smooth operator sets them in one
    loop (0.2 ms); it is used when `by_operator` (the caller runs in an operator or a
    property update, never in a frame handler) and no render is running. It is called on
    this object alone and directly: bpy.ops would update the view layer before and after,
    which evaluates the mesh being written. Anything unexpected falls back to foreach_set."""
    mesh = obj.data
    if hasattr(mesh, "shade_smooth"):
        try:
            mesh.shade_smooth()
            return
        except (TypeError, RuntimeError):
            pass
    if by_operator and not bpy.app.is_job_running("RENDER"):
        try:
            from _bpy import ops as _ops
            with bpy.context.temp_override(selected_editable_objects=[obj]):
                done = _ops.call("object.shade_smooth", None, {})
        except (ImportError, AttributeError, RuntimeError, TypeError):
            done = ()
        if "FINISHED" in done:
            return
    mesh.polygons.foreach_set("use_smooth", np.ones(len(mesh.polygons), bool))


def node_group_add_socket(group, in_out, socket_type, name):
    """Adds an input ('INPUT') or output ('OUTPUT') socket to a node group's interface.

    Blender 3.x: group.inputs/outputs.new; 4.0+: group.interface.new_socket."""
    if hasattr(group, "interface"):
        return group.interface.new_socket(name=name, in_out=in_out, socket_type=socket_type)
    sockets = group.inputs if in_out == "INPUT" else group.outputs
    return sockets.new(socket_type, name)


def node_group_clear(group):
    """Removes every node and interface socket of a node group (for a rebuild in place, so
    that modifiers using the group keep it)."""
    for node in list(group.nodes):
        group.nodes.remove(node)
    if hasattr(group, "interface"):
        group.interface.clear()
    else:
        group.inputs.clear()
        group.outputs.clear()


def node_group_socket_names(group, in_out):
    """Names of a node group's input or output sockets, in order."""
    if hasattr(group, "interface"):
        return [item.name for item in group.interface.items_tree
                if getattr(item, "item_type", "SOCKET") == "SOCKET" and item.in_out == in_out]
    sockets = group.inputs if in_out == "INPUT" else group.outputs
    return [s.name for s in sockets]


def compositor_tree(scene, create=True):
    """The scene's compositor node tree: scene.node_tree before 5.0,
    scene.compositing_node_group from 5.0 on (created and assigned when missing)."""
    if hasattr(scene, "compositing_node_group"):
        tree = scene.compositing_node_group
        if tree is None and create:
            tree = bpy.data.node_groups.new("Tussock Compositor", "CompositorNodeTree")
            scene.compositing_node_group = tree
        return tree
    if create and scene.node_tree is None:
        scene.use_nodes = True
    return scene.node_tree


def preferences_id(package):
    """bl_idname for AddonPreferences: the add-on's package, which is 'tussock' for a
    legacy add-on and 'bl_ext.<repo>.tussock' for a 4.2+ extension."""
    return package


# "tussock" for a legacy add-on; "bl_ext.<repository>.tussock" when installed as a 4.2+
# extension (this module sits at the add-on's top level).
ADDON_PACKAGE = __package__


def user_data_dir(name, create=False):
    """A folder for the artist's own files of kind `name` (e.g. tree presets). An extension
    (4.2+) writes only below bpy.utils.extension_path_user, which survives updates of the
    extension; a legacy add-on uses presets/<name> in Blender's user scripts folder."""
    if ADDON_PACKAGE.startswith("bl_ext.") and hasattr(bpy.utils, "extension_path_user"):
        return bpy.utils.extension_path_user(ADDON_PACKAGE, path=name, create=create)
    return bpy.utils.user_resource("SCRIPTS", path=os.path.join("presets", name), create=create)


def enabled_output(node, name=None):
    """The output socket that is in use. Nodes such as Named Attribute and Random Value
    have one output per data type in 3.x (same name, only one enabled) and a single
    output in 4.x; this picks the right one in both."""
    for socket in node.outputs:
        if socket.enabled and (name is None or socket.name == name):
            return socket
    raise KeyError(f"{node.bl_idname} has no enabled output {name!r}")


def node_group_socket_identifier(group, in_out, name):
    """Identifier of a node group's socket (the key of a Geometry Nodes modifier input)."""
    if hasattr(group, "interface"):
        for item in group.interface.items_tree:
            if getattr(item, "item_type", "SOCKET") == "SOCKET" and item.in_out == in_out \
                    and item.name == name:
                return item.identifier
    else:
        sockets = group.inputs if in_out == "INPUT" else group.outputs
        for socket in sockets:
            if socket.name == name:
                return socket.identifier
    raise KeyError(f"node group {group.name} has no {in_out.lower()} {name!r}")


def _modifier_input(modifier, name):
    """(container, key) of a Geometry Nodes modifier input. Blender 3.4-5.1: the modifier
    is an ID-property container keyed by the socket's identifier. Blender 5.2+: inputs are
    RNA structs, modifier.properties.inputs.<identifier>, each holding its `value`."""
    ident = node_group_socket_identifier(modifier.node_group, "INPUT", name)
    props = getattr(modifier, "properties", None)
    if props is not None and hasattr(props, "inputs"):  # 5.2+
        return getattr(props.inputs, ident), "value"
    return modifier, ident


def set_modifier_input(modifier, name, value):
    """Sets the value of a Geometry Nodes modifier's input by the socket's name, and tags
    the object for re-evaluation: neither the ID property of 3.4-5.1 nor the input property
    of 5.2 tags it when written (test_compat checks the evaluated mesh)."""
    container, key = _modifier_input(modifier, name)
    if container is modifier:
        modifier[key] = value
    else:
        setattr(container, key, value)
    modifier.id_data.update_tag()


def get_modifier_input(modifier, name):
    container, key = _modifier_input(modifier, name)
    return modifier[key] if container is modifier else getattr(container, key)


# Blender cuts a longer data-block name to this many bytes (MAX_ID_NAME - 2: 63 until 4.5,
# 255 since 5.0), at a character boundary.
ID_NAME_BYTES = 255 if VERSION >= (5, 0, 0) else 63


def id_name(base, suffix=""):
    """`base` + `suffix` as Blender stores it: `base` cut so that the whole fits a data-block
    name. A name made of a long object name and a suffix would otherwise lose its suffix
    when Blender cuts it, and never be found again by the name it was made with."""
    room = max(0, ID_NAME_BYTES - len(suffix.encode()))
    raw = base.encode()
    if len(raw) > room:
        base = raw[:room].decode("utf-8", "ignore")
    return base + suffix


def settings_of(idblock, name):
    """The Tussock property group `name` of a datablock if it was ever set, else None.
    Reading `obj.<group>` would create an empty group on every object looked at (and so
    change the file); this looks without touching. is_property_set answers that in every
    version; `name in idblock.keys()` did too until 5.0, which took the storage of
    registered properties out of keys()."""
    if idblock is None or not idblock.is_property_set(name):
        return None
    return getattr(idblock, name, None)


def fcurves(anim_data):
    """The F-curves that animate a datablock through `anim_data` (its AnimData, or None):
    the action's own list up to 4.x; from 5.0 (slotted actions) the channel bag of the
    action's layer for the slot assigned to this datablock. Empty when nothing is keyed."""
    action = anim_data.action if anim_data is not None else None
    if action is None:
        return ()
    if hasattr(action, "fcurves"):  # 3.4-4.5 (4.4+: the first slot's, as before)
        return action.fcurves
    from bpy_extras import anim_utils  # 5.0+
    bag = anim_utils.action_get_channelbag_for_slot(action, anim_data.action_slot)
    return bag.fcurves if bag is not None else ()


def fcurve(anim_data, path, index=0):
    """The F-curve animating `path`[`index`] through `anim_data`, or None."""
    curves = fcurves(anim_data)
    return curves.find(path, index=index) if len(curves) else None


# The node whose "Image" input is the compositor's result: the Composite node up to 4.5;
# from 5.0 the group output of the scene's compositing node group.
COMPOSITOR_OUTPUT = "NodeGroupOutput" if VERSION >= (5, 0, 0) else "CompositorNodeComposite"


def compositor_output(tree):
    """A new COMPOSITOR_OUTPUT node; from 5.0 an "Image" output socket is added to the
    group's interface when missing."""
    if VERSION >= (5, 0, 0):
        if "Image" not in node_group_socket_names(tree, "OUTPUT"):
            node_group_add_socket(tree, "OUTPUT", "NodeSocketColor", "Image")
    return tree.nodes.new(COMPOSITOR_OUTPUT)


def compositor_on_cpu(scene):
    """Renders the scene's compositor on the CPU, where Map UV's anisotropic filter is the
    EWA that the native 'map_uv'/'map_uv_5' sampling reproduces bit for bit. The setting
    exists from 4.2; 5.x defaults to the GPU, whose Map UV goes through the graphics driver's
    own anisotropic filter with mipmaps (a bright pixel spreads over three)."""
    if hasattr(scene.render, "compositor_device") and scene.render.compositor_device != "CPU":
        scene.render.compositor_device = "CPU"


def map_uv_like_ewa(node):
    """Makes a Map UV node filter as the native 'map_uv' sampling: always EWA in 3.x; the
    'ANISOTROPIC' filter_type property in 4.1-4.5; from 5.0 the "Interpolation" menu input
    set to "Anisotropic" (it defaults to "Bilinear"). Raises when a 5.x has none of these,
    so a Blender that renamed it again is noticed instead of rendering other pixels."""
    if hasattr(node, "filter_type"):  # 4.1-4.5
        node.filter_type = "ANISOTROPIC"
        return
    socket = node.inputs.get("Interpolation") or node.inputs.get("Filter")  # 5.0+
    if socket is None and VERSION < (5, 0, 0):  # 3.x, 4.0: EWA is all it does
        return
    if socket is None:
        raise RuntimeError("this Blender's Map UV node has no anisotropic filter setting")
    socket.default_value = "Anisotropic"


def map_uv_sampling():
    """The native warp's sampling that equals what this Blender's Map UV node draws once
    map_uv_like_ewa set it: 'map_uv' (the EWA of 3.x-4.3: central-difference derivatives)
    or, from 5.0, 'map_uv_5' (the rewritten node: derivatives across 2x2 pixel blocks and
    its own anisotropic sampler). 4.4 and 4.5 are not in Debian and were not measured."""
    return "map_uv_5" if VERSION >= (5, 0, 0) else "map_uv"


def alpha_over_premultiplied(node):
    """Alpha Over for premultiplied inputs: Convert Premultiplied off, Premultiplied 0
    (properties up to 4.x; from 5.0 a "Straight Alpha" input that must stay off)."""
    if hasattr(node, "use_premultiply"):
        node.use_premultiply = False
        node.premul = 0.0
    elif "Straight Alpha" in node.inputs:
        node.inputs["Straight Alpha"].default_value = False


def alpha_over_takes_premultiplied(node):
    """True when alpha_over_premultiplied(node) is in effect."""
    if hasattr(node, "use_premultiply"):
        return not node.use_premultiply and node.premul == 0.0
    return not node.inputs["Straight Alpha"].default_value


def alpha_over_inputs(node):
    """(background, foreground) image inputs of an Alpha Over node."""
    images = [s for s in node.inputs if s.type == "RGBA"]
    return images[0], images[1]


def image_node_sequence(node, first, count):
    """Makes a compositor Image node play its image sequence so that scene frame f reads
    the file numbered f, for frames first .. first + count - 1 (Blender holds the end
    frames outside them): the image user's start = first, offset = first - 1, duration =
    count, not cyclic, refreshed every frame. Node properties in 3.x and 4.x; Blender 5.x
    keeps the image user on the node too (written from its API notes, not exercised)."""
    user = node if hasattr(node, "frame_duration") else getattr(node, "image_user", node)
    values = {"frame_duration": count, "frame_start": first, "frame_offset": first - 1,
              "use_cyclic": False, "use_auto_refresh": True}
    for name, value in values.items():
        if getattr(user, name) != value:
            setattr(user, name, value)


def compositor_math(tree, operation):
    """A Math node in a compositor tree: CompositorNodeMath up to 4.5; 5.0 removed it, and
    compositor trees take the shader Math node instead (same inputs and operations)."""
    node = tree.nodes.new("ShaderNodeMath" if VERSION >= (5, 0, 0) else "CompositorNodeMath")
    node.operation = operation
    return node


def set_file_format(settings, file_format):
    """ImageFormatSettings.file_format = file_format. From 5.0 a format belongs to a media
    type (image, multilayer image, video) that must be chosen first: a File Output node
    starts as a multilayer image, and "FFMPEG" is only offered for video."""
    if hasattr(settings, "media_type"):  # 5.0+
        settings.media_type = {"FFMPEG": "VIDEO",
                               "OPEN_EXR_MULTILAYER": "MULTI_LAYER_IMAGE"}.get(file_format, "IMAGE")
    settings.file_format = file_format


def file_output(tree, directory, name, file_format):
    """A File Output node whose one input is written at frame f as directory/name0001.ext
    (f with four digits). Returns (node, input socket); the caller sets node.format. Up to
    4.5: base_path and the first slot's path, which Blender follows with the frame. From
    5.0: directory, a file name whose #### the frame replaces, and one item with an empty
    name (an item's name is written after the file name)."""
    node = tree.nodes.new("CompositorNodeOutputFile")
    set_file_format(node.format, file_format)
    if hasattr(node, "file_output_items"):  # 5.0+
        node.directory = directory
        node.file_name = name + "####"
        node.file_output_items.clear()
        node.file_output_items.new("RGBA", "")
    else:
        node.base_path = directory
        node.file_slots[0].path = name
    return node, node.inputs[0]


def sequencer_strips(editor):
    """The strips of a sequence editor: `sequences` up to 4.x, `strips` from 4.4 (5.0
    removed `sequences`)."""
    return editor.strips if hasattr(editor, "strips") else editor.sequences
