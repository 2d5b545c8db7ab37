/* Force-included (-include) into every C and C++ file of the portable build and of the
 * dependencies it carries, so that what ships needs no glibc symbol version above 2.28, the
 * floor of Blender's own Linux builds (manylinux_2_28), although it is compiled against
 * Debian 11's glibc 2.31. glibc 2.29 gave these libm functions new versions that only drop
 * the old SVID error handling (matherr); the GLIBC_2.2.5 versions call the same code on
 * any glibc since 2.28, so results do not change. tools/binary_floor.py checks the outcome.
 * (__GLIBC__ is not yet defined here: this comes before any system header.) */
#if defined(__x86_64__) && defined(__linux__)
__asm__(".symver exp,exp@GLIBC_2.2.5");
__asm__(".symver exp2,exp2@GLIBC_2.2.5");
__asm__(".symver log,log@GLIBC_2.2.5");
__asm__(".symver log2,log2@GLIBC_2.2.5");
__asm__(".symver pow,pow@GLIBC_2.2.5");
#endif
