"""The Weber-Penn parameters as Blender properties, generated from the native library's
own definition (tree_default_def), so the panel always offers exactly what C accepts.
Each level's parameters are a nested group (level_0 .. level_3)."""

import bpy

from .. import native

# names that stay internal (limits) or are set elsewhere (seed)
HIDDEN = {"seed", "max_branches", "max_leaves"}
LABELS = {"z_scale": "Z Scale", "z_scale_v": "Z Scale V", "scale0": "0 Scale",
          "scale0_v": "0 Scale V", "base_splits": "0 Base Splits"}


def _label(name):
    return LABELS.get(name, name.replace("_v", " V").replace("_", " ").title())


def _prop(name, value, update):
    if isinstance(value, bool):
        return bpy.props.BoolProperty(name=_label(name), default=value, update=update)
    if isinstance(value, int):
        return bpy.props.IntProperty(name=_label(name), default=value, update=update)
    return bpy.props.FloatProperty(name=_label(name), default=float(value), update=update)


def make_classes(update):
    """(level class, params class) built from the native defaults, or () without them."""
    if not native.available():
        return ()
    d = native.lib.tree_default_def()
    level_ann = {k: _prop(k, v, update) for k, v in d["level"][0].items()}
    level_cls = type("TussockTreeLevel", (bpy.types.PropertyGroup,),
                     {"__annotations__": level_ann})
    ann = {k: _prop(k, v, update) for k, v in d.items() if k not in HIDDEN and k != "level"}
    for i in range(len(d["level"])):
        ann[f"level_{i}"] = bpy.props.PointerProperty(type=level_cls, name=f"Level {i}")
    params_cls = type("TussockTreeParams", (bpy.types.PropertyGroup,), {"__annotations__": ann})
    return level_cls, params_cls


def to_dict(params):
    """The native definition dict from the properties."""
    d = native.lib.tree_default_def()
    for k in d:
        if k in HIDDEN or k == "level":
            continue
        d[k] = getattr(params, k)
    d["level"] = [{k: getattr(getattr(params, f"level_{i}"), k) for k in d["level"][i]}
                  for i in range(len(d["level"]))]
    return d


def from_dict(params, d):
    for k, v in d.items():
        if k == "level":
            for i, lv in enumerate(v):
                group = getattr(params, f"level_{i}")
                for kk, vv in lv.items():
                    setattr(group, kk, vv)
        elif k not in HIDDEN and hasattr(params, k):
            setattr(params, k, v)
