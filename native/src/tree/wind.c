/* The branch wind step of seed 001 §4: every branch is re-attached to its parent and bent
 * by the force sampled at its tip (eq. 14–17). Lagged mode is the seed's (parents from the
 * last step, all branches in parallel); exact mode walks the depths in order. */
#include <math.h>
#include <string.h>

#include "tree_internal.h"

enum { WIND_GRAIN = 2048 };

tsk_tree_wind_def tsk_default_tree_wind_def(void) {
    tsk_tree_wind_def w;
    w.mode = TSK_TREE_WIND_LAGGED;
    w.strength = 1.0f;
    w.bend_power = 1.8f;
    w.length_power = 1.0f;
    return w;
}

void tree_set_length_power(tsk_tree* t, float power) {
    for (size_t i = 0; i < t->n; ++i) {
        const float l = t->rest_seg[i];
        float inv = l > 1e-12f ? (power == 1.0f ? 1.0f / l : 1.0f / powf(l, power)) : 0.0f;
        t->inv_l[i] = inv <= 1e12f ? inv : 1e12f; /* a micrometre twig, power 3: still finite */
    }
    t->inv_l_power = power;
}

typedef struct step_ctx {
    tsk_tree* t;
    const float* force;
    const float* parent_pts; /* where parents are read */
    const sloan_frames* parent_frames;
    float strength, power, b2_scale;
    size_t base; /* first branch of the range */
} step_ctx;

/* One branch at a time: the reference path (trunks, degenerate frames, array tails). */
static void step_scalar(const step_ctx* c, size_t b, size_t e) {
    tsk_tree* t = c->t;
    for (size_t k = b; k < e; ++k) {
        const size_t i = c->base + k;
        v3 Pp[4] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
        const sloan_frames* fp = NULL;
        const int32_t p = t->parent[i];
        if (p >= 0) {
            tree_load_points(c->parent_pts, (size_t)p, Pp);
            fp = &c->parent_frames[p];
        }
        v3 F = tree_load3(c->force, i);
        if (c->strength != 1.0f) F = v3_scale(F, c->strength);
        v3 P[4], O;
        tree_pose_branch(t, i, Pp, fp, F, c->power, c->b2_scale, P, &O);
        tree_store_points(t->cur, i, P);
        tree_store3(t->cur_O, i, O);
        /* the frames children and leaves attach to (seed 001, eq. 8), once per parent */
        if (t->has_kids[i]) sloan_build(P, O, &t->frames[i]);
    }
}


int tree_wind_force_scalar = 0;

#if defined(__SSE2__)
#include <emmintrin.h>

/* Four branches at once with SSE. Every lane performs exactly the operations of the scalar
 * path in the same order (single-precision IEEE, no contraction), so the bytes are the same
 * whichever path computes a branch; blocks never straddle chunk boundaries. */
typedef __m128 f4;
#define ADD _mm_add_ps
#define SUB _mm_sub_ps
#define MUL _mm_mul_ps

typedef struct v4 {
    f4 x, y, z;
} v4;

static inline v4 v4_add(v4 a, v4 b) { return (v4){ADD(a.x, b.x), ADD(a.y, b.y), ADD(a.z, b.z)}; }
static inline v4 v4_sub(v4 a, v4 b) { return (v4){SUB(a.x, b.x), SUB(a.y, b.y), SUB(a.z, b.z)}; }
static inline v4 v4_scale(v4 a, f4 s) { return (v4){MUL(a.x, s), MUL(a.y, s), MUL(a.z, s)}; }
static inline f4 v4_dot(v4 a, v4 b) { return ADD(ADD(MUL(a.x, b.x), MUL(a.y, b.y)), MUL(a.z, b.z)); }
static inline v4 v4_comb(v4 a, f4 s, v4 b, f4 t) {
    return (v4){ADD(MUL(a.x, s), MUL(b.x, t)), ADD(MUL(a.y, s), MUL(b.y, t)),
                ADD(MUL(a.z, s), MUL(b.z, t))};
}
/* v3_norm_or's main branch; *bad gets the lanes where the length is <= 1e-20 (the scalar
 * path would take its fallback there). */
static inline v4 v4_norm(v4 a, f4* bad) {
    const f4 l = _mm_sqrt_ps(v4_dot(a, a));
    *bad = _mm_or_ps(*bad, _mm_cmpngt_ps(l, _mm_set1_ps(1e-20f)));
    const f4 inv = _mm_div_ps(_mm_set1_ps(1.0f), l);
    return v4_scale(a, inv);
}
/* gather component k of 4 records of `stride` floats */
static inline f4 gather(const float* base, const size_t* idx, size_t stride, size_t k) {
    return _mm_set_ps(base[idx[3] * stride + k], base[idx[2] * stride + k],
                      base[idx[1] * stride + k], base[idx[0] * stride + k]);
}

