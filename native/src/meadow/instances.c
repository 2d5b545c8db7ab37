/* What the meadow hands to Blender and to the simulation: per-tile instance data for
 * geometry nodes (tile corner, patch offset, count), per-chunk instances, and explicit
 * blades (root, turn, scale, rest knots) of a range of tiles. */
#include "meadow_internal.h"
#include "core/tmath.h"

#include <math.h>

enum { TILE_GRAIN = 1024 };

static void tile_corner(const tsk_meadow* m, int64_t t, float out[3]) {
    const int64_t i = t % m->tiles_x, j = t / m->tiles_x;
    out[0] = (float)((double)m->def.origin[0] + (double)i * m->def.tile_size);
    out[1] = (float)((double)m->def.origin[1] + (double)j * m->def.tile_size);
    out[2] = m->def.origin[2];
}

typedef struct inst_ctx {
    const tsk_meadow* m;
    const tsk_patch* p;
    int64_t tile_begin;
    int64_t blade_base; /* first_blade[tile_begin] */
    float *origins, *xyz, *turn, *scale, *knots, *widths, *sides;
    int32_t *offsets, *counts, *index, *tile;
} inst_ctx;

static void fill_instances(size_t begin, size_t end, size_t chunk, void* vctx) {
    (void)chunk;
    inst_ctx* c = vctx;
    for (size_t t = begin; t < end; ++t) {
        if (c->origins) tile_corner(c->m, (int64_t)t, &c->origins[3 * t]);
        if (c->offsets) c->offsets[t] = c->m->offsets[t];
        if (c->counts) c->counts[t] = c->m->counts[t];
    }
}

tsk_status tsk_meadow_instances(const tsk_meadow* m, float* origins, int32_t* offsets,
                                int32_t* counts) {
    if (m == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "meadow", "is NULL");
    inst_ctx c = {0};
    c.m = m;
    c.origins = origins;
    c.offsets = offsets;
    c.counts = counts;
    tsk_parallel_for((size_t)m->tile_count, TILE_GRAIN, fill_instances, &c);
    return TSK_OK;
}

static void fill_chunks(size_t begin, size_t end, size_t chunk, void* vctx) {
    (void)chunk;
    inst_ctx* c = vctx;
    const tsk_meadow* m = c->m;
    const int32_t C = m->def.chunk_blades;
    const int32_t runs = m->def.patch_blades / C;
    for (size_t t = begin; t < end; ++t) {
        const int64_t first = m->first_blade[t] / C;
        const int32_t n = m->counts[t] / C;
        if (n == 0) continue;
        float corner[3];
        tile_corner(m, (int64_t)t, corner);
        const int32_t start = m->offsets[t] / C;
        for (int32_t k = 0; k < n; ++k) {
            const int64_t o = first + k;
            if (c->origins) {
                c->origins[3 * o] = corner[0];
                c->origins[3 * o + 1] = corner[1];
                c->origins[3 * o + 2] = corner[2];
            }
            if (c->index) c->index[o] = (start + k) % runs;
            if (c->tile) c->tile[o] = (int32_t)t;
        }
    }
}

tsk_status tsk_meadow_chunk_instances(const tsk_meadow* m, float* origins, int32_t* chunk,
                                      int32_t* tile) {
    if (m == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "meadow", "is NULL");
    inst_ctx c = {0};
    c.m = m;
    c.origins = origins;
    c.index = chunk;
    c.tile = tile;
    tsk_parallel_for((size_t)m->tile_count, TILE_GRAIN, fill_chunks, &c);
    return TSK_OK;
}

static tsk_status check_range(const tsk_meadow* m, const tsk_patch* p, int64_t b, int64_t e) {
    if (m == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "meadow", "is NULL");
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "patch", "is NULL");
    if (p->blade_count != m->def.patch_blades)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "patch",
                             "has %d blades but the meadow was laid out for %d",
                             (int)p->blade_count, (int)m->def.patch_blades);
    if (b < 0 || e < b || e > m->tile_count)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "tile_begin",
                             "tile range [%lld, %lld) is not inside [0, %lld)", (long long)b,
                             (long long)e, (long long)m->tile_count);
    return TSK_OK;
}

static void fill_blades(size_t begin, size_t end, size_t chunk, void* vctx) {
    (void)chunk;
    inst_ctx* c = vctx;
    const tsk_meadow* m = c->m;
    const tsk_patch* p = c->p;
    const int32_t P = p->blade_count, K = p->knot_count;
    const float ts = m->def.tile_size;
    for (size_t r = begin; r < end; ++r) {
        const int64_t t = c->tile_begin + (int64_t)r;
        float corner[3];
        tile_corner(m, t, corner);
        const int64_t first = m->first_blade[t] - c->blade_base;
        const int32_t n = m->counts[t];
        int32_t b = m->offsets[t];
        for (int32_t k = 0; k < n; ++k, b = b + 1 == P ? 0 : b + 1) {
            const int64_t o = first + k;
            const float root[3] = {corner[0] + p->x[b] * ts, corner[1] + p->y[b] * ts, corner[2]};
            if (c->xyz) {
                c->xyz[3 * o] = root[0];
                c->xyz[3 * o + 1] = root[1];
                c->xyz[3 * o + 2] = root[2];
            }
            if (c->turn) c->turn[o] = p->turn[b];
            if (c->scale) c->scale[o] = p->scale[b];
            if (c->index) c->index[o] = b;
            if (c->knots || c->widths || c->sides) {
                const tsk_blade_model* bm = &p->models[p->model[b]];
                float co, si;
                tsk_sincosf(p->turn[b], &si, &co);
                if (c->knots)
                    tsk_meadow_place_knots(bm, co, si, p->scale[b], root,
                                           &c->knots[3 * (size_t)o * K]);
                if (c->widths)
                    for (int32_t q = 0; q < K; ++q)
                        c->widths[(size_t)o * K + q] = bm->width[q] * p->scale[b];
                if (c->sides) {
                    const float* s = &p->model_side[3 * p->model[b]];
                    c->sides[3 * o] = co * s[0] - si * s[1];
                    c->sides[3 * o + 1] = si * s[0] + co * s[1];
                    c->sides[3 * o + 2] = s[2];
                }
            }
        }
    }
}

tsk_status tsk_meadow_realise(const tsk_meadow* m, const tsk_patch* p, int64_t tile_begin,
                              int64_t tile_end, float* xyz, float* turn, float* scale,
                              int32_t* patch_index) {
    tsk_status s = check_range(m, p, tile_begin, tile_end);
    if (s != TSK_OK) return s;
    inst_ctx c = {0};
    c.m = m;
    c.p = p;
    c.tile_begin = tile_begin;
    c.blade_base = m->first_blade[tile_begin];
    c.xyz = xyz;
    c.turn = turn;
    c.scale = scale;
    c.index = patch_index;
    tsk_parallel_for((size_t)(tile_end - tile_begin), 256, fill_blades, &c);
    return TSK_OK;
}

tsk_status tsk_meadow_realise_knots(const tsk_meadow* m, const tsk_patch* p, int64_t tile_begin,
                                    int64_t tile_end, float* knots, float* widths, float* sides) {
    tsk_status s = check_range(m, p, tile_begin, tile_end);
    if (s != TSK_OK) return s;
    inst_ctx c = {0};
    c.m = m;
    c.p = p;
    c.tile_begin = tile_begin;
    c.blade_base = m->first_blade[tile_begin];
    c.knots = knots;
    c.widths = widths;
    c.sides = sides;
    tsk_parallel_for((size_t)(tile_end - tile_begin), 64, fill_blades, &c);
    return TSK_OK;
}
