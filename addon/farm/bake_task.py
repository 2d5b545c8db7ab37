"""A farm task inside `blender -b scene.blend --python bake_task.py -- FIRST LAST [save]`:
bakes frames FIRST..LAST of the scene with Tussock (and saves the .blend with `save`: the
assembly task, run once after every bake task). Tussock is enabled for this run if the
Blender's preferences do not enable it already. Copied beside the job script, which runs it."""

import sys

import addon_utils
import bpy

if not hasattr(bpy.types, "TUSSOCK_OT_bake"):
    # installed as an add-on ("tussock") or as an extension ("bl_ext.<repo>.tussock")
    names = [m.__name__ for m in addon_utils.modules() if m.__name__.split(".")[-1] == "tussock"]
    addon_utils.enable(names[0] if names else "tussock", default_set=False)
    if not hasattr(bpy.types, "TUSSOCK_OT_bake"):
        sys.exit("Tussock is not installed in this Blender: install it on the farm's nodes, "
                 "or bake on a machine that has it and render there (docs/farm.md)")
args = sys.argv[sys.argv.index("--") + 1:]
first, last, save = int(args[0]), int(args[1]), args[2:] == ["save"]
result = bpy.ops.tussock.bake(frame_start=first, frame_end=last, save=save)
if result != {"FINISHED"}:
    sys.exit(f"the bake of frames {first}-{last} ended {result}")
