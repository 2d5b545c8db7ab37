/* The tree wind's block kernel, written once and compiled once per instruction set
 * (wind_kernel.h): TSK_SIMD_LANES branches at a time, each lane performing exactly the
 * operations of tree_pose_branch (tree_internal.h) in the same order. Only single-precision
 * IEEE add, sub, mul, div, sqrt, comparisons, min/max as (a > b ? a : b) and exact conversions
 * are used, and no fused multiply-add (the one-branch path has none, and -ffp-contract=off
 * keeps the compiler from making any), so a branch gets the same bytes whichever kernel poses
 * it (test_wind_simd_path_equals_scalar_path). Values are GCC/Clang vector extensions of one
 * register; square roots, min/max, "any lane" tests and the transposes that move whole records
 * in and out use the instruction set's own instructions (the permutes of the wide units are
 * GCC's __builtin_shuffle: only GCC compiles those units).
 *
 * The includer defines TREE_KFN(name), the name with its instruction set's suffix. */
#include <string.h>

#include "tree/wind_kernel.h"

#if defined(TSK_SIMD_KERNEL_AVX512) || defined(TSK_SIMD_KERNEL_AVX2)
#include <immintrin.h>
#elif TSK_SIMD_SSE2
#include <emmintrin.h>
#elif TSK_SIMD_NEON
#include <arm_neon.h>
#endif

#if defined(__GNUC__) && !defined(__clang__)
/* The vector helpers below are always inlined static functions: no ABI crosses them. */
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

#define WK_LN TSK_SIMD_LANES
#define WK_INL static inline __attribute__((always_inline))

typedef float wk_f __attribute__((vector_size(4 * WK_LN)));
typedef int32_t wk_i __attribute__((vector_size(4 * WK_LN)));
typedef struct wk_v3 {
    wk_f x, y, z;
} wk_v3;

WK_INL wk_f wk_splat(float x) {
    wk_f v = {0};
    return v + x;
}
WK_INL wk_f wk_ld(const float* p) {
    wk_f v;
    memcpy(&v, p, sizeof v);
    return v;
}
/* a where m (all ones or all zeros per lane), else b */
WK_INL wk_f wk_sel(wk_i m, wk_f a, wk_f b) { return (wk_f)((m & (wk_i)a) | (~m & (wk_i)b)); }
/* exactly maxps(a, b) and minps(a, b), which x86 has (GCC does not see them in the select) */
WK_INL wk_f wk_max(wk_f a, wk_f b) {
#if defined(TSK_SIMD_KERNEL_AVX512)
    return (wk_f)_mm512_max_ps((__m512)a, (__m512)b);
#elif defined(TSK_SIMD_KERNEL_AVX2)
    return (wk_f)_mm256_max_ps((__m256)a, (__m256)b);
#elif TSK_SIMD_SSE2
    return (wk_f)_mm_max_ps((__m128)a, (__m128)b);
#else
    return wk_sel(a > b, a, b);
#endif
}
WK_INL wk_f wk_min(wk_f a, wk_f b) {
#if defined(TSK_SIMD_KERNEL_AVX512)
    return (wk_f)_mm512_min_ps((__m512)a, (__m512)b);
#elif defined(TSK_SIMD_KERNEL_AVX2)
    return (wk_f)_mm256_min_ps((__m256)a, (__m256)b);
#elif TSK_SIMD_SSE2
    return (wk_f)_mm_min_ps((__m128)a, (__m128)b);
#else
    return wk_sel(a < b, a, b);
#endif
}
/* correctly rounded, as sqrtf */
WK_INL wk_f wk_sqrt(wk_f a) {
#if defined(TSK_SIMD_KERNEL_AVX512)
    return (wk_f)_mm512_sqrt_ps((__m512)a);
#elif defined(TSK_SIMD_KERNEL_AVX2)
    return (wk_f)_mm256_sqrt_ps((__m256)a);
#elif TSK_SIMD_SSE2
    return (wk_f)_mm_sqrt_ps((__m128)a);
#elif TSK_SIMD_NEON
    return (wk_f)vsqrtq_f32((float32x4_t)a);
#else
    for (int l = 0; l < WK_LN; ++l) a[l] = sqrtf(a[l]);
    return a;
#endif
}
/* 1 when any lane of a comparison's result is set */
WK_INL int wk_any(wk_i m) {
#if defined(TSK_SIMD_KERNEL_AVX512)
    return _mm512_test_epi32_mask((__m512i)m, (__m512i)m) != 0;
#elif defined(TSK_SIMD_KERNEL_AVX2)
    return _mm256_movemask_ps((__m256)m) != 0;
#elif TSK_SIMD_SSE2
    return _mm_movemask_ps((__m128)m) != 0;
#else
    int32_t o = 0;
    for (int l = 0; l < WK_LN; ++l) o |= m[l];
    return o != 0;
#endif
}

