/* Blade expansion (seed 000 §4.5, Fig. 7-8): each skeleton knot becomes two vertices half a
 * width either side of the blade, so the skeleton the simulation moves is rendered as a
 * ribbon of triangles; and the whole patch expanded into one mesh for instancing. */
#include "core/simd.h"
#include "meadow_internal.h"
#include "ribbon_input.h"
#include "core/tmath.h"

#include <math.h>
#if TSK_SIMD_SSE2
#include <emmintrin.h>
#endif

size_t tsk_blade_vertex_count(int32_t knot_count) {
    return knot_count >= 2 ? 2 * (size_t)knot_count : 0;
}
size_t tsk_blade_triangle_count(int32_t knot_count) {
    return knot_count >= 2 ? 2 * (size_t)(knot_count - 1) : 0;
}

/* Unit tangent T and unit side S of every knot of a blade (columns x, y, z; room for
 * EXPAND_ROOM knots): the tangent by central differences (one-sided at the ends), the side
 * s0 made perpendicular to it (Gram-Schmidt). Four knots at a time with SSE2: the same IEEE
 * operations in the same order as the scalar path, so the same bits. */
#define EXPAND_ROOM (((TSK_BLADE_MAX_KNOTS) + 3) & ~3)

static void knot_frame(float tx, float ty, float tz, const float s0[3], float* T, float* S) {
    const float tl2 = tx * tx + ty * ty + tz * tz;
    if (tl2 > 0.0f) {
        const float inv = 1.0f / sqrtf(tl2);
        tx *= inv, ty *= inv, tz *= inv;
    } else {
        tx = 0.0f, ty = 0.0f, tz = 1.0f;
    }
    const float d = s0[0] * tx + s0[1] * ty + s0[2] * tz;
    float sx = s0[0] - d * tx, sy = s0[1] - d * ty, sz = s0[2] - d * tz;
    const float ssl2 = sx * sx + sy * sy + sz * sz;
    if (ssl2 > 1e-12f) {
        const float inv = 1.0f / sqrtf(ssl2);
        sx *= inv, sy *= inv, sz *= inv;
    } else { /* tangent along the side: keep the side as given */
        sx = s0[0], sy = s0[1], sz = s0[2];
    }
    T[0] = tx, T[EXPAND_ROOM] = ty, T[2 * EXPAND_ROOM] = tz;
    S[0] = sx, S[EXPAND_ROOM] = sy, S[2 * EXPAND_ROOM] = sz;
}

static void blade_frames(const float* knots, int32_t n, const float s0[3], float T[3 * EXPAND_ROOM],
                         float S[3 * EXPAND_ROOM]) {
    float D[3][EXPAND_ROOM]; /* knot b - knot a, per axis */
    for (int32_t k = 0; k < n; ++k) {
        const int32_t a = k > 0 ? k - 1 : 0, b = k < n - 1 ? k + 1 : n - 1;
        for (int q = 0; q < 3; ++q) D[q][k] = knots[3 * b + q] - knots[3 * a + q];
    }
    int32_t k = 0;
#if TSK_SIMD_SSE2
    const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f), eps = _mm_set1_ps(1e-12f);
    const __m128 sx0 = _mm_set1_ps(s0[0]), sy0 = _mm_set1_ps(s0[1]), sz0 = _mm_set1_ps(s0[2]);
    for (; k + 4 <= n; k += 4) {
        __m128 tx = _mm_loadu_ps(&D[0][k]), ty = _mm_loadu_ps(&D[1][k]),
               tz = _mm_loadu_ps(&D[2][k]);
        const __m128 tl2 =
            _mm_add_ps(_mm_add_ps(_mm_mul_ps(tx, tx), _mm_mul_ps(ty, ty)), _mm_mul_ps(tz, tz));
        const __m128 tok = _mm_cmpgt_ps(tl2, zero);
        /* lanes with tl2 <= 0 take (0, 0, 1); their quotient is never used */
        const __m128 tinv =
            _mm_div_ps(one, _mm_sqrt_ps(_mm_or_ps(_mm_and_ps(tok, tl2), _mm_andnot_ps(tok, one))));
        tx = _mm_and_ps(tok, _mm_mul_ps(tx, tinv));
        ty = _mm_and_ps(tok, _mm_mul_ps(ty, tinv));
        tz = _mm_or_ps(_mm_and_ps(tok, _mm_mul_ps(tz, tinv)), _mm_andnot_ps(tok, one));
        const __m128 d =
            _mm_add_ps(_mm_add_ps(_mm_mul_ps(sx0, tx), _mm_mul_ps(sy0, ty)), _mm_mul_ps(sz0, tz));
        __m128 sx = _mm_sub_ps(sx0, _mm_mul_ps(d, tx)), sy = _mm_sub_ps(sy0, _mm_mul_ps(d, ty)),
               sz = _mm_sub_ps(sz0, _mm_mul_ps(d, tz));
        const __m128 ssl2 =
            _mm_add_ps(_mm_add_ps(_mm_mul_ps(sx, sx), _mm_mul_ps(sy, sy)), _mm_mul_ps(sz, sz));
        const __m128 sok = _mm_cmpgt_ps(ssl2, eps);
        const __m128 sinv =
            _mm_div_ps(one, _mm_sqrt_ps(_mm_or_ps(_mm_and_ps(sok, ssl2), _mm_andnot_ps(sok, one))));
        sx = _mm_or_ps(_mm_and_ps(sok, _mm_mul_ps(sx, sinv)), _mm_andnot_ps(sok, sx0));
        sy = _mm_or_ps(_mm_and_ps(sok, _mm_mul_ps(sy, sinv)), _mm_andnot_ps(sok, sy0));
        sz = _mm_or_ps(_mm_and_ps(sok, _mm_mul_ps(sz, sinv)), _mm_andnot_ps(sok, sz0));
        _mm_storeu_ps(&T[k], tx), _mm_storeu_ps(&T[EXPAND_ROOM + k], ty);
        _mm_storeu_ps(&T[2 * EXPAND_ROOM + k], tz);
        _mm_storeu_ps(&S[k], sx), _mm_storeu_ps(&S[EXPAND_ROOM + k], sy);
        _mm_storeu_ps(&S[2 * EXPAND_ROOM + k], sz);
    }