/* bend_pow of tree_internal.h, four lanes, the same operations in the same order. */
static inline f4 bend_pow4(f4 m, float e) {
    const __m128i bits = _mm_castps_si128(m);
    const f4 ex = _mm_cvtepi32_ps(
        _mm_sub_epi32(_mm_and_si128(_mm_srli_epi32(bits, 23), _mm_set1_epi32(255)), _mm_set1_epi32(127)));
    const f4 mant = _mm_castsi128_ps(_mm_or_si128(_mm_and_si128(bits, _mm_set1_epi32(0x7FFFFF)),
                                                  _mm_set1_epi32(0x3F800000)));
    const f4 one = _mm_set1_ps(1.0f);
    const f4 s = _mm_div_ps(SUB(mant, one), ADD(mant, one)), s2 = MUL(s, s);
    f4 poly = ADD(_mm_set1_ps(0.142857143f), MUL(s2, _mm_set1_ps(0.111111111f)));
    poly = ADD(_mm_set1_ps(0.2f), MUL(s2, poly));
    poly = ADD(_mm_set1_ps(0.333333333f), MUL(s2, poly));
    poly = ADD(one, MUL(s2, poly));
    const f4 ln = MUL(MUL(_mm_set1_ps(2.0f), s), poly);
    f4 y = MUL(_mm_set1_ps(e), ADD(ex, MUL(ln, _mm_set1_ps(1.44269504f))));
    y = _mm_max_ps(y, _mm_set1_ps(-126.0f));
    y = _mm_min_ps(y, _mm_set1_ps(126.0f));
    f4 n = _mm_cvtepi32_ps(_mm_cvttps_epi32(y));
    n = SUB(n, _mm_and_ps(_mm_cmpgt_ps(n, y), one));
    const f4 f = MUL(SUB(y, n), _mm_set1_ps(0.693147181f));
    f4 p = ADD(_mm_set1_ps(0.00138888889f), MUL(f, _mm_set1_ps(0.000198412698f)));
    p = ADD(_mm_set1_ps(0.00833333333f), MUL(f, p));
    p = ADD(_mm_set1_ps(0.0416666667f), MUL(f, p));
    p = ADD(_mm_set1_ps(0.166666667f), MUL(f, p));
    p = ADD(_mm_set1_ps(0.5f), MUL(f, p));
    p = ADD(one, MUL(f, p));
    p = ADD(one, MUL(f, p));
    const f4 sc = _mm_castsi128_ps(_mm_slli_epi32(_mm_add_epi32(_mm_cvttps_epi32(n), _mm_set1_epi32(127)), 23));
    return MUL(p, sc);
}

/* component k of one record, in all lanes (siblings share their parent) */
static inline f4 bcast(const float* base, size_t idx, size_t stride, size_t k) {
    return _mm_set1_ps(base[idx * stride + k]);
}

/* Branches i..i+3, all with parents. Returns 0 (and writes nothing) when any lane needs
 * the scalar path. */
