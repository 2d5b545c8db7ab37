/* The blade solver for one block of SIM_W blades, written once and compiled once per
 * instruction set (blade_kernel_avx512.c, blade_kernel_avx2.c, blade_kernel.c for the portable
 * path). Verlet integration with damping, gravity (with preload) and wind drag; global and
 * local shape constraints; length constraints and collisions iterated, then a
 * follow-the-leader pass that sets every segment to its rest length (to a float's rounding)
 * while keeping knots outside colliders
 * (Han & Harada 2012, as seed 000 §2 and §4.5 adopt it: collision a hard constraint; length,
 * bending and twisting soft constraints of an iterative solver).
 *
 * The includer defines SIM_KFN(name) (the name with its instruction set's suffix) and, before
 * its first include, one of TSK_SIMD_KERNEL_AVX512 (16 lanes per vector), TSK_SIMD_KERNEL_AVX2
 * (8) or neither (portable, 4): core/simd.h decides. Every value is a vector of LN lanes
 * (GCC/Clang vector extensions of the machine's own width, so comparisons and selects stay
 * vector instructions); a block is worked in SIM_W / LN slices, two at a time, so that the
 * serial root-to-tip chains of the two overlap (one slice alone leaves the vector units waiting
 * on the chain's latency; wider values make GCC keep them in memory), and all of them at once in the length iterations of a block with no collider near.
 * Only IEEE add, sub, mul, div, sqrt, fused multiply-add (written out: fmadd, fnmadd, fmsub),
 * comparisons, min/max as (a > b ? a : b) and exact conversions are used, and -ffp-contract=off
 * keeps the compiler from fusing anything else, so every instruction set computes the same bits
 * (test_sim_kernel_paths_give_identical_bytes). A fused multiply-add rounds once, as IEEE's
 * fusedMultiplyAdd: one instruction on x86-64-v3 and later and on AArch64, tsk_fmaf
 * (core/tmath.h) lane by lane in the portable path elsewhere. */
#include "meadow/ribbon_input.h"
#include "sim/sim_internal.h"
#include "core/tmath.h"

#include <math.h>
#include <string.h>

#if defined(__GNUC__) && !defined(__clang__)
/* The vector helpers below are always inlined static functions: no ABI crosses them. */
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

/* Lanes per value: one register (core/simd.h). */
#define LN TSK_SIMD_LANES
#define RL TSK_SIMD_LANES /* lanes per register */
#if defined(TSK_SIMD_KERNEL_AVX512) || defined(TSK_SIMD_KERNEL_AVX2)
#include <immintrin.h>
#endif
#define W SIM_W
#define NSLICE (SIM_W / LN)

typedef float vf __attribute__((vector_size(4 * LN)));
typedef int32_t vi __attribute__((vector_size(4 * LN)));
typedef uint32_t vu __attribute__((vector_size(4 * LN)));
typedef int16_t vs16 __attribute__((vector_size(2 * LN)));
typedef uint8_t vu8 __attribute__((vector_size(LN)));

#define INL static inline __attribute__((always_inline))

/* Metres around a block's knots (plus its longest segment) within which a collider takes part
 * in the iterations. */
#define SIM_CULL_MARGIN 0.03f

INL vf ld(const float* p) {
    vf v;
    memcpy(&v, p, sizeof v);
    return v;
}
INL void st(float* p, vf v) { memcpy(p, &v, sizeof v); }
INL vf splat(float x) {
    vf v = {0};
    return v + x;
}
INL vf sel_bits(vi m, vf a, vf b) { return (vf)(((vi)a & m) | ((vi)b & ~m)); }

#if defined(TSK_SIMD_KERNEL_AVX512) || defined(TSK_SIMD_KERNEL_AVX2)
/* Comparisons, min, max, square roots and conversions register by register: GCC would split
   comparisons of values wider than a register into scalars. maxps(a, b) is exactly
   (a > b ? a : b) and minps(a, b) exactly (a < b ? a : b), as in the portable path. */
#define NR (LN / RL)
#define SPLIT(T, x, a) \
    T x[NR];           \
    memcpy(x, &(a), sizeof x)
#define JOIN(T, r, x) \
    T r;              \
    memcpy(&r, x, sizeof r)
#if defined(TSK_SIMD_KERNEL_AVX512)
typedef __m512 reg;
typedef __m512i ireg;
#define R_MAX _mm512_max_ps
#define R_MIN _mm512_min_ps
#define R_SQRT _mm512_sqrt_ps
#define R_GT(a, b) _mm512_movm_epi32(_mm512_cmp_ps_mask(a, b, _CMP_GT_OQ))
#define R_ANY(m) (_mm512_test_epi32_mask(m, m) != 0)
#define R_LD_HALF(p) _mm512_cvtph_ps(_mm256_loadu_si256((const __m256i*)(p)))
#define R_ST_HALF(p, v) \
    _mm256_storeu_si256((__m256i*)(p), _mm512_cvtps_ph(v, _MM_FROUND_TO_NEAREST_INT))
#define R_LD_S16(p) \
    _mm512_cvtepi32_ps(_mm512_cvtepi16_epi32(_mm256_loadu_si256((const __m256i*)(p))))
#define R_LD_U8(p) _mm512_cvtepi32_ps(_mm512_cvtepu8_epi32(_mm_loadu_si128((const __m128i*)(p))))
#define R_FMADD _mm512_fmadd_ps
#define R_FNMADD _mm512_fnmadd_ps
#define R_FMSUB _mm512_fmsub_ps
#else
typedef __m256 reg;
typedef __m256i ireg;
#define R_MAX _mm256_max_ps
#define R_MIN _mm256_min_ps
#define R_SQRT _mm256_sqrt_ps
#define R_GT(a, b) _mm256_castps_si256(_mm256_cmp_ps(a, b, _CMP_GT_OQ))
#define R_ANY(m) (_mm256_movemask_ps(_mm256_castsi256_ps(m)) != 0)
#define R_LD_HALF(p) _mm256_cvtph_ps(_mm_loadu_si128((const __m128i*)(p)))
#define R_ST_HALF(p, v) \
    _mm_storeu_si128((__m128i*)(p), _mm256_cvtps_ph(v, _MM_FROUND_TO_NEAREST_INT))
#define R_LD_S16(p) _mm256_cvtepi32_ps(_mm256_cvtepi16_epi32(_mm_loadu_si128((const __m128i*)(p))))
#define R_LD_U8(p) _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64((const __m128i*)(p))))
#define R_FMADD _mm256_fmadd_ps
#define R_FNMADD _mm256_fnmadd_ps
#define R_FMSUB _mm256_fmsub_ps
#endif
INL vi gt(vf a, vf b) {
    SPLIT(reg, x, a);
    SPLIT(reg, y, b);
    ireg m[NR];
    for (int i = 0; i < NR; ++i) m[i] = R_GT(x[i], y[i]);
    JOIN(vi, r, m);
    return r;
}
INL vf vmax(vf a, vf b) {
    SPLIT(reg, x, a);
    SPLIT(reg, y, b);
    for (int i = 0; i < NR; ++i) x[i] = R_MAX(x[i], y[i]);
    JOIN(vf, r, x);
    return r;
}
INL vf vmin(vf a, vf b) {
    SPLIT(reg, x, a);
    SPLIT(reg, y, b);
    for (int i = 0; i < NR; ++i) x[i] = R_MIN(x[i], y[i]);
    JOIN(vf, r, x);
    return r;
}
INL vf vsqrt(vf a) {
    SPLIT(reg, x, a);
    for (int i = 0; i < NR; ++i) x[i] = R_SQRT(x[i]);
    JOIN(vf, r, x);
    return r;
}
/* a * b + c, c - a * b and a * b - c, each rounded once */
#define FMA_OP(name, op)                                          \
    INL vf name(vf a, vf b, vf c) {                               \
        SPLIT(reg, x, a);                                         \
        SPLIT(reg, y, b);                                         \
        SPLIT(reg, z, c);                                         \
        for (int i = 0; i < NR; ++i) x[i] = op(x[i], y[i], z[i]); \
        JOIN(vf, r, x);                                           \
        return r;                                                 \
    }
