"""One definition for a setting that an operator takes and a property group stores: the
operator's argument is made from the stored property's definition, and its value is checked
against the stored property's hard limits before anything is built. Blender clamps a value
on assignment, so without this an operator could build with 0.005 and store 0.01, and the
scene would then disagree with itself until the next edit silently rebuilt it."""

import math


def operator_property(deferred, **overrides):
    """An operator property with the stored property's name, default, unit, description and
    limits, its hard limits turned into soft ones: the redo panel's slider stays in range, and
    a value typed or passed out of range reaches check() and is refused with a message instead
    of being clamped. `deferred` is the property group's annotation (bpy.props' deferred
    property, `.function` and `.keywords` in every supported Blender); its update callback is
    dropped (an operator's property has nothing to rebuild)."""
    kw = dict(deferred.keywords)
    kw.pop("update", None)
    for side in ("min", "max"):
        if side in kw:
            hard = kw.pop(side)
            soft = kw.get("soft_" + side)
            kw["soft_" + side] = hard if soft is None else soft
    kw.update(overrides)
    return deferred.function(**kw)


def annotation(group_cls, name):
    return group_cls.__annotations__[name]


def _fmt(v):
    return f"{v:g}" if isinstance(v, float) else str(v)


def check(group_cls, values):
    """Raises ValueError naming the first value that the property group would not store as
    it is (out of its hard limits, or NaN). `values`: {property name: value} (arrays as
    sequences). group_cls must be registered (its bl_rna carries the limits)."""
    props = group_cls.bl_rna.properties
    for name, value in values.items():
        p = props[name]
        if p.type not in ("INT", "FLOAT"):
            continue
        lo, hi = p.hard_min, p.hard_max
        items = value if getattr(p, "is_array", False) else (value,)
        for v in items:
            if not (lo <= v <= hi) or (isinstance(v, float) and math.isnan(v)):
                if hi >= 3.0e38 or hi >= 2 ** 31 - 1:
                    want = f"at least {_fmt(lo)}"
                elif lo <= -3.0e38 or lo <= -2 ** 31:
                    want = f"at most {_fmt(hi)}"
                else:
                    want = f"from {_fmt(lo)} to {_fmt(hi)}"
                raise ValueError(f"{p.name} ({name}) must be {want}, got {_fmt(v)}; "
                                 "nothing was changed")


def check_operator(operator, group_cls, names):
    """check() for the operator's own values of `names`."""
    check(group_cls, {n: getattr(operator, n) for n in names})
