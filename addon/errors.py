"""How a native error reaches the artist: an operator runs its work through run(), which
turns tussock.Error (and a missing build) into self.report({'ERROR'}, ...) and
{'CANCELLED'}. The work function must leave the scene untouched when it raises."""

from . import native


def run(operator, work, *args, **kwargs):
    """Calls work(*args, **kwargs) and returns its result set, or reports and cancels."""
    try:
        return work(*args, **kwargs)
    except native.NativeMissing as exc:
        operator.report({"ERROR"}, str(exc))
    except native.Error as exc:
        operator.report({"ERROR"}, f"Tussock: {exc}")
    except (ValueError, OSError) as exc:
        operator.report({"ERROR"}, f"Tussock: {exc}")
    return {"CANCELLED"}
