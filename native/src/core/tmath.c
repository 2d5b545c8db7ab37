/* Elementary functions with the same bits on every system (see tmath.h for why). Constants
 * are exact binary values: pi/2 and ln 2 split into parts whose products with the reduction's
 * integer are exact, and the bits of 2/pi for the reduction of large float arguments; all were
 * computed from pi and ln 2 in exact integer arithmetic (Machin's formula, atanh series). */
#include "core/tmath.h"

#include <float.h>
#include <stdint.h>
#include <string.h>

#ifndef __SIZEOF_INT128__
#error "tmath.c reduces large arguments with 128-bit integers (GCC or Clang, 64-bit target)"
#endif

/* pi/2 = P1 + P2 + P3 + P4 to 137 bits; P1..P3 have 28 significant bits, so k * Pi is exact
 * for |k| < 2^25 */
static const double PIO2_P1 = 0x1.921fb54p+0;
static const double PIO2_P2 = 0x1.10b461p-30;
static const double PIO2_P3 = 0x1.a62633p-58;
static const double PIO2_P4 = 0x1.45c06e0e68948p-86;
static const double PIO2_HI = 0x1.921fb54442d18p+0; /* pi/2 rounded, and what remains */
static const double PIO2_LO = 0x1.1a62633145c07p-54;
static const double PI_HI = 0x1.921fb54442d18p+1;
static const double PI_LO = 0x1.1a62633145c07p-53;
static const double TWO_OVER_PI = 0x1.45f306dc9c883p-1;
/* ln 2 = LN2_HI + LN2_LO, LN2_HI with 32 significant bits (k * LN2_HI exact for |k| < 2^21) */
static const double LN2_HI = 0x1.62e42feep-1;
static const double LN2_LO = 0x1.a39ef35793c76p-33;
static const double INV_LN2 = 0x1.71547652b82fep+0;
/* atan(1/2) = ATAN_HALF_HI + ATAN_HALF_LO */
static const double ATAN_HALF_HI = 0x1.dac670561bb4fp-2;
static const double ATAN_HALF_LO = 0x1.a2b7f222f65e2p-56;

/* the fraction bits of 2/pi, 32 at a time: enough for the largest double (bit 969 and the
 * 192 after it) */
static const uint32_t TWO_OVER_PI_BITS[38] = {
    0xa2f9836e, 0x4e441529, 0xfc2757d1, 0xf534ddc0, 0xdb629599, 0x3c439041, 0xfe5163ab, 0xdebbc561,
    0xb7246e3a, 0x424dd2e0, 0x06492eea, 0x09d1921c, 0xfe1deb1c, 0xb129a73e, 0xe88235f5, 0x2ebb4484,
    0xe99c7026, 0xb45f7e41, 0x3991d639, 0x835339f4, 0x9c845f8b, 0xbdf9283b, 0x1ff897ff, 0xde05980f,
    0xef2f118b, 0x5a0a6d1f, 0x6d367ecf, 0x27cb09b7, 0x4f463f66, 0x9e5fea2d, 0x7527bac7, 0xebe5f17b,
    0x3d0739f7, 0x8a5292ea, 0x6bfb5fb1, 0x1f8d5d08, 0x56033046, 0xfc7b6bab};

/* c[0] + c[1] z + ... + c[n-1] z^(n-1), n <= 16, by Estrin's scheme: pairs, then pairs of
 * pairs, so that the multiplications do not wait on each other as Horner's do (the same
 * operations in the same order on every system; a polynomial here takes about a third of
 * Horner's time) */
static inline __attribute__((always_inline)) double poly(const double* c, int n, double z) {
    double t[8] = {0}; /* GCC 10 cannot see that only the first m are read */
    int m = 0;
    for (int i = 0; i < n; i += 2) t[m++] = i + 1 < n ? c[i] + c[i + 1] * z : c[i];
    for (double zz = z * z; m > 1; zz *= zz) {
        int k = 0;
        for (int i = 0; i < m; i += 2) t[k++] = i + 1 < m ? t[i] + t[i + 1] * zz : t[i];
        m = k;
    }
    return t[0];
}

/* x rounded to the nearest integer (ties to even) for |x| < 2^51: exact IEEE additions */
static double round_int(double x) { return (x + 0x1.8p52) - 0x1.8p52; }

