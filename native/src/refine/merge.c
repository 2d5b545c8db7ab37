/* Skeleton refining by movement similarity (seed 000 §4.4, eq. 1-3, Algorithm 1): the
 * greedy merging of the adjacent knot pair with the smallest movement difference, made
 * O(K log K + K F) with a binary heap whose stale entries are skipped by version stamps.
 * The tests keep a naive O(K^2 F) version that this one must match bit for bit. */
#include "tussock/refine.h"

#include "core/simd.h"

#include <math.h>
#include <stdio.h>
#if TSK_SIMD_SSE2
#include <emmintrin.h>
#endif
#include <string.h>

tsk_refine_def tsk_default_refine_def(void) {
    tsk_refine_def def;
    memset(&def, 0, sizeof def);
    def.target_knots = 16;
    def.mu = 0.5f;
    return def;
}

/* seed 000, eq. 1-3. Eq. 3 as printed subtracts (sum d)^2 / n, which is not a variance;
 * the variance sum(d^2)/n - (sum(d)/n)^2 is used (clamped at 0 against rounding).
 * The sums are kept in two lanes (even and odd frames) that are added at the end, so that
 * the SSE2 version below and this scalar one give the same bits. */
static double finish_difference(float mu, double s0, double s1, double q0, double q1,
                                size_t frame_count) {
    const double n = (double)frame_count;
    const double dis = (s0 + s1) / n; /* eq. 2 */
    double var = (q0 + q1) / n - dis * dis; /* eq. 3, true variance */
    if (var < 0.0) var = 0.0;
    const double m = (double)mu;
    return dis * m + var * (1.0 - m); /* eq. 1 */
}

double tsk_refine_difference(float mu, const float* a, const float* b, size_t frame_count,
                             double inv_length) {
    if (a == NULL || b == NULL || frame_count == 0) return NAN;
    double s[2] = {0.0, 0.0}, q[2] = {0.0, 0.0};
    for (size_t f = 0; f < frame_count; ++f) {
        const double dx = (double)a[3 * f] - (double)b[3 * f];
        const double dy = (double)a[3 * f + 1] - (double)b[3 * f + 1];
        const double dz = (double)a[3 * f + 2] - (double)b[3 * f + 2];
        const double d = sqrt(dx * dx + dy * dy + dz * dz) * inv_length;
        s[f & 1] += d;
        q[f & 1] += d * d;
    }
    return finish_difference(mu, s[0], s[1], q[0], q[1], frame_count);
}

/* The same from the working layout: a knot's x, y and z rows of f floats each. */
static double difference_rows(float mu, const float* a, const float* b, size_t f,
                              double inv_length) {
    const float *ax = a, *ay = a + f, *az = a + 2 * f;
    const float *bx = b, *by = b + f, *bz = b + 2 * f;
    size_t i = 0;
#if TSK_SIMD_SSE2
    __m128d vs = _mm_setzero_pd(), vq = _mm_setzero_pd();
    const __m128d vinv = _mm_set1_pd(inv_length);
    for (; i + 2 <= f; i += 2) {
        const __m128d dx =
            _mm_sub_pd(_mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64((const __m128i*)(ax + i)))),
                       _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64((const __m128i*)(bx + i)))));
        const __m128d dy =
            _mm_sub_pd(_mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64((const __m128i*)(ay + i)))),
                       _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64((const __m128i*)(by + i)))));
        const __m128d dz =
            _mm_sub_pd(_mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64((const __m128i*)(az + i)))),
                       _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64((const __m128i*)(bz + i)))));
        const __m128d d2 =
            _mm_add_pd(_mm_add_pd(_mm_mul_pd(dx, dx), _mm_mul_pd(dy, dy)), _mm_mul_pd(dz, dz));
        const __m128d d = _mm_mul_pd(_mm_sqrt_pd(d2), vinv);
        vs = _mm_add_pd(vs, d);
        vq = _mm_add_pd(vq, _mm_mul_pd(d, d));
    }
    double s[2], q[2];
    _mm_storeu_pd(s, vs);
    _mm_storeu_pd(q, vq);
