"""A block of a document that a tool makes (the performance table, the module map): it sits
between a begin and an end marker line, is remade from its source with `write`, and `check`
fails when the document holds anything else there, so the document cannot fall behind."""

import sys


def splice(text, begin, end, body, where):
    """`text` with everything between the `begin` and `end` markers replaced by `body`."""
    if begin not in text or end not in text:
        raise ValueError(f"{where} has no '{begin}' … '{end}' lines")
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    return f"{head}{begin}\n{body}\n{end}{tail}"


def write_or_check(cmd, path, remake, stale):
    """`write`: remakes the block of the document at `path` (`remake(text)` gives the new
    text); `check`: exit status 1, printing `stale`, when the document is not what `remake`
    gives. Returns the exit status."""
    with open(path, encoding="utf-8") as f:
        text = f.read()
    new = remake(text)
    if new == text:
        return 0
    if cmd == "write":
        with open(path, "w", encoding="utf-8") as f:
            f.write(new)
        return 0
    print(stale, file=sys.stderr)
    return 1
