/* The choice of kernel unit per call (core/simd.h): what the CPU has, within the path that
 * tests (or the TSK_SIMD environment variable) force. */
#include "core/simd.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

static atomic_int g_path = -1; /* -1: TSK_SIMD not read yet */

void tsk_simd_force(int path) {
    atomic_store_explicit(&g_path, path < 0 ? -1 : path, memory_order_relaxed);
}

static int forced_path(void) {
    int p = atomic_load_explicit(&g_path, memory_order_relaxed);
    if (p >= 0) return p;
    const char* e = getenv("TSK_SIMD");
    p = TSK_SIMD_BEST; /* unset or not understood: the best, as without the variable */
    if (e != NULL && strcmp(e, "portable") == 0) p = TSK_SIMD_PORTABLE;
    if (e != NULL && strcmp(e, "avx2") == 0) p = TSK_SIMD_AT_MOST_AVX2;
    int unset = -1; /* a tsk_simd_force meanwhile wins */
    atomic_compare_exchange_strong(&g_path, &unset, p);
    return atomic_load_explicit(&g_path, memory_order_relaxed);
}

int tsk_simd_isa(void) {
#if TSK_SIMD_X86_PATHS
    const int p = forced_path();
    if (p == TSK_SIMD_PORTABLE) return TSK_ISA_PORTABLE;
    if (p != TSK_SIMD_AT_MOST_AVX2 && __builtin_cpu_supports("x86-64-v4")) return TSK_ISA_AVX512;
    if (__builtin_cpu_supports("x86-64-v3")) return TSK_ISA_AVX2;
#else
    (void)forced_path;
#endif
    return TSK_ISA_PORTABLE;
}