static int step_block4(const step_ctx* c, size_t i) {
    tsk_tree* t = c->t;
    size_t pi[4], bi[4] = {i, i + 1, i + 2, i + 3};
    for (int l = 0; l < 4; ++l) {
        if (t->parent[i + l] < 0) return 0;
        pi[l] = (size_t)t->parent[i + l];
    }
    f4 bad = _mm_setzero_ps();
    const f4 one = _mm_set1_ps(1.0f), three = _mm_set1_ps(3.0f), six = _mm_set1_ps(6.0f);
    const f4 two = _mm_set1_ps(2.0f);
    /* parent curve and frames */
    v4 P[4];
    const float* fr = (const float*)c->parent_frames;
    v4 S[3], T[3];
    if (pi[0] == pi[3]) { /* parents never decrease: all four share one */
        for (int k = 0; k < 4; ++k) {
            P[k].x = bcast(c->parent_pts, pi[0], 12, (size_t)(3 * k));
            P[k].y = bcast(c->parent_pts, pi[0], 12, (size_t)(3 * k + 1));
            P[k].z = bcast(c->parent_pts, pi[0], 12, (size_t)(3 * k + 2));
        }
        for (int k = 0; k < 3; ++k) {
            S[k].x = bcast(fr, pi[0], 18, (size_t)(3 * k));
            S[k].y = bcast(fr, pi[0], 18, (size_t)(3 * k + 1));
            S[k].z = bcast(fr, pi[0], 18, (size_t)(3 * k + 2));
            T[k].x = bcast(fr, pi[0], 18, (size_t)(9 + 3 * k));
            T[k].y = bcast(fr, pi[0], 18, (size_t)(9 + 3 * k + 1));
            T[k].z = bcast(fr, pi[0], 18, (size_t)(9 + 3 * k + 2));
        }
    } else {
        for (int k = 0; k < 4; ++k) {
            P[k].x = gather(c->parent_pts, pi, 12, (size_t)(3 * k));
            P[k].y = gather(c->parent_pts, pi, 12, (size_t)(3 * k + 1));
            P[k].z = gather(c->parent_pts, pi, 12, (size_t)(3 * k + 2));
        }
        for (int k = 0; k < 3; ++k) {
            S[k].x = gather(fr, pi, 18, (size_t)(3 * k));
            S[k].y = gather(fr, pi, 18, (size_t)(3 * k + 1));
            S[k].z = gather(fr, pi, 18, (size_t)(3 * k + 2));
            T[k].x = gather(fr, pi, 18, (size_t)(9 + 3 * k));
            T[k].y = gather(fr, pi, 18, (size_t)(9 + 3 * k + 1));
            T[k].z = gather(fr, pi, 18, (size_t)(9 + 3 * k + 2));
        }
    }
    const f4 u = _mm_loadu_ps(t->attach_v + i);
    /* trig: 4 floats per branch, transposed into cos theta, sin theta, cos alpha, sin alpha */
    f4 ct = _mm_loadu_ps(t->trig + 4 * i), st = _mm_loadu_ps(t->trig + 4 * i + 4);
    f4 ca = _mm_loadu_ps(t->trig + 4 * i + 8), sa = _mm_loadu_ps(t->trig + 4 * i + 12);
    _MM_TRANSPOSE4_PS(ct, st, ca, sa);
    /* tree_attach_frame: origin = bez_point */
    const f4 s = SUB(one, u);
    const f4 b0 = MUL(MUL(s, s), s), b1 = MUL(MUL(MUL(three, s), s), u);
    const f4 b2 = MUL(MUL(MUL(three, s), u), u), b3 = MUL(MUL(u, u), u);
    v4 origin;
    origin.x = ADD(ADD(ADD(MUL(P[0].x, b0), MUL(P[1].x, b1)), MUL(P[2].x, b2)), MUL(P[3].x, b3));
    origin.y = ADD(ADD(ADD(MUL(P[0].y, b0), MUL(P[1].y, b1)), MUL(P[2].y, b2)), MUL(P[3].y, b3));
    origin.z = ADD(ADD(ADD(MUL(P[0].z, b0), MUL(P[1].z, b1)), MUL(P[2].z, b2)), MUL(P[3].z, b3));
    /* U = normalize(bez_deriv); the chord fallback is taken scalar */
    const f4 d0 = MUL(MUL(three, s), s), d1 = MUL(MUL(six, s), u), d2 = MUL(MUL(three, u), u);
    const v4 ea = v4_sub(P[1], P[0]), eb = v4_sub(P[2], P[1]), ec = v4_sub(P[3], P[2]);
    v4 der;
    der.x = ADD(ADD(MUL(ea.x, d0), MUL(eb.x, d1)), MUL(ec.x, d2));
    der.y = ADD(ADD(MUL(ea.y, d0), MUL(eb.y, d1)), MUL(ec.y, d2));
    der.z = ADD(ADD(MUL(ea.z, d0), MUL(eb.z, d1)), MUL(ec.z, d2));
    f4 chord_bad = _mm_setzero_ps();
    (void)v4_norm(v4_sub(P[3], P[0]), &chord_bad); /* only its fallback matters */
    bad = _mm_or_ps(bad, chord_bad);
    const v4 U = v4_norm(der, &bad);
    /* sloan_at: quadratic Bernstein blend of the handles */
    const f4 sq = SUB(one, u);
    const f4 q0 = MUL(sq, sq), q1 = MUL(MUL(two, sq), u), q2 = MUL(u, u);
    const v4 Sv = v4_add(v4_add(v4_scale(S[0], q0), v4_scale(S[1], q1)), v4_scale(S[2], q2));
    const v4 Tv = v4_add(v4_add(v4_scale(T[0], q0), v4_scale(T[1], q1)), v4_scale(T[2], q2));
    v4 D = v4_comb(Sv, st, Tv, ct);
    D = v4_sub(D, v4_scale(U, v4_dot(D, U)));
    const v4 V = v4_norm(D, &bad);
    if (_mm_movemask_ps(bad)) return 0;
    /* tree_pose_branch */
    const v4 axis = v4_comb(U, ca, V, sa);
    const f4 nsa = MUL(sa, _mm_set1_ps(-1.0f)); /* -sa is exact: a sign flip */
    const v4 side = v4_comb(U, nsa, V, ca);
    v4 W;
    W.x = SUB(MUL(U.y, V.z), MUL(U.z, V.y));
    W.y = SUB(MUL(U.z, V.x), MUL(U.x, V.z));
    W.z = SUB(MUL(U.x, V.y), MUL(U.y, V.x));
    v4 Q[4];
    Q[0].x = Q[0].y = Q[0].z = _mm_setzero_ps();
    for (int k = 0; k < 3; ++k) {
        Q[k + 1].x = gather(t->local, bi, 9, (size_t)(3 * k));
        Q[k + 1].y = gather(t->local, bi, 9, (size_t)(3 * k + 1));
        Q[k + 1].z = gather(t->local, bi, 9, (size_t)(3 * k + 2));
    }
    v4 F;
    F.x = gather(c->force, bi, 3, 0);
    F.y = gather(c->force, bi, 3, 1);
    F.z = gather(c->force, bi, 3, 2);
    if (c->strength != 1.0f) F = v4_scale(F, _mm_set1_ps(c->strength));
    const f4 zero = _mm_setzero_ps();
    const f4 nonzero = _mm_or_ps(_mm_or_ps(_mm_cmpneq_ps(F.x, zero), _mm_cmpneq_ps(F.y, zero)),
                                 _mm_cmpneq_ps(F.z, zero));
    const int bend_mask = _mm_movemask_ps(nonzero);
    if (bend_mask) {
        const f4 rs = _mm_loadu_ps(t->rest_seg + i);
        const f4 l2 = _mm_loadu_ps(t->seg12 + i);
        const f4 inv_l = _mm_loadu_ps(t->inv_l + i);
        v4 f = {v4_dot(F, axis), v4_dot(F, side), v4_dot(F, W)};
        f = v4_scale(f, inv_l);
        const f4 m = _mm_sqrt_ps(v4_dot(f, f));
        if (_mm_movemask_ps(_mm_cmpnle_ps(m, _mm_set1_ps(TREE_BEND_MAX)))) return 0; /* scalar clamps */
        const f4 mag = _mm_and_ps(_mm_cmpgt_ps(m, zero), bend_pow4(m, c->power - 1.0f));
        const v4 bb3 = v4_scale(f, mag);
        const v4 bb2 = v4_scale(bb3, _mm_set1_ps(c->b2_scale));
        const v4 dd2 = v4_sub(Q[2], Q[1]), dd3 = v4_sub(Q[3], Q[2]);
        f4 nb = _mm_setzero_ps();
        const v4 n2 = v4_norm(v4_add(dd2, bb2), &nb);
        const v4 q2v = v4_add(Q[1], v4_scale(n2, l2));
        const v4 n3 = v4_norm(v4_add(dd3, bb3), &nb);
        const v4 q3v = v4_add(q2v, v4_scale(n3, rs));
        /* a zero-length sum takes the scalar fallback (zero vector) */
        if (_mm_movemask_ps(_mm_and_ps(nb, nonzero))) return 0;
        Q[2].x = _mm_or_ps(_mm_and_ps(nonzero, q2v.x), _mm_andnot_ps(nonzero, Q[2].x));
        Q[2].y = _mm_or_ps(_mm_and_ps(nonzero, q2v.y), _mm_andnot_ps(nonzero, Q[2].y));
        Q[2].z = _mm_or_ps(_mm_and_ps(nonzero, q2v.z), _mm_andnot_ps(nonzero, Q[2].z));
        Q[3].x = _mm_or_ps(_mm_and_ps(nonzero, q3v.x), _mm_andnot_ps(nonzero, Q[3].x));
        Q[3].y = _mm_or_ps(_mm_and_ps(nonzero, q3v.y), _mm_andnot_ps(nonzero, Q[3].y));
        Q[3].z = _mm_or_ps(_mm_and_ps(nonzero, q3v.z), _mm_andnot_ps(nonzero, Q[3].z));
    }
    f4 out[12];
    for (int k = 0; k < 4; ++k) {
        out[3 * k] = ADD(ADD(ADD(origin.x, MUL(axis.x, Q[k].x)), MUL(side.x, Q[k].y)), MUL(W.x, Q[k].z));
        out[3 * k + 1] = ADD(ADD(ADD(origin.y, MUL(axis.y, Q[k].x)), MUL(side.y, Q[k].y)), MUL(W.y, Q[k].z));
        out[3 * k + 2] = ADD(ADD(ADD(origin.z, MUL(axis.z, Q[k].x)), MUL(side.z, Q[k].y)), MUL(W.z, Q[k].z));
    }
    /* 12 components x 4 lanes -> 4 rows of 12 floats (the branches are contiguous) */
    float* dst = t->cur + 12 * i;
    for (int g = 0; g < 3; ++g) {
        f4 r0 = out[4 * g], r1 = out[4 * g + 1], r2 = out[4 * g + 2], r3 = out[4 * g + 3];
        _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
        _mm_storeu_ps(dst + 4 * g, r0);
        _mm_storeu_ps(dst + 12 + 4 * g, r1);
        _mm_storeu_ps(dst + 24 + 4 * g, r2);
        _mm_storeu_ps(dst + 36 + 4 * g, r3);
    }
    float Ox[4] __attribute__((aligned(16))), Oy[4] __attribute__((aligned(16))),
        Oz[4] __attribute__((aligned(16)));
    const f4 m1 = _mm_set1_ps(-1.0f);
    _mm_store_ps(Ox, MUL(side.x, m1));
    _mm_store_ps(Oy, MUL(side.y, m1));
    _mm_store_ps(Oz, MUL(side.z, m1));
    for (int l = 0; l < 4; ++l) {
        float* od = t->cur_O + 3 * (i + (size_t)l);
        od[0] = Ox[l], od[1] = Oy[l], od[2] = Oz[l];
        if (t->has_kids[i + (size_t)l]) {
            v3 Pl[4];
            tree_load_points(t->cur, i + (size_t)l, Pl);
            sloan_build(Pl, v3_make(Ox[l], Oy[l], Oz[l]), &t->frames[i + (size_t)l]);
        }
    }
    return 1;
}
#endif

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#include <immintrin.h>
#define TSK_TREE_AVX2 1
/* Eight branches at once with AVX2: step_block4 lane for lane (the same IEEE operations in
 * the same order, no FMA), so the bytes equal the scalar path's. Chosen at run time when
 * the CPU has AVX2. */
