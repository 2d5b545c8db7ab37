"""Add-on preferences: the native library's version and status, the worker thread count
(applied to the native library) and the Blender version."""

import bpy

from . import native


def _apply_threads(prefs, _context=None):
    if native.available():
        native.lib.set_threads(int(prefs.threads))


def _threads_update(self, context):
    _apply_threads(self, context)


class TUSSOCK_AP_preferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    threads: bpy.props.IntProperty(
        name="Threads",
        description="Worker threads of the native library (0 = all cores). "
        "Results are identical whatever the count",
        default=0, min=0, max=256, update=_threads_update)

    def draw(self, context):
        layout = self.layout
        col = layout.column()
        if native.available():
            col.label(text=f"Native library {native.version()}", icon="CHECKMARK")
        else:
            col.label(text=native.error, icon="ERROR")
        col.prop(self, "threads")
        if native.available():
            col.label(text=f"In use: {native.lib.get_threads()} threads")
        col.label(text=f"Blender {bpy.app.version_string}")


def get(context=None):
    """The add-on's preferences, or None when not registered (e.g. during tests)."""
    context = context or bpy.context
    addon = context.preferences.addons.get(__package__)
    return addon.preferences if addon else None


def register_extra():
    p = get()
    if p is not None:
        _apply_threads(p)


classes = (TUSSOCK_AP_preferences,)
