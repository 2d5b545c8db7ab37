"""What a process holds, for the leak checks of issue 42 (tools/leak_cycles.py, the soak's
memory step): resident memory, and the bytes its C allocator has handed out and not had
back.

Blender's allocator differs between builds: Debian's Blender 3.4 and 4.3 are linked with
jemalloc, Debian's 5.2 with TBB's scalable allocator (its proxy replaces malloc), others use
glibc's malloc. Each keeps freed pages for later, so resident memory grows where nothing
leaked unless they are given back first: jemalloc's purge of every arena, TBB's buffers
cleaned, or glibc's malloc_trim (which does nothing to the others' pages). trim() does
whichever applies."""

import ctypes

_self = ctypes.CDLL(None)
_jemalloc = getattr(_self, "mallctl", None)  # jemalloc's control call, where it is malloc
_tbb = getattr(_self, "scalable_allocation_command", None) \
    if hasattr(_self, "__TBB_malloc_proxy") else None
ALLOCATOR = "jemalloc" if _jemalloc is not None else "tbbmalloc" if _tbb is not None \
    else "glibc"
_ARENAS_ALL = 4096  # jemalloc's MALLCTL_ARENAS_ALL
_TBB_CLEAN_ALL_BUFFERS = 0  # TBBMALLOC_CLEAN_ALL_BUFFERS


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
    elif _tbb is not None:
        _tbb(ctypes.c_int(_TBB_CLEAN_ALL_BUFFERS), None)
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
    if _tbb is not None:
        return None  # TBB's allocator keeps no count of it
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
