/* Sum of sines (seed 001, eq. 11-14): the travelling waves of the analytic wind, with a
 * fast, deterministic sine and power written as plain float arithmetic so that the point
 * loops vectorise and give the same bytes on any thread count. */
#include "wind_internal.h"

#include <math.h>
#include <string.h>

static inline int32_t f2i_bits(float f) {
    int32_t i;
    memcpy(&i, &f, sizeof i);
    return i;
}
static inline float i2f_bits(int32_t i) {
    float f;
    memcpy(&f, &i, sizeof f);
    return f;
}

/* u^k for u in [0, 1], k > 0: exp2(k log2 u) with log2 from the exponent bits and an
 * atanh series on [sqrt(1/2), sqrt(2)], exp2 from the exponent bits and a degree-7
 * polynomial on [-1/2, 1/2]. Relative error < 1e-5; results below 2^-100 are clamped
 * to about 2^-100 (zero for the wind). Integer selects only, so that loops vectorise. */
static inline float fast_pow01(float u, float k) {
    int32_t bits = f2i_bits(u);
    const int32_t tiny = 0x0DA24260; /* 1e-30f: also catches u <= 0 */
    bits = bits < tiny ? tiny : bits;
    /* u = 2^e * m with m in [sqrt(1/2), sqrt(2)) */
    const int32_t mant = (bits & 0x007FFFFF) | 0x3F800000; /* [1, 2) */
    const int32_t big = mant > 0x3FB504F3 ? 1 : 0; /* m > sqrt(2) */
    const int32_t e = ((bits >> 23) & 255) - 127 + big;
    const float m = i2f_bits(mant - (big << 23));
    const float z = (m - 1.0f) / (m + 1.0f);
    const float z2 = z * z;
    float ln = 1.0f / 9.0f;
    ln = ln * z2 + 1.0f / 7.0f;
    ln = ln * z2 + 1.0f / 5.0f;
    ln = ln * z2 + 1.0f / 3.0f;
    ln = ln * z2 + 1.0f;
    ln = 2.0f * z * ln;
    const float y = k * ((float)e + ln * 1.44269504088896341f); /* k log2(u) <= 0 */
    const float magic = 12582912.0f;
    const float nf = (y + magic) - magic; /* round(y) */
    const float f = (y - nf) * 0.693147180559945309f; /* ln 2 * [-1/2, 1/2] */
    float p = 1.0f / 5040.0f;
    p = p * f + 1.0f / 720.0f;
    p = p * f + 1.0f / 120.0f;
    p = p * f + 1.0f / 24.0f;
    p = p * f + 1.0f / 6.0f;
    p = p * f + 0.5f;
    p = p * f + 1.0f;
    p = p * f + 1.0f;
    int32_t n = (int32_t)nf;
    n = n < -100 ? -100 : n; /* 2^-100: zero for the wind, and no denormals */
    return p * i2f_bits((n + 127) << 23);
}

float tsk_wind_sin(float x) { return tsk_fast_sin(x); }
float tsk_wind_pow01(float u, float k) { return fast_pow01(u, k); }

void tsk_sines_eval_add(tsk_sines_eval* ev, const tsk_wind_sines_def* def, float weight, double t) {
    const double two_pi = 6.283185307179586476925;
    ev->base_x += weight * def->base_x;
    ev->base_y += weight * def->base_y;
    for (int i = 0; i < def->wave_count && ev->wave_count < TSK_SINES_MAX_EVAL; ++i) {
        const tsk_wind_wave* w = &def->waves[i];
        if (!(w->amplitude * weight > 0.0f)) continue;
        const double len = sqrt((double)w->dir_x * w->dir_x + (double)w->dir_y * w->dir_y);
        const double dx = w->dir_x / len, dy = w->dir_y / len;
        const double k = two_pi / w->wavelength; /* w_i of eq. 11 */
        /* seed 001, eq. 11: phi_i = speed * 2 pi / wavelength; crests move along D */
        double ph = fmod((double)w->phase - k * (double)w->speed * t, two_pi);
        if (ph >= 0.5 * two_pi) ph -= two_pi;
        if (ph < -0.5 * two_pi) ph += two_pi;
        const int n = ev->wave_count++;
        ev->amp_x[n] = (float)(w->amplitude * weight * dx);
        ev->amp_y[n] = (float)(w->amplitude * weight * dy);
        ev->kx[n] = (float)(k * dx);
        ev->ky[n] = (float)(k * dy);
        ev->phase[n] = (float)ph;
        ev->power[n] = w->power;
    }
    const tsk_wind_gust_def* g = &def->gust;
    if (g->strength * weight > 0.0f && ev->gust_count < TSK_WIND_BLEND_HISTORY) {
        tsk_wind_gust_def* o = &ev->gust[ev->gust_count++];
        *o = *g;
        const double len = sqrt((double)g->dir_x * g->dir_x + (double)g->dir_y * g->dir_y);
        o->dir_x = (float)(g->dir_x / len);
        o->dir_y = (float)(g->dir_y / len);
        o->strength = g->strength * weight;
    }
    ev->t = t;
}

/* seed 001, eq. 14 with the [Fer04] offset: F += D A ((sin(theta) + 1) / 2)^k. The 1/l of
 * eq. 14 (branch segment length) belongs to the tree module that turns wind into bend. */
TSK_WIND_CLONES
void tsk_sines_accumulate(const tsk_sines_eval* ev, size_t count, const float* restrict x,
                          const float* restrict y, float* restrict vx, float* restrict vy) {
    for (int w = 0; w < ev->wave_count; ++w) {
        const float kx = ev->kx[w], ky = ev->ky[w], ph = ev->phase[w];
        const float ax = ev->amp_x[w], ay = ev->amp_y[w], k = ev->power[w];
        if (k == 1.0f) {
            for (size_t i = 0; i < count; ++i) {
                const float u = (tsk_fast_sin(kx * x[i] + ky * y[i] + ph) + 1.0f) * 0.5f;
                vx[i] += ax * u;
                vy[i] += ay * u;
            }
        } else if (k == 2.0f) {
            for (size_t i = 0; i < count; ++i) {
                const float u = (tsk_fast_sin(kx * x[i] + ky * y[i] + ph) + 1.0f) * 0.5f;
                const float p = u * u;
                vx[i] += ax * p;
                vy[i] += ay * p;
            }
        } else {
            for (size_t i = 0; i < count; ++i) {
                const float u = (tsk_fast_sin(kx * x[i] + ky * y[i] + ph) + 1.0f) * 0.5f;
                const float p = fast_pow01(u, k);
                vx[i] += ax * p;
                vy[i] += ay * p;
            }
        }
    }
}
