"""Tree settings on the tree object: preset, seed, leaves, smoothing, wind response and
the full Weber-Penn parameter set (generated from the native definition). Every change
regrows the tree interactively."""

import bpy

from .. import errors, meshes, native
from . import params


def _rebuild(self, context):
    obj = self.id_data
    settings = getattr(obj, "tussock_tree", None)
    if settings is None or not settings.is_tree or not native.available():
        return
    from . import build
    # keep the last good tree and show why; in Edit Mode, regrow it once out of it
    if not errors.in_update(settings, build.rebuild, obj) and meshes.in_edit_mode(obj):
        meshes.redo_after_edit_mode(obj, regrow)


def regrow(obj):
    """Regrows the tree after Edit Mode; the panel's error goes when it works."""
    settings = getattr(obj, "tussock_tree", None)
    if settings is not None and settings.is_tree:
        from . import build
        errors.in_update(settings, build.rebuild, obj)


_generated = params.make_classes(_rebuild)

annotations = {
    "is_tree": bpy.props.BoolProperty(default=False, options={"HIDDEN"}),
    "last_error": bpy.props.StringProperty(default="", options={"HIDDEN"}),
    "seed": bpy.props.IntProperty(name="Seed", default=1, min=0, update=_rebuild,
                                  description="Random seed of the tree's branching"),
    "leaves": bpy.props.BoolProperty(name="Leaves", default=True, update=_rebuild,
                                     description="Grow leaves on the last branch level"),
    "smooth_levels": bpy.props.IntProperty(name="Smooth", default=0, min=0, max=3,
                                           update=_rebuild,
                                           description="Catmull-Clark levels (OpenSubdiv)"),
    "wind_strength": bpy.props.FloatProperty(name="Wind response", default=0.05, min=0.0,
                                             max=10.0, update=_rebuild,
                                             description="How far branches bend per m/s of "
                                             "wind (0: the tree stands still)"),
}
if _generated:
    annotations["params"] = bpy.props.PointerProperty(
        type=_generated[1], description="The tree's Weber-Penn parameters")

TussockTreeSettings = type("TussockTreeSettings", (bpy.types.PropertyGroup,),
                           {"__annotations__": annotations})

classes = tuple(_generated) + (TussockTreeSettings,)


def register_extra():
    bpy.types.Object.tussock_tree = bpy.props.PointerProperty(type=TussockTreeSettings)


def unregister_extra():
    del bpy.types.Object.tussock_tree
