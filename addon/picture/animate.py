"""Pictures move on the timeline: before every frame is drawn or rendered, each layer's UV
pass of that frame is computed in C and written into its UV image. Two handlers, because
a picture's render is the compositor alone (no Render Layers node): Blender (3.4, measured)
then evaluates no view layer and calls no frame_change handler between the frames of an
animation render, only render_pre, with the scene already on the frame to render.
A baked picture (picture/baking.py) is read from its files instead, frame by frame as long
as they verify."""

import sys

import bpy

from .. import compat, errors, handlers, native
from . import baking as picture_baking
from . import frames


def _update(scene):
    settings = getattr(scene, "tussock_picture", None)
    if settings is None or not settings.applied or not native.available():
        return None  # no animated picture here

    def update():
        if not picture_baking.serves(scene, scene.frame_current):
            frames.update(scene)
        # else the compositor reads this frame from the bake's files

    # a handler cannot report: the panel shows why the picture stopped, the frame shows
    # magenta where the picture is missing (frames.show_missing), and so does the console
    if errors.in_update(settings, update):
        _printed.pop(scene.name, None)
        return True
    if _printed.get(scene.name) != settings.last_error:
        _printed[scene.name] = settings.last_error
        print(f"Tussock: the animated picture of scene '{scene.name}' cannot be shown: "
              f"{settings.last_error}", file=sys.stderr)
    return False


_printed = {}  # scene name -> the error last printed for it (once per error, not per frame)


@bpy.app.handlers.persistent
def on_frame_change(scene, depsgraph=None):
    if _update(scene) and not bpy.app.background:
        # let the compositor (Viewer in the Image Editor, backdrop) redraw with the new pass
        tree = compat.compositor_tree(scene, create=False)
        if tree is not None:
            tree.update_tag()


def _rendering_from_command_line():
    """True in a Blender started to render (`blender -b scene.blend -a` or `-f N`, as farm
    workers are), not in one that renders from a script or a window."""
    if not bpy.app.background:
        return False
    args = sys.argv[:sys.argv.index("--")] if "--" in sys.argv else sys.argv
    return any(a in ("-a", "--render-anim", "-f", "--render-frame") for a in args)


@bpy.app.handlers.persistent
def on_render_pre(scene, *_args):
    if _update(scene) is False and _rendering_from_command_line():
        # A farm worker would write a magenta frame and report success, and the farm would
        # take it. SystemExit out of a handler ends Blender with that status (3.4-5.2, tried)
        # before the frame is written, so the task fails and is retried or reported.
        print(f"Tussock: frame {scene.frame_current} of scene '{scene.name}' is not rendered: "
              f"{scene.tussock_picture.last_error}", file=sys.stderr, flush=True)
        sys.exit(1)


@bpy.app.handlers.persistent
def on_load(*_args):
    frames.forget()
    for scene in bpy.data.scenes:  # a freshly opened file: images hold no frame yet
        _update(scene)


@bpy.app.handlers.persistent
def on_save_pre(*_args):
    for scene in bpy.data.scenes:  # a saved .blend renders from its bake without Tussock
        picture_baking.wire_for_save(scene)


@bpy.app.handlers.persistent
def on_save_post(*_args):
    for scene in bpy.data.scenes:  # back to what the current frame needs
        _update(scene)


classes = ()


def register_extra():
    handlers.add("frame_change_post", on_frame_change)
    handlers.add("render_pre", on_render_pre)
    handlers.add("load_post", on_load)
    handlers.add("save_pre", on_save_pre)
    handlers.add("save_post", on_save_post)


def unregister_extra():
    frames.forget()
