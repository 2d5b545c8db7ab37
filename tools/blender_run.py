#!/usr/bin/python3
"""usage: blender_run.py [--window] SCRIPT [-- ARGS...]: runs SCRIPT in background Blender
(or with --window in a real window on Xvfb) with the add-on linked in (see blender_env.py),
streaming its output; exits with Blender's code."""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_env  # noqa: E402

if __name__ == "__main__":
    argv = sys.argv[1:]
    window = bool(argv) and argv[0] == "--window"
    if window:
        argv = argv[1:]
    script = os.path.abspath(argv[0])
    rest = argv[1:]
    if rest and rest[0] == "--":
        rest = rest[1:]
    code, _ = blender_env.run(script, rest, capture=False, window=window)
    sys.exit(code)
