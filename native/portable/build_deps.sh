#!/bin/bash
# Builds, inside the Debian 11 (bullseye, glibc 2.31) root, the libraries that the portable
# Linux extension carries, from Debian's own source packages (apt-get source): OpenCV's
# core, imgproc, imgcodecs and photo with the codecs Tussock reads and writes (PNG, JPEG,
# OpenEXR with Imath, zlib), OpenSubdiv's CPU library, and OpenNI2 with its drivers (and
# libusb, built without udev). build.sh runs it as `build_deps.sh SRC PREFIX`:
#   SRC     a folder for the downloaded source packages (kept between runs)
#   PREFIX  where the results go (kept between runs; build.sh stamps it with this file's hash)
#
# Everything except OpenNI2 is built static and position-independent, to be linked into
# _tussock.abi3.so with its symbols hidden: Blender itself loads OpenSubdiv (and, through
# OpenImageIO, often OpenCV and OpenEXR) under the same sonames, and a second copy of a
# library with the same soname would be the first one to the dynamic loader. OpenNI2 stays
# a shared library because it loads its drivers from the folder beside itself at run time.
# Every file is compiled with glibc_floor.h force-included (symbol versions ≤ GLIBC_2.28).
#
# Sources: the versions of Debian 12 (bookworm), so the portable build computes with the
# same OpenCV and OpenSubdiv as the Debian 12 build the tests compare it with.
set -euo pipefail

SRC="$1"
PREFIX="$2"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
JOBS="${TSK_JOBS:-$(nproc)}"
WORK="$PREFIX.work"
FLOOR="$HERE/glibc_floor.h"

say() { printf 'build_deps: %s\n' "$*" >&2; }

export CFLAGS="-O2 -fPIC -include $FLOOR"
export CXXFLAGS="-O2 -fPIC -include $FLOOR"
export LDFLAGS=""
export PKG_CONFIG_PATH="$PREFIX/lib/pkgconfig"

mkdir -p "$SRC" "$WORK" "$PREFIX"
cd "$WORK" # some of these builds resolve relative install paths against the current folder

# A run that failed half-way resumes after the last library it finished (build.sh empties
# PREFIX when this script or glibc_floor.h changes).
built() { [ -f "$PREFIX/.built-$1" ]; }
mark() { touch "$PREFIX/.built-$1"; }

# ---- sources -----------------------------------------------------------------------------
# The root's apt lists bookworm's (and sid's) source indexes beside bullseye's binaries
# (build.sh writes them). Some mirrors lack a file of one revision; a package is complete
# when its orig tarball and a debian tarball are here.
fetch() { # package [suite...]
  local p="$1" s
  shift
  for s in "$@"; do
    (cd "$SRC" && apt-get source -qq --download-only "$p/$s" >/dev/null 2>&1) || true
  done
}
need() { # glob...: the first file matching, or fail
  local g f
  for g in "$@"; do
    for f in $SRC/$g; do
      if [ -f "$f" ]; then printf '%s\n' "$f"; return 0; fi
    done
  done
  say "missing source file: $*"
  exit 1
}

