/* Force-included into every OpenNI2 source by CMakeLists.txt: the Visual C++ names that
 * OpenNI2's Windows code uses and mingw-w64's GCC lacks. */
#ifndef TSK_OPENNI2_MINGW_COMPAT_H
#define TSK_OPENNI2_MINGW_COMPAT_H

/* Visual C++'s intrinsic that compiles to nothing (OniFile's DEBUG_LOG_RECORD) */
#define __noop ((void)0)

#endif
