/* Gusts: deterministic random speed boosts with a raised-cosine shape in time whose front
 * travels downwind (model documented in wind.h, tsk_wind_gust_def). */
#include "wind_internal.h"
#include "core/tmath.h"

#include <math.h>

typedef struct gust_slot {
    int64_t slot;
    double start; /* s, local time the gust starts */
    float peak; /* m/s */
} gust_slot;

static void slot_of(const tsk_wind_gust_def* g, int64_t slot, gust_slot* out) {
    const uint64_t key = (uint64_t)slot;
    const double u1 = tsk_rand01(g->seed, key, 0x6775, 0); /* start inside the slot */
    const double u2 = tsk_rand01(g->seed, key, 0x6775, 1); /* peak */
    out->slot = slot;
    out->start = (double)slot * g->interval + u1 * ((double)g->interval - g->duration);
    out->peak = (float)(0.5 + 0.5 * u2);
}

static float envelope_in(const tsk_wind_gust_def* g, const gust_slot* s, double tau) {
    const double a = tau - s->start;
    if (!(a > 0.0) || a >= g->duration) return 0.0f;
    const double two_pi = 6.283185307179586476925;
    return s->peak * (float)(0.5 - 0.5 * tsk_cos(two_pi * a / g->duration));
}

static int64_t slot_index(const tsk_wind_gust_def* g, double tau) {
    double j = floor(tau / g->interval);
    if (j > 9.0e18) j = 9.0e18;
    if (j < -9.0e18) j = -9.0e18;
    return (int64_t)j;
}

float tsk_gust_envelope(const tsk_wind_gust_def* g, double tau) {
    gust_slot s;
    slot_of(g, slot_index(g, tau), &s);
    return envelope_in(g, &s, tau);
}

/* exact path in double, one point at a time (used when a block spans many slots) */
static void accumulate_scalar(const tsk_wind_gust_def* g, double t, size_t count, const float* x,
                              const float* y, float* vx, float* vy) {
    const double inv_front = g->front_speed > 0.0f ? 1.0 / g->front_speed : 0.0;
    gust_slot cached;
    slot_of(g, slot_index(g, t), &cached);
    for (size_t i = 0; i < count; ++i) {
        const double tau = t - ((double)g->dir_x * x[i] + (double)g->dir_y * y[i]) * inv_front;
        const int64_t j = slot_index(g, tau);
        if (j != cached.slot) slot_of(g, j, &cached);
        const float e = g->strength * envelope_in(g, &cached, tau);
        vx[i] += e * g->dir_x;
        vy[i] += e * g->dir_y;
    }
}

enum { GUST_BLOCK = 256, GUST_TABLE = 64 };

/* Fast path: local times relative to the start of the slot that holds t, in float; the
 * few slots a block of points spans go into a table, and the loop vectorises. */
TSK_WIND_CLONES
static void accumulate_block(const tsk_wind_gust_def* g, double t, size_t n, const float* x,
                             const float* y, float* vx, float* vy) {
    const double I = g->interval;
    const double j0 = floor(t / I);
    const float t0 = (float)(t - j0 * I); /* [0, I) */
    const float inv_front = g->front_speed > 0.0f ? 1.0f / g->front_speed : 0.0f;
    const float dx = g->dir_x, dy = g->dir_y;
    float tau[GUST_BLOCK];
    float lo = t0, hi = t0;
    for (size_t i = 0; i < n; ++i) {
        tau[i] = t0 - (dx * x[i] + dy * y[i]) * inv_front;
        lo = tau[i] < lo ? tau[i] : lo;
        hi = tau[i] > hi ? tau[i] : hi;
    }
    const double kmin = floor((double)lo / I) - 1.0, kmax = floor((double)hi / I) + 1.0;
    if (kmax - kmin + 1.0 > GUST_TABLE || !(j0 + kmin > -9.0e18 && j0 + kmax < 9.0e18)) {
        accumulate_scalar(g, t, n, x, y, vx, vy);
        return;
    }
    const int nk = (int)(kmax - kmin) + 1;
    float start[GUST_TABLE], peak[GUST_TABLE];
    for (int k = 0; k < nk; ++k) {
        gust_slot s;
        slot_of(g, (int64_t)(j0 + kmin) + k, &s);
        start[k] = (float)(s.start - j0 * I);
        peak[k] = g->strength * s.peak;
    }
    const float inv_i = (float)(1.0 / I), fkmin = (float)kmin, dur = g->duration;
    const float w = (float)(6.283185307179586 / g->duration), quarter = 1.57079632679489662f;
    for (size_t i = 0; i < n; ++i) {
        const float q = tau[i] * inv_i - fkmin;
        int k = (int)q; /* q > 0: truncation is floor */
        k = k < 0 ? 0 : (k > nk - 1 ? nk - 1 : k);
        const float a = tau[i] - start[k];
        const float inside = (a > 0.0f && a < dur) ? 1.0f : 0.0f;
        /* raised cosine: 0.5 - 0.5 cos(w a) = 0.5 - 0.5 sin(w a + pi/2) */
        const float e = inside * peak[k] * (0.5f - 0.5f * tsk_fast_sin(w * a + quarter));
        vx[i] += e * dx;
        vy[i] += e * dy;
    }
}

void tsk_gust_accumulate(const tsk_sines_eval* ev, size_t count, const float* x, const float* y,
                         float* vx, float* vy) {
    for (int k = 0; k < ev->gust_count; ++k)
        for (size_t b = 0; b < count; b += GUST_BLOCK) {
            const size_t n = count - b < GUST_BLOCK ? count - b : GUST_BLOCK;
            accumulate_block(&ev->gust[k], ev->t, n, x + b, y + b, vx + b, vy + b);
        }
}
