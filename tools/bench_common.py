"""What the Blender benchmark scripts (tools/bench_*.py) share: the benchmark names asked
for on the command line, and the JSON line of DESIGN.md, whose params name the Blender that
ran it (the same script runs in 3.4, 4.3 and 5.x: ./build.sh bench --blender N)."""

import json
import sys

import bpy

ARGS = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
NAMES = [a for a in ARGS if not a.startswith("-")]


def wanted(prefix):
    """True without names, or when a name asked for and `prefix` (a line's name or the
    prefix of a group of lines) overlap."""
    return not NAMES or any(prefix.startswith(a) or a.startswith(prefix) for a in NAMES)


def emit(name, value, unit, params, peer=None):
    line = {"name": name, "value": round(value, 6) if isinstance(value, float) else value,
            "unit": unit, "params": dict(params, blender=bpy.app.version_string)}
    if peer:
        line["peer"] = peer
    print(json.dumps(line), flush=True)
