"""Picture settings, stored on the scene: the picture file, its vegetation layers (how each
mask is made and how the layer moves), how layers are separated, and a seamless loop.
Motion settings (lambda, rigidity, roots, cells) take effect on the next frame; the picture,
the masks and the separation settings take effect when Animate Picture runs again."""

import bpy

from .. import compat


def _motion_changed(self, context):
    """Shows a changed motion setting at once on the current frame."""
    scene = context.scene if context is not None else None
    if scene is None or not scene.tussock_picture.applied:
        return
    from .. import errors
    from . import frames
    errors.in_update(scene.tussock_picture, frames.update, scene)


LOOP_FRAMES_MAX = 10000  # frames of a seamless loop; its first frame steps the wind 2N
LAMBDA_MAX = 1e6  # TSK_WARP_MAX_LAMBDA
CELL_MAX = 4096  # TSK_PICTURE_MAX_CELL, pixels
# the root line is passed as picture height - line, which the warp keeps within 1e7 pixels
# for a picture of up to TSK_PICTURE_MAX_SIDE (16384) pixels
ROOT_LINE_MAX = 1e7 - 16384

MASK_ITEMS = [
    ("FILE", "Mask file", "A black-and-white image file the size of the picture "
     "(white = vegetation)"),
    ("IMAGE", "Painted image", "A Blender image the size of the picture, painted or loaded "
     "in the Image Editor (white = vegetation)"),
    ("GRABCUT", "GrabCut", "Tussock proposes the mask from a rectangle around the "
     "vegetation (and optional strokes)"),
]

ROOT_ITEMS = [
    ("BOTTOM", "Bottom", "Roots on a line at the bottom: the higher, the more it moves "
     "(grass or trees seen from the side)"),
    ("TOP", "Top", "Root line at the top: far away at the top moves least (a field seen "
     "from above)"),
    ("NONE", "None", "Every part moves alike"),
]

INPAINT_ITEMS = [
    ("TELEA", "Telea", "Fast marching inpainting (Telea 2004)"),
    ("NS", "Navier-Stokes", "Navier-Stokes based inpainting (Bertalmio et al. 2001)"),
]


class TussockPictureLayer(bpy.types.PropertyGroup):
    # name (from PropertyGroup) labels the layer in the list
    mask_mode: bpy.props.EnumProperty(name="Mask", items=MASK_ITEMS, default="FILE",
                                      description="How this layer's vegetation is told apart from "
                                                  "the background")
    mask_path: bpy.props.StringProperty(name="Mask file", subtype="FILE_PATH",
                                        options=compat.PATH_OPTIONS,
                                        description="Image file the size of the picture; "
                                        "white (>= 50 %) is vegetation")
    mask_image: bpy.props.StringProperty(name="Mask image",
                                         description="Name of a Blender image the size of "
                                         "the picture; white (>= 50 %) is vegetation")
    rect: bpy.props.IntVectorProperty(name="Rectangle", size=4, default=(0, 0, 0, 0),
                                      description="GrabCut rectangle around the vegetation: "
                                      "x, y of its top-left corner (pixels from the "
                                      "picture's top-left), width, height")
    strokes_path: bpy.props.StringProperty(name="Strokes", subtype="FILE_PATH",
                                           options=compat.PATH_OPTIONS,
                                           description="Optional image file the size of "
                                           "the picture: red strokes force vegetation, blue "
                                           "strokes force background")
    grabcut_iterations: bpy.props.IntProperty(name="Iterations", default=5, min=1, max=50,
                                              description="GrabCut refinement rounds")
    grabcut_max_side: bpy.props.IntProperty(name="Proposal size", default=0, min=0,
                                            max=16384,
                                            description="Propose the mask on a copy "
                                            "shrunk to at most this many pixels per side "
                                            "(faster; the mask edge follows the coarse "
                                            "pixels). 0 = full resolution")
    # motion (seed 004, eq. 5-7); hard limits are those of the native warp (check_def in
    # native/src/picture/warp.c), so no value the panel takes is refused at a frame
    lambda_x: bpy.props.FloatProperty(name="λ x", default=24.0, soft_min=0.0, soft_max=200.0,
                                      min=-LAMBDA_MAX, max=LAMBDA_MAX,
                                      description="How far the vegetation moves sideways: "
                                      "cells per unit of continuum velocity and second",
                                      update=_motion_changed)
    lambda_y: bpy.props.FloatProperty(name="λ y", default=8.0, soft_min=0.0, soft_max=200.0,
                                      min=-LAMBDA_MAX, max=LAMBDA_MAX,
                                      description="How far it moves up and down (keep low "
                                      "for grass seen from the side)", update=_motion_changed)
    scale_map_path: bpy.props.StringProperty(name="Scale map", subtype="FILE_PATH",
                                             options=compat.PATH_OPTIONS,
                                             description="Optional image file the size of "
                                             "the picture multiplying λ (dark = far, moves "
                                             "less; white = 1)")
    rigidity: bpy.props.FloatProperty(name="Rigidity r", default=1.0, min=0.0, max=10.0,
                                      description="How much the roots hold: movement grows "
                                      "as (height above the roots / layer height)^r",
                                      update=_motion_changed)
    root: bpy.props.EnumProperty(name="Roots", items=ROOT_ITEMS, default="BOTTOM",
                                 update=_motion_changed,
                                 description="Where this layer is rooted: the farther from the "
                                             "root line, the more it moves")
    root_auto: bpy.props.BoolProperty(name="Root line from mask", default=True,
                                      description="Root line and height from the mask's "
                                      "bounding box", update=_motion_changed)
    root_line: bpy.props.FloatProperty(name="Root line", default=0.0, min=-ROOT_LINE_MAX,
                                       max=ROOT_LINE_MAX,
                                       description="Root line, pixels from the picture's "
                                       "bottom", update=_motion_changed)
    root_height: bpy.props.FloatProperty(name="Height", default=100.0, min=0.01, max=1e7,
                                         description="Height of the vegetation above its "
                                         "root line (below it when rooted at the top), pixels",
                                         update=_motion_changed)
    cell_x: bpy.props.IntProperty(name="Cell x", default=16, soft_min=1, soft_max=256, min=1,
                                  max=CELL_MAX,
                                  description="Warp grid cell width, pixels",
                                  update=_motion_changed)
    cell_y: bpy.props.IntProperty(name="Cell y", default=16, soft_min=1, soft_max=256, min=1,
                                  max=CELL_MAX,
                                  description="Warp grid cell height, pixels",
                                  update=_motion_changed)


