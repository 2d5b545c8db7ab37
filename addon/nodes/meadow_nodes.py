"""The geometry-node group that instances a meadow (seed 000 §4.5, Fig. 2e).

The patch of blades is split into chunks of C consecutive blades, one mesh object per chunk
in a collection, named so that their order is the chunk order. The meadow object is a
point cloud with one point per chunk instance, at its tile's corner, with an int point
attribute `tsk_chunk` saying which chunk it shows. The group picks that chunk from the
collection (Instance on Points, Pick Instance), so memory holds one patch, not the meadow.
Points with the boolean attribute `tsk_hidden` (tiles being simulated) show nothing, and in
the viewport neither do points with the boolean attribute `tsk_viewport_off`: the instances
that the meadow's Viewport display fraction leaves out, chosen by Tussock itself
(build.viewport_off) so that the simulated blades of a tile can show in the viewport exactly
as its instances did. A meadow made before the attribute existed shows every instance in the
viewport until a meadow is built (build.write gives it the attribute).

The group is shared by all meadows and rebuilt in place when GROUP_VERSION changes."""

import bpy

from .. import compat

GROUP_NAME = "Tussock Meadow"
GROUP_VERSION = 2  # 2: viewport display from tsk_viewport_off, not a Random Value node


def _named_attribute(nodes, data_type, name, location):
    node = nodes.new("GeometryNodeInputNamedAttribute")
    node.data_type = data_type
    node.inputs["Name"].default_value = name
    node.location = location
    return node


def _build(ng):
    compat.node_group_clear(ng)
    compat.node_group_add_socket(ng, "INPUT", "NodeSocketGeometry", "Geometry")
    compat.node_group_add_socket(ng, "INPUT", "NodeSocketCollection", "Chunks")
    compat.node_group_add_socket(ng, "OUTPUT", "NodeSocketGeometry", "Geometry")

    nodes, links = ng.nodes, ng.links
    gin = nodes.new("NodeGroupInput")
    gout = nodes.new("NodeGroupOutput")
    gin.location, gout.location = (-900, 0), (500, 0)

    info = nodes.new("GeometryNodeCollectionInfo")
    info.transform_space = "ORIGINAL"
    info.inputs["Separate Children"].default_value = True
    info.inputs["Reset Children"].default_value = True
    info.location = (-500, -250)
    links.new(gin.outputs["Chunks"], info.inputs["Collection"])

    chunk = _named_attribute(nodes, "INT", "tsk_chunk", (-500, -450))
    hidden = _named_attribute(nodes, "BOOLEAN", "tsk_hidden", (-700, 250))
    viewport = nodes.new("GeometryNodeIsViewport")
    viewport.location = (-700, 100)
    off = _named_attribute(nodes, "BOOLEAN", "tsk_viewport_off", (-700, -50))

    # shown = not (hidden or (viewport and viewport_off))
    cut = nodes.new("FunctionNodeBooleanMath")
    cut.operation = "AND"
    links.new(viewport.outputs[0], cut.inputs[0])
    links.new(compat.enabled_output(off), cut.inputs[1])
    gone = nodes.new("FunctionNodeBooleanMath")
    gone.operation = "OR"
    links.new(cut.outputs[0], gone.inputs[0])
    links.new(compat.enabled_output(hidden), gone.inputs[1])
    visible = nodes.new("FunctionNodeBooleanMath")
    visible.operation = "NOT"
    links.new(gone.outputs[0], visible.inputs[0])
    for i, n in enumerate((cut, gone, visible)):
        n.location = (-450 + 150 * i, 150)

    inst = nodes.new("GeometryNodeInstanceOnPoints")
    inst.location = (150, 0)
    inst.inputs["Pick Instance"].default_value = True
    links.new(gin.outputs["Geometry"], inst.inputs["Points"])
    links.new(info.outputs[0], inst.inputs["Instance"])
    links.new(compat.enabled_output(chunk), inst.inputs["Instance Index"])
    links.new(visible.outputs[0], inst.inputs["Selection"])
    links.new(inst.outputs["Instances"], gout.inputs["Geometry"])
    ng["tussock_version"] = GROUP_VERSION


def meadow_group():
    """The shared meadow node group, built or rebuilt when its version is not current."""
    ng = bpy.data.node_groups.get(GROUP_NAME)
    if ng is None:
        ng = bpy.data.node_groups.new(GROUP_NAME, "GeometryNodeTree")
    if ng.get("tussock_version") != GROUP_VERSION:
        _build(ng)
    return ng