WK_INL wk_v3 wk_add(wk_v3 a, wk_v3 b) { return (wk_v3){a.x + b.x, a.y + b.y, a.z + b.z}; }
WK_INL wk_v3 wk_sub(wk_v3 a, wk_v3 b) { return (wk_v3){a.x - b.x, a.y - b.y, a.z - b.z}; }
WK_INL wk_v3 wk_scale(wk_v3 a, wk_f s) { return (wk_v3){a.x * s, a.y * s, a.z * s}; }
WK_INL wk_f wk_dot(wk_v3 a, wk_v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
/* a*s + b*t, as v3_comb */
WK_INL wk_v3 wk_comb(wk_v3 a, wk_f s, wk_v3 b, wk_f t) {
    return (wk_v3){a.x * s + b.x * t, a.y * s + b.y * t, a.z * s + b.z * t};
}
/* v3_norm_or's main branch; *bad gets the lanes where the length is not > 1e-20 (where
 * v3_norm_or takes its fallback) */
WK_INL wk_v3 wk_norm(wk_v3 a, wk_i* bad) {
    const wk_f l = wk_sqrt(wk_dot(a, a));
    *bad |= ~(l > wk_splat(1e-20f));
    return wk_scale(a, wk_splat(1.0f) / l);
}
/* A vector of the LN values E(0) .. E(LN - 1), written as one constructor: GCC builds it in
 * registers (inserts), where filling lanes one by one goes through masked broadcasts or the
 * stack. */
#define WK_E4(E, o) E((o) + 0), E((o) + 1), E((o) + 2), E((o) + 3)
#if WK_LN == 4
#define WK_MAKE(E) ((wk_f){WK_E4(E, 0)})
#define WK_MAKEI(E) ((wk_i){WK_E4(E, 0)})
#elif WK_LN == 8
#define WK_MAKE(E) ((wk_f){WK_E4(E, 0), WK_E4(E, 4)})
#define WK_MAKEI(E) ((wk_i){WK_E4(E, 0), WK_E4(E, 4)})
#else
#define WK_MAKE(E) ((wk_f){WK_E4(E, 0), WK_E4(E, 4), WK_E4(E, 8), WK_E4(E, 12)})
#define WK_MAKEI(E) ((wk_i){WK_E4(E, 0), WK_E4(E, 4), WK_E4(E, 8), WK_E4(E, 12)})
#endif
/* component k of LN records of `stride` floats: records idx[l], or i + l */
WK_INL wk_f wk_gather(const float* base, const size_t* idx, size_t stride, size_t k) {
#define WK_G(l) base[idx[l] * stride + k]
    return WK_MAKE(WK_G);
#undef WK_G
}
WK_INL wk_f wk_strided(const float* base, size_t i, size_t stride, size_t k) {
    const float* p = base + i * stride + k;
#define WK_S(l) p[(l)*stride]
    return WK_MAKE(WK_S);
#undef WK_S
}

/* Where a block's parents are read: all lanes one parent (WK_ONE: its record a, broadcast),
 * two (WK_TWO: a where m is clear, b where it is set), or any (WK_ANY: records pi[l] of the
 * array base of `stride` floats). */
enum { WK_ONE, WK_TWO, WK_ANY };
typedef struct wk_src {
    const float *a, *b, *base;
    const size_t* pi;
    size_t stride;
    wk_i m;
} wk_src;
WK_INL wk_f wk_fetch(int mode, const wk_src* r, int k) {
    if (mode == WK_ONE) return wk_splat(r->a[k]);
    if (mode == WK_TWO) return wk_sel(r->m, wk_splat(r->b[k]), wk_splat(r->a[k]));
    return wk_gather(r->base, r->pi, r->stride, (size_t)k);
}
WK_INL wk_v3 wk_fetch3(int mode, const wk_src* r, int k) {
    return (wk_v3){wk_fetch(mode, r, k), wk_fetch(mode, r, k + 1), wk_fetch(mode, r, k + 2)};
}

/* What the kernel needs of the parents at u (bez_point, bez_deriv and sloan_at's blends of
 * S and T), computed where they are read so that their 30 vectors are not all live at once;
 * `mode` is a constant where called. */
typedef struct wk_terms {
    wk_v3 origin, der, Sv, Tv;
} wk_terms;
WK_INL wk_terms wk_parent_terms(int mode, wk_src pts, wk_src frames, wk_f u) {
    wk_terms o;
    wk_v3 P[4];
    for (int k = 0; k < 4; ++k) P[k] = wk_fetch3(mode, &pts, 3 * k);
    /* tree_attach_frame: origin = bez_point */
    const wk_f s = wk_splat(1.0f) - u;
    const wk_f b0 = s * s * s, b1 = 3.0f * s * s * u, b2 = 3.0f * s * u * u, b3 = u * u * u;
    o.origin.x = P[0].x * b0 + P[1].x * b1 + P[2].x * b2 + P[3].x * b3;
    o.origin.y = P[0].y * b0 + P[1].y * b1 + P[2].y * b2 + P[3].y * b3;
    o.origin.z = P[0].z * b0 + P[1].z * b1 + P[2].z * b2 + P[3].z * b3;
    const wk_f d0 = 3.0f * s * s, d1 = 6.0f * s * u, d2 = 3.0f * u * u;
    const wk_v3 ea = wk_sub(P[1], P[0]), eb = wk_sub(P[2], P[1]), ec = wk_sub(P[3], P[2]);
    o.der = (wk_v3){ea.x * d0 + eb.x * d1 + ec.x * d2, ea.y * d0 + eb.y * d1 + ec.y * d2,
                    ea.z * d0 + eb.z * d1 + ec.z * d2};
    /* sloan_at: quadratic Bernstein blend of the handles (bern2); frames are S[3], T[3] */
    const wk_f q0 = s * s, q1 = 2.0f * s * u, q2 = u * u;
    o.Sv = wk_add(wk_add(wk_scale(wk_fetch3(mode, &frames, 0), q0),
                         wk_scale(wk_fetch3(mode, &frames, 3), q1)),
                  wk_scale(wk_fetch3(mode, &frames, 6), q2));
    o.Tv = wk_add(wk_add(wk_scale(wk_fetch3(mode, &frames, 9), q0),
                         wk_scale(wk_fetch3(mode, &frames, 12), q1)),
                  wk_scale(wk_fetch3(mode, &frames, 15), q2));
    return o;
}

/* x86: 4x4 transposes inside every 128-bit lane of the vectors, for the records the kernel
 * reads and writes whole (the lane-by-lane loads and stores they replace cost an insert, or a
 * spill and a scalar store, per float) */
#if defined(TSK_SIMD_KERNEL_AVX512)
#define WK_X(p) _mm512_##p
typedef __m512 wk_m;
#elif defined(TSK_SIMD_KERNEL_AVX2)
#define WK_X(p) _mm256_##p
typedef __m256 wk_m;
#elif TSK_SIMD_SSE2
#define WK_X(p) _mm_##p
typedef __m128 wk_m;
#endif
#ifdef WK_X
/* c[j]'s 128-bit lane h holds element j of r[0..3]'s lane h */
WK_INL void wk_transpose4(const wk_f r[4], wk_f c[4]) {
    const wk_m t0 = WK_X(unpacklo_ps)((wk_m)r[0], (wk_m)r[1]);
    const wk_m t1 = WK_X(unpackhi_ps)((wk_m)r[0], (wk_m)r[1]);
    const wk_m t2 = WK_X(unpacklo_ps)((wk_m)r[2], (wk_m)r[3]);
    const wk_m t3 = WK_X(unpackhi_ps)((wk_m)r[2], (wk_m)r[3]);
    c[0] = (wk_f)WK_X(shuffle_ps)(t0, t2, 0x44); /* elements 0, 1 of t0, then of t2 */
    c[1] = (wk_f)WK_X(shuffle_ps)(t0, t2, 0xEE); /* elements 2, 3 */
    c[2] = (wk_f)WK_X(shuffle_ps)(t1, t3, 0x44);
    c[3] = (wk_f)WK_X(shuffle_ps)(t1, t3, 0xEE);
}
#endif
#undef WK_X

/* Rows of 12 floats for the LN lanes of 12 component vectors: dst[12 * l + k] = out[k][l]:
 * per group of 4 components one transpose, then one 16-byte store per 128-bit lane and row. */
WK_INL void wk_store_rows12(float* dst, const wk_f out[12]) {
#if defined(TSK_SIMD_KERNEL_AVX512) || defined(TSK_SIMD_KERNEL_AVX2) || TSK_SIMD_SSE2
    for (int g = 0; g < 3; ++g) {
        wk_f c[4];
        wk_transpose4(out + 4 * g, c);
        /* c[j]'s 128-bit lane h: components 4g .. 4g+3 of branch 4h + j */
        for (int h = 0; h < WK_LN / 4; ++h)
            for (int j = 0; j < 4; ++j)
                memcpy(dst + 12 * (4 * h + j) + 4 * g, (const float*)&c[j] + 4 * h, 16);
    }
#else
    for (int l = 0; l < WK_LN; ++l)
        for (int k = 0; k < 12; ++k) dst[12 * l + k] = out[k][l];
#endif
}

/* Rows of 3 floats for the LN lanes of out[0..2] (out[3] is scratch): dst[3 * l + k] =
 * out[k][l]. Each row is stored as 16 bytes, the next row overwriting the extra float, and
 * the last as 12, so nothing outside the rows is written. */
WK_INL void wk_store_rows3(float* dst, const wk_f out[4]) {
#if defined(TSK_SIMD_KERNEL_AVX512) || defined(TSK_SIMD_KERNEL_AVX2) || TSK_SIMD_SSE2
    wk_f c[4];
    wk_transpose4(out, c);
    /* c[j]'s 128-bit lane h: branch 4h + j */
    for (int h = 0; h < WK_LN / 4; ++h)
        for (int j = 0; j < 4; ++j)
            memcpy(dst + 3 * (4 * h + j), (const float*)&c[j] + 4 * h,
                   4 * h + j < WK_LN - 1 ? 16 : 12);
#else
    for (int l = 0; l < WK_LN; ++l)
        for (int k = 0; k < 3; ++k) dst[3 * l + k] = out[k][l];
#endif
}

/* 4 floats from each of p, p + step, ... in the LN/4 128-bit lanes of a vector */
WK_INL wk_f wk_ld_lanes4(const float* p, size_t step) {
#if defined(TSK_SIMD_KERNEL_AVX512)
    __m512 v = _mm512_castps128_ps512(_mm_loadu_ps(p));
    v = _mm512_insertf32x4(v, _mm_loadu_ps(p + step), 1);
    v = _mm512_insertf32x4(v, _mm_loadu_ps(p + 2 * step), 2);
    return (wk_f)_mm512_insertf32x4(v, _mm_loadu_ps(p + 3 * step), 3);
#elif defined(TSK_SIMD_KERNEL_AVX2)
    return (wk_f)_mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(p)),
                                      _mm_loadu_ps(p + step), 1);