class TussockPictureImages(bpy.types.PropertyGroup):
    """The images Tussock writes for one layer (kept apart from the layer settings, which
    the operator also takes as arguments and operators cannot hold data-blocks)."""
    layer_image: bpy.props.PointerProperty(type=bpy.types.Image,
                                           description="The layer's premultiplied colour, made by "
                                                       "Animate Picture")
    uv_image: bpy.props.PointerProperty(type=bpy.types.Image,
                                        description="The layer's UV pass of the current frame, "
                                                    "read by the compositor's Map UV")


class TussockPicture(bpy.types.PropertyGroup):
    filepath: bpy.props.StringProperty(name="Picture", subtype="FILE_PATH",
                                       options=compat.PATH_OPTIONS,
                                       description="PNG, JPEG or OpenEXR picture to animate")
    layers: bpy.props.CollectionProperty(type=TussockPictureLayer,
                                         description="Vegetation layers, back to front")
    active_layer: bpy.props.IntProperty(default=0, options={"HIDDEN"})
    inpaint: bpy.props.EnumProperty(name="Inpainting", items=INPAINT_ITEMS, default="TELEA",
                                    description="How the background behind the vegetation is "
                                                "filled in")
    inpaint_radius: bpy.props.FloatProperty(name="Radius", default=5.0, min=1.0, max=100.0,
                                            description="Neighbourhood of each filled "
                                            "background pixel, pixels")
    grow: bpy.props.FloatProperty(name="Grow", default=3.0, min=0.0, max=64.0,
                                  description="The filled region is the mask grown by this, "
                                  "pixels")
    feather: bpy.props.FloatProperty(name="Feather", default=4.0, min=0.0, max=256.0,
                                     description="Width of the soft matte edge, pixels (0 = "
                                     "hard edge)")
    # max: a loop of N frames steps the wind 2N frames ahead of the first (frames.py,
    # loop_field); with no limit, 2**31 - 1 froze Blender for good (soak, issue 42)
    loop_frames: bpy.props.IntProperty(name="Loop", default=0, soft_min=0, soft_max=10000,
                                       max=LOOP_FRAMES_MAX,
                                       description="Seamless loop of this many frames from "
                                       "the scene's first frame (0 = no loop)",
                                       update=_motion_changed)
    # what Animate Picture built (JSON); frames use this, not the edited settings above
    applied: bpy.props.StringProperty(default="", options={"HIDDEN"})
    background_image: bpy.props.PointerProperty(type=bpy.types.Image, options={"HIDDEN"})
    images: bpy.props.CollectionProperty(type=TussockPictureImages, options={"HIDDEN"})
    last_error: bpy.props.StringProperty(default="", options={"HIDDEN"})


classes = (TussockPictureLayer, TussockPictureImages, TussockPicture)


def register_extra():
    bpy.types.Scene.tussock_picture = bpy.props.PointerProperty(type=TussockPicture)


def unregister_extra():
    del bpy.types.Scene.tussock_picture
