"""Every application handler and timer Tussock adds goes through here, so that
unregistering removes exactly what was added and nothing leaks across enable/disable."""

import bpy

_added = []  # (list name, function)
_timers = []
_draws = []  # handles of SpaceView3D draw handlers


def add(list_name, fn):
    """Appends fn to bpy.app.handlers.<list_name> once."""
    handler_list = getattr(bpy.app.handlers, list_name)
    if fn not in handler_list:
        handler_list.append(fn)
        _added.append((list_name, fn))


def add_timer(fn, first_interval=0.0, persistent=False):
    if not bpy.app.timers.is_registered(fn):
        bpy.app.timers.register(fn, first_interval=first_interval, persistent=persistent)
        _timers.append(fn)


def remove_timer(fn):
    if bpy.app.timers.is_registered(fn):
        bpy.app.timers.unregister(fn)
    if fn in _timers:
        _timers.remove(fn)


def add_draw(fn):
    """fn() drawn in every 3D viewport after its scene (POST_VIEW: world-space coordinates),
    until remove_all."""
    _draws.append(bpy.types.SpaceView3D.draw_handler_add(fn, (), "WINDOW", "POST_VIEW"))


def remove_all():
    while _added:
        list_name, fn = _added.pop()
        handler_list = getattr(bpy.app.handlers, list_name)
        while fn in handler_list:
            handler_list.remove(fn)
    while _timers:
        remove_timer(_timers[-1])
    while _draws:
        bpy.types.SpaceView3D.draw_handler_remove(_draws.pop(), "WINDOW")
