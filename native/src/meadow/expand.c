/* Blade expansion (seed 000 §4.5, Fig. 7-8): each skeleton knot becomes two vertices half a
 * width either side of the blade, so the skeleton the simulation moves is rendered as a
 * ribbon of triangles; and the whole patch expanded into one mesh for instancing. */
#include "meadow_internal.h"

#include <math.h>

size_t tsk_blade_vertex_count(int32_t knot_count) {
    return knot_count >= 2 ? 2 * (size_t)knot_count : 0;
}
size_t tsk_blade_triangle_count(int32_t knot_count) {
    return knot_count >= 2 ? 2 * (size_t)(knot_count - 1) : 0;
}

/* Unchecked expansion of one blade; `side` need not be unit length but must be non-zero.
 * Each segment length is computed once (for UVs); side_k and tangent_k are unit and
 * perpendicular, so their cross product (the normal) is unit without normalising. */
static void expand_blade(const float* knots, const float* widths, int32_t n, const float side[3],
                         float* pos, float* nrm, float* uv) {
    const float inv_sl = 1.0f / sqrtf(side[0] * side[0] + side[1] * side[1] + side[2] * side[2]);
    const float s0[3] = {side[0] * inv_sl, side[1] * inv_sl, side[2] * inv_sl};
    float seg[TSK_BLADE_MAX_KNOTS];
    float total = 0.0f;
    if (uv) {
        seg[0] = 0.0f;
        for (int32_t k = 1; k < n; ++k) {
            const float dx = knots[3 * k] - knots[3 * k - 3], dy = knots[3 * k + 1] - knots[3 * k - 2],
                        dz = knots[3 * k + 2] - knots[3 * k - 1];
            seg[k] = sqrtf(dx * dx + dy * dy + dz * dz);
            total += seg[k];
        }
    }
    const float inv_total = total > 0.0f ? 1.0f / total : 0.0f;
    float along = 0.0f;
    for (int32_t k = 0; k < n; ++k) {
        const int32_t a = k > 0 ? k - 1 : 0, b = k < n - 1 ? k + 1 : n - 1;
        float t[3] = {knots[3 * b] - knots[3 * a], knots[3 * b + 1] - knots[3 * a + 1],
                      knots[3 * b + 2] - knots[3 * a + 2]};
        const float tl2 = t[0] * t[0] + t[1] * t[1] + t[2] * t[2];
        if (tl2 > 0.0f) {
            const float inv = 1.0f / sqrtf(tl2);
            t[0] *= inv;
            t[1] *= inv;
            t[2] *= inv;
        } else {
            t[0] = 0.0f;
            t[1] = 0.0f;
            t[2] = 1.0f;
        }
        /* side made perpendicular to the tangent (Gram-Schmidt), then unit length */
        const float d = s0[0] * t[0] + s0[1] * t[1] + s0[2] * t[2];
        float s[3] = {s0[0] - d * t[0], s0[1] - d * t[1], s0[2] - d * t[2]};
        const float ssl2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
        if (ssl2 > 1e-12f) {
            const float inv = 1.0f / sqrtf(ssl2);
            s[0] *= inv;
            s[1] *= inv;
            s[2] *= inv;
        } else { /* tangent along the side: keep the side as given */
            s[0] = s0[0];
            s[1] = s0[1];
            s[2] = s0[2];
        }
        const float h = 0.5f * widths[k];
        if (pos) {
            float* l = &pos[6 * k];
            for (int q = 0; q < 3; ++q) {
                l[q] = knots[3 * k + q] - h * s[q];
                l[3 + q] = knots[3 * k + q] + h * s[q];
            }
        }
        if (nrm) {
            const float nv[3] = {s[1] * t[2] - s[2] * t[1], s[2] * t[0] - s[0] * t[2],
                                 s[0] * t[1] - s[1] * t[0]};
            for (int q = 0; q < 3; ++q) {
                nrm[6 * k + q] = nv[q];
                nrm[6 * k + 3 + q] = nv[q];
            }
        }
        if (uv) {
            along += seg[k];
            float v = total > 0.0f ? along * inv_total : (float)k / (float)(n - 1);
            if (k == n - 1) v = 1.0f;
            uv[4 * k] = 0.0f;
            uv[4 * k + 1] = v;
            uv[4 * k + 2] = 1.0f;
            uv[4 * k + 3] = v;
        }
    }
}

