"""Blender's memory allocator, tuned for geometry rewritten every frame.

Debian's Blender 3.4 and 4.3 allocate through jemalloc 5, which by default gives the pages
of freed memory back to the kernel at once (`muzzy_decay_ms` 0: MADV_DONTNEED). Playing a
Tussock tree or simulated meadow frees and allocates the same tens of megabytes every frame
(Blender copies the written mesh for evaluation), so every frame faults all of those pages
back in and the kernel zeroes them: in Blender 3.4 that was most of a tree's frame
(docs/performance.md, "Tree playback").

With `muzzy_decay_ms` -1, pages that jemalloc has already released lazily (MADV_FREE) stay
mapped: the next allocation reuses them without a fault, and the kernel still takes them
back whenever it is short of memory, so nothing is held that the machine needs. The setting
is applied to every arena there is and to arenas made later; the values found are put back when the
preference is turned off or the add-on is disabled. Another allocator (Debian sid's 5.x uses
TBB's) is left alone.

Only `mallctl`, jemalloc's public control interface, is called, and only after its version
string says jemalloc 5 (whose names and value types are these)."""

import ctypes

KEEP = -1          # never purge lazily freed pages (the kernel reclaims them under pressure)

_saved = None      # the arenas' value before Tussock changed it, to put back


def _mallctl():
    """jemalloc's mallctl when it is this process's allocator (version 5), else None."""
    try:
        fn = ctypes.CDLL(None).mallctl
    except (AttributeError, OSError):
        return None
    fn.restype = ctypes.c_int
    fn.argtypes = (ctypes.c_char_p, ctypes.c_void_p, ctypes.POINTER(ctypes.c_size_t),
                   ctypes.c_void_p, ctypes.c_size_t)
    version = ctypes.c_char_p()
    size = ctypes.c_size_t(ctypes.sizeof(version))
    if fn(b"version", ctypes.byref(version), ctypes.byref(size), None, 0) != 0:
        return None
    if not (version.value or b"").startswith(b"5."):
        return None
    return fn


def _get(fn, name, ctype=ctypes.c_ssize_t):
    value = ctype()
    size = ctypes.c_size_t(ctypes.sizeof(value))
    if fn(name.encode(), ctypes.byref(value), ctypes.byref(size), None, 0) != 0:
        return None
    return value.value


def _set(fn, name, value):
    v = ctypes.c_ssize_t(value)
    return fn(name.encode(), None, None, ctypes.byref(v), ctypes.sizeof(v)) == 0


def state():
    """('jemalloc', the current muzzy decay in ms) or (None, None) for another allocator."""
    fn = _mallctl()
    if fn is None:
        return None, None
    return "jemalloc", _get(fn, "arenas.muzzy_decay_ms")


def keep_freed(on):
    """Keeps (on) or gives back at once (off: the value found before) the pages of freed
    memory. Returns True when jemalloc was found and set."""
    global _saved
    fn = _mallctl()
    if fn is None:
        return False
    if on:
        if _saved is None:
            _saved = _get(fn, "arenas.muzzy_decay_ms")
            if _saved is None:
                return False
        value = KEEP
    else:
        if _saved is None:
            return True  # never changed
        value, _saved = _saved, None
    ok = _set(fn, "arenas.muzzy_decay_ms", value)  # arenas made from now on
    # and each arena there is (jemalloc takes no "all arenas" index for this setting;
    # indices of arenas not made yet fail and are skipped)
    count = _get(fn, "arenas.narenas", ctypes.c_uint) or 0
    done = [_set(fn, f"arena.{i}.muzzy_decay_ms", value) for i in range(count)]
    return ok and any(done)
