"""A farm task inside `blender -b scene.blend --python bake_task.py -- FIRST LAST [save]`:
bakes frames FIRST..LAST of the scene with Tussock (and saves the .blend with `save`: the
assembly task, run once after every bake task). Tussock is enabled for this run if the
Blender's preferences do not enable it already. Copied beside the job script, which runs it.

When Tussock cannot bake, the task fails with the cause: Tussock is not installed; or it is
installed but enabling it raised (the exception, and for an import error where this
Blender's Python runs from: a venv, conda or pyenv Python inherited from the shell hides
numpy); or it is enabled but its native library did not load."""

import os
import sys
import traceback

import addon_utils
import bpy

NOT_INSTALLED = ("Tussock is not installed in this Blender: install it on the farm's nodes, "
                 "or bake on a machine that has it and render there (docs/farm.md)")


def python_clue():
    return (f"this Blender's Python runs from sys.prefix {sys.prefix} (sys.executable "
            f"{sys.executable}): if that is a venv, conda or pyenv Python and not the one "
            "this Blender was made for, the task inherited it from the shell that started it "
            "(PATH, PYTHONHOME, PYTHONPATH; see docs/farm.md)")


def enable_problem():
    """Enables Tussock when it is not enabled. None when its bake operator is there, else
    why not (a sentence)."""
    if hasattr(bpy.types, "TUSSOCK_OT_bake"):
        return None
    # installed as an add-on ("tussock") or as an extension ("bl_ext.<repo>.tussock")
    found = [m for m in addon_utils.modules() if m.__name__.split(".")[-1] == "tussock"]
    if not found:
        return NOT_INSTALLED
    raised = []

    def handle_error(exc):
        traceback.print_exc()  # the whole traceback in the task's log
        raised.append(exc)

    addon_utils.enable(found[0].__name__, default_set=False, handle_error=handle_error)
    if hasattr(bpy.types, "TUSSOCK_OT_bake") and not raised:
        return None
    where = os.path.dirname(getattr(found[0], "__file__", None) or "") or found[0].__name__
    if not raised:
        return (f"Tussock is installed ({where}) but could not be enabled: it registered no "
                "bake operator")
    exc = raised[0]
    text = f"Tussock is installed ({where}) but could not be enabled: " \
           f"{type(exc).__name__}: {exc}"
    if isinstance(exc, ImportError):
        text += "; " + python_clue()
    return text


def native_problem():
    """None when Tussock's native library is loaded, else its error (native.py)."""
    package = bpy.types.TUSSOCK_OT_bake.__module__.rpartition(".")[0]
    native = sys.modules.get(package + ".native")
    if native is None or native.lib is not None:
        return None
    return native.error


problem = enable_problem() or native_problem()
if problem:
    sys.exit(problem)
args = sys.argv[sys.argv.index("--") + 1:]
first, last, save = int(args[0]), int(args[1]), args[2:] == ["save"]
result = bpy.ops.tussock.bake(frame_start=first, frame_end=last, save=save)
if result != {"FINISHED"}:
    sys.exit(f"the bake of frames {first}-{last} ended {result}")