#define AVX __attribute__((target("avx2")))
typedef __m256 f8;
typedef struct v8 {
    f8 x, y, z;
} v8;
#define A8 _mm256_add_ps
#define S8 _mm256_sub_ps
#define M8 _mm256_mul_ps

AVX static inline v8 v8_add(v8 a, v8 b) { return (v8){A8(a.x, b.x), A8(a.y, b.y), A8(a.z, b.z)}; }
AVX static inline v8 v8_sub(v8 a, v8 b) { return (v8){S8(a.x, b.x), S8(a.y, b.y), S8(a.z, b.z)}; }
AVX static inline v8 v8_scale(v8 a, f8 s) { return (v8){M8(a.x, s), M8(a.y, s), M8(a.z, s)}; }
AVX static inline f8 v8_dot(v8 a, v8 b) { return A8(A8(M8(a.x, b.x), M8(a.y, b.y)), M8(a.z, b.z)); }
AVX static inline v8 v8_comb(v8 a, f8 s, v8 b, f8 t) {
    return (v8){A8(M8(a.x, s), M8(b.x, t)), A8(M8(a.y, s), M8(b.y, t)), A8(M8(a.z, s), M8(b.z, t))};
}
AVX static inline v8 v8_norm(v8 a, f8* bad) {
    const f8 l = _mm256_sqrt_ps(v8_dot(a, a));
    *bad = _mm256_or_ps(*bad, _mm256_cmp_ps(l, _mm256_set1_ps(1e-20f), _CMP_NGT_UQ));
    const f8 inv = _mm256_div_ps(_mm256_set1_ps(1.0f), l);
    return v8_scale(a, inv);
}
AVX static inline f8 gather8(const float* base, const size_t* idx, size_t stride, size_t k) {
    return _mm256_set_ps(base[idx[7] * stride + k], base[idx[6] * stride + k],
                         base[idx[5] * stride + k], base[idx[4] * stride + k],
                         base[idx[3] * stride + k], base[idx[2] * stride + k],
                         base[idx[1] * stride + k], base[idx[0] * stride + k]);
}
/* component k of 8 consecutive records of `stride` floats starting at record i */
AVX static inline f8 strided8(const float* base, size_t i, size_t stride, size_t k) {
    const float* p = base + i * stride + k;
    return _mm256_set_ps(p[7 * stride], p[6 * stride], p[5 * stride], p[4 * stride],
                         p[3 * stride], p[2 * stride], p[stride], p[0]);
}
AVX static inline f8 bend_pow8(f8 m, float e) {
    const __m256i bits = _mm256_castps_si256(m);
    const f8 ex = _mm256_cvtepi32_ps(_mm256_sub_epi32(
        _mm256_and_si256(_mm256_srli_epi32(bits, 23), _mm256_set1_epi32(255)), _mm256_set1_epi32(127)));
    const f8 mant = _mm256_castsi256_ps(_mm256_or_si256(
        _mm256_and_si256(bits, _mm256_set1_epi32(0x7FFFFF)), _mm256_set1_epi32(0x3F800000)));
    const f8 one = _mm256_set1_ps(1.0f);
    const f8 s = _mm256_div_ps(S8(mant, one), A8(mant, one)), s2 = M8(s, s);
    f8 poly = A8(_mm256_set1_ps(0.142857143f), M8(s2, _mm256_set1_ps(0.111111111f)));
    poly = A8(_mm256_set1_ps(0.2f), M8(s2, poly));
    poly = A8(_mm256_set1_ps(0.333333333f), M8(s2, poly));
    poly = A8(one, M8(s2, poly));
    const f8 ln = M8(M8(_mm256_set1_ps(2.0f), s), poly);
    f8 y = M8(_mm256_set1_ps(e), A8(ex, M8(ln, _mm256_set1_ps(1.44269504f))));
    y = _mm256_max_ps(y, _mm256_set1_ps(-126.0f));
    y = _mm256_min_ps(y, _mm256_set1_ps(126.0f));
    f8 n = _mm256_cvtepi32_ps(_mm256_cvttps_epi32(y));
    n = S8(n, _mm256_and_ps(_mm256_cmp_ps(n, y, _CMP_GT_OQ), one));
    const f8 f = M8(S8(y, n), _mm256_set1_ps(0.693147181f));
    f8 p = A8(_mm256_set1_ps(0.00138888889f), M8(f, _mm256_set1_ps(0.000198412698f)));
    p = A8(_mm256_set1_ps(0.00833333333f), M8(f, p));
    p = A8(_mm256_set1_ps(0.0416666667f), M8(f, p));
    p = A8(_mm256_set1_ps(0.166666667f), M8(f, p));
    p = A8(_mm256_set1_ps(0.5f), M8(f, p));
    p = A8(one, M8(f, p));
    p = A8(one, M8(f, p));
    const f8 sc = _mm256_castsi256_ps(
        _mm256_slli_epi32(_mm256_add_epi32(_mm256_cvttps_epi32(n), _mm256_set1_epi32(127)), 23));
    return M8(p, sc);
}
AVX static inline f8 blend8(f8 mask, f8 a, f8 b) { /* mask ? a : b, bitwise */
    return _mm256_or_ps(_mm256_and_ps(mask, a), _mm256_andnot_ps(mask, b));
}