static void blade_indices(int32_t n, int32_t base, int32_t* tris) {
    for (int32_t k = 0; k + 1 < n; ++k) {
        int32_t* q = &tris[6 * k];
        const int32_t v = base + 2 * k;
        q[0] = v;
        q[1] = v + 1;
        q[2] = v + 3;
        q[3] = v;
        q[4] = v + 3;
        q[5] = v + 2;
    }
}

/* What is wrong with one blade's input, checked knot by knot (its position, then its width)
 * and then its side: BAD_NONE, or which input with the knot in *at. */
enum { BAD_NONE, BAD_KNOT, BAD_WIDTH, BAD_SIDE };
static int bad_input(const float* knots, const float* widths, const float* side, size_t K,
                     size_t* at) {
    for (size_t k = 0; k < K; ++k) {
        *at = k;
        if (!isfinite(knots[3 * k]) || !isfinite(knots[3 * k + 1]) || !isfinite(knots[3 * k + 2]))
            return BAD_KNOT;
        if (!isfinite(widths[k]) || widths[k] < 0.0f) return BAD_WIDTH;
    }
    const float l2 = side[0] * side[0] + side[1] * side[1] + side[2] * side[2];
    return isfinite(l2) && l2 > 1e-20f ? BAD_NONE : BAD_SIDE;
}

tsk_status tsk_blade_expand(const float* knots, const float* widths, int32_t knot_count,
                            const float side[3], float* positions, float* normals, float* uvs) {
    if (knot_count < 2 || knot_count > TSK_BLADE_MAX_KNOTS)
        return tsk_error_arg(knot_count > TSK_BLADE_MAX_KNOTS ? TSK_ERR_LIMIT : TSK_ERR_ARGUMENT,
                             "knot_count", "must be 2..%d, got %d", TSK_BLADE_MAX_KNOTS,
                             (int)knot_count);
    if (knots == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "is NULL");
    if (widths == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "widths", "is NULL");
    if (side == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "side", "is NULL");
    size_t k = 0;
    switch (bad_input(knots, widths, side, (size_t)knot_count, &k)) {
    case BAD_KNOT: return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "knot %d is not finite", (int)k);
    case BAD_WIDTH:
        return tsk_error_arg(TSK_ERR_ARGUMENT, "widths", "width %d must be finite and >= 0", (int)k);
    case BAD_SIDE: return tsk_error_arg(TSK_ERR_ARGUMENT, "side", "must be a finite non-zero vector");
    default: break;
    }
    expand_blade(knots, widths, knot_count, side, positions, normals, uvs);
    return TSK_OK;
}

typedef struct many_ctx {
    const float *knots, *widths, *sides;
    int32_t K;
    float *pos, *nrm, *uv;
} many_ctx;

static void expand_many(size_t begin, size_t end, size_t chunk, void* vctx) {
    (void)chunk;
    const many_ctx* c = vctx;
    const size_t K = (size_t)c->K;
    for (size_t b = begin; b < end; ++b)
        expand_blade(&c->knots[3 * K * b], &c->widths[K * b], c->K, &c->sides[3 * b],
                     c->pos ? &c->pos[6 * K * b] : NULL, c->nrm ? &c->nrm[6 * K * b] : NULL,
                     c->uv ? &c->uv[4 * K * b] : NULL);
}