static uint64_t bits_of(double x) {
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

static double from_bits(uint64_t b) {
    double x;
    memcpy(&x, &b, sizeof x);
    return x;
}

/* 64 bits of 2/pi from fraction bit `first` (0 = the first bit after the point) */
static uint64_t two_over_pi_word(int first) {
    const int i = first / 32, s = first % 32;
    uint64_t u = ((uint64_t)TWO_OVER_PI_BITS[i] << 32) | TWO_OVER_PI_BITS[i + 1];
    if (s) u = (u << s) | (TWO_OVER_PI_BITS[i + 2] >> (32 - s));
    return u;
}

/* x = q pi/2 + r with |r| <= pi/4 (a hair more at the Cody-Waite path's rounding of k):
 * Cody-Waite for |x| < 2^25, where x - k P1 is exact (Sterbenz) and the rest is carried as a
 * two-term sum; Payne-Hanek for the larger float values, which are integer multiples of 4. */
static inline __attribute__((always_inline)) int reduce_pio2(double x, double* r, int for_float) {
    const double ax = fabs(x);
    if (ax <= 0x1.921fb5p-1) { /* pi/4: nothing to reduce */
        *r = x;
        return 0;
    }
    if (ax < 0x1p25) {
        int q;
        if (for_float && tsk_reduce_pio2_float(x, r, &q)) return q; /* the inline one's bits */
        const double k = round_int(x * TWO_OVER_PI);
        const double t = x - k * PIO2_P1;
        const double w = k * PIO2_P2;
        const double hi = t - w; /* two-sum: hi + lo = t - w exactly */
        const double bv = hi - t;
        const double lo = ((t - (hi - bv)) - (w + bv)) - k * PIO2_P3 - k * PIO2_P4;
        *r = hi + lo;
        return (int)((int64_t)k & 3);
    }
    /* x = m 2^e with m < 2^53 (a float's m < 2^24) and e >= 2 here for float arguments; a
     * double between 2^25 and 2^54 takes the path below with its low bits dropped (see the
     * header: same bits everywhere, coarser phase) */
    const uint64_t b = bits_of(ax);
    int e = (int)((b >> 52) & 0x7ff) - 1075;
    uint64_t m = (b & 0xfffffffffffffull) | 0x10000000000000ull;
    if (e < 2) {
        m >>= (2 - e);
        e = 2;
    }
    /* x (2/pi) mod 4 = 4 frac(m F), F = 0.b_(e-1) b_e ... (the bits of 2/pi from bit e-1);
     * the earlier bits give multiples of 4 */
    const int first = e - 2;
    const uint64_t w0 = two_over_pi_word(first), w1 = two_over_pi_word(first + 64),
                   w2 = two_over_pi_word(first + 128);
    const unsigned __int128 p0 = (unsigned __int128)m * w0, p1 = (unsigned __int128)m * w1,
                            p2 = (unsigned __int128)m * w2;
    /* the fraction of m F as three 64-bit words f0.f1.f2 (the integer part dropped) */
    const unsigned __int128 mid = (p1 & UINT64_MAX) + (uint64_t)(p2 >> 64);
    const uint64_t f1 = (uint64_t)mid, f2 = (uint64_t)p2;
    const uint64_t f0 = (uint64_t)p0 + (uint64_t)(p1 >> 64) + (uint64_t)(mid >> 64);
    /* times 4: the top two bits are the quadrant, the next 128 the fraction; read as a
     * signed number the fraction is in [-1/2, 1/2) and the quadrant rounds up with it */
    int q = (int)(f0 >> 62);
    const uint64_t hi = (f0 << 2) | (f1 >> 62), lo = (f1 << 2) | (f2 >> 62);
    q = (q + (int)(hi >> 63)) & 3;
    const double frac = (double)(int64_t)hi * 0x1p-64 + (double)lo * 0x1p-128;
    const double rr = frac * PIO2_HI + frac * PIO2_LO;
    *r = x < 0 ? -rr : rr;
    return x < 0 ? (4 - q) & 3 : q;
}

static inline __attribute__((always_inline)) void sincos_d(double x, double* s, double* c,
                                                           int for_float) {
    if (!isfinite(x)) {
        *s = *c = x - x; /* NaN */
        return;
    }
    double r;
    const int q = reduce_pio2(x, &r, for_float);
    tsk_sincos_quadrant(r, q, s, c);
}

double tsk_sin(double x) {
    if (fabs(x) < 0x1p-27) return x; /* sin x = x - x^3/6: below half an ulp */
    double s, c;
    sincos_d(x, &s, &c, 0);
    return s;
}

double tsk_cos(double x) {
    double s, c;
    sincos_d(x, &s, &c, 0);
    return c;
}

/* 2^k as a double for -1022 <= k <= 1023 */
static double pow2i(int k) { return from_bits((uint64_t)(k + 1023) << 52); }

double tsk_exp(double x) {
    if (isnan(x)) return x + x;
    if (x > 709.8) return HUGE_VAL;
    if (x < -745.2) return 0.0;
    const double k = round_int(x * INV_LN2);
    const double r = (x - k * LN2_HI) - k * LN2_LO; /* |r| <= ln2/2 + a hair */
    /* 1/0! ... 1/13!: the first term left out is below 2^-57 */
    static const double c[] = {1.0,
                               1.0,
                               1.0 / 2,
                               1.0 / 6,
                               1.0 / 24,
                               1.0 / 120,
                               1.0 / 720,
                               1.0 / 5040,
                               1.0 / 40320,
                               1.0 / 362880,
                               1.0 / 3628800,
                               1.0 / 39916800,
                               1.0 / 479001600,
                               1.0 / 6227020800.0};
    const double p = poly(c, 14, r);
    /* two steps, so that neither power of two leaves the normal range; only the last
     * product can round (into the subnormals) */
    const int ki = (int)k, k1 = ki / 2;
    return p * pow2i(k1) * pow2i(ki - k1);
}

/* ln x for finite x > 0 */
static double log_d(double x) {
    int e = 0;
    if (x < 0x1p-1022) { /* subnormal: make it normal first */
        x *= 0x1p54;
        e = -54;
    }
    const uint64_t b = bits_of(x);
    e += (int)((b >> 52) & 0x7ff) - 1023;
    double m = from_bits((b & 0xfffffffffffffull) | 0x3ff0000000000000ull); /* [1, 2) */
    if (m > 0x1.6a09e667f3bcdp+0) { /* sqrt 2 */
        m *= 0.5;
        e += 1;
    }
    /* ln m = 2 atanh s, s = (m - 1) / (m + 1), |s| <= 0.1716: the series to s^21 (the
     * first term left out is below 2^-55 of it) */
    const double s = (m - 1.0) / (m + 1.0), z = s * s;
    static const double c[] = {2.0 / 3,  2.0 / 5,  2.0 / 7,  2.0 / 9,  2.0 / 11,
                               2.0 / 13, 2.0 / 15, 2.0 / 17, 2.0 / 19, 2.0 / 21};
    const double p = poly(c, 10, z);
    const double ed = (double)e;
    return ed * LN2_HI + (ed * LN2_LO + (2.0 * s + s * z * p));
}

/* atan t for t >= 0 */
static double atan_pos(double t) {
    if (t > 1.0) {
        if (isinf(t)) return PIO2_HI + PIO2_LO;
        return PIO2_HI - (atan_pos(1.0 / t) - PIO2_LO);
    }
    /* atan t = atan c + atan u, u = (t - c) / (1 + t c) with c = 0, 1/2 or 1: |u| <= 1/4,
     * where the series to u^25 leaves out less than 2^-56 of it */
    double base_hi = 0.0, base_lo = 0.0, u = t;
    if (t > 0.75) {
        u = (t - 1.0) / (1.0 + t);
        base_hi = 0.5 * PIO2_HI, base_lo = 0.5 * PIO2_LO;
    } else if (t > 0.25) {
        u = (2.0 * t - 1.0) / (2.0 + t);
        base_hi = ATAN_HALF_HI, base_lo = ATAN_HALF_LO;
    }
    static const double c[] = {-1.0 / 3,  1.0 / 5,  -1.0 / 7,  1.0 / 9,  -1.0 / 11, 1.0 / 13,
                               -1.0 / 15, 1.0 / 17, -1.0 / 19, 1.0 / 21, -1.0 / 23, 1.0 / 25};
    const double z = u * u;
    return base_hi + (base_lo + (u + u * z * poly(c, 12, z)));
}

double tsk_atan(double x) {
    if (isnan(x)) return x + x;
    return x < 0 ? -atan_pos(-x) : atan_pos(x); /* keeps -0 */
}

double tsk_atan2(double y, double x) {
    if (isnan(x) || isnan(y)) return x + y;
    const double sy = signbit(y) ? -1.0 : 1.0;
    if (y == 0.0) return signbit(x) ? sy * (PI_HI + PI_LO) : y;
    if (isinf(y)) {
        if (isinf(x)) return sy * (x > 0 ? 0.5 * (PIO2_HI + PIO2_LO) : 1.5 * (PIO2_HI + PIO2_LO));
        return sy * (PIO2_HI + PIO2_LO);
    }
    if (x == 0.0) return sy * (PIO2_HI + PIO2_LO);
    if (isinf(x)) return x > 0 ? sy * 0.0 : sy * (PI_HI + PI_LO);
    const double a = atan_pos(fabs(y / x));
    return sy * (x > 0 ? a : PI_HI - (a - PI_LO));
}

float tsk_sinf_reduced(float x) {
    double s, c;
    sincos_d((double)x, &s, &c, 1);
    return (float)s;
}

float tsk_cosf_reduced(float x) {
    double s, c;
    sincos_d((double)x, &s, &c, 1);
    return (float)c;
}

void tsk_sincosf_reduced(float x, float* s, float* c) {
    double sd, cd;
    sincos_d((double)x, &sd, &cd, 1);
    *s = (float)sd;
    *c = (float)cd;
}

float tsk_tanf(float x) {
    if (fabs(x) < 0x1p-27f) return x;
    double s, c;
    sincos_d((double)x, &s, &c, 1);
    return (float)(s / c);
}

float tsk_acosf(float x) {
    if (!(fabsf(x) <= 1.0f)) return (x - x) / (x - x); /* NaN, as for |x| > 1 */
    if (x == -1.0f) return (float)(PI_HI + PI_LO);
    /* acos x = 2 atan sqrt((1 - x) / (1 + x)); 1 - x and 1 + x are exact for floats > -1 */
    const double xd = (double)x;
    return (float)(2.0 * atan_pos(sqrt((1.0 - xd) / (1.0 + xd))));
}

float tsk_atan2f(float y, float x) { return (float)tsk_atan2((double)y, (double)x); }

float tsk_expf(float x) { return (float)tsk_exp((double)x); }

/* 1 if y is an odd integer, 0 if even, -1 if not an integer (floats of 2^24 and more are
 * even integers) */
static int parity(float y) {
    if (fabsf(y) >= 0x1p24f) return 0;
    if (y != floorf(y)) return -1;
    return (int)((int64_t)y & 1);
}

/* C99 Annex F's pow, exp(y ln x) in double for the finite cases */
float tsk_powf(float x, float y) {
    if (y == 0.0f || x == 1.0f) return 1.0f;
    if (isnan(x) || isnan(y)) return x + y;
    const int par = parity(y);
    if (x == 0.0f) {
        if (y < 0) return par == 1 ? copysignf(INFINITY, x) : INFINITY;
        return par == 1 ? x : 0.0f;
    }
    if (isinf(y)) {
        if (x == -1.0f) return 1.0f;
        return (fabsf(x) < 1.0f) == (y < 0) ? INFINITY : 0.0f;
    }
    if (isinf(x)) {
        const float mag = y > 0 ? INFINITY : 0.0f;
        return x < 0 && par == 1 ? -mag : mag;
    }
    double sign = 1.0;
    if (x < 0) {
        if (par < 0) return (x - x) / (x - x); /* NaN: a negative number to a fraction */
        sign = par == 1 ? -1.0 : 1.0;
    }
    return (float)(sign * tsk_exp((double)y * log_d(fabs((double)x))));
}

float tsk_hypotf(float x, float y) {
    if (isinf(x) || isinf(y)) return INFINITY;
    const double xd = x, yd = y; /* the squares are exact in double */
    return (float)sqrt(xd * xd + yd * yd);
}

float tsk_fmaf_exact(float a, float b, float c) {
    const double p = (double)a * (double)b; /* exact: 48 bits at most */
    const double s = p + (double)c;
    if (!isfinite(s)) return (float)s;
    const double bv = s - p; /* two-sum: the sum's rounding error */
    const double err = (p - (s - bv)) + ((double)c - bv);
    const float f = (float)s;
    if (err == 0.0 || (double)f == s) return f;
    /* s was rounded; rounding it again to float is wrong only when s lies exactly halfway
     * between two floats: then the exact sum's side of that midpoint decides */
    const double fd = isinf(f) ? copysign(0x1p128, s) : (double)f; /* past FLT_MAX: 2^128 */
    const float g = nextafterf(f, s > fd ? INFINITY : -INFINITY);
    const double gd = isinf(g) ? copysign(0x1p128, s) : (double)g;
    if (s != 0.5 * (fd + gd)) return f;
    return (err > 0) == (gd > fd) ? g : f;
}
