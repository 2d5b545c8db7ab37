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
