"""What the plain-Python tests (tests/test_*.py) share: every function of a test module whose
name starts with test_ is run in the order it is defined (or only those whose names contain a
command-line argument), a failure's traceback printed, and 'N passed, N failed' printed last,
the line ./build.sh reads."""

import sys
import traceback


def run(namespace, argv=None):
    """Runs the tests of a module's globals(); returns the exit status (1 on any failure)."""
    argv = sys.argv[1:] if argv is None else argv
    names = [n for n, v in namespace.items() if n.startswith("test_") and callable(v)]
    chosen = [n for n in names if not argv or any(a in n for a in argv)]
    failed = 0
    for name in chosen:
        try:
            namespace[name]()
            print(f"ok   {name}")
        except Exception:  # every test runs; the failure is printed and counted
            traceback.print_exc()
            print(f"FAIL {name}")
            failed += 1
    print(f"{len(chosen) - failed} passed, {failed} failed")
    return 1 if failed else 0
