/* Small array math shared by modules and exercised through the Python binding. */
#include "tussock/core.h"

#include <math.h>
#include <string.h>

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

enum { BOUNDS_GRAIN = 16384 };

typedef struct bounds_ctx {
    const float* xyz;
    float* part;        /* 6 floats per chunk: lo xyz, hi xyz */
    size_t* first_bad;  /* per chunk: its first non-finite point, or count */
    size_t count;
} bounds_ctx;

static void bounds_range(size_t begin, size_t end, size_t chunk, void* vctx) {
    const bounds_ctx* c = vctx;
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    c->first_bad[chunk] = c->count;
    for (size_t i = begin; i < end; ++i) {
        const float* p = &c->xyz[3 * i];
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) {
            c->first_bad[chunk] = i;
            return;
        }
        for (int q = 0; q < 3; ++q) {
            lo[q] = p[q] < lo[q] ? p[q] : lo[q];
            hi[q] = p[q] > hi[q] ? p[q] : hi[q];
        }
    }
    memcpy(&c->part[6 * chunk], lo, sizeof lo);
    memcpy(&c->part[6 * chunk + 3], hi, sizeof hi);
}

tsk_status tsk_vec3_bounds(const float* xyz, size_t count, float lo[3], float hi[3]) {
    if (lo == NULL || hi == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, lo ? "hi" : "lo", "is NULL");
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
        for (size_t k = 1; k < chunks; ++k)
            for (int q = 0; q < 3; ++q) {
                lo[q] = part[6 * k + q] < lo[q] ? part[6 * k + q] : lo[q];
                hi[q] = part[6 * k + 3 + q] > hi[q] ? part[6 * k + 3 + q] : hi[q];
            }
    }
    tsk_free(part), tsk_free(first_bad);
    return s;
}