#else
    (void)step;
    return wk_ld(p);
#endif
}

/* The 3 components of LN contiguous records of 3 floats: c[k][l] = p[3 * l + k]. The wide
 * (GCC-only) units permute 3 whole vectors; the portable one builds them from scalars. */
WK_INL void wk_load_rows3(const float* p, wk_f c[3]) {
#if WK_LN > 4
    const wk_f a = wk_ld(p), b = wk_ld(p + WK_LN), d = wk_ld(p + 2 * WK_LN);
    /* first the lanes found in a or b, then those in d */
#define WK_M1(l) (3 * (l) + K < 2 * WK_LN ? 3 * (l) + K : 0)
#define WK_M2(l) (3 * (l) + K < 2 * WK_LN ? (l) : 3 * (l) + K - WK_LN)
#define K 0
    c[0] = __builtin_shuffle(__builtin_shuffle(a, b, WK_MAKEI(WK_M1)), d, WK_MAKEI(WK_M2));
#undef K
#define K 1
    c[1] = __builtin_shuffle(__builtin_shuffle(a, b, WK_MAKEI(WK_M1)), d, WK_MAKEI(WK_M2));
#undef K
#define K 2
    c[2] = __builtin_shuffle(__builtin_shuffle(a, b, WK_MAKEI(WK_M1)), d, WK_MAKEI(WK_M2));
#undef K
#undef WK_M1
#undef WK_M2
#else
    for (int k = 0; k < 3; ++k) c[k] = wk_strided(p, 0, 3, (size_t)k);
#endif
}

