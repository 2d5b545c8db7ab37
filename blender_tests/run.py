#!/usr/bin/python3
"""Runs every blender_tests/test_*.py in its own background Blender
(`blender -b --factory-startup`), so a crash in one file is that file's failure and not a
lost suite; test_window_*.py files run in a real Blender window on Xvfb instead. Each Blender
gets a fresh user folder whose addons/tussock links to addon/ (tools/blender_env.py).
Prints per-file results and, last, "N passed, N failed"; exits non-zero on any failure.

usage: run.py [NAME_FILTER ...]   (environment: BLENDER, TSK_TEST_TIMEOUT seconds,
TSK_TEST_FILTER: only tests whose name holds it, TSK_TEST_VERBOSE=1: every file's output)"""

import glob
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(REPO, "tools"))
import blender_env  # noqa: E402

SUMMARY = re.compile(r"^(\d+) passed, (\d+) failed", re.M)


def run_file(path, timeout):
    start = time.time()
    with blender_env.BlenderUser() as user:
        try:
            window = os.path.basename(path).startswith("test_window_")
            proc = subprocess.run(blender_env.command(path, [REPO], window=window), env=user.env,
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                  timeout=timeout, text=True, errors="replace")
            out, code = proc.stdout, proc.returncode
        except subprocess.TimeoutExpired as exc:
            out = exc.stdout.decode(errors="replace") if isinstance(exc.stdout, bytes) \
                else (exc.stdout or "")
            out += f"\nTIMEOUT after {timeout} s\n"
            code = -1
    return out, code, time.time() - start


def main():
    timeout = float(os.environ.get("TSK_TEST_TIMEOUT", "900"))
    filters = sys.argv[1:]
    files = sorted(glob.glob(os.path.join(HERE, "test_*.py")))
    if filters:
        files = [f for f in files if any(x in os.path.basename(f) for x in filters)]
    total_p = total_f = 0
    version = subprocess.run([os.environ.get("BLENDER", "blender"), "--version"],
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                             errors="replace").stdout.strip().splitlines()
    print(f"{version[0] if version else 'Blender (no version printed)'} "
          f"(add-on: {blender_env.ADDON})")
    for path in files:
        name = os.path.basename(path)
        out, code, secs = run_file(path, timeout)
        found = SUMMARY.findall(out)
        p, f = (int(found[-1][0]), int(found[-1][1])) if found else (0, 0)
        if code != 0 and f == 0:
            f = 1  # crashed, timed out or failed outside a test: count the file as a failure
        if f or code != 0 or os.environ.get("TSK_TEST_VERBOSE") == "1":
            sys.stdout.write(out)
        print(f"{name}: {p} passed, {f} failed ({secs:.1f} s, exit {code})")
        sys.stdout.flush()
        total_p += p
        total_f += f
    print(f"{total_p} passed, {total_f} failed")
    return 0 if total_f == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
