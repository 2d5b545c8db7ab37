/* The tree wind's block kernel for CPUs with AVX-512 (x86-64-v4): 16 branches per call, chosen
 * at run time by wind.c. */
#define TSK_SIMD_KERNEL_AVX512
#include "tree/wind_kernel.h"

#if TSK_SIMD_X86_PATHS
TSK_SIMD_TARGET_AVX512
#define TREE_KFN(name) name##_avx512
#include "tree/wind_kernel_impl.h"
#else
typedef int tree_no_avx512_kernel; /* not an empty translation unit */
#endif
