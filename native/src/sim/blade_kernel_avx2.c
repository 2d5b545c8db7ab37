/* The blade solver for CPUs with AVX2 and F16C (x86-64-v3): 8 lanes per vector, chosen at run
 * time by blade_kernel.c. */
#define TSK_SIMD_KERNEL_AVX2
#include "sim/sim_internal.h"

#if TSK_SIMD_X86_PATHS
TSK_SIMD_TARGET_AVX2
#define SIM_KFN(name) name##_avx2
#include "sim/blade_kernel_impl.h"
#else
typedef int sim_no_avx2_kernel; /* not an empty translation unit */
#endif
