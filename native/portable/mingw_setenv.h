/* Force-included into the C++ files of a Windows build (native/CMakeLists.txt): POSIX's
 * setenv, which mingw-w64's C library lacks and the OpenCV bridges call to switch OpenCV's
 * EXR codec on before its first use, made of the C library's _putenv_s. The environment it
 * changes is the one OpenCV's getenv reads: both are the module's own msvcrt.dll. */
#pragma once
#include <stdlib.h>

static inline int setenv(const char* name, const char* value, int overwrite) {
    if (!overwrite && getenv(name) != NULL) return 0;
    return _putenv_s(name, value) == 0 ? 0 : -1;
}
