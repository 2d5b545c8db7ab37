#!/usr/bin/python3
"""usage: blender_run.py SCRIPT [-- ARGS...]: runs SCRIPT in background Blender with the
add-on linked in (see blender_env.py), streaming its output; exits with Blender's code."""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_env  # noqa: E402

if __name__ == "__main__":
    script = os.path.abspath(sys.argv[1])
    rest = sys.argv[2:]
    if rest and rest[0] == "--":
        rest = rest[1:]
    code, _ = blender_env.run(script, rest, capture=False)
    sys.exit(code)