/* The error for blade b's bad input (bad_input says which). */
static tsk_status report_bad_blade(const float* knots, const float* widths, const float* sides,
                                   size_t K, size_t b) {
    size_t k = 0;
    switch (bad_input(&knots[3 * K * b], &widths[K * b], &sides[3 * b], K, &k)) {
    case BAD_KNOT:
        return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "knot %zu of blade %zu is not finite", k, b);
    case BAD_WIDTH:
        return tsk_error_arg(TSK_ERR_ARGUMENT, "widths",
                             "width %zu of blade %zu must be finite and >= 0", k, b);
    case BAD_SIDE:
        return tsk_error_arg(TSK_ERR_ARGUMENT, "sides",
                             "side of blade %zu must be a finite non-zero vector", b);
    default: return TSK_OK;
    }
}

typedef struct check_ctx {
    const float *knots, *widths, *sides;
    size_t K, n;
    size_t* first_bad; /* per chunk: its first bad blade, or n */
} check_ctx;

static void check_many(size_t begin, size_t end, size_t chunk, void* vctx) {
    const check_ctx* c = vctx;
    const size_t K = c->K;
    size_t k;
    c->first_bad[chunk] = c->n;
    for (size_t b = begin; b < end; ++b)
        if (bad_input(&c->knots[3 * K * b], &c->widths[K * b], &c->sides[3 * b], K, &k) !=
            BAD_NONE) {
            c->first_bad[chunk] = b;
            return;
        }
}

tsk_status tsk_blades_expand(const float* knots, const float* widths, const float* sides,
                             size_t blade_count, int32_t knot_count, float* positions,
                             float* normals, float* uvs) {
    if (knot_count < 2 || knot_count > TSK_BLADE_MAX_KNOTS)
        return tsk_error_arg(knot_count > TSK_BLADE_MAX_KNOTS ? TSK_ERR_LIMIT : TSK_ERR_ARGUMENT,
                             "knot_count", "must be 2..%d, got %d", TSK_BLADE_MAX_KNOTS,
                             (int)knot_count);
    if (blade_count > (size_t)TSK_MEADOW_MAX_BLADES)
        return tsk_error_arg(TSK_ERR_LIMIT, "blade_count", "%zu exceeds the limit of %lld",
                             blade_count, (long long)TSK_MEADOW_MAX_BLADES);
    if (blade_count == 0) return TSK_OK;
    if (knots == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "is NULL");
    if (widths == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "widths", "is NULL");
    if (sides == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "sides", "is NULL");
    const size_t K = (size_t)knot_count;
    /* every input checked first, in parallel; the first bad blade (in blade order, whatever
     * the threads) is reported and nothing is written */
    const size_t grain = 256, chunks = tsk_chunk_count(blade_count, grain);
    size_t* first_bad = tsk_alloc(chunks * sizeof *first_bad, "blade checks");
    if (first_bad == NULL) return TSK_ERR_MEMORY;
    check_ctx cc = {knots, widths, sides, K, blade_count, first_bad};
    tsk_parallel_for(blade_count, grain, check_many, &cc);
    size_t bad = blade_count;
    for (size_t i = 0; i < chunks && bad == blade_count; ++i) bad = first_bad[i];
    tsk_free(first_bad);
    if (bad < blade_count) return report_bad_blade(knots, widths, sides, K, bad);
    many_ctx c = {knots, widths, sides, knot_count, positions, normals, uvs};
    tsk_parallel_for(blade_count, 256, expand_many, &c);
    return TSK_OK;
}

tsk_status tsk_blade_indices(int32_t knot_count, int32_t vertex_base, int32_t* tris) {
    if (knot_count < 2 || knot_count > TSK_BLADE_MAX_KNOTS)
        return tsk_error_arg(knot_count > TSK_BLADE_MAX_KNOTS ? TSK_ERR_LIMIT : TSK_ERR_ARGUMENT,
                             "knot_count", "must be 2..%d, got %d", TSK_BLADE_MAX_KNOTS,
                             (int)knot_count);
    if (tris == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "tris", "is NULL");
    if (vertex_base < 0 || vertex_base > INT32_MAX - 2 * knot_count)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "vertex_base", "must be 0..%d, got %d",
                             (int)(INT32_MAX - 2 * knot_count), (int)vertex_base);
    blade_indices(knot_count, vertex_base, tris);
    return TSK_OK;
}