FMA_OP(fmadd, R_FMADD)
FMA_OP(fnmadd, R_FNMADD)
FMA_OP(fmsub, R_FMSUB)
#undef FMA_OP
INL int any(vi m) {
    SPLIT(ireg, x, m);
    int k = 0;
    for (int i = 0; i < NR; ++i) k |= R_ANY(x[i]);
    return k;
}
INL vf ld_half(const uint16_t* p) {
    reg x[NR];
    for (int i = 0; i < NR; ++i) x[i] = R_LD_HALF(p + RL * i);
    JOIN(vf, r, x);
    return r;
}
INL void st_half(uint16_t* p, vf v) {
    SPLIT(reg, x, v);
    for (int i = 0; i < NR; ++i) R_ST_HALF(p + RL * i, x[i]);
}
INL vf ld_s16(const int16_t* p) {
    reg x[NR];
    for (int i = 0; i < NR; ++i) x[i] = R_LD_S16(p + RL * i);
    JOIN(vf, r, x);
    return r;
}
INL vf ld_u8(const uint8_t* p) {
    reg x[NR];
    for (int i = 0; i < NR; ++i) x[i] = R_LD_U8(p + RL * i);
    JOIN(vf, r, x);
    return r;
}
#else
INL vi gt(vf a, vf b) { return a > b; }
INL vf vmax(vf a, vf b) { return sel_bits(a > b, a, b); }
INL vf vmin(vf a, vf b) { return sel_bits(a < b, a, b); }
#if TSK_SIMD_SSE2
#include <emmintrin.h>
INL vf vsqrt(vf a) { return (vf)_mm_sqrt_ps((__m128)a); }
#elif TSK_SIMD_NEON
#include <arm_neon.h>
INL vf vsqrt(vf a) { return (vf)vsqrtq_f32((float32x4_t)a); }
#else
INL vf vsqrt(vf a) {
    for (int l = 0; l < LN; ++l) a[l] = sqrtf(a[l]); /* correctly rounded, as sqrtps */
    return a;
}
#endif
/* a * b + c, c - a * b and a * b - c, each rounded once: tsk_fmaf is IEEE fusedMultiplyAdd
   (one instruction where the target has one, glibc's exact fmaf or Tussock's own elsewhere;
   not every C library's fmaf is fused). Negating an operand is exact, so these are the bits
   of vfmadd, vfnmadd and vfmsub. */
INL vf fmadd(vf a, vf b, vf c) {
    for (int l = 0; l < LN; ++l) a[l] = tsk_fmaf(a[l], b[l], c[l]);
    return a;
}
INL vf fnmadd(vf a, vf b, vf c) {
    for (int l = 0; l < LN; ++l) a[l] = tsk_fmaf(-a[l], b[l], c[l]);
    return a;
}
INL vf fmsub(vf a, vf b, vf c) {
    for (int l = 0; l < LN; ++l) a[l] = tsk_fmaf(a[l], b[l], -c[l]);
    return a;
}
INL int any(vi m) {
    int32_t o = 0;
    for (int l = 0; l < LN; ++l) o |= m[l];
    return o != 0;
}
typedef uint16_t vh16 __attribute__((vector_size(2 * LN)));
/* binary16 <-> binary32 on whole vectors, bit for bit as sim_half_to_float and
   sim_float_to_half (and F16C). */
INL vf ld_half(const uint16_t* p) {
    vh16 h16;
    memcpy(&h16, p, sizeof h16);
    const vu h = __builtin_convertvector(h16, vu);
    const vu sign = (h & 0x8000u) << 16, e = (h >> 10) & 0x1fu, m = h & 0x3ffu;
    const vu normal = sign | ((e + 112u) << 23) | (m << 13);
    const vu special = sign | 0x7f800000u | (m << 13); /* inf, nan */
    const vu small = sign | (vu)(__builtin_convertvector(m, vf) * 0x1p-24f); /* 0, subnormal */
    const vi is_small = (vi)(e == 0u), is_special = (vi)(e == 31u);
    return (vf)(((vu)is_small & small) | ((vu)is_special & special) |
                (~(vu)(is_small | is_special) & normal));
}
INL void st_half(uint16_t* p, vf f) {
    const vu bits = (vu)f, x = bits & 0x7fffffffu, sign = (bits >> 16) & 0x8000u;
    const vu mm = x - (112u << 23);
    const vu normal = (mm + 0xfffu + ((mm >> 13) & 1u)) >> 13;
    /* below 2^-14: |f| 2^24 rounded to an integer (to nearest even, by adding 2^23) */
    const vf t = (vf)x * 0x1p24f + 0x1p23f;
    const vu small = (vu)t - 0x4b000000u;
    const vu nan = 0x7c00u | ((vu)(x > 0x7f800000u) & 0x200u);
    const vu is_nan_inf = (vu)(x >= 0x7f800000u), is_over = (vu)(x >= 0x477ff000u) & ~is_nan_inf;
    const vu is_small = (vu)(x < 0x38800000u);
    const vu is_normal = ~(is_nan_inf | is_over | is_small);
    const vu h =
        sign | (is_normal & normal) | (is_small & small) | (is_over & 0x7c00u) | (is_nan_inf & nan);
    const vh16 h16 = __builtin_convertvector(h, vh16);
    memcpy(p, &h16, sizeof h16);
}
INL vf ld_s16(const int16_t* p) {
    vs16 s;
    memcpy(&s, p, sizeof s);
    return __builtin_convertvector(__builtin_convertvector(s, vi), vf);
}
INL vf ld_u8(const uint8_t* p) {
    vu8 s;
    memcpy(&s, p, sizeof s);
    return __builtin_convertvector(__builtin_convertvector(s, vi), vf);
}
#endif
/* a where m is set, else b; m's lanes are all ones or all zeros (comparisons). With AVX2 one
   vblendvps, which looks at each lane's sign bit only, gives the bits of sel_bits' three
   and-or instructions in one, on the kernel's most frequent operation. (AVX-512 builds need
   no such help: GCC makes the and-or one vpternlogd, Clang a masked move.) */
#if defined(TSK_SIMD_KERNEL_AVX2)
INL vf sel(vi m, vf a, vf b) {
    SPLIT(reg, x, a);
    SPLIT(reg, y, b);
    SPLIT(ireg, k, m);
    for (int i = 0; i < NR; ++i) x[i] = _mm256_blendv_ps(y[i], x[i], _mm256_castsi256_ps(k[i]));
    JOIN(vf, r, x);
    return r;
}
#else
INL vf sel(vi m, vf a, vf b) { return sel_bits(m, a, b); }
#endif
/* |a|: the sign bit cleared */
INL vf vabs(vf a) { return (vf)((vi)a & 0x7fffffff); }
INL vi lt(vf a, vf b) { return gt(b, a); }
INL int all(vi m) { return !any(~m); }
INL vi gts(vf a, float b) { return gt(a, splat(b)); }
INL vi lts(vf a, float b) { return gt(splat(b), a); }

