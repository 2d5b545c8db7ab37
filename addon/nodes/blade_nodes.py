"""The geometry-node group that shows a blade object expanded by its `width` attribute
into a ribbon, as the seed's vertex shader does (seed 000 Fig. 6–7). The blade object
itself stays a polyline of knots (DESIGN.md's contract); only its display is a ribbon."""

import bpy

from .. import compat

GROUP_NAME = "Tussock Blade Ribbon"
GROUP_VERSION = 2
MATERIAL = "Tussock Blade"
MODIFIER = "Tussock Ribbon"


def _build(ng):
    compat.node_group_clear(ng)
    compat.node_group_add_socket(ng, "INPUT", "NodeSocketGeometry", "Geometry")
    compat.node_group_add_socket(ng, "INPUT", "NodeSocketMaterial", "Material")
    compat.node_group_add_socket(ng, "OUTPUT", "NodeSocketGeometry", "Geometry")
    n, link = ng.nodes, ng.links.new
    gin, gout = n.new("NodeGroupInput"), n.new("NodeGroupOutput")
    to_curve = n.new("GeometryNodeMeshToCurve")
    width = n.new("GeometryNodeInputNamedAttribute")
    width.data_type = "FLOAT"
    width.inputs["Name"].default_value = "width"
    radius = n.new("GeometryNodeSetCurveRadius")
    # The profile runs along the curve's binormal, which for a blade lying in a plane is in
    # that plane and across the blade; its length 1 is scaled by the radius = full width.
    profile = n.new("GeometryNodeCurvePrimitiveLine")
    profile.inputs["Start"].default_value = (0.0, -0.5, 0.0)
    profile.inputs["End"].default_value = (0.0, 0.5, 0.0)
    to_mesh = n.new("GeometryNodeCurveToMesh")
    link(gin.outputs[0], to_curve.inputs["Mesh"])
    link(to_curve.outputs[0], radius.inputs["Curve"])
    link(compat.enabled_output(width), radius.inputs["Radius"])
    link(radius.outputs[0], to_mesh.inputs["Curve"])
    link(profile.outputs[0], to_mesh.inputs["Profile Curve"])
    # curves carry no material: give the ribbon the blade material
    set_mat = n.new("GeometryNodeSetMaterial")
    link(to_mesh.outputs[0], set_mat.inputs["Geometry"])
    link(gin.outputs["Material"], set_mat.inputs["Material"])
    link(set_mat.outputs[0], gout.inputs[0])
    for i, node in enumerate((gin, to_curve, radius, to_mesh, set_mat, gout)):
        node.location = (220 * i, 0)
    width.location, profile.location = (220, -200), (440, -250)
    ng["tussock_version"] = GROUP_VERSION


def ribbon_group():
    ng = bpy.data.node_groups.get(GROUP_NAME)
    if ng is None:
        ng = bpy.data.node_groups.new(GROUP_NAME, "GeometryNodeTree")
    if ng.get("tussock_version") != GROUP_VERSION:
        _build(ng)
    return ng


def blade_material():
    """A plain two-sided leaf-green material for blade ribbons (artists may replace it)."""
    mat = bpy.data.materials.get(MATERIAL)
    if mat is None:
        mat = bpy.data.materials.new(MATERIAL)
        mat.use_nodes = True
        nodes = mat.node_tree.nodes
        bsdf = nodes["Principled BSDF"]
        bsdf.inputs["Base Color"].default_value = (0.10, 0.38, 0.06, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.5
        mat.diffuse_color = (0.10, 0.38, 0.06, 1.0)
    return mat


def show_ribbon(obj):
    """Adds (once) the ribbon display modifier to a blade object."""
    mod = obj.modifiers.get(MODIFIER)
    if mod is None:
        mod = obj.modifiers.new(MODIFIER, "NODES")
    mod.node_group = ribbon_group()
    if compat.get_modifier_input(mod, "Material") is None:
        compat.set_modifier_input(mod, "Material", blade_material())
    return mod
