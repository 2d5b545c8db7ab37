"""How a failure reaches the artist: an operator runs its work through run(), which turns any
exception (tussock.Error, a missing build, and also a Blender API that behaves otherwise in
this version, or a bug) into self.report({'ERROR'}, ...) and {'CANCELLED'}, and removes every
datablock the work had created before it failed, so that a cancelled operator leaves no half-
built objects behind. The work function must not change existing data before it can fail;
creating new data and failing is safe."""

import traceback

import bpy

from . import native

# The kinds of datablock Tussock's operators create, users first: removing an object before
# its mesh lets the mesh go without a dangling user.
_CREATED = ("objects", "collections", "meshes", "curves", "hair_curves", "materials",
            "node_groups", "images", "textures", "actions", "cameras", "lights")


def _snapshot():
    """Each datablock kind's members, by pointer (names can be taken over by new data)."""
    return {attr: {idb.as_pointer() for idb in getattr(bpy.data, attr)}
            for attr in _CREATED if hasattr(bpy.data, attr)}


def _remove_created(before):
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


def run(operator, work, *args, **kwargs):
    """Calls work(*args, **kwargs) and returns its result set, or reports and cancels."""
    before = _snapshot()
    try:
        return work(*args, **kwargs)
    except native.NativeMissing as exc:
        message = str(exc)
    except native.Error as exc:
        message = f"Tussock: {exc}"
    except (ValueError, OSError) as exc:
        message = f"Tussock: {exc}"
    except Exception as exc:  # noqa: BLE001 - whatever fails, the artist's scene comes first
        traceback.print_exc()
        message = f"Tussock failed unexpectedly ({exc.__class__.__name__}: {exc}); " \
                  "nothing was changed. The system console has the details."
    try:
        _remove_created(before)
    except Exception:  # noqa: BLE001 - report the first failure, not the clean-up's
        traceback.print_exc()
    operator.report({"ERROR"}, message)
    return {"CANCELLED"}