typedef struct v3 {
    vf x, y, z;
} v3;

/* three rows of a [row][lane] array with rows W floats apart */
INL v3 ld3(const float* p) { return (v3){ld(p), ld(p + W), ld(p + 2 * W)}; }
INL void st3(float* p, v3 v) {
    st(p, v.x);
    st(p + W, v.y);
    st(p + 2 * W, v.z);
}
INL v3 add3(v3 a, v3 b) { return (v3){a.x + b.x, a.y + b.y, a.z + b.z}; }
INL v3 sub3(v3 a, v3 b) { return (v3){a.x - b.x, a.y - b.y, a.z - b.z}; }

/* Stores a knot's displacement over the step (its Verlet velocity) as binary16. Each
 * component is clamped to +-SIM_MAX_STEP_DISP first: binary16 ends at 65504, and a knot thrown
 * that far in one step (a collider of 200 km pushing it out, found by fuzz_sim) would store
 * inf, and inf - inf makes every later position NaN. (vmin/vmax give the same bytes in every
 * build, NaN included.) */
#define SIM_MAX_STEP_DISP 1000.0f
INL vf clamp_disp(vf d) {
    return vmin(vmax(d, splat(-SIM_MAX_STEP_DISP)), splat(SIM_MAX_STEP_DISP));
}
INL void st_velocity(uint16_t* Vk, v3 v) {
    st_half(Vk, clamp_disp(v.x));
    st_half(Vk + W, clamp_disp(v.y));
    st_half(Vk + 2 * W, clamp_disp(v.z));
}
INL v3 mul3(vf s, v3 a) { return (v3){s * a.x, s * a.y, s * a.z}; }
/* c + s a and c - s a, fused */
INL v3 madd3(vf s, v3 a, v3 c) {
    return (v3){fmadd(s, a.x, c.x), fmadd(s, a.y, c.y), fmadd(s, a.z, c.z)};
}
INL v3 nmadd3(vf s, v3 a, v3 c) {
    return (v3){fnmadd(s, a.x, c.x), fnmadd(s, a.y, c.y), fnmadd(s, a.z, c.z)};
}
/* Products summed x, y, z, fused: as sim_dot3 for one lane. */
INL vf dot3(v3 a, v3 b) { return fmadd(a.z, b.z, fmadd(a.y, b.y, a.x * b.x)); }
/* as sim_cross3 */
INL v3 cross3(v3 a, v3 b) {
    return (v3){fmsub(a.y, b.z, a.z * b.y), fmsub(a.z, b.x, a.x * b.z), fmsub(a.x, b.y, a.y * b.x)};
}
INL v3 sel3(vi m, v3 a, v3 b) { return (v3){sel(m, a.x, b.x), sel(m, a.y, b.y), sel(m, a.z, b.z)}; }
/* frame (t, s, n) applied to local coordinates (a, b, c), fused as dot3 */
INL v3 apply3(v3 t, v3 s, v3 n, vf a, vf b, vf c) {
    return (v3){fmadd(n.x, c, fmadd(s.x, b, t.x * a)), fmadd(n.y, c, fmadd(s.y, b, t.y * a)),
                fmadd(n.z, c, fmadd(s.z, b, t.z * a))};
}

/* The pointers into a block. */
typedef struct blk {
    float* P;
    uint16_t* V;
    const int16_t* D;
    const float* Q;
    const uint8_t* WD;
    const float* lane;
} blk;

INL blk blk_of(int K, float* block) {
    char* b = (char*)block;
    return (blk){block,
                 (uint16_t*)(b + SIM_BOFF_V(K)),
                 (const int16_t*)(b + SIM_BOFF_D(K)),
                 (const float*)(b + SIM_BOFF_Q(K)),
                 (const uint8_t*)(b + SIM_BOFF_WD(K)),
                 (const float*)(b + SIM_BOFF_LANE(K))};
}

/* One segment of the rest pose (sim_rest_segment does the same for one lane): from the rest
 * frame (t, s, n) of the segment before, segment k's stored vector D and its stored quotients
 * (Q: 1 / |D| and the coefficient c of the rotation, sim_rest_quotients) give its length, its
 * unit direction r in that frame and c; the frame turns into segment k's own: t' = u =
 * (t, s, n) r, s' = s - c (t + u), n' = t' x s'. With the quotients stored, the rebuild needs
 * no square root or division: the step is about a tenth faster. */
typedef struct rest_seg {
    vf len, il; /* length and 1 / length */
    vf rx, ry, rz; /* unit direction in the parent's frame */
    vf c; /* r_y / (1 + r_x) */
} rest_seg;

INL rest_seg rest_segment(const int16_t* Dk, const float* Qk, vf ds, v3* t, v3* s, v3* n) {
    rest_seg g;
    const vf dx = ld_s16(Dk) * ds, dy = ld_s16(Dk + W) * ds, dz = ld_s16(Dk + 2 * W) * ds;
    g.il = ld(Qk);
    g.c = ld(Qk + W);
    g.len = dot3((v3){dx, dy, dz}, (v3){dx, dy, dz}) * g.il;
    g.rx = g.il * dx, g.ry = g.il * dy, g.rz = g.il * dz;
    const v3 u = apply3(*t, *s, *n, g.rx, g.ry, g.rz);
    const v3 sw = nmadd3(g.c, add3(*t, u), *s);
    *t = u, *s = sw, *n = cross3(u, sw);
    return g;
}

/* The point of a collider's core (a + t ab, t in [0, 1]) nearest to x; for a sphere, a. */
INL v3 core_point(v3 x, const sim_collider* col) {
    const v3 a = {splat(col->a[0]), splat(col->a[1]), splat(col->a[2])};
    if (col->inv_ab2 == 0.0f) return a;
    const v3 ab = {splat(col->ab[0]), splat(col->ab[1]), splat(col->ab[2])};
    const vf t = vmin(vmax(dot3(sub3(x, a), ab) * col->inv_ab2, splat(0.0f)), splat(1.0f));
    return madd3(t, ab, a);
}

/* Pushes x out of a collider (capsule core a + t ab, t in [0, 1]; ab = 0 for a sphere) along
 * the surface normal. A knot exactly on the core goes straight up. */
INL v3 push_out(v3 x, const sim_collider* col) {
    const vf r = splat(col->r);
    const v3 c = core_point(x, col);
    const v3 d = sub3(x, c);
    const vf dd = dot3(d, d);
    const vi inside = lt(dd, r * r);
    if (!any(inside)) return x; /* most knots of most blocks: no work */
    const vi centred = lts(dd, 1e-24f);
    const vf s = r / vsqrt(vmax(dd, splat(1e-24f)));
    v3 y = madd3(s, d, c);
    y = sel3(centred, (v3){c.x, c.y, c.z + r}, y);
    return sel3(inside, y, x);
}

/* A unit may leave out the step (with tsk_sim_block_rest, which must rebuild the rest pose as
 * the step does) or the ribbons: the AVX-512 unit is built twice, the step by Clang and the
 * ribbons by GCC (blade_kernel_avx512.c). */