#endif
    for (; k < n; ++k) knot_frame(D[0][k], D[1][k], D[2][k], s0, &T[k], &S[k]);
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
            const float dx = knots[3 * k] - knots[3 * k - 3],
                        dy = knots[3 * k + 1] - knots[3 * k - 2],
                        dz = knots[3 * k + 2] - knots[3 * k - 1];
            seg[k] = sqrtf(dx * dx + dy * dy + dz * dz);
            total += seg[k];
        }
    }
    const float inv_total = total > 0.0f ? 1.0f / total : 0.0f;
    float T[3 * EXPAND_ROOM], S[3 * EXPAND_ROOM];
    blade_frames(knots, n, s0, T, S);
    float along = 0.0f;
    for (int32_t k = 0; k < n; ++k) {
        const float t[3] = {T[k], T[EXPAND_ROOM + k], T[2 * EXPAND_ROOM + k]};
        const float s[3] = {S[k], S[EXPAND_ROOM + k], S[2 * EXPAND_ROOM + k]};
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
        if (!tsk_ribbon_coord_ok(knots[3 * k]) || !tsk_ribbon_coord_ok(knots[3 * k + 1]) ||
            !tsk_ribbon_coord_ok(knots[3 * k + 2]))
            return BAD_KNOT;
        if (!tsk_ribbon_width_ok(widths[k])) return BAD_WIDTH;
    }
    return tsk_ribbon_side_ok(side) ? BAD_NONE : BAD_SIDE;
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
        case BAD_KNOT:
            return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "knot %d is not finite", (int)k);
        case BAD_WIDTH:
            return tsk_error_arg(TSK_ERR_ARGUMENT, "widths", "width %d must be finite and >= 0",
                                 (int)k);
        case BAD_SIDE:
            return tsk_error_arg(TSK_ERR_ARGUMENT, "side", "must be a finite non-zero vector");
        default:
            break;
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

tsk_status tsk_ribbon_report_bad(const float* knots, const float* widths, const float* side,
                                 size_t K, size_t b) {
    size_t k = 0;
    switch (bad_input(knots, widths, side, K, &k)) {
        case BAD_KNOT:
            return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "knot %zu of blade %zu is not finite",
                                 k, b);
        case BAD_WIDTH:
            return tsk_error_arg(TSK_ERR_ARGUMENT, "widths",
                                 "width %zu of blade %zu must be finite and >= 0", k, b);
        case BAD_SIDE:
            return tsk_error_arg(TSK_ERR_ARGUMENT, "sides",
                                 "side of blade %zu must be a finite non-zero vector", b);
        default:
            return TSK_OK;
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
    /* one branch-free pass over the chunk that vectorizes (NaN fails every comparison);
     * blade by blade only when it finds something */
    int bad = 0;
    const float* kn = &c->knots[3 * K * begin];
    for (size_t i = 0; i < 3 * K * (end - begin); ++i) bad |= !tsk_ribbon_coord_ok(kn[i]);
    const float* w = &c->widths[K * begin];
    for (size_t i = 0; i < K * (end - begin); ++i) bad |= !tsk_ribbon_width_ok(w[i]);
    for (size_t b = begin; b < end; ++b) bad |= !tsk_ribbon_side_ok(&c->sides[3 * b]);
    if (!bad) return;
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
    if (bad < blade_count)
        return tsk_ribbon_report_bad(&knots[3 * K * bad], &widths[K * bad], &sides[3 * bad], K,
                                     bad);
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

tsk_status tsk_patch_mesh_counts(const tsk_patch* p, size_t* vertex_count, size_t* triangle_count) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "patch", "is NULL");
    if (vertex_count)
        *vertex_count = (size_t)p->blade_count * tsk_blade_vertex_count(p->knot_count);
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
        float co, si;
        tsk_sincosf(p->turn[b], &si, &co);
        const float sc = p->scale[b];
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

tsk_status tsk_patch_expand(const tsk_patch* p, float tile_size, float* positions, float* normals,
                            float* uvs, int32_t* tris, int32_t* blade_index) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "patch", "is NULL");
    if (!isfinite(tile_size) || !(tile_size > 0.0f) || tile_size > 1e6f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "tile_size",
                             "must be finite, > 0 and <= 1000 km, got %g", (double)tile_size);
    expand_ctx c = {p, tile_size, positions, normals, uvs, tris, blade_index};
    tsk_parallel_for((size_t)p->blade_count, 256, expand_range, &c);
    return TSK_OK;
}