/* Branches i..i+7, all with parents; 0 (nothing written) when a lane needs the scalar path. */
AVX static int step_block8(const step_ctx* c, size_t i) {
    tsk_tree* t = c->t;
    size_t pi[8];
    for (int l = 0; l < 8; ++l) {
        if (t->parent[i + (size_t)l] < 0) return 0;
        pi[l] = (size_t)t->parent[i + (size_t)l];
    }
    f8 bad = _mm256_setzero_ps();
    const f8 one = _mm256_set1_ps(1.0f), three = _mm256_set1_ps(3.0f), six = _mm256_set1_ps(6.0f);
    const f8 two = _mm256_set1_ps(2.0f);
    v8 P[4], S[3], T[3];
    const float* fr = (const float*)c->parent_frames;
    if (pi[0] == pi[7]) { /* parents never decrease: all eight share one */
        const float* pp = c->parent_pts + 12 * pi[0];
        const float* pf = fr + 18 * pi[0];
        for (int k = 0; k < 4; ++k)
            P[k] = (v8){_mm256_set1_ps(pp[3 * k]), _mm256_set1_ps(pp[3 * k + 1]), _mm256_set1_ps(pp[3 * k + 2])};
        for (int k = 0; k < 3; ++k) {
            S[k] = (v8){_mm256_set1_ps(pf[3 * k]), _mm256_set1_ps(pf[3 * k + 1]), _mm256_set1_ps(pf[3 * k + 2])};
            T[k] = (v8){_mm256_set1_ps(pf[9 + 3 * k]), _mm256_set1_ps(pf[9 + 3 * k + 1]),
                        _mm256_set1_ps(pf[9 + 3 * k + 2])};
        }
    } else {
        for (int k = 0; k < 4; ++k)
            P[k] = (v8){gather8(c->parent_pts, pi, 12, (size_t)(3 * k)),
                        gather8(c->parent_pts, pi, 12, (size_t)(3 * k + 1)),
                        gather8(c->parent_pts, pi, 12, (size_t)(3 * k + 2))};
        for (int k = 0; k < 3; ++k) {
            S[k] = (v8){gather8(fr, pi, 18, (size_t)(3 * k)), gather8(fr, pi, 18, (size_t)(3 * k + 1)),
                        gather8(fr, pi, 18, (size_t)(3 * k + 2))};
            T[k] = (v8){gather8(fr, pi, 18, (size_t)(9 + 3 * k)), gather8(fr, pi, 18, (size_t)(9 + 3 * k + 1)),
                        gather8(fr, pi, 18, (size_t)(9 + 3 * k + 2))};
        }
    }
    const f8 u = _mm256_loadu_ps(t->attach_v + i);
    const f8 ct = strided8(t->trig, i, 4, 0), st = strided8(t->trig, i, 4, 1);
    const f8 ca = strided8(t->trig, i, 4, 2), sa = strided8(t->trig, i, 4, 3);
    const f8 s = S8(one, u);
    const f8 b0 = M8(M8(s, s), s), b1 = M8(M8(M8(three, s), s), u);
    const f8 b2 = M8(M8(M8(three, s), u), u), b3 = M8(M8(u, u), u);
    v8 origin;
    origin.x = A8(A8(A8(M8(P[0].x, b0), M8(P[1].x, b1)), M8(P[2].x, b2)), M8(P[3].x, b3));
    origin.y = A8(A8(A8(M8(P[0].y, b0), M8(P[1].y, b1)), M8(P[2].y, b2)), M8(P[3].y, b3));
    origin.z = A8(A8(A8(M8(P[0].z, b0), M8(P[1].z, b1)), M8(P[2].z, b2)), M8(P[3].z, b3));
    const f8 d0 = M8(M8(three, s), s), d1 = M8(M8(six, s), u), d2 = M8(M8(three, u), u);
    const v8 ea = v8_sub(P[1], P[0]), eb = v8_sub(P[2], P[1]), ec = v8_sub(P[3], P[2]);
    v8 der;
    der.x = A8(A8(M8(ea.x, d0), M8(eb.x, d1)), M8(ec.x, d2));
    der.y = A8(A8(M8(ea.y, d0), M8(eb.y, d1)), M8(ec.y, d2));
    der.z = A8(A8(M8(ea.z, d0), M8(eb.z, d1)), M8(ec.z, d2));
    f8 chord_bad = _mm256_setzero_ps();
    (void)v8_norm(v8_sub(P[3], P[0]), &chord_bad);
    bad = _mm256_or_ps(bad, chord_bad);
    const v8 U = v8_norm(der, &bad);
    const f8 sq = S8(one, u);
    const f8 q0 = M8(sq, sq), q1 = M8(M8(two, sq), u), q2 = M8(u, u);
    const v8 Sv = v8_add(v8_add(v8_scale(S[0], q0), v8_scale(S[1], q1)), v8_scale(S[2], q2));
    const v8 Tv = v8_add(v8_add(v8_scale(T[0], q0), v8_scale(T[1], q1)), v8_scale(T[2], q2));
    v8 D = v8_comb(Sv, st, Tv, ct);
    D = v8_sub(D, v8_scale(U, v8_dot(D, U)));
    const v8 V = v8_norm(D, &bad);
    if (_mm256_movemask_ps(bad)) return 0;
    const v8 axis = v8_comb(U, ca, V, sa);
    const f8 nsa = M8(sa, _mm256_set1_ps(-1.0f));
    const v8 side = v8_comb(U, nsa, V, ca);
    v8 W;
    W.x = S8(M8(U.y, V.z), M8(U.z, V.y));
    W.y = S8(M8(U.z, V.x), M8(U.x, V.z));
    W.z = S8(M8(U.x, V.y), M8(U.y, V.x));
    v8 Q[4];
    Q[0].x = Q[0].y = Q[0].z = _mm256_setzero_ps();
    for (int k = 0; k < 3; ++k)
        Q[k + 1] = (v8){strided8(t->local, i, 9, (size_t)(3 * k)), strided8(t->local, i, 9, (size_t)(3 * k + 1)),
                        strided8(t->local, i, 9, (size_t)(3 * k + 2))};
    v8 F = {strided8(c->force, i, 3, 0), strided8(c->force, i, 3, 1), strided8(c->force, i, 3, 2)};
    if (c->strength != 1.0f) F = v8_scale(F, _mm256_set1_ps(c->strength));
    const f8 zero = _mm256_setzero_ps();
    const f8 nonzero = _mm256_or_ps(_mm256_or_ps(_mm256_cmp_ps(F.x, zero, _CMP_NEQ_UQ),
                                                 _mm256_cmp_ps(F.y, zero, _CMP_NEQ_UQ)),
                                    _mm256_cmp_ps(F.z, zero, _CMP_NEQ_UQ));
    if (_mm256_movemask_ps(nonzero)) {
        const f8 rs = _mm256_loadu_ps(t->rest_seg + i);
        const f8 l2 = _mm256_loadu_ps(t->seg12 + i);
        const f8 inv_l = _mm256_loadu_ps(t->inv_l + i);
        v8 f = {v8_dot(F, axis), v8_dot(F, side), v8_dot(F, W)};
        f = v8_scale(f, inv_l);
        const f8 m = _mm256_sqrt_ps(v8_dot(f, f));
        if (_mm256_movemask_ps(_mm256_cmp_ps(m, _mm256_set1_ps(TREE_BEND_MAX), _CMP_NLE_UQ))) return 0;
        const f8 mag = _mm256_and_ps(_mm256_cmp_ps(m, zero, _CMP_GT_OQ), bend_pow8(m, c->power - 1.0f));
        const v8 bb3 = v8_scale(f, mag);
        const v8 bb2 = v8_scale(bb3, _mm256_set1_ps(c->b2_scale));
        const v8 dd2 = v8_sub(Q[2], Q[1]), dd3 = v8_sub(Q[3], Q[2]);
        f8 nb = _mm256_setzero_ps();
        const v8 n2 = v8_norm(v8_add(dd2, bb2), &nb);
        const v8 q2v = v8_add(Q[1], v8_scale(n2, l2));
        const v8 n3 = v8_norm(v8_add(dd3, bb3), &nb);
        const v8 q3v = v8_add(q2v, v8_scale(n3, rs));
        if (_mm256_movemask_ps(_mm256_and_ps(nb, nonzero))) return 0;
        Q[2] = (v8){blend8(nonzero, q2v.x, Q[2].x), blend8(nonzero, q2v.y, Q[2].y), blend8(nonzero, q2v.z, Q[2].z)};
        Q[3] = (v8){blend8(nonzero, q3v.x, Q[3].x), blend8(nonzero, q3v.y, Q[3].y), blend8(nonzero, q3v.z, Q[3].z)};
    }
    f8 out[12];
    for (int k = 0; k < 4; ++k) {
        out[3 * k] = A8(A8(A8(origin.x, M8(axis.x, Q[k].x)), M8(side.x, Q[k].y)), M8(W.x, Q[k].z));
        out[3 * k + 1] = A8(A8(A8(origin.y, M8(axis.y, Q[k].x)), M8(side.y, Q[k].y)), M8(W.y, Q[k].z));
        out[3 * k + 2] = A8(A8(A8(origin.z, M8(axis.z, Q[k].x)), M8(side.z, Q[k].y)), M8(W.z, Q[k].z));
    }
    /* 12 components x 8 lanes -> 8 rows of 12 floats: 4x4 transposes per half and group */
    float* dst = t->cur + 12 * i;
    for (int g = 0; g < 3; ++g) {
        for (int h = 0; h < 2; ++h) {
            __m128 r0, r1, r2, r3;
            if (h == 0) {
                r0 = _mm256_castps256_ps128(out[4 * g]), r1 = _mm256_castps256_ps128(out[4 * g + 1]);
                r2 = _mm256_castps256_ps128(out[4 * g + 2]), r3 = _mm256_castps256_ps128(out[4 * g + 3]);
            } else {
                r0 = _mm256_extractf128_ps(out[4 * g], 1), r1 = _mm256_extractf128_ps(out[4 * g + 1], 1);
                r2 = _mm256_extractf128_ps(out[4 * g + 2], 1), r3 = _mm256_extractf128_ps(out[4 * g + 3], 1);
            }
            _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
            float* row = dst + 48 * h + 4 * g;
            _mm_storeu_ps(row, r0);
            _mm_storeu_ps(row + 12, r1);
            _mm_storeu_ps(row + 24, r2);
            _mm_storeu_ps(row + 36, r3);
        }
    }
    float O[3][8] __attribute__((aligned(32)));
    const f8 m1 = _mm256_set1_ps(-1.0f);
    _mm256_store_ps(O[0], M8(side.x, m1));
    _mm256_store_ps(O[1], M8(side.y, m1));
    _mm256_store_ps(O[2], M8(side.z, m1));
    for (int l = 0; l < 8; ++l) {
        float* od = t->cur_O + 3 * (i + (size_t)l);
        od[0] = O[0][l], od[1] = O[1][l], od[2] = O[2][l];
        if (t->has_kids[i + (size_t)l]) {
            v3 Pl[4];
            tree_load_points(t->cur, i + (size_t)l, Pl);
            sloan_build(Pl, v3_make(O[0][l], O[1][l], O[2][l]), &t->frames[i + (size_t)l]);
        }
    }
    return 1;
}
#undef A8
#undef S8
#undef M8
#endif

