"""Progress of Tussock's long interactive operators (capturing a sequence, growing a large
meadow, baking) where the artist looks for it: a line in the status bar that says what runs,
how far it is and that Esc cancels, and the cursor's progress number. STATE holds the same for
tests and scripts; it is empty ("operator" is "") when nothing runs."""

STATE = {"operator": "", "phase": "", "done": 0, "total": 0}


def begin(context, operator, phase, total):
    STATE.update(operator=operator, phase=phase, done=0, total=total)
    context.window_manager.progress_begin(0, 1000)
    _show(context, 0.0)


def update(context, done, total=None, phase=None, fraction=None):
    """`fraction` (0..1) of the whole run for the cursor, when the phases are not equal
    parts of it; else done / total."""
    STATE["done"] = done
    if total is not None:
        STATE["total"] = total
    if phase is not None:
        STATE["phase"] = phase
    if fraction is None:
        fraction = done / max(1, STATE["total"])
    _show(context, fraction)


def end(context):
    context.window_manager.progress_end()
    if context.workspace is not None:
        context.workspace.status_text_set(None)
    STATE.update(operator="", phase="", done=0, total=0)


def _show(context, fraction):
    context.window_manager.progress_update(int(1000 * min(1.0, max(0.0, fraction))))
    if context.workspace is not None:
        s = STATE
        context.workspace.status_text_set(
            f"{s['operator']}: {s['phase']} {s['done']}/{s['total']} (Esc to cancel)")
