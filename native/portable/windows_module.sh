#!/usr/bin/env bash
# The binding for Windows x64: _tussock.pyd cross-built with Debian's mingw-w64 against
# python3.dll (the stable ABI, which every Python 3 for Windows ships, Blender's included),
# with the OpenSubdiv and OpenCV that build_deps_windows.sh cross-built (build.sh's
# windows_deps) linked in statically, and the windows_x64 zip. With the OpenNI2 of
# build_openni2_windows.sh, the zip carries OpenNI2.dll beside the .pyd (Python's importer
# searches the .pyd's folder for the DLLs it imports), its drivers in OpenNI2/Drivers beside
# that (where OpenNI2.dll looks for them), and tussock_oni_reader.exe beside both (the library
# starts it from its own folder, and Windows finds the reader's OpenNI2.dll in the same one).
# CPython's Windows headers (Include/ and PC/pyconfig.h) come from Debian's python3.11 source
# package; python3.dll's import library is made from the list of its exports in that source
# (PC/python3dll.c) with mingw-w64's dlltool. The import table of the .pyd is checked by
# tools/binary_floor.py: python3.dll, the zip's own DLLs and Windows's; and under wine the .pyd is
# loaded as Python's importer loads it, beside a stand-in python3.dll that exports the stable
# ABI's names (native/portable/wine/pyd_load.c), so Windows's loader resolves every import and
# runs its start-up code. No Python for Windows is at hand to call PyInit__tussock.
#   native/portable/windows_module.sh BUILD_DIR PYTHON_ORIG_TARBALL DIST
# Prints a line per check and "N passed, N failed" last; exits non-zero on a failure.
set -euo pipefail

[ $# -eq 3 ] || { echo "usage: $0 BUILD_DIR PYTHON_ORIG_TARBALL DIST" >&2; exit 2; }
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
NATIVE="$(dirname "$HERE")"
REPO="$(dirname "$NATIVE")"
mkdir -p "$1" "$3"
BUILD_DIR="$(cd "$1" && pwd)"
DIST="$(cd "$3" && pwd)"
TARBALL="$2"
PY="${PY:-/usr/bin/python3}"

for tool in x86_64-w64-mingw32-gcc x86_64-w64-mingw32-dlltool cmake ninja "${WINE:-wine}"; do
  command -v "$tool" >/dev/null || { echo "$0: $tool is missing (apt-get install mingw-w64 cmake ninja-build)" >&2; exit 2; }
done

source "$REPO/build.sh" # quiet, windows_deps

# CPython's headers for Windows, and python3.dll's exports
CPY="$BUILD_DIR/cpython"
if [ ! -f "$CPY/.from" ] || [ "$(cat "$CPY/.from")" != "$(basename "$TARBALL")" ]; then
  rm -rf "$CPY"
  mkdir -p "$CPY"
  tar xzf "$TARBALL" -C "$CPY" --strip-components=1 --wildcards '*/Include/*' \
    '*/PC/pyconfig.h' '*/PC/python3dll.c'
  basename "$TARBALL" >"$CPY/.from"
fi
# EXPORT_FUNC(name) and EXPORT_DATA(name) lines: the stable ABI's functions and data
{
  echo "LIBRARY python3.dll"
  echo "EXPORTS"
  sed -n 's/^EXPORT_FUNC(\([A-Za-z0-9_]*\))$/    \1/p; s/^EXPORT_DATA(\([A-Za-z0-9_]*\))$/    \1 DATA/p' \
    "$CPY/PC/python3dll.c"
} >"$BUILD_DIR/python3.def"
n="$(grep -c '^    ' "$BUILD_DIR/python3.def")"
[ "$n" -gt 500 ] || { echo "$0: only $n exports read from PC/python3dll.c" >&2; exit 1; }
x86_64-w64-mingw32-dlltool -d "$BUILD_DIR/python3.def" -l "$BUILD_DIR/libpython3.a" -D python3.dll

B="$BUILD_DIR/build"
windows_deps # WINDOWS_WITH
# configured again when the libraries at hand change
options=(-DCMAKE_TOOLCHAIN_FILE="$NATIVE/cmake/mingw-w64-x86_64.cmake" -DCMAKE_BUILD_TYPE=Release
  -DTSK_THIRD_PARTY=ON "${WINDOWS_WITH[@]}" -DTSK_PYTHON=ON
  "-DTSK_PYTHON_INCLUDE=$CPY/Include;$CPY/PC" "-DTSK_PYTHON_LIBRARY=$BUILD_DIR/libpython3.a")
if [ ! -f "$B/build.ninja" ] || [ "$(cat "$B/.options" 2>/dev/null)" != "${options[*]}" ]; then
  quiet cmake -S "$NATIVE" -B "$B" -G Ninja "${options[@]}" \
    || { echo "$0: cmake configure failed ($B)" >&2; exit 1; }
  printf '%s\n' "${options[*]}" >"$B/.options"
fi
with_openni2=0
case " ${WINDOWS_WITH[*]} " in *" -DTSK_WITH_OPENNI2=ON "*) with_openni2=1 ;; esac
targets=(_tussock)
[ "$with_openni2" = 0 ] || targets+=(tussock_oni_reader openni2_runtime)
quiet cmake --build "$B" --target "${targets[@]}" --parallel "${CMAKE_BUILD_PARALLEL_LEVEL:-2}" \
  || { echo "$0: the Windows module failed to build" >&2; exit 1; }
