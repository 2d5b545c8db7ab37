"""Bark and leaf materials for trees (node inputs that exist from Blender 3.4 to 5.x)."""

import bpy


def _principled(name, colour, roughness, translucent=0.0):
    mat = bpy.data.materials.get(name)
    if mat is not None:
        return mat
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    mat.diffuse_color = colour
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = colour
    bsdf.inputs["Roughness"].default_value = roughness
    if translucent > 0.0:
        out = nodes["Material Output"]
        trans = nodes.new("ShaderNodeBsdfTranslucent")
        trans.inputs["Color"].default_value = colour
        mix = nodes.new("ShaderNodeMixShader")
        mix.inputs["Fac"].default_value = translucent
        links.new(bsdf.outputs[0], mix.inputs[1])
        links.new(trans.outputs[0], mix.inputs[2])
        links.new(mix.outputs[0], out.inputs["Surface"])
    return mat


def bark():
    return _principled("Tussock Bark", (0.16, 0.11, 0.07, 1.0), 0.85)


def leaf():
    return _principled("Tussock Leaf", (0.08, 0.28, 0.04, 1.0), 0.5, translucent=0.35)
