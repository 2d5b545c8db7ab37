/* Helpers shared by the libFuzzer targets: a reader that turns the fuzzer's bytes into
 * parameters (mostly defaults with some fields replaced by edge values: 0, negative, NaN,
 * inf, huge, tiny, raw bit patterns) so that inputs get past validation often enough to
 * reach the code behind it; temporary files for entry points that take a path; and the
 * per-input leak check through tsk_allocated_bytes. */
#ifndef TSK_FUZZ_H
#define TSK_FUZZ_H

#define _GNU_SOURCE
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "tussock/core.h"

typedef struct fz {
    const uint8_t* p;
    size_t n;
} fz;

static inline uint8_t fz_u8(fz* r) {
    if (r->n == 0) return 0;
    r->n--;
    return *r->p++;
}
static inline uint32_t fz_u32(fz* r) {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v = v << 8 | fz_u8(r);
    return v;
}
static inline uint64_t fz_u64(fz* r) { return (uint64_t)fz_u32(r) << 32 | fz_u32(r); }

/* A float parameter: usually `def`, sometimes an edge value or raw bits. */
static inline float fz_float(fz* r, float def) {
    const uint8_t k = fz_u8(r);
    switch (k % 16) {
        case 0:
            return 0.0f;
        case 1:
            return -def;
        case 2:
            return NAN;
        case 3:
            return (k & 16) ? INFINITY : -INFINITY;
        case 4:
            return (k & 16) ? FLT_MAX : -FLT_MAX;
        case 5:
            return (k & 16) ? FLT_MIN : 1e-30f;
        case 6:
            return def * (float)(fz_u8(r) + 1) / 16.0f;
        case 7: {
            uint32_t b = fz_u32(r);
            float f;
            memcpy(&f, &b, sizeof f);
            return f;
        }
        case 8:
            return (float)(int8_t)fz_u8(r);
        case 9:
            return def * 1e6f;
        default:
            return def;
    }
}

/* An integer parameter: usually `def`, sometimes 0, -1, extremes, a small value, raw bits. */
static inline int fz_int(fz* r, int def) {
    const uint8_t k = fz_u8(r);
    switch (k % 14) {
        case 0:
            return 0;
        case 1:
            return -1;
        case 2:
            return INT_MAX;
        case 3:
            return INT_MIN;
        case 4:
            return (int)fz_u8(r);
        /* wrapping arithmetic: a default near the limits must not overflow in the harness */
        case 5:
            return (int)((uint32_t)def + (uint32_t)(int32_t)(int8_t)fz_u8(r));
        case 6:
            return (int)fz_u32(r);
        case 7:
            return (int)((uint32_t)def * 2u);
        default:
            return def;
    }
}

/* Writes the bytes to a temporary file named by pid and `ext` (no '#' in it, so the depth
 * reader does not take it for a sequence pattern). Returns 0 on failure. */
static inline int fz_write_temp(const uint8_t* data, size_t size, const char* ext, char* path,
                                size_t path_size) {
    snprintf(path, path_size, "/tmp/tsk_fuzz_%ld.%s", (long)getpid(), ext);
    FILE* f = fopen(path, "wb");
    if (f == NULL) return 0;
    const size_t w = fwrite(data, 1, size, f);
    fclose(f);
    return w == size;
}

/* Every input must give back what it took: a leak through tsk_alloc is a finding. */
static inline void fz_check_leaks(const char* where) {
    const size_t live = tsk_allocated_bytes();
    if (live != 0) {
        fprintf(stderr, "tussock fuzz: %zu bytes still allocated after %s\n", live, where);
        abort();
    }
}

/* One thread (the fuzzer wants determinism and the machine is shared) and a small memory
 * budget, so that inputs asking for huge work are refused by the library's own limit. */
static inline void fz_init(void) {
    tsk_set_threads(1);
    tsk_set_memory_budget((uint64_t)256 << 20);
}

#endif