/* Components k0 .. k0+3 of LN contiguous records of `stride` (>= k0 + 4) floats:
 * c[q][l] = p[stride * l + k0 + q]. */
WK_INL void wk_load_cols4(const float* p, size_t stride, size_t k0, wk_f c[4]) {
#if defined(TSK_SIMD_KERNEL_AVX512) || defined(TSK_SIMD_KERNEL_AVX2) || TSK_SIMD_SSE2
    /* r[j]'s lane h: record 4h + j, so that the transpose leaves record l in lane l */
    wk_f r[4];
    for (int j = 0; j < 4; ++j) r[j] = wk_ld_lanes4(p + stride * (size_t)j + k0, 4 * stride);
    wk_transpose4(r, c);
#else
    for (int q = 0; q < 4; ++q) c[q] = wk_strided(p, 0, stride, k0 + (size_t)q);
#endif
}

/* The 4 components of LN contiguous records of 4 floats: c[k][l] = p[4 * l + k]. */
WK_INL void wk_load_rows4(const float* p, wk_f c[4]) {
#if defined(TSK_SIMD_KERNEL_AVX512) || defined(TSK_SIMD_KERNEL_AVX2) || TSK_SIMD_SSE2
    wk_f r[4];
    for (int m = 0; m < 4; ++m) r[m] = wk_ld(p + m * WK_LN);
    wk_transpose4(r, c);
#if WK_LN > 4
    /* lane 4h + j now holds record j * LN/4 + h: put record l in lane l (GCC only: the wide
     * kernel units are GCC's) */
#define WK_P(l) 4 * ((l) % (WK_LN / 4)) + (l) / (WK_LN / 4)
    const wk_i perm = WK_MAKEI(WK_P);
#undef WK_P
    for (int k = 0; k < 4; ++k) c[k] = __builtin_shuffle(c[k], perm);
#endif
#else
    for (int k = 0; k < 4; ++k) c[k] = wk_strided(p, 0, 4, (size_t)k);
#endif
}

