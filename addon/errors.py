"""How a failure reaches the artist: an operator runs its work through run(), which turns any
exception (tussock.Error, a missing build, and also a Blender API that behaves otherwise in
this version, or a bug) into self.report({'ERROR'}, ...) and {'CANCELLED'}, and removes every
datablock the work had created before it failed, so that a cancelled operator leaves no half-
built objects behind. The work function must not change existing data before it can fail;
creating new data and failing is safe. Property update callbacks and frame handlers, which
cannot report, run their work through in_update(), which puts any failure in the panel's
last_error in the same words."""

import traceback

import bpy

from . import native

# The kinds of datablock Tussock's operators create, users first: removing an object before
# its mesh lets the mesh go without a dangling user.
_CREATED = ("objects", "collections", "meshes", "curves", "hair_curves", "materials",
            "node_groups", "images", "textures", "actions", "cameras", "lights")


def snapshot():
    """Each datablock kind's members, by pointer (names can be taken over by new data). A
    modal operator takes one when it starts and, cancelled or failing in a later step,
    gives it to remove_created(), as run() does within one call."""
    return {attr: {idb.as_pointer() for idb in getattr(bpy.data, attr)}
            for attr in _CREATED if hasattr(bpy.data, attr)}


def remove_created(before):
    """Removes the datablocks that are not in `before`; returns how many."""
    new = []
    for attr, old in before.items():
        new += [idb for idb in getattr(bpy.data, attr) if idb.as_pointer() not in old]
    if new:
        bpy.data.batch_remove(new)
    return len(new)


def reraise(exc):
    """For run(): reports an exception caught elsewhere (a modal step) the same way."""
    raise exc


_KNOWN = (native.Error, ValueError, OSError)  # failures whose own words say what is wrong


def message(exc):
    """The artist's message for any exception: a known failure's or a missing build's own
    words, else an unexpected failure named with its type (its traceback printed)."""
    if isinstance(exc, (native.NativeMissing,) + _KNOWN):
        return str(exc)
    traceback.print_exception(type(exc), exc, exc.__traceback__)
    return (f"Tussock failed unexpectedly ({exc.__class__.__name__}: {exc}); "
            "nothing was changed. The system console has the details.")


def run(operator, work, *args, **kwargs):
    """Calls work(*args, **kwargs) and returns its result set, or reports and cancels."""
    before = snapshot()
    try:
        return work(*args, **kwargs)
    except Exception as exc:  # noqa: BLE001 - whatever fails, the artist's scene comes first
        text = f"Tussock: {message(exc)}" if isinstance(exc, _KNOWN) else message(exc)
    try:
        remove_created(before)
    except Exception:  # noqa: BLE001 - report the first failure, not the clean-up's
        traceback.print_exc()
    operator.report({"ERROR"}, text)
    return {"CANCELLED"}


def in_update(settings, work, *args, clear=True):
    """Runs a property update callback's work. An update callback cannot report, and an
    exception out of it is only a console traceback: any failure goes to
    `settings.last_error` instead (the panel shows it), worded as run() words it; success
    clears it when `clear` (work that redoes what last_error is about). Returns True on
    success."""
    try:
        work(*args)
    except Exception as exc:  # noqa: BLE001 - never a traceback out of an update callback
        text = message(exc)
        if settings.last_error != text:
            settings.last_error = text
        return False
    if clear and settings.last_error:
        settings.last_error = ""
    return True
