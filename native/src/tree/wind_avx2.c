/* The tree wind's block kernel for CPUs with AVX2 (x86-64-v3): 8 branches per call, chosen at
 * run time by wind.c. */
#define TSK_SIMD_KERNEL_AVX2
#include "tree/wind_kernel.h"

#if TSK_SIMD_X86_PATHS
TSK_SIMD_TARGET_AVX2
#define TREE_KFN(name) name##_avx2
#include "tree/wind_kernel_impl.h"
#else
typedef int tree_no_avx2_kernel; /* not an empty translation unit */
#endif
