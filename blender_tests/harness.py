"""Test harness for scripts that run inside `blender -b --factory-startup`: a @test
decorator, a name filter, and the closing line "N passed, N failed". Imported by every
test_*.py in this folder; run.py starts one Blender per file."""

import os
import sys
import traceback

_tests = []

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test(fn):
    _tests.append(fn)
    return fn


def args():
    """Arguments after '--' on Blender's command line."""
    return sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def enable_addon(name="tussock"):
    import addon_utils
    mod = addon_utils.enable(name, default_set=True, handle_error=_raise)
    if mod is None:
        raise RuntimeError(f"add-on {name} did not enable")
    return mod


def disable_addon(name="tussock"):
    import addon_utils
    addon_utils.disable(name, default_set=True, handle_error=_raise)


def _raise(exc):
    raise exc


def check_near(a, b, tol, what=""):
    if not abs(a - b) <= tol:
        raise AssertionError(f"{what} |{a} - {b}| = {abs(a - b)} > {tol}")


def scene_fingerprint():
    """A digest of every datablock and its key properties, to check that a cancelled
    operator left the file exactly as it was."""
    import hashlib
    return hashlib.sha256("\n".join(scene_description()).encode()).hexdigest()


def scene_description():
    """The lines that scene_fingerprint digests (printed when a check fails)."""
    import bpy
    lines = []

    class _Lines:
        def update(self, b):
            lines.append(b.decode())
    h = _Lines()
    for attr in ("objects", "meshes", "collections", "materials", "images", "node_groups",
                 "textures", "cameras", "lights", "curves", "worlds"):
        for idb in getattr(bpy.data, attr):
            h.update(f"{attr}:{idb.name}:{idb.users}".encode())
            if attr == "objects":
                h.update(repr([tuple(r) for r in idb.matrix_world]).encode())
                h.update(repr(sorted(idb.keys())).encode())
                h.update(repr([m.name for m in idb.modifiers]).encode())
            elif attr == "meshes":
                h.update(f"{len(idb.vertices)}:{len(idb.polygons)}:{len(idb.attributes)}".encode())
            elif attr == "collections":
                h.update(repr(sorted(o.name for o in idb.objects)).encode())
    for scene in bpy.data.scenes:
        h.update(repr(sorted(o.name for o in scene.objects)).encode())
        h.update(repr(sorted(c.name for c in scene.collection.children)).encode())
    return lines


def expect_cancel(op, needle, **kwargs):
    """Runs an operator that must fail: it reports an error containing `needle`, returns
    CANCELLED (raised as RuntimeError in background) and leaves the scene unchanged."""
    before = scene_description()
    try:
        result = op(**kwargs)
    except RuntimeError as exc:
        msg = str(exc)
        assert needle in msg, f"error {msg!r} lacks {needle!r}"
    else:
        raise AssertionError(f"{op} with {kwargs} returned {result}, expected an error")
    after = scene_description()
    changed = [(a, b) for a, b in zip(before, after) if a != b]
    assert before == after, f"{op} with {kwargs} changed the scene: {changed[:3]}"


def main():
    flt = os.environ.get("TSK_TEST_FILTER", "")
    passed = failed = 0
    for fn in _tests:
        if flt and flt not in fn.__name__:
            continue
        try:
            fn()
        except Exception:
            failed += 1
            print(f"FAIL {fn.__name__}")
            traceback.print_exc()
        else:
            passed += 1
            print(f"ok   {fn.__name__}")
        sys.stdout.flush()
    print(f"{passed} passed, {failed} failed")
    sys.stdout.flush()
    # Leave without running Blender's exit path with half-registered state.
    os._exit(0 if failed == 0 else 1)
