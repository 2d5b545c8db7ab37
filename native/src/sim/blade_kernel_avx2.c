/* The blade solver for CPUs with AVX2 and F16C (x86-64-v3): 8 lanes per vector, chosen at run
 * time by blade_kernel.c. */
#include "sim/sim_internal.h"

#if SIM_HAVE_X86_PATHS
#pragma GCC target("avx2,fma,f16c,bmi,bmi2,lzcnt,popcnt")
#define SIM_ISA_AVX2
#define SIM_KFN(name) name##_avx2
#include "sim/blade_kernel_impl.h"
#else
typedef int sim_no_avx2_kernel; /* not an empty translation unit */
#endif