# Unpacks orig + debian tarballs into $WORK/NAME and applies debian/patches/series, leaving
# out the patches named after the globs (those for parts we do not build, or that point
# paths at /etc).
unpack() { # name orig-glob debian-glob [patch-to-skip...]
  local name="$1" orig deb dir p
  orig="$(need "$2")"
  deb="$(need "$3")"
  shift 3
  dir="$WORK/$name"
  rm -rf "$dir" "$dir.tmp"
  mkdir -p "$dir.tmp"
  tar -xf "$orig" -C "$dir.tmp"
  mv "$dir.tmp"/* "$dir"
  rm -rf "$dir.tmp"
  tar -xf "$deb" -C "$dir"
  if [ -f "$dir/debian/patches/series" ]; then
    while read -r p _; do
      case "$p" in ''|'#'*) continue ;; esac
      local skip=0 s
      for s in "$@"; do [ "$s" = "$p" ] && skip=1; done
      [ "$skip" = 1 ] && continue
      patch -d "$dir" -p1 -s -N -f <"$dir/debian/patches/$p" >/dev/null
    done <"$dir/debian/patches/series"
  fi
  printf '%s\n' "$dir"
}

cmake_build() { # source dir, cmake args...
  local src="$1"
  shift
  cmake -S "$src" -B "$src/_build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_INSTALL_PREFIX="$PREFIX" -DCMAKE_PREFIX_PATH="$PREFIX" \
    -DCMAKE_POSITION_INDEPENDENT_CODE=ON -DBUILD_SHARED_LIBS=OFF "$@" >/dev/null
  cmake --build "$src/_build" -j "$JOBS" >/dev/null
  cmake --install "$src/_build" >/dev/null
}

# OpenCV's options here and in build_deps_windows.sh: the four modules Tussock uses, no GUI,
# video, GDAL or other codecs; CPU baseline and optimisation as Debian's own build sets them
# (debian/rules): the same code paths, so that results match the Debian build's bytes
OPENCV_OPTIONS=(
  -DBUILD_LIST=core,imgproc,imgcodecs,photo -DCPU_BASELINE=SSE2 -DCPU_BASELINE_DISABLE=SSE3
  -DCMAKE_CXX_FLAGS_RELEASE="-O2" -DCMAKE_C_FLAGS_RELEASE="-O2" -DBUILD_ZLIB=OFF
  -DBUILD_PNG=OFF -DBUILD_JPEG=OFF -DBUILD_OPENEXR=OFF -DBUILD_TIFF=OFF -DBUILD_WEBP=OFF
  -DBUILD_JASPER=OFF -DBUILD_OPENJPEG=OFF -DBUILD_PROTOBUF=OFF -DWITH_PNG=ON -DWITH_JPEG=ON
  -DWITH_OPENEXR=ON -DWITH_TIFF=OFF -DWITH_WEBP=OFF -DWITH_JASPER=OFF -DWITH_OPENJPEG=OFF
  -DWITH_GDAL=OFF -DWITH_GDCM=OFF -DWITH_IMGCODEC_HDR=ON -DWITH_GTK=OFF -DWITH_QT=OFF
  -DWITH_OPENGL=OFF -DWITH_VTK=OFF -DWITH_FFMPEG=OFF -DWITH_GSTREAMER=OFF -DWITH_V4L=OFF
  -DWITH_1394=OFF -DWITH_OPENCL=OFF -DWITH_IPP=OFF -DWITH_ITT=OFF -DWITH_TBB=OFF
  -DWITH_OPENMP=OFF -DWITH_EIGEN=OFF -DWITH_LAPACK=OFF -DWITH_PROTOBUF=OFF -DWITH_QUIRC=OFF
  -DWITH_ADE=OFF -DWITH_VA=OFF -DWITH_VA_INTEL=OFF -DWITH_CAROTENE=OFF -DWITH_OPENVX=OFF
  -DWITH_CUDA=OFF -DBUILD_TESTS=OFF -DBUILD_PERF_TESTS=OFF -DBUILD_EXAMPLES=OFF
  -DBUILD_DOCS=OFF -DBUILD_opencv_apps=OFF -DBUILD_JAVA=OFF -DBUILD_opencv_python2=OFF
  -DBUILD_opencv_python3=OFF -DOPENCV_GENERATE_PKGCONFIG=OFF -DOPENCV_FORCE_3RDPARTY_BUILD=OFF
  -DCMAKE_INSTALL_LIBDIR=lib -DOPENCV_LIB_INSTALL_PATH=lib -DOPENCV_3P_LIB_INSTALL_PATH=lib
  -DZLIB_ROOT="$PREFIX" -DOpenEXR_DIR="$PREFIX/lib/cmake/OpenEXR"
)
# (three of Debian's patches are for opencv_contrib, which we do not build)
OPENCV_SKIPPED_PATCHES=(
  0005-Fix-building-error-with-OGRE-1.12.9.patch
  0009-fix-wechat_qrcode-Init-nBytes-after-the-count-value-.patch
  0010-fix-wechat_qrcode-fixed-memory-leaks.patch
)
# OpenSubdiv's: the CPU library alone
OPENSUBDIV_OPTIONS=(
  -DNO_EXAMPLES=ON -DNO_TUTORIALS=ON -DNO_REGRESSION=ON -DNO_DOC=ON -DNO_TESTS=ON
  -DNO_GLTESTS=ON -DNO_PTEX=ON -DNO_TBB=ON -DNO_OMP=ON -DNO_CUDA=ON -DNO_OPENCL=ON -DNO_CLEW=ON
  -DNO_OPENGL=ON -DNO_GLEW=ON -DNO_GLFW=ON -DNO_DX=ON -DNO_METAL=ON -DNO_MACOS_FRAMEWORK=ON
  -DNO_GPU=ON -DCMAKE_INSTALL_LIBDIR=lib
)

# build_deps_windows.sh sources this file for the helpers above, with its own flags
[ "${BASH_SOURCE[0]}" = "$0" ] || return 0

say "fetching Debian source packages into $SRC"
for p in zlib libpng1.6 libjpeg-turbo imath openexr opencv opensubdiv libusb-1.0; do
  fetch "$p" bookworm
done
fetch openni2 bookworm sid

# ---- zlib, libpng, libjpeg-turbo -----------------------------------------------------------
if ! built zlib; then
  say "zlib"
  d="$(unpack zlib 'zlib_*.orig.tar.*' 'zlib_*.debian.tar.*')"
  (cd "$d" && ./configure --prefix="$PREFIX" --static >/dev/null && make -j "$JOBS" >/dev/null \
    && make install >/dev/null)
  mark zlib
fi

if ! built libpng; then
  say "libpng"
  d="$(unpack libpng 'libpng1.6_*.orig.tar.*' 'libpng1.6_*.debian.tar.*')"
  cmake_build "$d" -DPNG_SHARED=OFF -DPNG_STATIC=ON -DPNG_TESTS=OFF -DPNG_EXECUTABLES=OFF \
    -DZLIB_ROOT="$PREFIX"
  mark libpng
fi

if ! built jpeg; then
  say "libjpeg-turbo"
  d="$(unpack libjpeg-turbo 'libjpeg-turbo_*.orig.tar.*' 'libjpeg-turbo_*.debian.tar.*')"
  # (an absolute libdir: libjpeg-turbo resolves a relative one against the current folder)
  cmake_build "$d" -DENABLE_SHARED=OFF -DENABLE_STATIC=ON -DWITH_TURBOJPEG=OFF \
    -DCMAKE_INSTALL_LIBDIR="$PREFIX/lib"
  mark jpeg
fi

# ---- Imath and OpenEXR (OpenCV's EXR codec) ------------------------------------------------
if ! built imath; then
  say "Imath"
  d="$(unpack imath 'imath_*.orig.tar.*' 'imath_*.debian.tar.*')"
  cmake_build "$d" -DBUILD_TESTING=OFF -DPYTHON=OFF -DCMAKE_INSTALL_LIBDIR=lib
  mark imath
fi

if ! built openexr; then
  say "OpenEXR"
  d="$(unpack openexr 'openexr_*.orig.tar.*' 'openexr_*.debian.tar.*')"
  cmake_build "$d" -DBUILD_TESTING=OFF -DOPENEXR_BUILD_TOOLS=OFF -DOPENEXR_INSTALL_EXAMPLES=OFF \
    -DOPENEXR_INSTALL_TOOLS=OFF -DOPENEXR_ENABLE_THREADING=ON -DCMAKE_INSTALL_LIBDIR=lib
  mark openexr
fi

# ---- OpenCV: the four modules Tussock uses, no GUI, video, GDAL or other codecs --------------
if ! built opencv; then
  say "OpenCV (core imgproc imgcodecs photo)"
  d="$(unpack opencv 'opencv_*+dfsg.orig.tar.*' 'opencv_*.debian.tar.*' \
    "${OPENCV_SKIPPED_PATCHES[@]}")"
  cmake_build "$d" "${OPENCV_OPTIONS[@]}"
  mark opencv
fi

# ---- OpenSubdiv's CPU library --------------------------------------------------------------
if ! built opensubdiv; then
  say "OpenSubdiv (osdCPU)"
  d="$(unpack opensubdiv 'opensubdiv_*.orig.tar.*' 'opensubdiv_*.debian.tar.*')"
  cmake_build "$d" "${OPENSUBDIV_OPTIONS[@]}"
  mark opensubdiv
fi

# ---- libusb (static, no udev) and OpenNI2 with its drivers ---------------------------------
if ! built libusb; then
  say "libusb"
  d="$(unpack libusb 'libusb-1.0_*.orig.tar.*' 'libusb-1.0_*.debian.tar.*')"
  (cd "$d" && ./configure --prefix="$PREFIX" --disable-shared --enable-static --disable-udev \
    >/dev/null && make -j "$JOBS" >/dev/null && make install >/dev/null)
  mark libusb
fi

if ! built openni2; then
  say "OpenNI2 (core and drivers)"
  # 0002 points the configuration at /etc/openni2 (the portable copy reads its own folder);
  # 0004 only drops rpaths of programs we do not build.
  d="$(unpack openni2 'openni2_*.orig.tar.*' 'openni2_*.debian.tar.*' \
    0002-Change-path-of-config-files-to-etc-openni2.patch)"
  # Without libudev (outside the base system a binary may need, and different on every
  # distribution): XnLib enumerates USB devices through libusb alone, its non-udev path.
  sed -i -e 's|^#include <libudev.h>|/* no libudev in the portable build */|' \
    -e 's|^#define XN_USE_UDEV$||' "$d/ThirdParty/PSCommon/XnLib/Source/Linux/XnLinuxUSB.cpp"
  sed -i -e 's/ udev$//' -e 's/ udev / /' "$d/ThirdParty/PSCommon/XnLib/Source/Makefile" \
    "$d/Source/Drivers/PS1080/Makefile" "$d/Source/Drivers/PSLink/Makefile"
  # (flags through the environment: OpenNI2's makefiles append to CFLAGS and LDFLAGS, which a
  # command-line assignment would replace)
  oni_make() {
    CFLAGS="$CFLAGS -I$PREFIX/include -Wno-error" LDFLAGS="-L$PREFIX/lib -static-libstdc++" \
      make -C "$d" ALLOW_WARNINGS=1 "$@" >/dev/null
  }
  oni_make ThirdParty/PSCommon/XnLib/Source
  oni_make Source/Core
  oni_make Source/DepthUtils
  oni_make Source/Drivers/DummyDevice Source/Drivers/OniFile Source/Drivers/PS1080 \
    Source/Drivers/PSLink
  bin="$(echo "$d"/Bin/x64-Release)"
  mkdir -p "$PREFIX/openni2/OpenNI2/Drivers" "$PREFIX/include/openni2"
  cp "$bin/libOpenNI2.so" "$PREFIX/openni2/libOpenNI2.so.0"
  for drv in DummyDevice OniFile PS1080 PSLink; do # Debian's OpenNI2 loads lib*.so.0 (0001)
    cp "$bin/OpenNI2/Drivers/lib$drv.so" "$PREFIX/openni2/OpenNI2/Drivers/lib$drv.so.0"
  done
  cp -r "$d"/Include/* "$PREFIX/include/openni2/"
  mark openni2
fi
say "done: $PREFIX"
