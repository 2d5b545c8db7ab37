/* The choice of kernel unit per call (core/simd.h): what the CPU has, within the path that
 * tests (or the TSK_SIMD environment variable) force. */
#include "core/simd.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#if TSK_SIMD_X86_PATHS
#include <cpuid.h>
#endif

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

#if TSK_SIMD_X86_PATHS
/* The x86-64 micro-architecture levels, read with cpuid as GCC 12's
 * __builtin_cpu_supports("x86-64-v3"/"x86-64-v4") reads them (older compilers, such as the
 * portable build's GCC 10, know neither name): v3 is AVX, AVX2, BMI1, BMI2, F16C, FMA, LZCNT
 * and MOVBE (and v2's SSE4.2 and POPCNT) with the AVX state enabled by the OS; v4 adds
 * AVX-512 F, BW, CD, DQ and VL with the opmask and ZMM states enabled. Returns 4, 3, or 0 for
 * anything less. */
static int x86_level(void) {
    unsigned a, b, c, d;
    if (__get_cpuid_max(0, NULL) < 7 || !__get_cpuid(1, &a, &b, &c, &d)) return 0;
    const unsigned c1 = c;
    if (!(c1 & bit_OSXSAVE)) return 0;
    unsigned xlo, xhi;
    __asm__ volatile("xgetbv" : "=a"(xlo), "=d"(xhi) : "c"(0));
    (void)xhi;
    __cpuid_count(7, 0, a, b, c, d);
    const unsigned b7 = b;
    if (!__get_cpuid(0x80000001u, &a, &b, &c, &d)) return 0;
    const int v3 = (c1 & bit_SSE4_2) && (c1 & bit_POPCNT) && (c1 & bit_AVX) && (c1 & bit_FMA) &&
                   (c1 & bit_F16C) && (c1 & bit_MOVBE) && (b7 & bit_AVX2) && (b7 & bit_BMI) &&
                   (b7 & bit_BMI2) && (c & bit_LZCNT) &&
                   (xlo & 0x6u) == 0x6u; /* XMM and YMM state */
    if (!v3) return 0;
    const int v4 = (b7 & bit_AVX512F) && (b7 & bit_AVX512BW) && (b7 & bit_AVX512CD) &&
                   (b7 & bit_AVX512DQ) && (b7 & bit_AVX512VL) &&
                   (xlo & 0xe0u) == 0xe0u; /* opmask, upper ZMM and high ZMM state */
    return v4 ? 4 : 3;
}
#endif

int tsk_simd_x86_level(void) {
#if TSK_SIMD_X86_PATHS
    static atomic_int level = -1;
    int l = atomic_load_explicit(&level, memory_order_relaxed);
    if (l < 0) {
        l = x86_level();
        atomic_store_explicit(&level, l, memory_order_relaxed);
    }
    return l;
#else
    return 0;
#endif
}

int tsk_simd_isa(void) {
#if TSK_SIMD_X86_PATHS
    const int p = forced_path();
    if (p == TSK_SIMD_PORTABLE) return TSK_ISA_PORTABLE;
    const int level = tsk_simd_x86_level();
    if (p != TSK_SIMD_AT_MOST_AVX2 && level >= 4) return TSK_ISA_AVX512;
    if (level >= 3) return TSK_ISA_AVX2;
#else
    (void)forced_path;
#endif
    return TSK_ISA_PORTABLE;
}
