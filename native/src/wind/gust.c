/* Gusts: deterministic random speed boosts with a raised-cosine shape in time whose front
 * travels downwind (model documented in wind.h, tsk_wind_gust_def). */
#include "wind_internal.h"

#include <math.h>

typedef struct gust_slot {
    int64_t slot;
    double start; /* s, local time the gust starts */
    float peak;   /* m/s */
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
    return s->peak * (float)(0.5 - 0.5 * cos(two_pi * a / g->duration));
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

void tsk_gust_accumulate(const tsk_sines_eval* ev, size_t count, const float* x, const float* y,
                         float* vx, float* vy) {
    for (int k = 0; k < ev->gust_count; ++k) {
        const tsk_wind_gust_def* g = &ev->gust[k];
        const double inv_front = g->front_speed > 0.0f ? 1.0 / g->front_speed : 0.0;
        gust_slot cached;
        slot_of(g, slot_index(g, ev->t), &cached);
        for (size_t i = 0; i < count; ++i) {
            const double tau =
                ev->t - ((double)g->dir_x * x[i] + (double)g->dir_y * y[i]) * inv_front;
            const int64_t j = slot_index(g, tau);
            if (j != cached.slot) slot_of(g, j, &cached);
            const float e = g->strength * envelope_in(g, &cached, tau);
            vx[i] += e * g->dir_x;
            vy[i] += e * g->dir_y;
        }
    }
}
