/* The elementary functions whose results become bytes that must be the same on every system:
 * tree geometry, blade turns, the solver's parameters, the capture's angles. The C library's
 * sinf, cosf, acosf, powf, fmaf... differ between systems in the last bit (glibc's against
 * mingw-w64's: about 1 % of sinf inputs; mingw-w64's fmaf is not even fused), so a Windows
 * node of a farm, or the Windows build's tests, would give other bytes than Linux.
 *
 * These use IEEE double arithmetic alone (+ - * / sqrt, exact conversions and bit operations;
 * the library is built with -ffp-contract=off), so they give the same bits wherever IEEE
 * doubles do. The float functions are evaluated in double with a relative error below about
 * 2^-45 and rounded once, so they agree with the correctly rounded result except within
 * 2^-45 of a float's rounding boundary (test_core compares them with glibc's doubles). The
 * double functions are within 2 ulp for the arguments given in the comments.
 *
 * tsk_fmaf is IEEE fusedMultiplyAdd: exact (one rounding) everywhere. */
#ifndef TSK_CORE_TMATH_H
#define TSK_CORE_TMATH_H

#include <math.h>

static inline float tsk_sinf(float x);
static inline float tsk_cosf(float x);
static inline void tsk_sincosf(float x, float* s, float* c);
float tsk_tanf(float x);
float tsk_acosf(float x);
float tsk_atan2f(float y, float x);
float tsk_expf(float x);
float tsk_powf(float x, float y);
float tsk_hypotf(float x, float y);

/* accurate for |x| < 2^25; beyond, still the same bits everywhere but a coarser phase */
double tsk_sin(double x);
double tsk_cos(double x);
double tsk_exp(double x);
double tsk_atan(double x);
double tsk_atan2(double y, double x);

/* a * b + c rounded once, in portable code (no FMA instruction, no exact C library fmaf) */
float tsk_fmaf_exact(float a, float b, float c);

/* a * b + c rounded once: the instruction where the target has one, glibc's fmaf (exact, and
 * the instruction through its ifunc where the processor has one), tsk_fmaf_exact elsewhere.
 * The vector kernels call it lane by lane and GCC makes it one instruction in their AVX2 and
 * AVX-512 units. */
static inline float tsk_fmaf(float a, float b, float c) {
#if defined(__FMA__) || defined(__aarch64__)
    return __builtin_fmaf(a, b, c);
#elif defined(__GLIBC__)
    return fmaf(a, b, c);
#else
    return tsk_fmaf_exact(a, b, c);
#endif
}

/* ---- inline parts: the angles below pi/4 (most of a tree's) skip the call and the
 * reduction, and a loop's calls overlap ---- */

/* Taylor polynomials on |r| <= pi/4 + a hair, by Estrin's scheme (the multiplications do not
 * wait on each other as Horner's do); the first term left out is below 2^-54 of the result */
static inline double tsk_sin_kernel(double r) {
    const double z = r * r, z2 = z * z, z4 = z2 * z2; /* -1/3! ... -1/15! */
    const double p =
        ((-1.0 / 6 + (1.0 / 120) * z) + (-1.0 / 5040 + (1.0 / 362880) * z) * z2) +
        ((-1.0 / 39916800 + (1.0 / 6227020800.0) * z) + (-1.0 / 1307674368000.0) * z2) * z4;
    return r + r * z * p;
}

static inline double tsk_cos_kernel(double r) {
    const double z = r * r, z2 = z * z, z4 = z2 * z2; /* 1/4! ... 1/16! */
    const double p =
        ((1.0 / 24 + (-1.0 / 720) * z) + (1.0 / 40320 + (-1.0 / 3628800) * z) * z2) +
        ((1.0 / 479001600.0 + (-1.0 / 87178291200.0) * z) + (1.0 / 20922789888000.0) * z2) * z4;
    return 1.0 - 0.5 * z + z * z * p;
}

/* the out-of-line parts, for what the inline code below leaves: |x| >= 2^25, x within 2^-8 of
 * a multiple of pi/2, infinities and NaN */
float tsk_sinf_reduced(float x);
float tsk_cosf_reduced(float x);
void tsk_sincosf_reduced(float x, float* s, float* c);

#define TSK_TMATH_PIO4F 0x1.921fb4p-1f /* a float below pi/4 */

/* x = q pi/2 + r for a float |x| < 2^25: k = x 2/pi rounded (exact IEEE additions), then
 * x - k P1 (exact: P1 has 28 bits, Sterbenz) minus k times the rest of pi/2, one rounded
 * product and difference, 2^-57 at most: a float's 2^-45 wherever |r| > 2^-8. 0 where that
 * does not hold (tmath.c's reduce_pio2 starts with this, then reduces exactly). */
static inline int tsk_reduce_pio2_float(double x, double* r, int* q) {
    if (!(fabs(x) < 0x1p25)) return 0;
    const double k = (x * 0x1.45f306dc9c883p-1 + 0x1.8p52) - 0x1.8p52;
    const double rr = (x - k * 0x1.921fb54p+0) - k * 0x1.10b4611a62633p-30;
    if (!(fabs(rr) > 0x1p-8)) return 0;
    *r = rr;
    *q = (int)((long long)k & 3);
    return 1;
}

/* sin and cos of q pi/2 + r by selections and sign flips, not a switch: random angles would
 * mispredict its branches */
static inline void tsk_sincos_quadrant(double r, int q, double* s, double* c) {
    const double sr = tsk_sin_kernel(r), cr = tsk_cos_kernel(r);
    const double s0 = (q & 1) ? cr : sr, c0 = (q & 1) ? sr : cr;
    *s = (q & 2) ? -s0 : s0;
    *c = ((q + 1) & 2) ? -c0 : c0;
}

static inline float tsk_sinf(float x) {
    double r, s, c;
    int q;
    if (fabsf(x) <= TSK_TMATH_PIO4F)
        return fabsf(x) < 0x1p-27f ? x : (float)tsk_sin_kernel((double)x); /* sin x = x there */
    if (!tsk_reduce_pio2_float((double)x, &r, &q)) return tsk_sinf_reduced(x);
    tsk_sincos_quadrant(r, q, &s, &c);
    return (float)s;
}

static inline float tsk_cosf(float x) {
    double r, s, c;
    int q;
    if (fabsf(x) <= TSK_TMATH_PIO4F) return (float)tsk_cos_kernel((double)x);
    if (!tsk_reduce_pio2_float((double)x, &r, &q)) return tsk_cosf_reduced(x);
    tsk_sincos_quadrant(r, q, &s, &c);
    return (float)c;
}

static inline void tsk_sincosf(float x, float* s, float* c) {
    double r, sd, cd;
    int q;
    if (fabsf(x) <= TSK_TMATH_PIO4F) {
        *s = fabsf(x) < 0x1p-27f ? x : (float)tsk_sin_kernel((double)x);
        *c = (float)tsk_cos_kernel((double)x);
        return;
    }
    if (!tsk_reduce_pio2_float((double)x, &r, &q)) {
        tsk_sincosf_reduced(x, s, c);
        return;
    }
    tsk_sincos_quadrant(r, q, &sd, &cd);
    *s = (float)sd;
    *c = (float)cd;
}

#endif
