"""Pictures move on the timeline: before every frame is drawn or rendered, each layer's UV
pass of that frame is computed in C and written into its UV image. Two handlers, because
a picture's render is the compositor alone (no Render Layers node): Blender (3.4, measured)
then evaluates no view layer and calls no frame_change handler between the frames of an
animation render, only render_pre, with the scene already on the frame to render."""

import bpy

from .. import handlers, native
from . import frames


@bpy.app.handlers.persistent
def on_frame_change(scene, depsgraph=None):
    settings = getattr(scene, "tussock_picture", None)
    if settings is None or not settings.applied or not native.available():
        return
    try:
        frames.update(scene)
    except (native.Error, ValueError, OSError) as exc:
        # a handler cannot report; the panel shows why the picture stopped
        settings.last_error = str(exc)
    else:
        if settings.last_error:
            settings.last_error = ""


@bpy.app.handlers.persistent
def on_render_pre(scene, *_args):
    on_frame_change(scene)


@bpy.app.handlers.persistent
def on_load(*_args):
    frames.forget()
    for scene in bpy.data.scenes:  # a freshly opened file: images hold no frame yet
        on_frame_change(scene)


classes = ()


def register_extra():
    handlers.add("frame_change_post", on_frame_change)
    handlers.add("render_pre", on_render_pre)
    handlers.add("load_post", on_load)


def unregister_extra():
    frames.forget()