/* bend_pow of tree_internal.h, lane for lane the same operations in the same order */
WK_INL wk_f wk_bend_pow(wk_f m, float e) {
    const wk_i bits = (wk_i)m;
    const wk_f ex = __builtin_convertvector(((bits >> 23) & 255) - 127, wk_f);
    const wk_f mant = (wk_f)((bits & 0x7FFFFF) | 0x3F800000);
    const wk_f one = wk_splat(1.0f);
    const wk_f s = (mant - one) / (mant + one), s2 = s * s;
    wk_f poly = 0.142857143f + s2 * 0.111111111f;
    poly = 0.2f + s2 * poly;
    poly = 0.333333333f + s2 * poly;
    poly = one + s2 * poly;
    const wk_f ln = 2.0f * s * poly;
    wk_f y = e * (ex + ln * 1.44269504f);
    y = wk_max(y, wk_splat(-126.0f));
    y = wk_min(y, wk_splat(126.0f));
    wk_f n = __builtin_convertvector(__builtin_convertvector(y, wk_i), wk_f); /* truncation */
    n = n - (wk_f)((n > y) & (wk_i)one); /* then floor */
    const wk_f f = (y - n) * 0.693147181f;
    wk_f p = 0.00138888889f + f * 0.000198412698f;
    p = 0.00833333333f + f * p;
    p = 0.0416666667f + f * p;
    p = 0.166666667f + f * p;
    p = 0.5f + f * p;
    p = one + f * p;
    p = one + f * p;
    const wk_f sc = (wk_f)((__builtin_convertvector(n, wk_i) + 127) << 23);
    return p * sc;
}

