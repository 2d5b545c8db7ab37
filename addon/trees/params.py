"""The Weber-Penn parameters as Blender properties, generated from the native library's
own definition (tree_default_def), so the panel always offers exactly what C accepts.
Each level's parameters are a nested group (level_0 .. level_3)."""

import bpy
import numpy as np

from .. import native

# names that stay internal (limits) or are set elsewhere (seed)
HIDDEN = {"seed", "max_branches", "max_leaves"}
LABELS = {"z_scale": "Z Scale", "z_scale_v": "Z Scale V", "scale0": "0 Scale",
          "scale0_v": "0 Scale V", "base_splits": "0 Base Splits"}


def _label(name):
    return LABELS.get(name, name.replace("_v", " V").replace("_", " ").title())


# The ranges tsk_tree_validate accepts (native/src/tree/def.c), as hard limits, so that no
# value the panel lets through is refused at the next regrow. Limits between two settings
# (scale_v below scale, ...) are checked by C and reported with both names.
MAX_CHILDREN = 10000  # TSK_TREE_MAX_CHILDREN
LIMITS = {"shape": (0, 7), "base_size": (0.0, 0.999), "scale": (1e-3, 1000.0),
          "scale_v": (0.0, 1000.0), "z_scale": (1e-3, 100.0), "z_scale_v": (0.0, 100.0),
          "levels": (1, 4), "ratio": (1e-6, 1.0), "ratio_power": (0.0, 10.0),
          "lobes": (0, 64), "lobe_depth": (0.0, 0.9), "flare": (0.0, 10.0),
          "scale0": (1e-6, 100.0), "scale0_v": (0.0, 100.0), "base_splits": (0, 32),
          "leaves": (0, MAX_CHILDREN), "leaf_shape": (0, 9), "leaf_scale": (0.0, 100.0),
          "leaf_scale_x": (0.0, 10.0), "attraction_up": (-10.0, 10.0),
          "prune_ratio": (0.0, 1.0), "prune_width": (0.0, 10.0),
          "prune_width_peak": (0.0, 1.0), "prune_power_low": (0.0, 10.0),
          "prune_power_high": (0.0, 10.0), "taper_power": (1e-3, 100.0),
          "lobe_fade": (0.0, 1.0), "bulges": (0, 1000), "bulge_depth": (0.0, 0.9)}
LEVEL_LIMITS = {"length": (0.0, 10.0), "length_v": (0.0, 10.0), "taper": (0.0, 1.0),
                "seg_splits": (0.0, 4.0), "split_angle": (-180.0, 180.0),
                "split_angle_v": (-180.0, 180.0), "curve_res": (1, 64),
                "curve": (-3600.0, 3600.0), "curve_back": (-3600.0, 3600.0),
                "curve_v": (-3600.0, 3600.0), "down_angle": (-180.0, 180.0),
                "down_angle_v": (-180.0, 180.0), "rotate": (-360.0, 360.0),
                "rotate_v": (-360.0, 360.0), "branches": (0, MAX_CHILDREN)}


def _inside(lo, hi):
    """(lo, hi) as float32 values within [lo, hi]: Blender keeps floats in float32, and C
    compares them, widened, with the double limits."""
    f_lo, f_hi = np.float32(lo), np.float32(hi)
    if float(f_lo) < lo:  # (compared as doubles: numpy 2 compares float32 with a float in float32)
        f_lo = np.nextafter(f_lo, np.float32(np.inf))
    if float(f_hi) > hi:
        f_hi = np.nextafter(f_hi, np.float32(-np.inf))
    return float(f_lo), float(f_hi)


def _prop(name, value, update, limits):
    if isinstance(value, bool):
        return bpy.props.BoolProperty(name=_label(name), default=value, update=update)
    lo, hi = limits[name]
    if isinstance(value, int):
        return bpy.props.IntProperty(name=_label(name), default=value, min=lo, max=hi,
                                     update=update)
    lo, hi = _inside(lo, hi)
    return bpy.props.FloatProperty(name=_label(name), default=float(value), min=lo, max=hi,
                                   update=update)


def make_classes(update):
    """(level class, params class) built from the native defaults, or () without them."""
    if not native.available():
        return ()
    d = native.lib.tree_default_def()
    level_ann = {k: _prop(k, v, update, LEVEL_LIMITS) for k, v in d["level"][0].items()}
    level_cls = type("TussockTreeLevel", (bpy.types.PropertyGroup,),
                     {"__annotations__": level_ann})
    ann = {k: _prop(k, v, update, LIMITS) for k, v in d.items()
           if k not in HIDDEN and k != "level"}
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
