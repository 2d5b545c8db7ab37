"""The grass material: translucent blades, darker at the root (UV v, or the point attribute
`tsk_v` of simulated ribbons), with colour varying per blade (point attribute
`tsk_blade_rand`) and per instance (Object Info > Random), so
Cycles and EEVEE renders look like grass out of the box. Uses only node inputs that
exist from Blender 3.4 to 5.x."""

import bpy

MATERIAL = "Tussock Grass"
MATERIAL_VERSION = 2


def _build(mat):
    mat.use_nodes = True
    tree = mat.node_tree
    for node in list(tree.nodes):
        tree.nodes.remove(node)
    n, link = tree.nodes, tree.links.new
    out = n.new("ShaderNodeOutputMaterial")
    out.location = (900, 0)
    blade_rand = n.new("ShaderNodeAttribute")
    blade_rand.attribute_name = "tsk_blade_rand"
    blade_rand.location = (-900, 200)
    info = n.new("ShaderNodeObjectInfo")
    info.location = (-900, -50)
    mix_rand = n.new("ShaderNodeMath")
    mix_rand.operation = "WRAP"
    mix_rand.inputs[1].default_value = 1.0
    mix_rand.inputs[2].default_value = 0.0
    add = n.new("ShaderNodeMath")
    add.operation = "ADD"
    link(blade_rand.outputs["Fac"], add.inputs[0])
    link(info.outputs["Random"], add.inputs[1])
    link(add.outputs[0], mix_rand.inputs[0])
    ramp = n.new("ShaderNodeValToRGB")
    ramp.location = (-450, 150)
    ramp.color_ramp.elements[0].color = (0.045, 0.16, 0.02, 1.0)
    ramp.color_ramp.elements[1].color = (0.20, 0.36, 0.06, 1.0)
    mid = ramp.color_ramp.elements.new(0.7)
    mid.color = (0.11, 0.30, 0.035, 1.0)
    link(mix_rand.outputs[0], ramp.inputs["Fac"])
    # darker toward the root: multiply by a ramp on the blade's v coordinate (0 root, 1 tip),
    # the UV map's v on instanced blades, the point attribute tsk_v on simulated ribbons
    # (which carry no UV map: Blender copies one per face corner every frame); each is 0
    # where the other is given
    uv = n.new("ShaderNodeUVMap")
    uv.location = (-900, -250)
    sep = n.new("ShaderNodeSeparateXYZ")
    link(uv.outputs["UV"], sep.inputs[0])
    along = n.new("ShaderNodeAttribute")
    along.attribute_name = "tsk_v"
    along.location = (-900, -400)
    v = n.new("ShaderNodeMath")
    v.operation = "MAXIMUM"
    link(sep.outputs["Y"], v.inputs[0])
    link(along.outputs["Fac"], v.inputs[1])
    root = n.new("ShaderNodeMapRange")
    root.inputs["To Min"].default_value = 0.35
    root.inputs["To Max"].default_value = 1.0
    link(v.outputs[0], root.inputs["Value"])
    shade = n.new("ShaderNodeMixRGB")
    shade.blend_type = "MULTIPLY"
    shade.inputs["Fac"].default_value = 1.0
    shade.location = (-150, 100)
    link(ramp.outputs["Color"], shade.inputs["Color1"])
    link(root.outputs["Result"], shade.inputs["Color2"])
    bsdf = n.new("ShaderNodeBsdfPrincipled")
    bsdf.location = (150, 250)
    bsdf.inputs["Roughness"].default_value = 0.55
    link(shade.outputs["Color"], bsdf.inputs["Base Color"])
    trans = n.new("ShaderNodeBsdfTranslucent")
    trans.location = (150, -150)
    link(shade.outputs["Color"], trans.inputs["Color"])
    mix = n.new("ShaderNodeMixShader")
    mix.location = (600, 0)
    mix.inputs["Fac"].default_value = 0.3
    link(bsdf.outputs[0], mix.inputs[1])
    link(trans.outputs[0], mix.inputs[2])
    link(mix.outputs[0], out.inputs["Surface"])
    mat["tussock_version"] = MATERIAL_VERSION


def grass_material():
    mat = bpy.data.materials.get(MATERIAL)
    if mat is None:
        mat = bpy.data.materials.new(MATERIAL)
    if mat.get("tussock_version") != MATERIAL_VERSION:
        _build(mat)
    return mat
