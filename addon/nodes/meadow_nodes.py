"""The geometry-node group that instances a meadow (seed 000 §4.5, Fig. 2e).

The patch of blades is split into chunks of C consecutive blades, one mesh object per chunk
in a collection, named so that their order is the chunk order. The meadow object is a
point cloud with one point per chunk instance, at its tile's corner, with an int point
attribute `tsk_chunk` saying which chunk it shows. The group picks that chunk from the
collection (Instance on Points, Pick Instance), so memory holds one patch, not the meadow.
Points with the boolean attribute `tsk_hidden` (tiles being simulated) show nothing, and in
the viewport only a random fraction `Display` of the instances is shown.

The group is shared by all meadows and rebuilt in place when GROUP_VERSION changes."""

import bpy

from .. import compat

GROUP_NAME = "Tussock Meadow"
GROUP_VERSION = 1


def _build(ng):
    compat.node_group_clear(ng)
    compat.node_group_add_socket(ng, "INPUT", "NodeSocketGeometry", "Geometry")
    compat.node_group_add_socket(ng, "INPUT", "NodeSocketCollection", "Chunks")
    display = compat.node_group_add_socket(ng, "INPUT", "NodeSocketFloat", "Display")
    display.default_value, display.min_value, display.max_value = 1.0, 0.0, 1.0
    compat.node_group_add_socket(ng, "INPUT", "NodeSocketInt", "Seed")
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

    chunk = nodes.new("GeometryNodeInputNamedAttribute")
    chunk.data_type = "INT"
    chunk.inputs["Name"].default_value = "tsk_chunk"
    chunk.location = (-500, -450)

    hidden = nodes.new("GeometryNodeInputNamedAttribute")
    hidden.data_type = "BOOLEAN"
    hidden.inputs["Name"].default_value = "tsk_hidden"
    hidden.location = (-700, 250)

    viewport = nodes.new("GeometryNodeIsViewport")
    viewport.location = (-700, 100)
    rand = nodes.new("FunctionNodeRandomValue")
    rand.data_type = "BOOLEAN"
    rand.location = (-700, -50)
    links.new(gin.outputs["Display"], rand.inputs["Probability"])
    links.new(gin.outputs["Seed"], rand.inputs["Seed"])

    # shown = not hidden and (not viewport or random < display)
    not_vp = nodes.new("FunctionNodeBooleanMath")
    not_vp.operation = "NOT"
    links.new(viewport.outputs[0], not_vp.inputs[0])
    keep = nodes.new("FunctionNodeBooleanMath")
    keep.operation = "OR"
    links.new(not_vp.outputs[0], keep.inputs[0])
    links.new(compat.enabled_output(rand), keep.inputs[1])
    visible = nodes.new("FunctionNodeBooleanMath")
    visible.operation = "NIMPLY"  # keep and not hidden
    links.new(keep.outputs[0], visible.inputs[0])
    links.new(compat.enabled_output(hidden), visible.inputs[1])
    for i, n in enumerate((not_vp, keep, visible)):
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
