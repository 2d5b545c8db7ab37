"""Every application handler and timer Tussock adds goes through here, so that
unregistering removes exactly what was added and nothing leaks across enable/disable."""

import bpy

_added = []  # (list name, function)
_timers = []


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


def remove_all():
    while _added:
        list_name, fn = _added.pop()
        handler_list = getattr(bpy.app.handlers, list_name)
        while fn in handler_list:
            handler_list.remove(fn)
    while _timers:
        remove_timer(_timers[-1])