#if !defined(SIM_KERNEL_NO_STEP)
void SIM_KFN(tsk_sim_block_rest)(int32_t K, float* block) {
    const blk b = blk_of(K, block);
    for (int h = 0; h < NSLICE; ++h) {
        const int lo = h * LN;
        float* P = b.P + lo;
        v3 gt = ld3(b.lane + SIM_LANE_T0 * W + lo), gs = ld3(b.lane + SIM_LANE_S0 * W + lo);
        v3 gn = cross3(gt, gs);
        const vf ds = ld(b.lane + SIM_LANE_DS * W + lo);
        v3 p = ld3(P);
        for (int k = 1; k < K; ++k) {
            const rest_seg g = rest_segment(b.D + (size_t)(k - 1) * 3 * W + lo,
                                            b.Q + (size_t)(k - 1) * 2 * W + lo, ds, &gt, &gs, &gn);
            p = madd3(g.len, gt, p);
            st3(P + (size_t)k * 3 * W, p);
            for (int c = 0; c < 3; ++c) memset(b.V + ((size_t)(k - 1) * 3 + c) * W + lo, 0, 2 * LN);
        }
    }
}

/* Slices are worked two at a time (h and h + 1), their root-to-tip chains interleaved. */
#define PAIR_LO1(h) ((h) + 1 < NSLICE ? ((h) + 1) * LN : (h)*LN)

/* Per step and block, [k][c][lane] (rows of W floats), what the passes after the sweep need:
 * rest positions, positions at the start of the step, segment lengths and 1 / (4 length^2).
 * On the stack: 64 KB for 64 knots, of which a step touches 16 KB at 16 knots. */
enum { MK = TSK_BLADE_SIM_MAX_KNOTS };
typedef struct scratch {
    float rest[MK * 3 * W], xold[MK * 3 * W];
    float len[MK * W], il2q[MK * W];
} scratch;

/* What every knot of a step needs. */
typedef struct kconst {
    int K;
    float* P;
    uint16_t* V;
    const float* wind;
    size_t wind_stride;
    const char* next; /* the next block, prefetched during pass 1; NULL for none */
    size_t next_lines; /* its 64-byte lines per knot of pass 1 */
    scratch* S;
    vf damp, dtv, alc1, alc2;
    v3 g1, gp;
} kconst;

/* ---- the rest pose, rebuilt from the stored segments inside pass 1's sweep: each knot's rest
        segment just before the knot moves. Its chain from knot to knot is independent of the
        sweep's, so the two overlap, and what pass 1 needs of it stays in registers (a
        separate pass 0 wrote it to the stack and read it back: 196 -> 189 TSC cycles per
        blade-step for one block in cache). */
typedef struct rest_state {
    v3 t, s, n, rp;
    vf ds, dragw, ar, kat, arc;
} rest_state;

INL void rest_start(rest_state* R, const blk* b, const sim_step_params* p, scratch* S, int lo) {
    const float* lane = b->lane + lo;
    R->t = ld3(lane + SIM_LANE_T0 * W), R->s = ld3(lane + SIM_LANE_S0 * W);
    R->n = cross3(R->t, R->s);
    R->ds = ld(lane + SIM_LANE_DS * W);
    R->dragw = p->drag * ld(lane + SIM_LANE_WS * W);
    R->ar = splat(p->alpha_root);
    R->kat = (splat(p->alpha_tip) - R->ar) / ld(lane + SIM_LANE_LT * W);
    R->arc = splat(0.0f);
    R->rp = ld3(b->P + lo);
    st3(S->rest + lo, R->rp);
}

/* What the sweep needs of knot k's rest segment. */
typedef struct rest_knot_out {
    rest_seg g;
    v3 rp; /* rest position */
    vf al, kd; /* global shape and drag fractions */
} rest_knot_out;

INL rest_knot_out rest_knot(rest_state* R, const blk* b, scratch* S, int k, int lo) {
    const size_t o3 = (size_t)k * 3 * W + lo, o1 = (size_t)k * W + lo;
    rest_knot_out o;
    o.g = rest_segment(b->D + (size_t)(k - 1) * 3 * W + lo, b->Q + (size_t)(k - 1) * 2 * W + lo,
                       R->ds, &R->t, &R->s, &R->n);
    R->rp = madd3(o.g.len, R->t, R->rp);
    o.rp = R->rp;
    st3(S->rest + o3, R->rp);
    st(S->len + o1, o.g.len);
    st(S->il2q + o1, 0.25f * (o.g.il * o.g.il));
    /* global shape fraction, linear in arc length; drag fraction kd = wind_drag /
       linear_density * width * dt, at most 1 */
    R->arc = R->arc + o.g.len;
    o.al = fmadd(R->kat, R->arc, R->ar);
    o.kd = vmin(R->dragw * ld_u8(b->WD + (size_t)(k - 1) * W + lo), splat(1.0f));
    return o;
}

/* ---- pass 1, one knot of one slice: its rest segment, then Verlet with damping, gravity (minus the preload the rest
        pose carries) and wind drag; the global shape constraint toward the rest pose; then the
        local shape constraint of segment k-1 -> k: it is pulled toward its rest direction
        expressed in the current frame of the segment before it. The preload is -g at rest. Its
        part along the segment turns with the segment (a blade pressed flat no longer carries
        its weight along itself); the small part across the segment stays fixed in the world:
        acc = g - pre (ga t + g - ga u),  ga = u . g,  u the rest direction, t the current one. */
typedef struct move_state {
    v3 ft, fs, fn; /* current frame of the segment before */
    v3 xp; /* new position of the knot before */
} move_state;

INL void move_start(move_state* M, const blk* b, scratch* S, int lo) {
    const float* lane = b->lane + lo;
    M->ft = ld3(lane + SIM_LANE_T0 * W), M->fs = ld3(lane + SIM_LANE_S0 * W);
    M->fn = cross3(M->ft, M->fs);
    M->xp = ld3(b->P + lo);
    st3(S->xold + lo, M->xp); /* the root */
}

INL void move_knot(move_state* M, rest_state* R, const blk* b, const kconst* C, int k, int lo,
                   int has_wind) {
    /* knot k of the rest pose first */
    scratch* S = C->S;
    const size_t o3 = (size_t)k * 3 * W + lo;
    const size_t r3 = (size_t)(k - 1) * 3 * W + lo;
    const rest_knot_out rk = rest_knot(R, b, S, k, lo);
    const vf len = rk.g.len, il = rk.g.il, kd = rk.kd;
    const v3 u = R->t;
    /* current direction of the segment (old positions): the last step ended with every segment
       at its rest length (follow-the-leader pass), so d / L is a unit vector */
    const v3 x = ld3(C->P + o3);
    st3(S->xold + o3, x);
    const v3 dc = sub3(x, ld3(S->xold + o3 - 3 * W)); /* t = il dc */
    /* Verlet: x' = x + damp v + a dt^2 + kd (wind dt - v), v = x - x_prev */
    const v3 v = {ld_half(C->V + r3), ld_half(C->V + r3 + W), ld_half(C->V + r3 + 2 * W)};
    const vf ga = dot3(u, C->gp);
    v3 xn = add3(madd3(C->damp - kd, v, x), madd3(ga, nmadd3(il, dc, u), C->g1));
    if (has_wind) xn = madd3(kd * C->dtv, ld3(C->wind + (size_t)k * C->wind_stride + lo), xn);
    /* global shape constraint */
    xn = madd3(rk.al, sub3(rk.rp, xn), xn);
    /* local shape constraint of segment k-1 -> k: its rest direction in the current frame of
       the segment before, and that frame turned by the rest rotation */
    const v3 r = {rk.g.rx, rk.g.ry, rk.g.rz};
    const vf c = rk.g.c;
    const v3 pt = apply3(M->ft, M->fs, M->fn, r.x, r.y, r.z);
    const v3 ps = nmadd3(c, add3(M->ft, pt), M->fs);
    /* e = (xp + len pt) - xn, taken as len pt - (xn - xp): the knots' old difference is
       known before the frame is, so the chain from the frame to the next one is shorter */
    const v3 dc0 = sub3(xn, M->xp);
    const v3 e = {fmsub(len, pt.x, dc0.x), fmsub(len, pt.y, dc0.y), fmsub(len, pt.z, dc0.z)};
    if (k == 1) { /* the root does not move */
        xn = madd3(C->alc1, e, xn);
    } else {
        xn = madd3(C->alc2, e, xn);
        M->xp = nmadd3(C->alc2, e, M->xp);
        st3(C->P + o3 - 3 * W, M->xp);
    }
    /* the current frame moves to segment k: the prediction (pt, ps) turned by the smallest
       rotation taking pt onto the segment's actual direction a = d / |d|. d is xn - xp after
       the constraint, dc0 + alpha_local e (at knot 1 xn moves by alpha_local, further on both
       knots by half of it), not the difference of the rounded knots. The rotation's
       coefficient (a . ps) / (1 + pt . a) is taken as (d . ps) / (|d| + pt . d), so it need
       not wait for a. A zero direction keeps the prediction: its lanes' quotients (inf or NaN
       for a zero |d| or den) are computed and then dropped by the selects, so that the square
       root and the division do not wait for a select first. */
    const v3 d = madd3(C->alc1, e, dc0);
    const vf dd = dot3(d, d);
    const vi ok = gts(dd, 1e-30f);
    const vf len_d = vsqrt(dd);
    const vf den = len_d + dot3(pt, d);
    const vi okd = ok & gt(den, 1e-6f * len_d);
    const vf q = sel(okd, dot3(d, ps) / den, splat(0.0f));
    const v3 a = sel3(ok, mul3(1.0f / len_d, d), pt);
    M->ft = a;
    M->fs = nmadd3(q, add3(pt, a), ps);
    M->fn = cross3(M->ft, M->fs);
    M->xp = xn;
}

