#!/bin/bash
# Cross-builds OpenNI2 for Windows x64 with Debian's mingw-w64 (cmake/mingw-w64-x86_64.cmake),
# from the Debian source package that the portable Linux build uses (build_deps.sh, whose
# helpers this script sources): Debian's patches as there, then ours for mingw-w64
# (openni2_windows/*.patch, each saying why), built by our CMake file in place of upstream's
# Visual Studio projects (openni2_windows/CMakeLists.txt): OpenNI2.dll and the drivers
# DummyDevice, OniFile, PS1080 and PSLink, each needing Windows's own DLLs only.
#   build_openni2_windows.sh SRC PREFIX
#   SRC     the folder of Debian's source packages that build_deps.sh fetched
#   PREFIX  where the results go (build.sh's windows_deps stamps it with the hash of this
#           script, openni2_windows/ and the toolchain file): bin/OpenNI2.dll,
#           bin/OpenNI2/Drivers/*.dll, lib/libOpenNI2.dll.a, include/openni2/
# A live PS1080 or PSLink camera on Windows also needs PrimeSense's USB driver (psdrv3.sys,
# which XnLib's Win32 USB layer talks to); this build does not install it.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
source "$HERE/build_deps.sh" "$1" "$2" # SRC PREFIX WORK JOBS, say unpack built mark
TOOLCHAIN="$(dirname "$HERE")/cmake/mingw-w64-x86_64.cmake"

# As build_deps_windows.sh: no glibc floor, and every aligned vector move an unaligned one
# (GCC spills AVX registers with aligned moves to a stack Win64 aligns to 16 bytes only, GCC
# bug 54412)
export CFLAGS="-O2 -Wa,-muse-unaligned-vector-move"
export CXXFLAGS="$CFLAGS"
export LDFLAGS=""
unset PKG_CONFIG_PATH

if ! built openni2; then
  say "OpenNI2 (core and drivers) for Windows"
  # 0002 points the configuration at /etc/openni2, as in build_deps.sh (and Windows has none)
  d="$(unpack openni2 'openni2_*.orig.tar.*' 'openni2_*.debian.tar.*' \
    0002-Change-path-of-config-files-to-etc-openni2.patch)"
  for p in "$HERE"/openni2_windows/*.patch; do
    patch -d "$d" -p1 -s -N -f <"$p" >/dev/null
  done
  # (not build_deps.sh's cmake_build: the CMake file is ours, the sources are elsewhere;
  # Release at -O2 as OpenNI2's own makefiles build it)
  cmake -S "$HERE/openni2_windows" -B "$WORK/openni2-build" -G Ninja \
    -DCMAKE_TOOLCHAIN_FILE="$TOOLCHAIN" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_C_FLAGS_RELEASE="-DNDEBUG" -DCMAKE_CXX_FLAGS_RELEASE="-DNDEBUG" \
    -DCMAKE_INSTALL_PREFIX="$PREFIX" -DOPENNI2_SOURCE="$d" >/dev/null
  cmake --build "$WORK/openni2-build" -j "$JOBS"
  cmake --install "$WORK/openni2-build" >/dev/null
  mark openni2
fi
say "done: $PREFIX"
