"""Loads the compiled module _tussock. A missing or broken build never raises at
registration: it becomes one clear message that the panel shows and operators report."""

import os

HERE = os.path.dirname(os.path.abspath(__file__))
BUILD_HINT = "run ./build.sh build in the Tussock source folder, then restart Blender"
# An installed zip whose module is there but does not load (a Debian build on another
# system): the self-contained zip is the answer, not a source folder the artist lacks.
ZIP_HINT = ("install the Tussock zip made for this platform (tussock-VERSION-linux_x64.zip "
            "on Linux), which carries its own libraries, then restart Blender")

# Spinning OpenMP waiters steal the cores from Blender's own threads on small machines.
# Tussock's parallel loops run on their own sleeping threads (native/src/core/parallel.c);
# this setting reaches only OpenMP code in libraries we load (OpenCV) and only where the
# OpenMP runtime has not started yet: inside Blender it already has, so it changes nothing
# there, while outside (scripts, tests) it keeps their waiters asleep too.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

lib = None
error = ""

try:
    from . import _tussock as lib  # noqa: F401
except Exception as exc:  # ImportError, OSError from a missing shared library, ...
    lib = None
    _source = os.path.isfile(os.path.join(os.path.dirname(os.path.realpath(HERE)), "build.sh"))
    error = (f"Tussock's native library is not available ({exc.__class__.__name__}: {exc}); "
             f"{BUILD_HINT if _source else ZIP_HINT}.")

Error = lib.Error if lib is not None else RuntimeError

# OpenNI2 recordings are read by a helper program beside the library (a damaged recording
# can crash OpenNI2's player; in its own process that crash is only an error message).
# Blender unpacks add-on zips and extensions without file modes, so the program needs its
# execute bit back. Where the installed folder is read-only (a studio's shared install),
# a copy in a private temporary folder runs instead: the library spawns $TSK_ONI_READER
# when it is set (native/src/capture/depth_oni_proxy.c).
ONI_READER = os.path.join(HERE, "tussock_oni_reader")


def _private_reader_copy():
    import atexit
    import shutil
    import tempfile
    folder = tempfile.mkdtemp(prefix="tussock-")  # mode 0700, this process's alone
    atexit.register(shutil.rmtree, folder, True)
    copy = os.path.join(folder, "tussock_oni_reader")
    shutil.copyfile(ONI_READER, copy)
    os.chmod(copy, 0o700)
    # the portable build's reader finds OpenNI2 and its drivers in lib/ beside itself
    # (RPATH $ORIGIN/lib): the copy gets a link to the installed lib/
    lib = os.path.join(os.path.dirname(ONI_READER), "lib")
    if os.path.isdir(lib):
        os.symlink(lib, os.path.join(folder, "lib"))
    return copy


def _ensure_reader_executable():
    if os.environ.get("TSK_ONI_READER") or not os.path.isfile(ONI_READER) \
            or os.access(ONI_READER, os.X_OK):
        return
    try:
        os.chmod(ONI_READER, os.stat(ONI_READER).st_mode | 0o111)
        if os.access(ONI_READER, os.X_OK):
            return
    except OSError:
        pass
    try:
        os.environ["TSK_ONI_READER"] = _private_reader_copy()
    except OSError:
        pass  # nowhere to run it from: opening a recording then reports the reader missing


if lib is not None:
    _ensure_reader_executable()


class NativeMissing(RuntimeError):
    """Raised by require() when the native library could not be loaded."""


def available():
    return lib is not None


def require():
    """Returns the native module, or raises NativeMissing with the clear message."""
    if lib is None:
        raise NativeMissing(error)
    return lib


def version():
    return lib.version() if lib is not None else ""