/* Pass 1 over slices h and h + 1; the first knot (the root stays) and the wind are decided
   outside the loop. */
INL void move_sweep(const blk* b, const sim_step_params* p, kconst* C, int h, int has_wind) {
    const int K = C->K, lo0 = h * LN, lo1 = PAIR_LO1(h);
    move_state A, B;
    rest_state RA, RB;
    rest_start(&RA, b, p, C->S, lo0);
    move_start(&A, b, C->S, lo0);
    if (lo1 != lo0) {
        rest_start(&RB, b, p, C->S, lo1);
        move_start(&B, b, C->S, lo1);
    }
    move_knot(&A, &RA, b, C, 1, lo0, has_wind);
    if (lo1 != lo0) move_knot(&B, &RB, b, C, 1, lo1, has_wind);
    for (int k = 2; k < K; ++k) {
        move_knot(&A, &RA, b, C, k, lo0, has_wind);
        if (lo1 != lo0) move_knot(&B, &RB, b, C, k, lo1, has_wind);
        if (C->next && h == 0) { /* the next block into L2 while this one computes */
            const char* q = C->next + (size_t)(k - 2) * C->next_lines * 64;
            const char* end = C->next + SIM_BLOCK_FLOATS(K) * 4;
            for (size_t i = 0; i < C->next_lines && q < end; ++i, q += 64)
                __builtin_prefetch(q, 1, 2);
        }
    }
    st3(b->P + (size_t)(K - 1) * 3 * W + lo0, A.xp);
    if (lo1 != lo0) st3(b->P + (size_t)(K - 1) * 3 * W + lo1, B.xp);
}

/* ---- pass 2 without colliders, one iteration: segments relaxed odd then even (segments of
        one parity share no knot, so their updates are independent), then the ground. Done as
        one sweep that runs the even segment k-1 right after the odd segment k: every knot is
        loaded and stored once, and the result is the same as two separate passes. */
INL void length_segment(v3* xp, v3* x, vf il2q, int first) {
    const v3 d = sub3(*x, *xp);
    /* half the exact correction (len - L) / len, to first order in len/L - 1:
       (len^2 / L^2 - 1) / 4 (il2q = 1 / 4L^2), no square root; at most 1/4 for large errors.
       It is never below -1/4 (len^2 il2q >= 0), so it needs no lower bound (a NaN d now
       gives f = 1/4 rather than -1/4; the knots it moves are NaN either way). The
       follow-the-leader pass sets the lengths. */
    const vf f = vmin(fmsub(dot3(d, d), il2q, splat(0.25f)), splat(0.25f));
    if (first) { /* the root does not move: the knot takes the whole correction */
        *x = nmadd3(f + f, d, *x);
    } else {
        *x = nmadd3(f, d, *x);
        *xp = madd3(f, d, *xp);
    }
}

/* A knot done with this iteration's length constraints: out of the colliders near the block, in
   their order, then above the ground. */
typedef struct near_list {
    const sim_collider* const* c;
    int n;
} near_list;

INL v3 finish_knot(v3 x, vf ground, near_list nl) {
    for (int ci = 0; ci < nl.n; ++ci) x = push_out(x, nl.c[ci]);
    x.z = vmax(x.z, ground);
    return x;
}

/* The sweep state of one slice: the knot held between steps. */
typedef struct length_state {
    v3 hold;
    int lo;
} length_state;

INL void length_start(length_state* L, float* P, const float* il2q, int lo) {
    L->lo = lo;
    L->hold = ld3(P + 3 * W + lo); /* knot 1 */
    v3 root = ld3(P + lo);
    length_segment(&root, &L->hold, ld(il2q + W + lo), 1);
}

/* odd segment j and even segment j - 1 */
INL void length_step(length_state* L, float* P, const float* il2q, int j, vf ground, near_list nl) {
    const int lo = L->lo;
    v3 a = ld3(P + (size_t)(j - 1) * 3 * W + lo), c = ld3(P + (size_t)j * 3 * W + lo);
    length_segment(&a, &c, ld(il2q + (size_t)j * W + lo), 0);
    length_segment(&L->hold, &a, ld(il2q + (size_t)(j - 1) * W + lo), 0);
    st3(P + (size_t)(j - 2) * 3 * W + lo, finish_knot(L->hold, ground, nl));
    st3(P + (size_t)(j - 1) * 3 * W + lo, finish_knot(a, ground, nl));
    L->hold = c;
}

INL void length_end(length_state* L, int K, float* P, const float* il2q, int j, vf ground,
                    near_list nl) {
    const int lo = L->lo;
    if (j - 1 < K) { /* an even last segment j - 1 */
        v3 c = ld3(P + (size_t)(j - 1) * 3 * W + lo);
        length_segment(&L->hold, &c, ld(il2q + (size_t)(j - 1) * W + lo), 0);
        st3(P + (size_t)(j - 2) * 3 * W + lo, finish_knot(L->hold, ground, nl));
        st3(P + (size_t)(j - 1) * 3 * W + lo, finish_knot(c, ground, nl));
    } else {
        st3(P + (size_t)(j - 2) * 3 * W + lo, finish_knot(L->hold, ground, nl));
    }
}

/* One length iteration over the nh slices from slice h0 on (nh a constant: the loops unroll
   and the states stay in registers), interleaved so that their chains overlap. */
INL void length_iteration(int K, float* P, const float* il2q, int h0, int nh, vf ground,
                          near_list nl) {
    length_state L[NSLICE];
    for (int q = 0; q < nh; ++q) length_start(&L[q], P, il2q, (h0 + q) * LN);
    int j = 3;
    for (; j < K; j += 2)
        for (int q = 0; q < nh; ++q) length_step(&L[q], P, il2q, j, ground, nl);
    for (int q = 0; q < nh; ++q) length_end(&L[q], K, P, il2q, j, ground, nl);
}

