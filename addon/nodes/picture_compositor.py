"""The compositor tree of an animated picture, which Tussock owns: the inpainted
background plate, then per layer (back to front) a Map UV node that reads the layer image
through the layer's per-frame UV pass, laid over what is behind with Alpha Over
(premultiplied, Convert Premultiplied off), to the Composite output and a Viewer for the
Image Editor. There is no Render Layers node, so rendering draws no 3D scene: a render is
the compositor alone (docs/picture.md, "In Blender: the compositor passes")."""

from .. import compat

COLUMN = 260


def _image_node(tree, name, image, x, y):
    node = tree.nodes.new("CompositorNodeImage")
    node.name = node.label = name
    node.image = image
    node.location = (x, y)
    return node


def build(scene, background, layers):
    """Replaces the scene's compositor nodes. `layers` is a list of (layer image, UV image)
    back to front. Returns the tree."""
    tree = compat.compositor_tree(scene)
    compat.compositor_on_cpu(scene)  # renders equal the native frames (previews, bakes)
    tree.nodes.clear()
    bg = _image_node(tree, "Tussock Background", background, 0, 0)
    behind = bg.outputs["Image"]
    for i, (layer_image, uv_image) in enumerate(layers, 1):
        x = COLUMN * 2 * i
        img = _image_node(tree, f"Tussock Layer {i}", layer_image, x - COLUMN, -300)
        uv = _image_node(tree, f"Tussock UV {i}", uv_image, x - COLUMN, -600)
        map_uv = tree.nodes.new("CompositorNodeMapUV")
        map_uv.name = map_uv.label = f"Tussock Map UV {i}"
        map_uv.location = (x, -400)
        compat.map_uv_like_ewa(map_uv)
        tree.links.new(img.outputs["Image"], map_uv.inputs["Image"])
        tree.links.new(uv.outputs["Image"], map_uv.inputs["UV"])
        over = tree.nodes.new("CompositorNodeAlphaOver")
        over.name = over.label = f"Tussock Alpha Over {i}"
        over.location = (x + COLUMN, 0)
        compat.alpha_over_premultiplied(over)
        back, front = compat.alpha_over_inputs(over)
        tree.links.new(behind, back)
        tree.links.new(map_uv.outputs["Image"], front)
        behind = over.outputs["Image"]
    x = COLUMN * 2 * (len(layers) + 1)
    out = compat.compositor_output(tree)
    out.name = "Tussock Output"
    out.location = (x, 0)
    if hasattr(out, "use_alpha"):
        out.use_alpha = True
    tree.links.new(behind, out.inputs["Image"])
    viewer = tree.nodes.new("CompositorNodeViewer")
    viewer.name = "Tussock Viewer"
    viewer.location = (x, -250)
    tree.links.new(behind, viewer.inputs["Image"])
    return tree


def set_images(tree, background, layers, sequence=None):
    """Points the Image nodes of a tree that build() made at other images: `background`
    and per layer (layer image, UV image), back to front. With sequence = (first frame,
    frame count), the UV images are image sequences whose file numbers are scene frames
    (a baked picture, addon/picture/baking.py); sequence=None is Tussock's live images.
    Sets only what differs, so calling it every frame costs nothing; returns True when an
    image changed."""
    changed = []

    def put(node, image):
        if node is not None and node.image != image:
            node.image = image
            changed.append(node)

    put(tree.nodes.get("Tussock Background"), background)
    for i, (layer_image, uv_image) in enumerate(layers, 1):
        put(tree.nodes.get(f"Tussock Layer {i}"), layer_image)
        uv = tree.nodes.get(f"Tussock UV {i}")
        put(uv, uv_image)
        if uv is not None and sequence is not None:
            compat.image_node_sequence(uv, sequence[0], sequence[1])
    return bool(changed)