#else
    double s[2] = {0.0, 0.0}, q[2] = {0.0, 0.0};
#endif
    for (; i < f; ++i) {
        const double dx = (double)ax[i] - (double)bx[i];
        const double dy = (double)ay[i] - (double)by[i];
        const double dz = (double)az[i] - (double)bz[i];
        const double d = sqrt(dx * dx + dy * dy + dz * dz) * inv_length;
        s[i & 1] += d;
        q[i & 1] += d * d;
    }
    return finish_difference(mu, s[0], s[1], q[0], q[1], f);
}

/* ---- validation ------------------------------------------------------------------------ */

static tsk_status check_def(const tsk_refine_def* def) {
    if (def == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "def", "is NULL");
    if (def->target_knots < TSK_REFINE_MIN_TARGET || def->target_knots > TSK_REFINE_MAX_TARGET)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "target_knots", "must be from %d to %d, got %d",
                             TSK_REFINE_MIN_TARGET, TSK_REFINE_MAX_TARGET, def->target_knots);
    if (!(def->mu >= 0.0f && def->mu <= 1.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "mu", "must be in [0, 1], got %g", (double)def->mu);
    return TSK_OK;
}

static tsk_status check_blade(const tsk_refine_def* def, const tsk_refine_input* in,
                              const tsk_refine_output* out) {
    if (in == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "blade", "is NULL");
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    const size_t k = in->knot_count, f = in->frame_count;
    if (k < 2)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "knot_count",
                             "a blade needs at least 2 knots (root and tip), got %zu", k);
    if (k > TSK_REFINE_MAX_KNOTS)
        return tsk_error_arg(TSK_ERR_LIMIT, "knot_count", "%zu knots exceed the limit of %d", k,
                             TSK_REFINE_MAX_KNOTS);
    if (f == 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "frame_count",
                             "movement data needs at least 1 frame, got 0");
    if (f > TSK_REFINE_MAX_FRAMES)
        return tsk_error_arg(TSK_ERR_LIMIT, "frame_count", "%zu frames exceed the limit of %d", f,
                             TSK_REFINE_MAX_FRAMES);
    if (k * f > TSK_REFINE_MAX_SAMPLES)
        return tsk_error_arg(TSK_ERR_LIMIT, "frame_count",
                             "%zu knots x %zu frames exceed the limit of %zu samples", k, f,
                             TSK_REFINE_MAX_SAMPLES);
    if ((size_t)def->target_knots > k)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "target_knots",
                             "%d knots asked but the blade has only %zu", def->target_knots, k);
    if (in->knots == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "is NULL");
    if (in->widths == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "widths", "is NULL");
    if (in->trajectories == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "trajectories", "is NULL");
    if (out->knots == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out.knots", "is NULL");
    if (out->widths == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out.widths", "is NULL");
    if (out->ranges == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out.ranges", "is NULL");
    const float* p = in->knots;
    for (size_t j = 0; j < k; ++j) {
        if (!isfinite(p[3 * j]) || !isfinite(p[3 * j + 1]) || !isfinite(p[3 * j + 2]))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "knot %zu is not finite", j);
        if (!(in->widths[j] >= 0.0f) || !isfinite(in->widths[j]))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "widths",
                                 "width %zu must be finite and >= 0, got %g", j,
                                 (double)in->widths[j]);
        if (j > 0 && p[3 * j] == p[3 * j - 3] && p[3 * j + 1] == p[3 * j - 2] &&
            p[3 * j + 2] == p[3 * j - 1])
            return tsk_error_arg(TSK_ERR_ARGUMENT, "knots",
                                 "knots %zu and %zu are at the same place (duplicate knot)", j - 1,
                                 j);
    }
    /* a branch-free scan of the exponent bits first (all ones: inf or NaN), then the culprit */
    const size_t n = k * f * 3;
    uint32_t bad = 0;
    for (size_t i = 0; i < n; ++i) {
        uint32_t u;
        memcpy(&u, in->trajectories + i, sizeof u);
        bad |= (uint32_t)((u & 0x7f800000u) == 0x7f800000u);
    }
    if (bad)
        for (size_t i = 0; i < n; ++i)
            if (!isfinite(in->trajectories[i]))
                return tsk_error_arg(TSK_ERR_ARGUMENT, "trajectories",
                                     "frame %zu, knot %zu is not finite", i / (3 * k), (i / 3) % k);
    return TSK_OK;
}

