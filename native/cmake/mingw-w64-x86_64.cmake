# Cross-compiling the native library for Windows x64 with Debian's mingw-w64 (package
# mingw-w64): cmake -DCMAKE_TOOLCHAIN_FILE=native/cmake/mingw-w64-x86_64.cmake ...
# native/portable/windows_tests.sh builds with it and runs the tests under wine.
set(CMAKE_SYSTEM_NAME Windows)
set(CMAKE_SYSTEM_PROCESSOR x86_64)

# The posix thread model of Debian's two (posix, win32): its libstdc++ has std::thread and
# std::mutex, which the C++ bridges and OpenCV use; pthread.h (winpthreads) is there in both.
set(TSK_MINGW_TRIPLET x86_64-w64-mingw32)
find_program(CMAKE_C_COMPILER NAMES ${TSK_MINGW_TRIPLET}-gcc-posix ${TSK_MINGW_TRIPLET}-gcc
             REQUIRED)
find_program(CMAKE_CXX_COMPILER NAMES ${TSK_MINGW_TRIPLET}-g++-posix ${TSK_MINGW_TRIPLET}-g++
             REQUIRED)
find_program(CMAKE_RC_COMPILER NAMES ${TSK_MINGW_TRIPLET}-windres)

# Headers, libraries and CMake packages come from the mingw-w64 root (and from prefixes
# given in CMAKE_PREFIX_PATH / CMAKE_FIND_ROOT_PATH); programs from the build machine.
list(APPEND CMAKE_FIND_ROOT_PATH /usr/${TSK_MINGW_TRIPLET})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# ctest and try_run start the programs under wine (Debian's wine64 for x86-64 programs)
find_program(TSK_WINE NAMES wine64 wine)
if(TSK_WINE)
  set(CMAKE_CROSSCOMPILING_EMULATOR "${TSK_WINE}")
endif()
