#!/usr/bin/env bash
# The native library and its tests for Windows x64: cross-built with Debian's mingw-w64
# (native/cmake/mingw-w64-x86_64.cmake) into BUILD_DIR, with the OpenSubdiv and OpenCV that
# build_deps_windows.sh cross-built and the OpenNI2 of build_openni2_windows.sh, its DLL and
# drivers copied into BUILD_DIR (build.sh's windows_deps; tests that need a library that did
# not build print "skip"), and every test_*.exe run under Debian's wine in a wine prefix of its
# own (BUILD_DIR/wine).
# Prints the per-test lines of build.sh's run_native_tests and "N passed, N failed" last;
# exits non-zero on any failure.
#   native/portable/windows_tests.sh BUILD_DIR
# Needs the Debian packages mingw-w64 and wine (wine64). CMAKE_BUILD_PARALLEL_LEVEL sets the
# compile jobs (default 2).
set -euo pipefail

[ $# -eq 1 ] || { echo "usage: $0 BUILD_DIR" >&2; exit 2; }
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
NATIVE="$(dirname "$HERE")"
mkdir -p "$1"
BUILD_DIR="$(cd "$1" && pwd)"
WINE="${WINE:-wine}"
LABEL=windows

for tool in x86_64-w64-mingw32-gcc "$WINE" cmake ninja; do
  command -v "$tool" >/dev/null || { echo "$0: $tool is missing (apt-get install mingw-w64 wine wine64 cmake ninja-build)" >&2; exit 2; }
done

# quiet, run_native_tests and windows_deps: the same as for the Linux builds
source "$(dirname "$NATIVE")/build.sh"

t0=$(date +%s)
windows_deps # WINDOWS_WITH
# configured again when the libraries at hand change
options=(-DCMAKE_TOOLCHAIN_FILE="$NATIVE/cmake/mingw-w64-x86_64.cmake" -DCMAKE_BUILD_TYPE=Release
  -DTSK_THIRD_PARTY=ON "${WINDOWS_WITH[@]}" -DTSK_PYTHON=OFF)
if [ ! -f "$BUILD_DIR/build.ninja" ] \
    || [ "$(cat "$BUILD_DIR/.options" 2>/dev/null)" != "${options[*]}" ]; then
  quiet cmake -S "$NATIVE" -B "$BUILD_DIR" -G Ninja "${options[@]}" \
    || { echo "$0: cmake configure failed ($BUILD_DIR)" >&2; exit 1; }
  printf '%s\n' "${options[*]}" >"$BUILD_DIR/.options"
fi
quiet cmake --build "$BUILD_DIR" --parallel "${CMAKE_BUILD_PARALLEL_LEVEL:-2}" \
  || { echo "$0: the Windows cross-build failed" >&2; exit 1; }
t1=$(date +%s)

# a prefix of its own, made on first use; no dialogs, no Mono or Gecko installers
export WINEPREFIX="$BUILD_DIR/wine" WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml=" DISPLAY=
trap '"${WINESERVER:-wineserver}" -k >/dev/null 2>&1 || true' EXIT

# Windows programs end their lines with \r\n; each test's "skip" lines are kept for the
# summary below
SKIPS="$BUILD_DIR/skipped.txt"
: >"$SKIPS"
wine_test() { # test program
  local out rc=0
  out="$(timeout "${TSK_WINDOWS_TEST_TIMEOUT:-1200}" "$WINE" "$1" 2>&1 | tr -d '\r'
    exit "${PIPESTATUS[0]}")" || rc=$?
  printf '%s\n' "$out" | sed -n 's/^skip //p' >>"$SKIPS"
  printf '%s\n' "$out"
  return "$rc"
}
run_native_tests "$BUILD_DIR" "$LABEL" wine_test
mapfile -t skipped <"$SKIPS"
t2=$(date +%s)

if [ "${#skipped[@]}" -gt 0 ]; then
  printf '%-8s %d tests skipped:' "$LABEL" "${#skipped[@]}"
  printf '%s\n' "${skipped[@]}" | sed -n 's/.*(\(.*\))$/\1/p' | sort | uniq -c \
    | awk '{n=$1; $1=""; printf "%s %s (%d)", (NR>1?",":""), substr($0,2), n} END {print ""}'
fi
echo "$LABEL: cross-build $((t1 - t0)) s, tests under wine $((t2 - t1)) s" >&2
echo "$PASSED passed, $FAILED failed"
[ "$FAILED" -eq 0 ]