/* ---- the heap -------------------------------------------------------------------------- */

/* A candidate merge of the live knot `left` with its right neighbour `right`. The entry is
 * stale when either knot changed since (version stamps) or they are no longer neighbours. */
typedef struct pair_entry {
    double d;
    int32_t left, right;
    uint32_t vleft, vright;
} pair_entry;

/* Order: smaller D first, ties to the lower index (= nearer the root, as the naive scan). */
static inline int entry_less(const pair_entry* a, const pair_entry* b) {
    return a->d < b->d || (a->d == b->d && a->left < b->left);
}

static void heap_push(pair_entry* heap, size_t* size, pair_entry e) {
    size_t i = (*size)++;
    while (i > 0) {
        size_t parent = (i - 1) / 2;
        if (!entry_less(&e, &heap[parent])) break;
        heap[i] = heap[parent];
        i = parent;
    }
    heap[i] = e;
}

static pair_entry heap_pop(pair_entry* heap, size_t* size) {
    pair_entry top = heap[0];
    pair_entry last = heap[--*size];
    size_t i = 0, n = *size;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= n) break;
        if (c + 1 < n && entry_less(&heap[c + 1], &heap[c])) ++c;
        if (!entry_less(&heap[c], &last)) break;
        heap[i] = heap[c];
        i = c;
    }
    if (n > 0) heap[i] = last;
    return top;
}

/* ---- one blade ----------------------------------------------------------------------------- */

/* Working state, knot-major so that a knot's trajectory is contiguous and in rows:
 * traj[j] = f x values, f y values, f z values (vectorises eq. 1-3). A
 * live knot keeps the slot of its first source knot, so its source range is
 * [slot, next[slot]) and slot order is blade order. */
typedef struct work {
    float* traj; /* [k][3][f] */
    float* rest; /* [k][3] */
    double* wl; /* sum of l_j * w_j over the range */
    double* l; /* sum of l_j over the range */
    int32_t* next; /* next live slot, k past the tip */
    int32_t* prev; /* previous live slot, -1 before the root */
    uint32_t* version;
    pair_entry* heap;
} work;

