"""Add-on preferences: the native library's version and status, the worker thread count
(applied to the native library), whether Blender's allocator keeps freed pages for reuse
(addon/allocator.py) and the Blender version."""

import bpy

from . import allocator, native


def _apply_threads(prefs, _context=None):
    if native.available():
        native.lib.set_threads(int(prefs.threads))


def _threads_update(self, context):
    _apply_threads(self, context)


def _keep_memory_update(self, _context):
    allocator.keep_freed(bool(self.keep_freed_memory))


class TUSSOCK_AP_preferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    threads: bpy.props.IntProperty(
        name="Threads",
        description="Worker threads of the native library (0 = all cores). "
        "Results are identical whatever the count",
        default=0, min=0, max=256, update=_threads_update)

    keep_freed_memory: bpy.props.BoolProperty(
        name="Reuse Freed Memory",
        description="Let Blender's memory allocator keep the pages of freed memory for reuse "
        "instead of giving them back at once: trees and simulated meadows rewrite their "
        "geometry every frame and play much faster. The system still takes those pages back "
        "when it runs short of memory. Only where Blender uses jemalloc (Blender 3.x, 4.x)",
        default=True, update=_keep_memory_update)

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
        kind, _ = allocator.state()
        row = col.row()
        row.enabled = kind is not None
        row.prop(self, "keep_freed_memory")
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
        allocator.keep_freed(bool(p.keep_freed_memory))


def unregister_extra():
    allocator.keep_freed(False)  # the allocator as Blender had it


classes = (TUSSOCK_AP_preferences,)