static void step_range(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const step_ctx* c = vctx;
    size_t k = b;
#if defined(TSK_TREE_AVX2)
    if (tree_wind_force_scalar == 0 && __builtin_cpu_supports("avx2")) {
        for (; k + 8 <= e; k += 8)
            if (!step_block8(c, c->base + k)) step_scalar(c, k, k + 8);
    }
#endif
#if defined(__SSE2__)
    if (tree_wind_force_scalar != 1) {
        for (; k + 4 <= e; k += 4)
            if (!step_block4(c, c->base + k)) step_scalar(c, k, k + 4);
    }
#endif
    step_scalar(c, k, e);
}

tsk_status tsk_tree_wind_step(tsk_tree* t, const float* force, const tsk_tree_wind_def* wind) {
    if (t == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "tree", "is NULL");
    if (force == NULL && t->n > 0) return tsk_error_arg(TSK_ERR_ARGUMENT, "force", "is NULL");
    tsk_tree_wind_def w = wind ? *wind : tsk_default_tree_wind_def();
    if (w.mode != TSK_TREE_WIND_LAGGED && w.mode != TSK_TREE_WIND_EXACT)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "wind.mode", "must be 0 (lagged) or 1 (exact), got %d",
                             w.mode);
    if (!isfinite(w.strength) || w.strength < 0.0f || w.strength > 1e6f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "wind.strength", "must be in [0, 1e6], got %g",
                             (double)w.strength);
    if (!isfinite(w.bend_power) || w.bend_power < 0.5f || w.bend_power > 4.0f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "wind.bend_power", "must be in [0.5, 4], got %g",
                             (double)w.bend_power);
    if (!isfinite(w.length_power) || w.length_power < 0.0f || w.length_power > 3.0f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "wind.length_power", "must be in [0, 3], got %g",
                             (double)w.length_power);
    /* one branch-free pass that vectorizes (NaN fails the comparison); the message search
     * only runs on bad input */
    int bad = 0;
    for (size_t i = 0; i < 3 * t->n; ++i) bad |= !(fabsf(force[i]) <= 1e6f);
    for (size_t i = 0; bad && i < 3 * t->n; ++i) {
        if (!(fabsf(force[i]) <= 1e6f))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "force",
                                 "component %zu of branch %zu is %g (must be finite, |F| <= 1e6)",
                                 i % 3, i / 3, (double)force[i]);
    }
    if (w.length_power != t->inv_l_power) tree_set_length_power(t, w.length_power);
    t->at_rest = 0;
    step_ctx c = {t, force, NULL, NULL, w.strength, w.bend_power,
                  powf(1.0f / 3.0f, w.bend_power), 0};
    if (w.mode == TSK_TREE_WIND_LAGGED) {
        /* seed §4: parents from the last step; swap so that prev holds the last pose */
        float* tmp = t->prev;
        t->prev = t->cur;
        t->cur = tmp;
        tmp = t->prev_O;
        t->prev_O = t->cur_O;
        t->cur_O = tmp;
        sloan_frames* ftmp = t->prev_frames;
        t->prev_frames = t->frames;
        t->frames = ftmp;
        c.parent_pts = t->prev;
        c.parent_frames = t->prev_frames;
        tsk_parallel_for(t->n, WIND_GRAIN, step_range, &c);
    } else {
        /* exact: depth by depth, parents of this step (earlier depths are already done) */
        c.parent_pts = t->cur;
        c.parent_frames = t->frames;
        for (int d = 0; d < t->depth_count; ++d) {
            c.base = t->depth_start[d];
            tsk_parallel_for(t->depth_start[d + 1] - t->depth_start[d], WIND_GRAIN, step_range, &c);
        }
    }
    return TSK_OK;
}