static tsk_status refine_one(const tsk_refine_def* def, const tsk_refine_input* in,
                             const tsk_refine_output* out) {
    tsk_status s = check_def(def);
    if (s == TSK_OK) s = check_blade(def, in, out);
    if (s != TSK_OK) return s;
    const size_t k = in->knot_count, f = in->frame_count;
    const size_t m = (size_t)def->target_knots;

    work w;
    memset(&w, 0, sizeof w);
    const size_t heap_cap = 3 * k;
    w.traj = tsk_alloc(k * f * 3 * sizeof(float), "refine trajectories");
    w.rest = tsk_alloc(k * 3 * sizeof(float), "refine knots");
    w.wl = tsk_alloc(k * sizeof(double), "refine widths");
    w.l = tsk_alloc(k * sizeof(double), "refine lengths");
    w.next = tsk_alloc(k * sizeof(int32_t), "refine links");
    w.prev = tsk_alloc(k * sizeof(int32_t), "refine links");
    w.version = tsk_calloc(k, sizeof(uint32_t), "refine versions");
    w.heap = tsk_alloc(heap_cap * sizeof(pair_entry), "refine heap");
    if (!w.traj || !w.rest || !w.wl || !w.l || !w.next || !w.prev || !w.version || !w.heap) {
        s = TSK_ERR_MEMORY;
        goto done;
    }

    /* transpose [f][k][3] -> [k][3][f], in blocks of 16 knots to stay in cache */
    for (size_t j0 = 0; j0 < k; j0 += 16) {
        const size_t j1 = j0 + 16 < k ? j0 + 16 : k;
        for (size_t fr = 0; fr < f; ++fr) {
            const float* src = in->trajectories + fr * k * 3;
            for (size_t j = j0; j < j1; ++j) {
                float* dst = w.traj + j * 3 * f + fr;
                dst[0] = src[3 * j];
                dst[f] = src[3 * j + 1];
                dst[2 * f] = src[3 * j + 2];
            }
        }
    }
    memcpy(w.rest, in->knots, k * 3 * sizeof(float));

    /* rest length and the arc length each knot owns (double, in blade order) */
    double total = 0.0;
    for (size_t j = 0; j < k; ++j) w.l[j] = 0.0;
    for (size_t j = 0; j + 1 < k; ++j) {
        const float* p = in->knots + 3 * j;
        const double dx = (double)p[3] - (double)p[0], dy = (double)p[4] - (double)p[1],
                     dz = (double)p[5] - (double)p[2];
        const double seg = sqrt(dx * dx + dy * dy + dz * dz);
        total += seg;
        w.l[j] += 0.5 * seg;
        w.l[j + 1] += 0.5 * seg;
    }
    if (!(total > 0.0) || !isfinite(total)) {
        s = tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "the blade has no finite length");
        goto done;
    }
    const double inv_length = 1.0 / total;
    for (size_t j = 0; j < k; ++j) {
        w.wl[j] = w.l[j] * (double)in->widths[j];
        w.next[j] = (int32_t)j + 1;
        w.prev[j] = (int32_t)j - 1;
    }

    const int32_t tip = (int32_t)k - 1, end = (int32_t)k;
    size_t hsize = 0;
    for (int32_t j = 0; j < tip; ++j) {
        pair_entry e = {difference_rows(def->mu, w.traj + (size_t)j * f * 3,
                                        w.traj + (size_t)(j + 1) * f * 3, f, inv_length),
                        j, j + 1, 0, 0};
        heap_push(w.heap, &hsize, e);
    }

    size_t live = k;
    while (live > m) {
        if (hsize == 0) { /* cannot happen: every live pair has a fresh entry */
            s = tsk_error(TSK_ERR_INTERNAL, "refine: heap ran empty with %zu knots left", live);
            goto done;
        }
        pair_entry e = heap_pop(w.heap, &hsize);
        if (w.next[e.left] != e.right || w.version[e.left] != e.vleft ||
            w.version[e.right] != e.vright || w.prev[e.right] != e.left)
            continue; /* stale */
        const int32_t left = e.left, right = e.right;
        const int32_t after = w.next[right];
        /* merge (keeps slot `left`); slot 0 is always the root, and the tip is whichever
         * live knot has no successor */
        float* a = w.traj + (size_t)left * f * 3;
        const float* b = w.traj + (size_t)right * f * 3;
        float* ra = w.rest + 3 * (size_t)left;
        const float* rb = w.rest + 3 * (size_t)right;
        if (left == 0) {
            /* the root stays where it is */
        } else if (after == end) {
            memcpy(a, b, f * 3 * sizeof(float)); /* the tip stays where it is */
            memcpy(ra, rb, 3 * sizeof(float));
        } else {
            /* the midpoint as 0.5 a + 0.5 b: the same bits as 0.5 (a + b) wherever that is
               finite (halving is exact above the subnormals), and finite for two knots
               near +-FLT_MAX, whose sum overflows (found by fuzz_refine) */
            size_t i = 0;
#if TSK_SIMD_SSE2
            const __m128 half = _mm_set1_ps(0.5f); /* same IEEE operations as below */
            for (; i + 4 <= 3 * f; i += 4)
                _mm_storeu_ps(a + i, _mm_add_ps(_mm_mul_ps(half, _mm_loadu_ps(a + i)),
                                                _mm_mul_ps(half, _mm_loadu_ps(b + i))));
#endif
            for (; i < 3 * f; ++i) a[i] = 0.5f * a[i] + 0.5f * b[i];
            for (int c = 0; c < 3; ++c) ra[c] = 0.5f * ra[c] + 0.5f * rb[c];
        }
        w.wl[left] += w.wl[right];
        w.l[left] += w.l[right];
        w.next[left] = after;
        if (after != end) w.prev[after] = left;
        w.version[left]++;
        w.version[right]++;
        w.next[right] = -1;
        w.prev[right] = -2;
        --live;
        /* new candidate pairs with the neighbours */
        const int32_t before = w.prev[left];
        if (before >= 0) {
            pair_entry ne = {
                difference_rows(def->mu, w.traj + (size_t)before * f * 3, a, f, inv_length), before,
                left, w.version[before], w.version[left]};
            heap_push(w.heap, &hsize, ne);
        }
        if (after != end) {
            pair_entry ne = {
                difference_rows(def->mu, a, w.traj + (size_t)after * f * 3, f, inv_length), left,
                after, w.version[left], w.version[after]};
            heap_push(w.heap, &hsize, ne);
        }
    }

    /* write the live knots in order */
    size_t o = 0;
    for (int32_t j = 0; j != end; j = w.next[j], ++o) {
        const int32_t nx = w.next[j];
        memcpy(out->knots + 3 * o, w.rest + 3 * (size_t)j, 3 * sizeof(float));
        out->widths[o] = (float)(w.wl[j] / w.l[j]);
        out->ranges[2 * o] = j;
        out->ranges[2 * o + 1] = nx - j;
        if (out->trajectories) {
            const float* src = w.traj + (size_t)j * 3 * f;
            for (size_t fr = 0; fr < f; ++fr)
                for (int c = 0; c < 3; ++c)
                    out->trajectories[(fr * m + o) * 3 + (size_t)c] = src[(size_t)c * f + fr];
        }
    }
    if (o != m) s = tsk_error(TSK_ERR_INTERNAL, "refine: %zu knots written, %zu expected", o, m);

