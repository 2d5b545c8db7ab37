"""What the plain-Python checks of the binding (native/tests/py_*.py) share: a tally of checks
that could fail, each failure printed with what it checked, and 'N passed, N failed' printed
last (the line ./build.sh reads), with the exit status to match."""
import sys

passed = failed = 0


def check(cond, what):
    global passed, failed
    if cond:
        passed += 1
    else:
        failed += 1
        print("FAIL", what)


def finish():
    print("%d passed, %d failed" % (passed, failed))
    sys.exit(1 if failed else 0)
