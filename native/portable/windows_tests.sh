#!/usr/bin/env bash
# The native library and its tests for Windows x64: cross-built with Debian's mingw-w64
# (native/cmake/mingw-w64-x86_64.cmake) into BUILD_DIR, without the third-party libraries
# for now (TSK_THIRD_PARTY=OFF: tests that need OpenCV, OpenSubdiv or OpenNI2 print "skip"),
# and every test_*.exe run under Debian's wine in a wine prefix of its own (BUILD_DIR/wine).
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

quiet() { # runs a command, shows its output only if it fails
  local log rc=0
  log="$(mktemp)"
  "$@" >"$log" 2>&1 || rc=$?
  [ "$rc" -eq 0 ] || cat "$log" >&2
  rm -f "$log"
  return "$rc"
}

t0=$(date +%s)
if [ ! -f "$BUILD_DIR/build.ninja" ]; then
  quiet cmake -S "$NATIVE" -B "$BUILD_DIR" -G Ninja \
    -DCMAKE_TOOLCHAIN_FILE="$NATIVE/cmake/mingw-w64-x86_64.cmake" -DCMAKE_BUILD_TYPE=Release \
    -DTSK_THIRD_PARTY=OFF -DTSK_PYTHON=OFF \
    || { echo "$0: cmake configure failed ($BUILD_DIR)" >&2; exit 1; }
fi
quiet cmake --build "$BUILD_DIR" --parallel "${CMAKE_BUILD_PARALLEL_LEVEL:-2}" \
  || { echo "$0: the Windows cross-build failed" >&2; exit 1; }
t1=$(date +%s)

# a prefix of its own, made on first use; no dialogs, no Mono or Gecko installers
export WINEPREFIX="$BUILD_DIR/wine" WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml=" DISPLAY=
trap '"${WINESERVER:-wineserver}" -k >/dev/null 2>&1 || true' EXIT

passed=0 failed=0
skipped=()
for t in "$BUILD_DIR"/test_*.exe; do
  [ -f "$t" ] || continue
  # Windows programs end their lines with \r\n
  if out="$(cd "$BUILD_DIR" && timeout "${TSK_WINDOWS_TEST_TIMEOUT:-1200}" "$WINE" "$t" 2>&1 | tr -d '\r'; exit "${PIPESTATUS[0]}")"; then :; else
    printf '%s\n' "$out"
  fi
  line="$(printf '%s\n' "$out" | grep -E '^[0-9]+ passed, [0-9]+ failed' | tail -n 1 || true)"
  if [ -z "$line" ]; then
    printf '%s\n' "$out"
    p=0; f=1
  else
    p="${line%% passed*}"; f="${line#*passed, }"; f="${f%% failed*}"
    if [ "$f" -eq 0 ] && ! printf '%s\n' "$out" | grep -q "^$line\$"; then f=1; fi
  fi
  mapfile -t -O "${#skipped[@]}" skipped < <(printf '%s\n' "$out" | sed -n 's/^skip //p')
  printf '%-8s %-28s %s passed, %s failed\n' "$LABEL" "$(basename "$t")" "$p" "$f"
  passed=$((passed + p)); failed=$((failed + f))
done
t2=$(date +%s)

if [ "${#skipped[@]}" -gt 0 ]; then
  printf '%-8s %d tests skipped:' "$LABEL" "${#skipped[@]}"
  printf '%s\n' "${skipped[@]}" | sed -n 's/.*(\(.*\))$/\1/p' | sort | uniq -c \
    | awk '{n=$1; $1=""; printf "%s %s (%d)", (NR>1?",":""), substr($0,2), n} END {print ""}'
fi
echo "$LABEL: cross-build $((t1 - t0)) s, tests under wine $((t2 - t1)) s" >&2
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