done:
    tsk_free(w.traj);
    tsk_free(w.rest);
    tsk_free(w.wl);
    tsk_free(w.l);
    tsk_free(w.next);
    tsk_free(w.prev);
    tsk_free(w.version);
    tsk_free(w.heap);
    return s;
}

tsk_status tsk_refine_blade(const tsk_refine_def* def, const tsk_refine_input* blade,
                            const tsk_refine_output* out) {
    return refine_one(def, blade, out);
}

/* ---- many blades ------------------------------------------------------------------------ */

typedef struct batch_ctx {
    const tsk_refine_def* def;
    const tsk_refine_input* blades;
    const tsk_refine_output* outs;
    tsk_status* status;
} batch_ctx;

static void batch_range(size_t begin, size_t end, size_t chunk, void* vctx) {
    (void)chunk;
    batch_ctx* ctx = vctx;
    for (size_t i = begin; i < end; ++i)
        ctx->status[i] = refine_one(ctx->def, &ctx->blades[i], &ctx->outs[i]);
}

tsk_status tsk_refine_blades(const tsk_refine_def* def, const tsk_refine_input* blades,
                             const tsk_refine_output* outs, size_t count) {
    tsk_status s = check_def(def);
    if (s != TSK_OK) return s;
    if (count == 0) return TSK_OK;
    if (blades == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "blades", "is NULL");
    if (outs == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "outs", "is NULL");
    tsk_status* status = tsk_alloc(count * sizeof(tsk_status), "refine status");
    if (status == NULL) return TSK_ERR_MEMORY;
    batch_ctx ctx = {def, blades, outs, status};
    tsk_parallel_for(count, 8, batch_range, &ctx);
    size_t bad = count;
    for (size_t i = 0; i < count && bad == count; ++i)
        if (status[i] != TSK_OK) bad = i;
    tsk_free(status);
    if (bad == count) return TSK_OK;
    /* The message was set on a worker thread: redo the failing blade here (it fails the
     * same way, deterministically) to set it on the caller's thread, then name the blade. */
    s = refine_one(def, &blades[bad], &outs[bad]);
    if (s == TSK_OK) s = tsk_error(TSK_ERR_INTERNAL, "refine: blade %zu failed only once", bad);
    char msg[512];
    snprintf(msg, sizeof msg, "%s", tsk_last_error());
    return tsk_error(s, "blades[%zu]: %s", bad, msg);
}