void tsk_tree_reset_pose(tsk_tree* t) {
    if (t != NULL && !t->at_rest) tree_pose_rest(t); /* else new, or reset since its last step */
}

tsk_status tsk_tree_attachment_gap(const tsk_tree* t, double* max_relative_gap,
                                   double* max_metres) {
    if (t == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "tree", "is NULL");
    double worst = 0.0, worst_m = 0.0;
    for (size_t i = 0; i < t->n; ++i) {
        const int32_t p = t->parent[i];
        if (p < 0) continue;
        v3 Pp[4];
        tree_load_points(t->cur, (size_t)p, Pp);
        const float v = t->attach_v[i];
        const v3 on = bez_point(Pp, v);
        const v3 P0 = tree_load3(t->cur + 12 * i, 0);
        const double gap = v3_len(v3_sub(P0, on));
        double r = tsk_branch_radius(&t->shape[p], v, 0.0f);
        const double floor_r = 0.1 * (double)t->shape[p].radius;
        if (r < floor_r) r = floor_r;
        if (r < 1e-9) r = 1e-9;
        if (gap / r > worst) worst = gap / r;
        if (gap > worst_m) worst_m = gap;
    }
    if (max_relative_gap) *max_relative_gap = worst;
    if (max_metres) *max_metres = worst_m;
    return TSK_OK;
}
