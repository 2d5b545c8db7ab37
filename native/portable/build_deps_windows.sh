#!/bin/bash
# Cross-builds for Windows x64, with Debian's mingw-w64 (cmake/mingw-w64-x86_64.cmake), the
# third-party libraries of the Windows build from the same Debian source packages as the
# portable Linux build (build_deps.sh, whose helpers this script sources): OpenSubdiv's CPU
# library first, then OpenCV's core, imgproc, imgcodecs and photo with the PNG, JPEG and
# OpenEXR codecs (zlib, libpng, libjpeg-turbo, Imath, OpenEXR). All static, linked into the
# test programs and _tussock.pyd. OpenNI2 is built apart (build_openni2_windows.sh), as DLLs.
#   build_deps_windows.sh SRC PREFIX
#   SRC     the folder of Debian's source packages that build_deps.sh fetched
#   PREFIX  where the results go (build.sh's windows_deps stamps it with this file's hash)
# Each library is marked built in PREFIX as it finishes (a failed run resumes there), and
# windows_tests.sh / windows_module.sh use whichever of OpenSubdiv and OpenCV are marked.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
source "$HERE/build_deps.sh" "$1" "$2" # SRC PREFIX WORK JOBS, say unpack cmake_build built mark
TOOLCHAIN="$(dirname "$HERE")/cmake/mingw-w64-x86_64.cmake"
TRIPLET=x86_64-w64-mingw32

# No glibc floor here. Every aligned vector move becomes an unaligned one, as in the
# library's own Windows build: GCC spills AVX registers with aligned moves to a stack that
# Win64 aligns to 16 bytes only (GCC bug 54412), and OpenCV dispatches to AVX2 code.
export CFLAGS="-O2 -Wa,-muse-unaligned-vector-move"
export CXXFLAGS="$CFLAGS"
export LDFLAGS=""
unset PKG_CONFIG_PATH

# cmake_build with the toolchain; PREFIX joins the toolchain's find root (which finds
# libraries, headers and packages only below its roots)
win_cmake() { # source dir, cmake args...
  local src="$1"
  shift
  cmake_build "$src" -DCMAKE_TOOLCHAIN_FILE="$TOOLCHAIN" -DCMAKE_FIND_ROOT_PATH="$PREFIX" "$@"
}

# ---- OpenSubdiv's CPU library --------------------------------------------------------------
if ! built opensubdiv; then
  say "OpenSubdiv (osdCPU) for Windows"
  d="$(unpack opensubdiv 'opensubdiv_*.orig.tar.*' 'opensubdiv_*.debian.tar.*')"
  win_cmake "$d" "${OPENSUBDIV_OPTIONS[@]}"
  mark opensubdiv
fi

# ---- zlib, libpng, libjpeg-turbo -----------------------------------------------------------
if ! built zlib; then
  say "zlib for Windows"
  d="$(unpack zlib 'zlib_*.orig.tar.*' 'zlib_*.debian.tar.*')"
  # (its configure cross-compiles for the CHOST it is given: gcc, ar of the triplet, libz.a)
  (cd "$d" && CHOST="$TRIPLET" ./configure --prefix="$PREFIX" --static >/dev/null \
    && make -j "$JOBS" libz.a >/dev/null && make install >/dev/null)
  mark zlib
fi

if ! built libpng; then
  say "libpng for Windows"
  d="$(unpack libpng 'libpng1.6_*.orig.tar.*' 'libpng1.6_*.debian.tar.*')"
  win_cmake "$d" -DPNG_SHARED=OFF -DPNG_STATIC=ON -DPNG_TESTS=OFF -DPNG_EXECUTABLES=OFF \
    -DZLIB_ROOT="$PREFIX"
  mark libpng
fi

if ! built jpeg; then
  say "libjpeg-turbo for Windows"
  d="$(unpack libjpeg-turbo 'libjpeg-turbo_*.orig.tar.*' 'libjpeg-turbo_*.debian.tar.*')"
  # No SIMD: its x86 kernels are NASM sources. Its C code gives the same bytes for the integer
  # DCT that OpenCV uses (libjpeg-turbo's own tests check both against one set of checksums).
  win_cmake "$d" -DENABLE_SHARED=OFF -DENABLE_STATIC=ON -DWITH_TURBOJPEG=OFF -DWITH_SIMD=OFF \
    -DCMAKE_INSTALL_LIBDIR="$PREFIX/lib"
  mark jpeg
fi

# ---- Imath and OpenEXR (OpenCV's EXR codec) ------------------------------------------------
if ! built imath; then
  say "Imath for Windows"
  d="$(unpack imath 'imath_*.orig.tar.*' 'imath_*.debian.tar.*')"
  win_cmake "$d" -DBUILD_TESTING=OFF -DPYTHON=OFF -DCMAKE_INSTALL_LIBDIR=lib
  mark imath
fi

if ! built openexr; then
  say "OpenEXR for Windows"
  d="$(unpack openexr 'openexr_*.orig.tar.*' 'openexr_*.debian.tar.*')"
  win_cmake "$d" -DBUILD_TESTING=OFF -DOPENEXR_BUILD_TOOLS=OFF -DOPENEXR_INSTALL_EXAMPLES=OFF \
    -DOPENEXR_INSTALL_TOOLS=OFF -DOPENEXR_ENABLE_THREADING=ON -DCMAKE_INSTALL_LIBDIR=lib
  mark openexr
fi

# ---- OpenCV: build_deps.sh's options, and no Windows GUI or media back ends -------------------
if ! built opencv; then
  say "OpenCV (core imgproc imgcodecs photo) for Windows"
  d="$(unpack opencv 'opencv_*+dfsg.orig.tar.*' 'opencv_*.debian.tar.*' \
    "${OPENCV_SKIPPED_PATCHES[@]}")"
  # (cross-built on Linux, it installs as on Linux: lib/, include/opencv4, lib/cmake/opencv4)
  win_cmake "$d" "${OPENCV_OPTIONS[@]}" -DWITH_WIN32UI=OFF -DWITH_DSHOW=OFF -DWITH_MSMF=OFF \
    -DWITH_DIRECTX=OFF
  mark opencv
fi
say "done: $PREFIX"
