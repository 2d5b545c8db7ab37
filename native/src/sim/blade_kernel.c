/* The blade solver's entry points: the portable kernel (blade_kernel_impl.h compiled for the
 * machine's baseline) and the choice, per call, of the kernel unit to run (core/simd.h). All
 * kernels give the same bytes. */
#include "sim/sim_internal.h"

#define SIM_KFN(name) name##_generic
#include "sim/blade_kernel_impl.h"
#undef SIM_KFN

/* TSK_ISA_AVX512, TSK_ISA_AVX2 or TSK_ISA_PORTABLE (core/simd.h) */
static int kernel_isa(void) { return tsk_simd_isa(); }

const char* tsk_sim_avx512_step_running(void) {
#if TSK_SIMD_X86_PATHS
    if (kernel_isa() == TSK_ISA_AVX512) return tsk_sim_avx512_step_compiler();
#endif
    return "none";
}

void tsk_sim_block_step(const sim_step_params* p, float* block, const float* wind,
                        size_t wind_stride, const sim_collider* const* cols, int ncol, float blend,
                        const float* next, sim_block_stats* stats) {
    switch (kernel_isa()) {
#if TSK_SIMD_X86_PATHS
        case TSK_ISA_AVX512:
            tsk_sim_block_step_avx512(p, block, wind, wind_stride, cols, ncol, blend, next, stats);
            return;
        case TSK_ISA_AVX2:
            tsk_sim_block_step_avx2(p, block, wind, wind_stride, cols, ncol, blend, next, stats);
            return;
#endif
        default:
            tsk_sim_block_step_generic(p, block, wind, wind_stride, cols, ncol, blend, next, stats);
            return;
    }
}

void tsk_sim_block_rest(int32_t K, float* block) {
    switch (kernel_isa()) {
#if TSK_SIMD_X86_PATHS
        case TSK_ISA_AVX512:
            tsk_sim_block_rest_avx512(K, block);
            return;
        case TSK_ISA_AVX2:
            tsk_sim_block_rest_avx2(K, block);
            return;
#endif
        default:
            tsk_sim_block_rest_generic(K, block);
            return;
    }
}

int tsk_sim_block_ribbons(int32_t K, const float* P, int l0, int l1, const float* widths,
                          const float* sides, float* out) {
    switch (kernel_isa()) {
#if TSK_SIMD_X86_PATHS
        case TSK_ISA_AVX512:
            return tsk_sim_block_ribbons_avx512(K, P, l0, l1, widths, sides, out);
        case TSK_ISA_AVX2:
            return tsk_sim_block_ribbons_avx2(K, P, l0, l1, widths, sides, out);
#endif
        default:
            return tsk_sim_block_ribbons_generic(K, P, l0, l1, widths, sides, out);
    }
}