/* ---- pass 3, one knot of one slice: follow the leader (Mueller et al. 2012): the segment is
        set to its rest length (to a float's rounding); a knot this puts inside a collider goes
        to the nearest point that is both at the segment's length from the knot before it and
        on the collider's surface (the circle where the two spheres meet); under the ground, to the
        nearest point of the circle where that sphere meets the ground plane. The iterations
        leave small residuals, so this pass moves knots little. The new displacement over the
        step (the velocity) and the statistics are taken on the way. */
typedef struct ftl_state {
    v3 xp;
    vf md, ms;
} ftl_state;

/* Depth, as a fraction of r^2, within which the follow-the-leader pass stops refining a knot's
 * projection onto a capsule and leaves it to push_out: r^2 (1 - 1e-4) is about r / 20,000 deep
 * (12 um for a 25 cm log), a change of a segment's length far below the 1 % the solver keeps. */
#define SIM_FTL_SLACK 1e-4f

INL void ftl_knot(ftl_state* F, const kconst* C, const sim_collider* const* near, int nnear,
                  vf ground, int k, int lo) {
    scratch* S = C->S;
    const size_t o3 = (size_t)k * 3 * W + lo;
    const vf len = ld(S->len + (size_t)k * W + lo);
    const v3 xp = F->xp;
    v3 x = ld3(C->P + o3);
    {
        /* x = xp + (len / |d|) d. The iterations leave |d| within a fraction of a percent of
           len, so len / |d| = (1 + y)^(-1/2), y = |d|^2 / len^2 - 1 = 4 e, is taken from its
           series, 1 - 2e + 6e^2 - 20e^3, where |e| < 1/256 (the next term, 70 e^4, is then
           below 1.6e-8, under a float's rounding): no square root or division on the
           root-to-tip chain. Lanes further off take the quotient; there a zero or tiny d's
           lanes compute inf or NaN and keep x. */
        const v3 d = sub3(x, xp);
        const vf dd = dot3(d, d);
        const vf e = fmsub(dd, ld(S->il2q + (size_t)k * W + lo), splat(0.25f));
        const vf f =
            fmadd(e, fmadd(e, fmadd(e, splat(-20.0f), splat(6.0f)), splat(-2.0f)), splat(1.0f));
        const vi close = lt(vabs(e), splat(1.0f / 256.0f));
        v3 y = madd3(f, d, xp);
        if (!all(close)) {
            const vi ok = gts(dd, 1e-30f);
            y = sel3(close, y, sel3(ok, madd3(len / vsqrt(dd), d, xp), x));
        }
        x = y;
    }
    for (int ci = 0; ci < nnear; ++ci) {
        const sim_collider* col = near[ci];
        const vf r = splat(col->r), r2 = r * r, r2_slack = r2 * (1.0f - SIM_FTL_SLACK);
        /* a capsule's nearest core point moves with the knot: more rounds refine it */
        const int rounds = col->inv_ab2 > 0.0f ? 3 : 1;
        int projected = 0;
        for (int round = 0; round < rounds; ++round) {
            const v3 c = core_point(x, col);
            const v3 xd = sub3(x, c);
            /* after the first round, a knot within the slack of the surface is left to
               push_out below: a projection from the core point nearest to the knot before
               lands a hair inside, by rounding or because the nearest point moved, and
               rounds spent on that changed nothing that push_out does not */
            const vi inside = lt(dot3(xd, xd), round ? r2_slack : r2);
            if (!any(inside)) break; /* no lane inside: nothing to project */
            projected = 1;
            /* circle of sphere(xp, len) and sphere(c, r): centre xp + h0 u, radius h */
            const v3 e = sub3(c, xp);
            const vf D2 = dot3(e, e);
            const vf D = vsqrt(vmax(D2, splat(1e-24f)));
            const vf iD = 1.0f / D;
            const v3 u = mul3(iD, e);
            const vf h0 = (fmadd(len, len, D2) - r2) * 0.5f * iD;
            const vf h2 = vmax(fnmadd(h0, h0, len * len), splat(0.0f));
            const vf hh = vsqrt(h2);
            const v3 q = sub3(x, xp);
            const v3 w = nmadd3(dot3(q, u), u, q);
            const vf ww = dot3(w, w);
            const vi wok = gts(ww, 1e-30f);
            const vf iw = sel(wok, hh / vsqrt(sel(wok, ww, splat(1.0f))), splat(0.0f));
            /* the circle exists when the previous knot is outside (it may lie on the surface,
               up to rounding), within len + r */
            const vi ok = inside & gt(D, r * 0.999f) & lt(D, len + r) & wok;
            const v3 y = madd3(iw, w, madd3(h0, u, xp));
            x = sel3(ok, y, x);
        }
        if (projected) x = push_out(x, col); /* what is left: tiny */
    }
    if (any(lt(x.z, ground))) {
        const vf hz = xp.z - ground;
        const vf h2 = vmax(fnmadd(hz, hz, len * len), splat(0.0f));
        const vf qx = x.x - xp.x, qy = x.y - xp.y;
        const vf qq = fmadd(qy, qy, qx * qx);
        const vi ok = gts(qq, 1e-30f);
        const vf s = sel(ok, vsqrt(h2) / vsqrt(sel(ok, qq, splat(1.0f))), splat(0.0f));
        const vi below = lt(x.z, ground);
        x = sel3(below, (v3){fmadd(s, qx, xp.x), fmadd(s, qy, xp.y), ground}, x);
    }
    st3(C->P + o3, x);
    F->xp = x;
    /* velocity (displacement over the step) and statistics */
    const v3 v = sub3(x, ld3(S->xold + o3));
    st_velocity(C->V + (size_t)(k - 1) * 3 * W + lo, v);
    const v3 e = sub3(x, ld3(S->rest + o3));
    F->md = vmax(F->md, dot3(e, e));
    F->ms = vmax(F->ms, dot3(v, v));
}

/* The last length iteration without colliders near, over every slice of the block, with the
   follow-the-leader pass running right behind it: each knot is set to its segment's length as
   soon as the sweep is done with it, while the sweep goes on (the same operations as the two
   passes one after the other). F: one state per slice. */
INL void length_iteration_ftl(int K, float* P, const float* il2q, vf ground, const kconst* C,
                              ftl_state* F) {
    const near_list nl = {NULL, 0};
    length_state L[NSLICE];
    for (int q = 0; q < NSLICE; ++q) length_start(&L[q], P, il2q, q * LN);
    int j = 3;
    for (; j < K; j += 2) {
        for (int q = 0; q < NSLICE; ++q) length_step(&L[q], P, il2q, j, ground, nl);
        /* knots j - 2 and j - 1 are done */
        for (int q = 0; q < NSLICE; ++q) ftl_knot(&F[q], C, NULL, 0, ground, j - 2, q * LN);
        for (int q = 0; q < NSLICE; ++q) ftl_knot(&F[q], C, NULL, 0, ground, j - 1, q * LN);
    }
    for (int q = 0; q < NSLICE; ++q) length_end(&L[q], K, P, il2q, j, ground, nl);
    for (int k = j - 2; k < K; ++k)
        for (int q = 0; q < NSLICE; ++q) ftl_knot(&F[q], C, NULL, 0, ground, k, q * LN);
}