quiet x86_64-w64-mingw32-strip --strip-unneeded "$B/_tussock.pyd"

# the add-on folder as it ships: the sources, and the module in place of the Linux one
A="$BUILD_DIR/addon"
rm -rf "$A"
mkdir -p "$A"
for e in "$REPO"/addon/*; do
  name="${e##*/}"
  case "$name" in _tussock*.so|tussock_oni_reader|__pycache__) continue ;; esac
  ln -s "$e" "$A/$name"
done
cp "$B/_tussock.pyd" "$A/_tussock.pyd"
if [ "$with_openni2" = 1 ]; then
  mkdir -p "$A/OpenNI2/Drivers"
  cp "$B/tussock_oni_reader.exe" "$B/OpenNI2.dll" "$A/"
  cp "$B"/OpenNI2/Drivers/*.dll "$A/OpenNI2/Drivers/"
  # (the copies only: the build folder keeps its symbols for a debugger)
  quiet x86_64-w64-mingw32-strip --strip-unneeded "$A/tussock_oni_reader.exe" "$A/OpenNI2.dll" \
    "$A"/OpenNI2/Drivers/*.dll
fi
"$PY" "$REPO/tools/package.py" "$REPO" "$DIST" "$A" --platform windows_x64 >/dev/null \
  || { echo "$0: packaging the windows_x64 zip failed" >&2; exit 1; }
zip="$(ls -t "$DIST"/*-windows_x64.zip | head -n 1)"

passed=0 failed=0
check() { # name, command...: one line, and the command's output when it fails
  local name="$1" out
  shift
  if out="$("$@" 2>&1)"; then
    passed=$((passed + 1))
    printf '%-8s %-28s 1 passed, 0 failed\n' windows "$name"
  else
    failed=$((failed + 1))
    printf '%s\n' "$out"
    printf '%-8s %-28s 0 passed, 1 failed\n' windows "$name"
  fi
}
check "pyd imports (binary_floor)" "$PY" "$REPO/tools/binary_floor.py" "$zip"

# the stand-in python3.dll: a function or a variable for each export, nothing more
L="$BUILD_DIR/load"
mkdir -p "$L"
awk '/^    /{ if ($2 == "DATA") printf "__declspec(dllexport) int %s;\n", $1;
               else printf "__declspec(dllexport) void %s(void) {}\n", $1 }' \
  "$BUILD_DIR/python3.def" >"$L/python3_stand_in.c"
x86_64-w64-mingw32-gcc -shared -o "$L/python3.dll" "$L/python3_stand_in.c"
x86_64-w64-mingw32-gcc -municode -O2 -Wall -Werror -o "$L/pyd_load.exe" "$HERE/wine/pyd_load.c"
cp "$B/_tussock.pyd" "$L/"
[ "$with_openni2" = 0 ] || cp "$A/OpenNI2.dll" "$L/" # (what the .pyd imports beside python3.dll)
export WINEPREFIX="$BUILD_DIR/wine" WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml=" DISPLAY=
trap '"${WINESERVER:-wineserver}" -k >/dev/null 2>&1 || true' EXIT
check "pyd loads under wine" "${WINE:-wine}" "$L/pyd_load.exe" "$L/_tussock.pyd" PyInit__tussock
if [ "$with_openni2" = 1 ]; then
  # OpenNI2's drivers as shipped, loaded as OpenNI2.dll loads them (their imports resolved,
  # their start-up code run), and the reader started: it prints its usage when run by hand
  drivers_load() {
    local d
    for d in "$A"/OpenNI2/Drivers/*.dll; do
      "${WINE:-wine}" "$L/pyd_load.exe" "$d" oniDriverCreate || return 1
    done
  }
  check "OpenNI2 drivers load (wine)" drivers_load
  reader_runs() {
    local out
    out="$("${WINE:-wine}" "$A/tussock_oni_reader.exe" 2>&1)" || true
    printf '%s\n' "$out"
    printf '%s\n' "$out" | grep -q "usage: "
  }
  check "oni reader starts (wine)" reader_runs
fi

echo "windows_x64 zip: $zip ($(du -k "$zip" | cut -f1) KiB)" >&2
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
