"""Tree presets: the native library's built-in species and the artist's own, saved as
JSON files in the add-on's user folder (compat.user_data_dir: presets/tussock_trees in
Blender's user scripts for a legacy add-on, the extension's own user folder from 4.2)."""

import json
import os
import re

from .. import compat, native
from . import params

_items = []  # kept alive: Blender needs enum item strings to outlive the callback


def user_dir(create=False):
    return compat.user_data_dir("tussock_trees", create=create)


def user_presets():
    d = user_dir()
    if not d or not os.path.isdir(d):
        return []
    return sorted(f[:-5] for f in os.listdir(d) if f.endswith(".json"))


def builtin_presets():
    return list(native.lib.tree_presets()) if native.available() else []


def items(_self=None, _context=None):
    _items.clear()
    for name in builtin_presets():
        _items.append((name, name.replace("_", " ").title(), "Built-in preset"))
    for name in user_presets():
        _items.append(("user:" + name, name, "Your preset"))
    if not _items:
        _items.append(("NONE", "None", "The native library is missing"))
    return _items


def load(name):
    """The definition dict of a preset (built-in name or 'user:NAME')."""
    if name.startswith("user:"):
        path = os.path.join(user_dir(), name[5:] + ".json")
        try:
            with open(path) as f:
                d = json.load(f)
        except (OSError, ValueError) as exc:
            raise ValueError(f"preset '{name[5:]}': cannot read {path}: {exc}") from None
        if not isinstance(d, dict):
            raise ValueError(f"preset '{name[5:]}': {path} does not hold a tree definition")
        check(name[5:], d)
        return d
    return native.require().tree_preset(name)


def check(name, d):
    """Raises ValueError naming the first entry of a preset dict that is not a tree parameter
    of the right type (a hand-edited or foreign JSON file), so that applying it cannot fail
    half-way with a TypeError, or whose value is outside the parameter's limits (the
    properties would clamp it on the way in and grow another tree than the file says).
    Limits between parameters are the native check's."""
    schema = native.require().tree_default_def()

    def bad(key, why):
        raise ValueError(f"preset '{name}': {key}: {why}")

    def value(key, ref, v):
        if ref is None:
            bad(key, "is not a tree parameter")
        if isinstance(ref, bool):
            ok = isinstance(v, bool)
        elif isinstance(ref, int):
            hi = 2 ** 64 - 1 if key == "seed" else 2 ** 31 - 1
            lo = 0 if key == "seed" else -2 ** 31
            ok = isinstance(v, int) and not isinstance(v, bool) and lo <= v <= hi
        else:
            ok = isinstance(v, (int, float)) and not isinstance(v, bool)
        if not ok:
            bad(key, f"must be {'an integer' if type(ref) is int else 'a number'} "
                     f"in range, got {v!r}")
        limits = (params.LEVEL_LIMITS if key.startswith("level[") else params.LIMITS)
        lo_hi = limits.get(key.rsplit(".", 1)[-1])
        if lo_hi is not None and not lo_hi[0] <= v <= lo_hi[1]:  # (NaN too)
            bad(key, f"must be in [{lo_hi[0]:g}, {lo_hi[1]:g}], got {v!r}")

    for k, v in d.items():
        if k == "level":
            n = len(schema["level"])
            if not isinstance(v, list) or len(v) > n:
                bad("level", f"must be a list of at most {n} levels")
            for i, lv in enumerate(v):
                if not isinstance(lv, dict):
                    bad(f"level[{i}]", "must be an object of level parameters")
                for kk, vv in lv.items():
                    value(f"level[{i}].{kk}", schema["level"][0].get(kk), vv)
        else:
            value(k, schema.get(k), v)


def save(name, d):
    clean = re.sub(r"[^A-Za-z0-9 _-]", "", name).strip()
    if not clean:
        raise ValueError("name: use letters, digits, spaces, - or _")
    path = os.path.join(user_dir(create=True), clean + ".json")
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(d, f, indent=1, sort_keys=True)
    os.replace(tmp, path)
    return clean


def remove(name):
    if not name.startswith("user:"):
        raise ValueError(f"'{name}' is a built-in preset and cannot be removed")
    os.remove(os.path.join(user_dir(), name[5:] + ".json"))
