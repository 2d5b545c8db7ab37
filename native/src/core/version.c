/* The library version, taken from manifest.toml by CMake. */
#include "tussock/core.h"

#ifndef TSK_VERSION_STRING
#error "TSK_VERSION_STRING must be defined by the build (from manifest.toml)"
#endif

const char* tsk_version(void) { return TSK_VERSION_STRING; }
