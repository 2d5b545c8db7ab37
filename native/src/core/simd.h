/* How the library uses vector instructions, decided in this one header.
 *
 * Two kinds of source use them:
 * - a kernel written once with GCC/Clang vector extensions (the blade solver,
 *   sim/blade_kernel_impl.h; the tree wind, tree/wind_kernel_impl.h) and compiled once per
 *   instruction set: the portable unit for the compile target, plus, on x86-64 with GCC, one
 *   unit for AVX2 and one for AVX-512, chosen per call by tsk_simd_isa(). A kernel unit defines
 *   TSK_SIMD_KERNEL_AVX2 or TSK_SIMD_KERNEL_AVX512 before its first include, opens its code with
 *   TSK_SIMD_TARGET_AVX2 / TSK_SIMD_TARGET_AVX512, and gets TSK_SIMD_LANES, its vector width.
 * - a few loops with SSE2 or NEON intrinsics (core/vecmath.c, tree/mesh.c, meadow/expand.c,
 *   refine/merge.c, picture/warp.c), each beside a portable branch, chosen by TSK_SIMD_SSE2 and
 *   TSK_SIMD_NEON.
 *
 * Defining TSK_NO_SIMD (the CMake option of the same name) turns all of them off: only the
 * portable kernels and the portable branches are compiled, so that a build on x86-64 runs (and
 * the tests check) the code other targets get. Every path gives the same bytes: kernels use only
 * IEEE operations, fused multiply-adds only where every path writes them out (tsk_fmaf), and
 * -ffp-contract=off forbids the compiler's own contraction. */
#ifndef TSK_CORE_SIMD_H
#define TSK_CORE_SIMD_H

#if !defined(TSK_NO_SIMD) && defined(__SSE2__)
#define TSK_SIMD_SSE2 1
#else
#define TSK_SIMD_SSE2 0
#endif

#if !defined(TSK_NO_SIMD) && defined(__ARM_NEON) && defined(__aarch64__)
#define TSK_SIMD_NEON 1
#else
#define TSK_SIMD_NEON 0
#endif

/* The AVX2 and AVX-512 kernel units: GCC on x86-64 compiles them inside one library with its
 * target pragma. Clang builds (the sanitizer build) and other targets get the portable kernel
 * only. */
#if !defined(TSK_NO_SIMD) && defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define TSK_SIMD_X86_PATHS 1
#else
#define TSK_SIMD_X86_PATHS 0
#endif

/* Lanes of a kernel's vectors: one register of its instruction set. The portable kernel keeps
 * 4 (a 128-bit register of SSE2 or NEON; without them GCC splits the vectors into scalars). */
#if defined(TSK_SIMD_KERNEL_AVX512)
#define TSK_SIMD_LANES 16
#elif defined(TSK_SIMD_KERNEL_AVX2)
#define TSK_SIMD_LANES 8
#else
#define TSK_SIMD_LANES 4
#endif

/* The instruction sets of the kernel units (x86-64-v3 and x86-64-v4, which tsk_simd_isa checks
 * for): function attributes for everything that follows in the unit. */
/* _Pragma takes one string literal, which clang-format must not split */
/* clang-format off */
#define TSK_SIMD_TARGET_AVX2 _Pragma("GCC target(\"avx2,fma,f16c,bmi,bmi2,lzcnt,popcnt\")")
#define TSK_SIMD_TARGET_AVX512 \
    _Pragma("GCC target(\"fma,avx512f,avx512vl,avx512bw,avx512dq,avx512cd,avx2,f16c,bmi,bmi2,lzcnt,popcnt\")")
/* clang-format on */

enum { TSK_ISA_PORTABLE = 0, TSK_ISA_AVX2 = 1, TSK_ISA_AVX512 = 2 };

/* Which kernel units run: TSK_SIMD_BEST the widest the CPU has, TSK_SIMD_PORTABLE the portable
 * one, TSK_SIMD_AT_MOST_AVX2 AVX2 where the CPU has it. Tests set it to run every path; the
 * environment variable TSK_SIMD (best, portable, avx2) sets it when the library first asks. */
enum { TSK_SIMD_BEST = 0, TSK_SIMD_PORTABLE = 1, TSK_SIMD_AT_MOST_AVX2 = 2 };
/* Forces a path; a negative one makes the next call read TSK_SIMD again. */
void tsk_simd_force(int path);

/* The kernel unit to run now (TSK_ISA_*): what the CPU has, within the forced path. */
int tsk_simd_isa(void);

/* The CPU's x86-64 level as the kernel units need it: 4 (x86-64-v4), 3 (x86-64-v3) or 0. */
int tsk_simd_x86_level(void);

#endif