tsk_status tsk_blades_indices(int32_t knot_count, size_t blade_count, int32_t* tris) {
    if (knot_count < 2 || knot_count > TSK_BLADE_MAX_KNOTS)
        return tsk_error_arg(knot_count > TSK_BLADE_MAX_KNOTS ? TSK_ERR_LIMIT : TSK_ERR_ARGUMENT,
                             "knot_count", "must be 2..%d, got %d", TSK_BLADE_MAX_KNOTS,
                             (int)knot_count);
    if (blade_count > (size_t)INT32_MAX / (2 * (size_t)knot_count))
        return tsk_error_arg(TSK_ERR_LIMIT, "blade_count",
                             "%zu blades of %d knots exceed 2^31 vertices", blade_count,
                             (int)knot_count);
    if (blade_count > 0 && tris == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "tris", "is NULL");
    const size_t per = 6 * (size_t)(knot_count - 1);
    for (size_t b = 0; b < blade_count; ++b)
        blade_indices(knot_count, (int32_t)(2 * (size_t)knot_count * b), &tris[per * b]);
    return TSK_OK;
}

tsk_status tsk_patch_mesh_counts(const tsk_patch* p, size_t* vertex_count,
                                 size_t* triangle_count) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "patch", "is NULL");
    if (vertex_count) *vertex_count = (size_t)p->blade_count * tsk_blade_vertex_count(p->knot_count);
    if (triangle_count)
        *triangle_count = (size_t)p->blade_count * tsk_blade_triangle_count(p->knot_count);
    return TSK_OK;
}

typedef struct expand_ctx {
    const tsk_patch* p;
    float tile_size;
    float *pos, *nrm, *uv;
    int32_t *tris, *blade;
} expand_ctx;

static void expand_range(size_t begin, size_t end, size_t chunk, void* vctx) {
    (void)chunk;
    const expand_ctx* c = vctx;
    const tsk_patch* p = c->p;
    const int32_t K = p->knot_count;
    const size_t nv = 2 * (size_t)K, nt = 2 * (size_t)(K - 1);
    float knots[3 * TSK_BLADE_MAX_KNOTS], widths[TSK_BLADE_MAX_KNOTS];
    for (size_t b = begin; b < end; ++b) {
        const tsk_blade_model* bm = &p->models[p->model[b]];
        const float co = cosf(p->turn[b]), si = sinf(p->turn[b]), sc = p->scale[b];
        const float root[3] = {p->x[b] * c->tile_size, p->y[b] * c->tile_size, 0.0f};
        tsk_meadow_place_knots(bm, co, si, sc, root, knots);
        for (int32_t k = 0; k < K; ++k) widths[k] = bm->width[k] * sc;
        const float* s = &p->model_side[3 * p->model[b]];
        const float side[3] = {co * s[0] - si * s[1], si * s[0] + co * s[1], s[2]};
        expand_blade(knots, widths, K, side, c->pos ? &c->pos[3 * nv * b] : NULL,
                     c->nrm ? &c->nrm[3 * nv * b] : NULL, c->uv ? &c->uv[2 * nv * b] : NULL);
        if (c->tris) blade_indices(K, (int32_t)(nv * b), &c->tris[3 * nt * b]);
        if (c->blade)
            for (size_t v = 0; v < nv; ++v) c->blade[nv * b + v] = (int32_t)b;
    }
}

tsk_status tsk_patch_expand(const tsk_patch* p, float tile_size, float* positions,
                            float* normals, float* uvs, int32_t* tris, int32_t* blade_index) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "patch", "is NULL");
    if (!isfinite(tile_size) || !(tile_size > 0.0f) || tile_size > 1e6f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "tile_size", "must be finite, > 0 and <= 1000 km, got %g",
                             (double)tile_size);
    expand_ctx c = {p, tile_size, positions, normals, uvs, tris, blade_index};
    tsk_parallel_for((size_t)p->blade_count, 256, expand_range, &c);
    return TSK_OK;
}
