"""Trees sway on the timeline: after every frame change each tree in the scene is bent by
the scene's wind at that frame."""

import bpy

from .. import cache, compat, errors, handlers, meshes, native
from ..wind import runtime
from . import baking, build
from .props import regrow


@bpy.app.handlers.persistent
def on_frame_change(scene, depsgraph=None):
    if not native.available():
        return
    for obj in scene.objects:  # one pose per tree object
        s = compat.settings_of(obj, "tussock_tree")
        if s is None or not s.is_tree:
            continue
        if cache.baked_frame(obj, scene, scene.frame_current, baking.inputs_key):
            continue  # the Mesh Cache modifier shows the baked frame
        # any failure goes to the panel (once, not a write on every frame), never a
        # traceback out of the handler
        if not errors.in_update(s, build.pose, obj, scene, scene.frame_current, clear=False) \
                and meshes.in_edit_mode(obj):
            meshes.redo_after_edit_mode(obj, regrow)


@bpy.app.handlers.persistent
def on_load(*_args):
    build.forget()
    runtime.clear()


classes = ()


def register_extra():
    handlers.add("frame_change_post", on_frame_change)
    handlers.add("load_post", on_load)
