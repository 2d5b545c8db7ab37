/* The blade solver's entry points: the portable kernel (blade_kernel_impl.h compiled for the
 * machine's baseline) and the choice, per call, of the widest kernel the CPU runs. All kernels
 * give the same bytes. */
#include "sim/sim_internal.h"

#define SIM_KFN(name) name##_generic
#include "sim/blade_kernel_impl.h"
#undef SIM_KFN

int tsk_sim_kernel_path = 0;

/* 2 AVX-512, 1 AVX2 + F16C, 0 portable */
static int kernel_isa(void) {
#if SIM_HAVE_X86_PATHS
    if (tsk_sim_kernel_path == 1) return 0;
    if (tsk_sim_kernel_path != 2 && __builtin_cpu_supports("x86-64-v4")) return 2;
    if (__builtin_cpu_supports("x86-64-v3")) return 1;
#endif
    return 0;
}

const char* tsk_sim_avx512_step_running(void) {
#if SIM_HAVE_X86_PATHS
    if (kernel_isa() == 2) return tsk_sim_avx512_step_compiler();
#endif
    return "none";
}

void tsk_sim_block_step(const sim_step_params* p, float* block, const float* wind,
                        size_t wind_stride, const sim_collider* const* cols, int ncol,
                        float blend, const float* next, sim_block_stats* stats) {
    switch (kernel_isa()) {
#if SIM_HAVE_X86_PATHS
    case 2: tsk_sim_block_step_avx512(p, block, wind, wind_stride, cols, ncol, blend, next, stats); return;
    case 1: tsk_sim_block_step_avx2(p, block, wind, wind_stride, cols, ncol, blend, next, stats); return;
#endif
    default: tsk_sim_block_step_generic(p, block, wind, wind_stride, cols, ncol, blend, next, stats); return;
    }
}

void tsk_sim_block_rest(int32_t K, float* block) {
    switch (kernel_isa()) {
#if SIM_HAVE_X86_PATHS
    case 2: tsk_sim_block_rest_avx512(K, block); return;
    case 1: tsk_sim_block_rest_avx2(K, block); return;
#endif
    default: tsk_sim_block_rest_generic(K, block); return;
    }
}

int tsk_sim_block_ribbons(int32_t K, const float* P, int l0, int l1, const float* widths,
                          const float* sides, float* out) {
    switch (kernel_isa()) {
#if SIM_HAVE_X86_PATHS
    case 2: return tsk_sim_block_ribbons_avx512(K, P, l0, l1, widths, sides, out);
    case 1: return tsk_sim_block_ribbons_avx2(K, P, l0, l1, widths, sides, out);
#endif
    default: return tsk_sim_block_ribbons_generic(K, P, l0, l1, widths, sides, out);
    }
}
