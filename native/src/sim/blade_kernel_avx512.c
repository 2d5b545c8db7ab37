/* The blade solver for CPUs with AVX-512 (x86-64-v4): 16 lanes per vector, chosen at run time
 * by blade_kernel.c. */
#include "sim/sim_internal.h"

#if SIM_HAVE_X86_PATHS
#pragma GCC target("fma,avx512f,avx512vl,avx512bw,avx512dq,avx512cd,avx2,f16c,bmi,bmi2,lzcnt,popcnt")
#define SIM_ISA_AVX512
#define SIM_KFN(name) name##_avx512
#include "sim/blade_kernel_impl.h"
#else
typedef int sim_no_avx512_kernel; /* not an empty translation unit */
#endif