void SIM_KFN(tsk_sim_block_step)(const sim_step_params* p, float* block, const float* wind,
                                 size_t wind_stride, const sim_collider* const* cols, int ncol,
                                 float blend, const float* next, sim_block_stats* stats) {
    const int K = p->K;
    const blk b = blk_of(K, block);
    scratch S __attribute__((aligned(64)));

    kconst C;
    C.K = K, C.P = b.P, C.V = b.V, C.wind = wind, C.wind_stride = wind_stride, C.S = &S;
    C.next = (const char*)next;
    C.next_lines = K > 2 ? (SIM_BLOCK_FLOATS(K) * 4 / 64 + (size_t)K - 3) / (size_t)(K - 2) : 0;
    C.damp = splat(p->damp), C.dtv = splat(p->dt);
    C.alc1 = splat(p->alpha_local), C.alc2 = splat(0.5f * p->alpha_local);
    /* acceleration times dt^2: (1 - pre) g + pre ga (u - t) with ga = u . g */
    C.g1 = (v3){splat((1.0f - p->preload) * p->gravity[0] * p->dt2),
                splat((1.0f - p->preload) * p->gravity[1] * p->dt2),
                splat((1.0f - p->preload) * p->gravity[2] * p->dt2)};
    C.gp =
        (v3){splat(p->preload * p->dt2 * p->gravity[0]), splat(p->preload * p->dt2 * p->gravity[1]),
             splat(p->preload * p->dt2 * p->gravity[2])};

    /* ---- pass 1: one sweep root to tip per slice */
    for (int h = 0; h < NSLICE; h += 2) {
        if (wind) move_sweep(&b, p, &C, h, 1);
        else move_sweep(&b, p, &C, h, 0);
    }

    /* ---- colliders near the block now: its knots' box grown by SIM_CULL_MARGIN. The iterations
            and the follow-the-leader pass use these; a last pass below checks every collider
            that can reach the block, so no knot ends inside any of them. */
    const sim_collider* near[TSK_BLADE_SIM_MAX_COLLIDERS];
    int nnear = 0;
    if (ncol > 0) {
        float bl[3] = {INFINITY, INFINITY, INFINITY}, bh[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int h = 0; h < NSLICE; ++h) {
            const float* P = b.P + h * LN;
            v3 lo = ld3(P), hi = lo;
            for (int k = 1; k < K; ++k) {
                const v3 x = ld3(P + (size_t)k * 3 * W);
                lo = (v3){vmin(lo.x, x.x), vmin(lo.y, x.y), vmin(lo.z, x.z)};
                hi = (v3){vmax(hi.x, x.x), vmax(hi.y, x.y), vmax(hi.z, x.z)};
            }
            for (int l = 0; l < LN; ++l) {
                bl[0] = bl[0] < lo.x[l] ? bl[0] : lo.x[l],
                bh[0] = bh[0] > hi.x[l] ? bh[0] : hi.x[l];
                bl[1] = bl[1] < lo.y[l] ? bl[1] : lo.y[l],
                bh[1] = bh[1] > hi.y[l] ? bh[1] : hi.y[l];
                bl[2] = bl[2] < lo.z[l] ? bl[2] : lo.z[l],
                bh[2] = bh[2] > hi.z[l] ? bh[2] : hi.z[l];
            }
        }
        /* knots move in the passes below by about a segment length at most (the longest,
           taken here rather than in the sweep, which then holds one value less) */
        vf max_len = splat(0.0f);
        for (int k = 1; k < K; ++k)
            for (int h = 0; h < NSLICE; ++h)
                max_len = vmax(max_len, ld(S.len + (size_t)k * W + h * LN));
        float m = 0.0f;
        for (int l = 0; l < LN; ++l) m = m > max_len[l] ? m : max_len[l];
        m += SIM_CULL_MARGIN;
        for (int ci = 0; ci < ncol; ++ci) {
            const sim_collider* c = cols[ci];
            int overlap = 1;
            for (int a = 0; a < 3; ++a) overlap &= c->lo[a] <= bh[a] + m && c->hi[a] >= bl[a] - m;
            if (overlap) near[nnear++] = c;
        }
    }

    const vf ground = splat(p->ground);
    /* ---- pass 2: length constraints (each segment's two knots move half way; the root never)
            and collisions, iterated; then pass 3, follow the leader, with the new velocities
            and the statistics. Without colliders near (most blocks), every slice of the block
            goes through the iterations together, and pass 3 runs inside the last one: with
            AVX2's four slices that measured faster than two at a time; with colliders,
            two slices at a time. */
    vf md = splat(0.0f), ms = splat(0.0f);
    if (nnear == 0) {
        for (int it = 0; it + 1 < p->iterations; ++it)
            length_iteration(K, b.P, S.il2q, 0, NSLICE, ground, (near_list){near, 0});
        ftl_state F[NSLICE];
        for (int q = 0; q < NSLICE; ++q) F[q] = (ftl_state){ld3(b.P + q * LN), md, ms};
        length_iteration_ftl(K, b.P, S.il2q, ground, &C, F);
        for (int q = 0; q < NSLICE; ++q) md = vmax(md, F[q].md), ms = vmax(ms, F[q].ms);
    } else {
        for (int h = 0; h < NSLICE; h += 2) {
            const int lo0 = h * LN, lo1 = PAIR_LO1(h);
            ftl_state A = {ld3(b.P + lo0), md, ms}, B = {ld3(b.P + lo1), md, ms};
            for (int it = 0; it < p->iterations; ++it)
                length_iteration(K, b.P, S.il2q, h, lo1 != lo0 ? 2 : 1, ground,
                                 (near_list){near, nnear});
            for (int k = 1; k < K; ++k) {
                ftl_knot(&A, &C, near, nnear, ground, k, lo0);
                if (lo1 != lo0) ftl_knot(&B, &C, near, nnear, ground, k, lo1);
            }
            md = vmax(A.md, B.md), ms = vmax(A.ms, B.ms);
        }
    }

    /* ---- last check against every collider that can reach the block (a knot the passes above
            moved into one they did not consider goes to its surface), then the ground. */
    int moved = 0;
    if (ncol > nnear) {
        for (int h = 0; h < NSLICE; ++h) {
            float* P = b.P + h * LN;
            for (int ci = 0; ci < ncol; ++ci) {
                const sim_collider* col = cols[ci];
                const vf r2 = splat(col->r * col->r);
                vi hit = (vi){0};
                for (int k = 1; k < K; ++k) {
                    const v3 x = ld3(P + (size_t)k * 3 * W);
                    const v3 d = sub3(x, core_point(x, col));
                    hit |= lt(dot3(d, d), r2);
                }
                if (!any(hit)) continue;
                moved = 1;
                for (int k = 1; k < K; ++k) {
                    float* pk = P + (size_t)k * 3 * W;
                    st3(pk, push_out(ld3(pk), col));
                }
                for (int k = 1; k < K; ++k) {
                    float* pz = P + (size_t)k * 3 * W + 2 * W;
                    st(pz, vmax(ld(pz), ground));
                }
            }
        }
    }

    /* ---- pass 4, seldom: blend back toward rest (the tile is released soon), or a knot moved
            by the last check; then velocity and statistics again. Blending moves the position
            and the previous position alike: the velocity shrinks by (1 - blend). */
    if (blend > 0.0f || moved) {
        md = splat(0.0f), ms = splat(0.0f);
        const vi snap = (vi){0} + (blend >= 1.0f ? -1 : 0);
        const vf bl = splat(blend);
        for (int h = 0; h < NSLICE; ++h) {
            const int lo = h * LN;
            for (int k = 1; k < K; ++k) {
                const size_t o3 = (size_t)k * 3 * W + lo;
                v3 x = ld3(b.P + o3), q = ld3(S.xold + o3);
                const v3 rs = ld3(S.rest + o3);
                if (blend > 0.0f) {
                    x = sel3(snap, rs, madd3(bl, sub3(rs, x), x));
                    q = sel3(snap, rs, madd3(bl, sub3(rs, q), q));
                    st3(b.P + o3, x);
                }
                const v3 v = sub3(x, q);
                st_velocity(b.V + (size_t)(k - 1) * 3 * W + lo, v);
                const v3 e = sub3(x, rs);
                md = vmax(md, dot3(e, e));
                ms = vmax(ms, dot3(v, v));
            }
        }
    }
    float m1 = 0.0f, m2 = 0.0f;
    for (int l = 0; l < LN; ++l) {
        m1 = m1 > md[l] ? m1 : md[l];
        m2 = m2 > ms[l] ? m2 : ms[l];
    }
    stats->max_disp2 = m1;
    stats->max_step2 = m2;
}
#endif /* !SIM_KERNEL_NO_STEP */

