/* Small array math shared by modules and exercised through the Python binding. */
#include "tussock/core.h"

#include "core/simd.h"

#include <math.h>
#include <string.h>

#if TSK_SIMD_SSE2
#include <emmintrin.h>
#endif

tsk_status tsk_vec3_lengths(const float* xyz, size_t count, float* out) {
    if (count > 0 && (xyz == NULL || out == NULL))
        return tsk_error_arg(TSK_ERR_ARGUMENT, xyz == NULL ? "xyz" : "out", "is NULL");
    for (size_t i = 0; i < count; ++i) {
        const float x = xyz[3 * i], y = xyz[3 * i + 1], z = xyz[3 * i + 2];
        if (!isfinite(x) || !isfinite(y) || !isfinite(z))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "vector %zu is not finite", i);
        out[i] = sqrtf(x * x + y * y + z * z);
    }
    return TSK_OK;
}

enum { BOUNDS_GRAIN = 65536 };

typedef struct bounds_ctx {
    const float* xyz;
    float* part; /* 6 floats per chunk: lo xyz, hi xyz */
    size_t* first_bad; /* per chunk: its first non-finite point, or count */
    size_t count;
} bounds_ctx;

/* lo/hi widened by a box plo..phi (a point: plo == phi) */
static void bounds_fold(float lo[3], float hi[3], const float plo[3], const float phi[3]) {
    for (int q = 0; q < 3; ++q) {
        lo[q] = plo[q] < lo[q] ? plo[q] : lo[q];
        hi[q] = phi[q] > hi[q] ? phi[q] : hi[q];
    }
}

/* min/max of points [begin, end) into lo/hi; the index of the first non-finite point, or
 * `bad_none` when all are finite. */
static size_t bounds_scalar(const float* xyz, size_t begin, size_t end, float lo[3], float hi[3],
                            size_t bad_none) {
    for (size_t i = begin; i < end; ++i) {
        const float* p = &xyz[3 * i];
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) return i;
        bounds_fold(lo, hi, p, p);
    }
    return bad_none;
}

static void bounds_range(size_t begin, size_t end, size_t chunk, void* vctx) {
    const bounds_ctx* c = vctx;
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    size_t i = begin;
#if TSK_SIMD_SSE2
    /* four points (twelve floats) a step, in three registers whose lanes hold
     * x y z x | y z x y | z x y z. A non-finite value turns v * 0 into NaN, which the sum
     * `odd` keeps; then the scalar pass below finds the first such point. */
    if (end - begin >= 4) {
        const __m128 zero = _mm_setzero_ps();
        __m128 lo0 = _mm_set1_ps(INFINITY), lo1 = lo0, lo2 = lo0;
        __m128 hi0 = _mm_set1_ps(-INFINITY), hi1 = hi0, hi2 = hi0;
        __m128 odd = zero;
        for (; i + 4 <= end; i += 4) {
            const float* p = &c->xyz[3 * i];
            const __m128 a = _mm_loadu_ps(p), b = _mm_loadu_ps(p + 4), d = _mm_loadu_ps(p + 8);
            lo0 = _mm_min_ps(a, lo0), lo1 = _mm_min_ps(b, lo1), lo2 = _mm_min_ps(d, lo2);
            hi0 = _mm_max_ps(a, hi0), hi1 = _mm_max_ps(b, hi1), hi2 = _mm_max_ps(d, hi2);
            odd = _mm_add_ps(odd, _mm_add_ps(_mm_mul_ps(a, zero),
                                             _mm_add_ps(_mm_mul_ps(b, zero), _mm_mul_ps(d, zero))));
        }
        if (_mm_movemask_ps(_mm_cmpunord_ps(odd, odd)) != 0) {
            c->first_bad[chunk] = bounds_scalar(c->xyz, begin, end, lo, hi, c->count);
            return;
        }
        /* stored one after another, the registers are four boxes x y z | x y z | ... */
        float l[12], h[12];
        _mm_storeu_ps(l, lo0), _mm_storeu_ps(l + 4, lo1), _mm_storeu_ps(l + 8, lo2);
        _mm_storeu_ps(h, hi0), _mm_storeu_ps(h + 4, hi1), _mm_storeu_ps(h + 8, hi2);
        for (int k = 0; k < 4; ++k) bounds_fold(lo, hi, l + 3 * k, h + 3 * k);
    }
#endif
    c->first_bad[chunk] = bounds_scalar(c->xyz, i, end, lo, hi, c->count);
    if (c->first_bad[chunk] < c->count) return;
    memcpy(&c->part[6 * chunk], lo, sizeof lo);
    memcpy(&c->part[6 * chunk + 3], hi, sizeof hi);
}

tsk_status tsk_vec3_bounds(const float* xyz, size_t count, float lo[3], float hi[3]) {
    if (lo == NULL || hi == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, lo ? "hi" : "lo", "is NULL");
    if (count == 0) return tsk_error_arg(TSK_ERR_ARGUMENT, "count", "is 0: no points, no bounds");
    if (xyz == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "is NULL");
    const size_t chunks = tsk_chunk_count(count, BOUNDS_GRAIN);
    float* part = tsk_alloc(chunks * 6 * sizeof(float), "bounds");
    size_t* first_bad = tsk_alloc(chunks * sizeof(size_t), "bounds");
    if (part == NULL || first_bad == NULL) {
        tsk_free(part), tsk_free(first_bad);
        return TSK_ERR_MEMORY;
    }
    bounds_ctx c = {xyz, part, first_bad, count};
    tsk_parallel_for(count, BOUNDS_GRAIN, bounds_range, &c);
    tsk_status s = TSK_OK;
    for (size_t k = 0; k < chunks; ++k)
        if (first_bad[k] < count) {
            s = tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "point %zu is not finite", first_bad[k]);
            break;
        }
    if (s == TSK_OK) {
        memcpy(lo, part, 3 * sizeof(float));
        memcpy(hi, part + 3, 3 * sizeof(float));
        for (size_t k = 1; k < chunks; ++k) bounds_fold(lo, hi, &part[6 * k], &part[6 * k + 3]);
    }
    tsk_free(part), tsk_free(first_bad);
    return s;
}
