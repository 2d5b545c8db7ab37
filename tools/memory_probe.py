"""What a process holds, for the leak checks of issue 42 (tools/leak_cycles.py, the soak's
memory step): resident memory, and the bytes its C allocator has handed out and not had
back.

Blender's allocator differs between builds: Debian's Blender 3.4 is linked with jemalloc,
others use glibc's malloc. Each keeps freed pages for later, so resident memory grows
where nothing leaked unless they are given back first: glibc's malloc_trim, or jemalloc's
purge of every arena (malloc_trim does nothing to jemalloc's pages). trim() does whichever
applies."""

import ctypes

_self = ctypes.CDLL(None)
_jemalloc = getattr(_self, "mallctl", None)  # jemalloc's control call, where it is malloc
ALLOCATOR = "jemalloc" if _jemalloc is not None else "glibc"
_ARENAS_ALL = 4096  # jemalloc's MALLCTL_ARENAS_ALL


def _mallctl_write(name):
    return _jemalloc(name.encode(), None, None, None, ctypes.c_size_t(0))


def _mallctl_size(name):
    value = ctypes.c_size_t(0)
    size = ctypes.c_size_t(ctypes.sizeof(value))
    if _jemalloc(name.encode(), ctypes.byref(value), ctypes.byref(size), None,
                 ctypes.c_size_t(0)) != 0:
        return None
    return value.value


def trim():
    """Gives the allocator's free pages back to the system."""
    if _jemalloc is not None:
        _mallctl_write(f"arena.{_ARENAS_ALL}.purge")
    else:
        try:
            _self.malloc_trim(0)
        except AttributeError:  # not glibc: nothing to give back this way
            pass


class _Mallinfo2(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd",
                                               "usmblks", "fsmblks", "uordblks", "fordblks",
                                               "keepcost")]


def heap_in_use():
    """Bytes the C allocator has handed out and not had back (None where it cannot say)."""
    if _jemalloc is not None:
        epoch = ctypes.c_uint64(1)
        # stats are a snapshot taken at each new epoch
        _jemalloc(b"epoch", None, None, ctypes.byref(epoch), ctypes.c_size_t(8))
        return _mallctl_size("stats.allocated")
    fn = getattr(_self, "mallinfo2", None)
    if fn is None:
        return None
    fn.restype = _Mallinfo2
    info = fn()
    return info.uordblks + info.hblkhd  # small chunks in use + mmapped chunks


def rss_bytes():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    return 0
