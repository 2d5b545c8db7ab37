/* The blade solver for CPUs with AVX-512 (x86-64-v4): 16 lanes per vector, chosen at run time
 * by blade_kernel.c.
 *
 * When the library is built by GCC and Clang is installed, this file is compiled twice
 * (native/CMakeLists.txt): Clang builds the step and the rest pose (SIM_AVX512_STEP_UNIT), GCC
 * the ribbons (SIM_AVX512_STEP_BY_CLANG). Clang's code for the step is faster
 * (docs/performance.md, "Blade solver") and gives the same bytes: the kernel uses only IEEE
 * operations and written-out fused multiply-adds, and both compilers run with
 * -ffp-contract=off (test_sim_kernel_paths_give_identical_bytes). */
#define TSK_SIMD_KERNEL_AVX512
#include "sim/sim_internal.h"

#if defined(SIM_AVX512_STEP_UNIT) /* Clang, the AVX-512 flags on its command line */
#define SIM_KERNEL_NO_RIBBONS
#define SIM_KFN(name) name##_avx512
#include "sim/blade_kernel_impl.h"
#define SIM_STR2(x) #x
#define SIM_STR(x) SIM_STR2(x)
const char* tsk_sim_avx512_step_compiler(void) {
    return "clang " SIM_STR(__clang_major__) "." SIM_STR(__clang_minor__) "." SIM_STR(
        __clang_patchlevel__);
}
#elif TSK_SIMD_X86_PATHS
TSK_SIMD_TARGET_AVX512
#define SIM_KFN(name) name##_avx512
#if defined(SIM_AVX512_STEP_BY_CLANG)
#define SIM_KERNEL_NO_STEP
#else
const char* tsk_sim_avx512_step_compiler(void) { return "gcc " __VERSION__; }
#endif
#include "sim/blade_kernel_impl.h"
#else
typedef int sim_no_avx512_kernel; /* not an empty translation unit */
#endif