#if !defined(SIM_KERNEL_NO_RIBBONS)

/* Transposes an LN x LN block of floats held as LN rows: r[i][x] becomes r[x][i]. log2(LN)
 * stages, each exchanging the halves of 2b x 2b sub-blocks with two-vector shuffles. */
#if !defined(__clang__)
INL void transpose_rows(vf* r) {
    for (int b = 1; b < LN; b *= 2) {
        vi lo, hi;
        for (int x = 0; x < LN; ++x) {
            lo[x] = (x & b) ? LN + x - b : x;
            hi[x] = (x & b) ? LN + x : x + b;
        }
        for (int i = 0; i < LN; ++i)
            if (!(i & b)) {
                const vf A = r[i], B = r[i + b];
                r[i] = __builtin_shuffle(A, B, lo);
                r[i + b] = __builtin_shuffle(A, B, hi);
            }
    }
}
#endif

/* (x, y, z) made unit in the lanes where its squared length is above `above`, (fx, fy, fz)
 * in the others: x * (1 / sqrt(l2)), as tsk_blades_expand does it. */
INL void unit_or(vf* x, vf* y, vf* z, vf above, vf fx, vf fy, vf fz) {
    const vf l2 = *x * *x + *y * *y + *z * *z;
    const vi ok = gt(l2, above);
    const vf inv = splat(1.0f) / vsqrt(sel(ok, l2, splat(1.0f)));
    *x = sel(ok, *x * inv, fx);
    *y = sel(ok, *y * inv, fy);
    *z = sel(ok, *z * inv, fz);
}

/* Ribbon vertices of lanes [l0, l1) of a block (seed 000 §4.5, Fig. 7-8: each knot becomes two
 * vertices half a width either side of the blade), read straight from the block's knots: the
 * same IEEE operations in the same order as tsk_blades_expand on the knots
 * tsk_blade_sim_get_knots gives (the tangent by central differences, the side made
 * perpendicular to it and unit, knot -/+ width / 2 * side), so the same bytes, but with the
 * blades in the vector lanes. widths (K per blade) and sides (3 per blade) start at lane l0's
 * blade, and so does out (2K vertices, 6K floats per blade). A slice's vertices are gathered
 * as 6K rows of LN lanes and turned into each blade's 6K floats by LN x LN transposes.
 * Returns 1, writing nothing, when a knot, width or side of these lanes is not good input
 * (ribbon_input.h). */
int SIM_KFN(tsk_sim_block_ribbons)(int32_t K, const float* P, int l0, int l1, const float* widths,
                                   const float* sides, float* out) {
    const int n = l1 - l0;
    int bad = 0;
    for (int32_t r = 0; r < 3 * K; ++r)
        for (int l = l0; l < l1; ++l) bad |= !tsk_ribbon_coord_ok(P[(size_t)r * W + l]);
    for (size_t i = 0; i < (size_t)n * (size_t)K; ++i) bad |= !tsk_ribbon_width_ok(widths[i]);
    for (int i = 0; i < n; ++i) bad |= !tsk_ribbon_side_ok(&sides[3 * i]);
    if (bad) return 1;
    const vf zero = splat(0.0f), one = splat(1.0f), eps = splat(1e-12f), half = splat(0.5f);
    const size_t rows = 6 * (size_t)K; /* floats per blade */
    float tmp[6 * TSK_BLADE_SIM_MAX_KNOTS][LN] __attribute__((aligned(64)));
    for (int j = l0 - l0 % LN; j < l1; j += LN) {
        /* lanes of this slice that are asked for: [a, b) of the block */
        const int a = j > l0 ? j : l0, b = j + LN < l1 ? j + LN : l1;
        float sl[3][LN];
        for (int i = 0; i < LN; ++i) sl[0][i] = 1.0f, sl[1][i] = 0.0f, sl[2][i] = 0.0f;
        for (int l = a; l < b; ++l)
            for (int q = 0; q < 3; ++q) sl[q][l - j] = sides[3 * (l - l0) + q];
        const vf sx = ld(sl[0]), sy = ld(sl[1]), sz = ld(sl[2]);
        const vf inv_sl = one / vsqrt(sx * sx + sy * sy + sz * sz);
        const vf sx0 = sx * inv_sl, sy0 = sy * inv_sl, sz0 = sz * inv_sl;
        for (int32_t k = 0; k < K; ++k) {
            const int32_t ka = k > 0 ? k - 1 : 0, kb = k < K - 1 ? k + 1 : K - 1;
            const float* pa = P + (size_t)ka * 3 * W + j;
            const float* pb = P + (size_t)kb * 3 * W + j;
            const float* pk = P + (size_t)k * 3 * W + j;
            vf tx = ld(pb) - ld(pa), ty = ld(pb + W) - ld(pa + W),
               tz = ld(pb + 2 * W) - ld(pa + 2 * W);
            unit_or(&tx, &ty, &tz, zero, zero, zero, one); /* the tangent, else +z */
            const vf d = sx0 * tx + sy0 * ty + sz0 * tz;
            vf rx = sx0 - d * tx, ry = sy0 - d * ty, rz = sz0 - d * tz;
            unit_or(&rx, &ry, &rz, eps, sx0, sy0, sz0); /* the side, else the side given */
            float hw[LN] = {0};
            for (int l = a; l < b; ++l) hw[l - j] = widths[(size_t)(l - l0) * K + k];
            const vf h = half * ld(hw);
            const vf hx = h * rx, hy = h * ry, hz = h * rz;
            const vf kx = ld(pk), ky = ld(pk + W), kz = ld(pk + 2 * W);
            float(*v)[LN] = &tmp[6 * k];
            st(v[0], kx - hx), st(v[1], ky - hy), st(v[2], kz - hz);
            st(v[3], kx + hx), st(v[4], ky + hy), st(v[5], kz + hz);
        }
        /* row r of tmp is float r of every lane's blade */
        size_t r0 = 0;
#if !defined(__clang__)
        for (; r0 + LN <= rows; r0 += LN) {
            vf tr[LN];
            for (int i = 0; i < LN; ++i) tr[i] = ld(tmp[r0 + (size_t)i]);
            transpose_rows(tr);
            for (int l = a; l < b; ++l) st(out + (size_t)(l - l0) * rows + r0, tr[l - j]);
        }
#endif
        for (int l = a; l < b; ++l)
            for (size_t r = r0; r < rows; ++r) out[(size_t)(l - l0) * rows + r] = tmp[r][l - j];
    }
    return 0;
}
#endif /* !SIM_KERNEL_NO_RIBBONS */

#undef LN
#undef W
#undef NSLICE
#undef INL