int TREE_KFN(tree_wind_block)(const tree_wind_ctx* c, size_t i) {
    tsk_tree* t = c->t;
    wk_i par;
    memcpy(&par, t->parent + i, sizeof par);
    if (wk_any(par < 0)) return 0; /* a trunk */
    const int32_t p0 = t->parent[i], pl = t->parent[i + WK_LN - 1];
    wk_i bad = {0};
    const wk_f u = wk_ld(t->attach_v + i);
    const float* fr = (const float*)c->parent_frames;
    wk_src pts = {c->parent_pts + 12 * (size_t)p0,
                  c->parent_pts + 12 * (size_t)pl,
                  c->parent_pts,
                  NULL,
                  12,
                  par == pl};
    wk_src frames = {fr + 18 * (size_t)p0, fr + 18 * (size_t)pl, fr, NULL, 18, par == pl};
    /* siblings are contiguous: a block mostly shares one parent, or spans two */
    wk_terms pt;
    if (!wk_any(par != p0)) {
        pt = wk_parent_terms(WK_ONE, pts, frames, u);
    } else if (!wk_any((par != p0) & (par != pl))) {
        pt = wk_parent_terms(WK_TWO, pts, frames, u);
    } else {
        size_t pi[WK_LN];
        for (int l = 0; l < WK_LN; ++l) pi[l] = (size_t)t->parent[i + (size_t)l];
        pts.pi = frames.pi = pi;
        pt = wk_parent_terms(WK_ANY, pts, frames, u);
    }
    const wk_v3 origin = pt.origin, der = pt.der, Sv = pt.Sv, Tv = pt.Tv;
    wk_f trig[4];
    wk_load_rows4(t->trig + 4 * i, trig);
    const wk_f ct = trig[0], st = trig[1], ca = trig[2], sa = trig[3];
    /* U = normalize(bez_deriv); where it is degenerate (the chord fallback) the block goes
     * one branch at a time */
    const wk_v3 U = wk_norm(der, &bad);
    wk_v3 D = wk_comb(Sv, st, Tv, ct);
    D = wk_sub(D, wk_scale(U, wk_dot(D, U)));
    const wk_v3 V = wk_norm(D, &bad);
    if (wk_any(bad)) return 0;
    /* tree_pose_branch */
    const wk_v3 axis = wk_comb(U, ca, V, sa);
    const wk_v3 side = wk_comb(U, -sa, V, ca);
    const wk_v3 W = {U.y * V.z - U.z * V.y, U.z * V.x - U.x * V.z, U.x * V.y - U.y * V.x};
    wk_v3 Q[4];
    Q[0].x = Q[0].y = Q[0].z = wk_splat(0.0f);
    wk_f loc[9];
    wk_load_cols4(t->local + 9 * i, 9, 0, loc);
    wk_load_cols4(t->local + 9 * i, 9, 4, loc + 4);
    loc[8] = wk_strided(t->local, i, 9, 8);
    for (int k = 0; k < 3; ++k) Q[k + 1] = (wk_v3){loc[3 * k], loc[3 * k + 1], loc[3 * k + 2]};
    wk_f fc[3];
    wk_load_rows3(c->force + 3 * i, fc);
    wk_v3 F = {fc[0], fc[1], fc[2]};
    if (c->strength != 1.0f) F = wk_scale(F, wk_splat(c->strength));
    const wk_f zero = wk_splat(0.0f);
    const wk_i nonzero = (F.x != zero) | (F.y != zero) | (F.z != zero);
    if (wk_any(nonzero)) {
        const wk_f rs = wk_ld(t->rest_seg + i), l2 = wk_ld(t->seg12 + i);
        const wk_f inv_l = wk_ld(t->inv_l + i);
        wk_v3 f = {wk_dot(F, axis), wk_dot(F, side), wk_dot(F, W)};
        f = wk_scale(f, inv_l);
        const wk_f m = wk_sqrt(wk_dot(f, f));
        if (wk_any(~(m <= wk_splat(TREE_BEND_MAX)))) return 0; /* the one-branch path clamps */
        const wk_f mag = (wk_f)((m > zero) & (wk_i)wk_bend_pow(m, c->power - 1.0f));
        const wk_v3 bb3 = wk_scale(f, mag);
        const wk_v3 bb2 = wk_scale(bb3, wk_splat(c->b2_scale));
        const wk_v3 dd2 = wk_sub(Q[2], Q[1]), dd3 = wk_sub(Q[3], Q[2]);
        wk_i nb = {0};
        const wk_v3 n2 = wk_norm(wk_add(dd2, bb2), &nb);
        const wk_v3 q2v = wk_add(Q[1], wk_scale(n2, l2));
        const wk_v3 n3 = wk_norm(wk_add(dd3, bb3), &nb);
        const wk_v3 q3v = wk_add(q2v, wk_scale(n3, rs));
        /* a zero-length sum takes the one-branch fallback (a zero vector) */
        if (wk_any(nb & nonzero)) return 0;
        Q[2] = (wk_v3){wk_sel(nonzero, q2v.x, Q[2].x), wk_sel(nonzero, q2v.y, Q[2].y),
                       wk_sel(nonzero, q2v.z, Q[2].z)};
        Q[3] = (wk_v3){wk_sel(nonzero, q3v.x, Q[3].x), wk_sel(nonzero, q3v.y, Q[3].y),
                       wk_sel(nonzero, q3v.z, Q[3].z)};
    }
    /* 12 components x LN lanes -> LN rows of 12 floats (the branches are contiguous) */
    wk_f out[12];
    for (int k = 0; k < 4; ++k) {
        out[3 * k] = origin.x + axis.x * Q[k].x + side.x * Q[k].y + W.x * Q[k].z;
        out[3 * k + 1] = origin.y + axis.y * Q[k].x + side.y * Q[k].y + W.y * Q[k].z;
        out[3 * k + 2] = origin.z + axis.z * Q[k].x + side.z * Q[k].y + W.z * Q[k].z;
    }
    wk_store_rows12(t->cur + 12 * i, out);
    /* O of seed 001, eq. 8 */
    const wk_f m1 = wk_splat(-1.0f);
    wk_store_rows3(t->cur_O + 3 * i, (wk_f[4]){side.x * m1, side.y * m1, side.z * m1, m1});
    /* most blocks are twigs without children: one test of their LN flags */
    uint32_t kids = 0;
    for (int w = 0; w < WK_LN; w += 4) {
        uint32_t x;
        memcpy(&x, t->has_kids + i + (size_t)w, sizeof x);
        kids |= x;
    }
    for (int l = 0; kids && l < WK_LN; ++l) {
        if (t->has_kids[i + (size_t)l]) {
            v3 Pl[4];
            tree_load_points(t->cur, i + (size_t)l, Pl);
            sloan_build(Pl, tree_load3(t->cur_O, i + (size_t)l), &t->frames[i + (size_t)l]);
        }
    }
    return 1;
}

#undef WK_LN
#undef WK_INL
