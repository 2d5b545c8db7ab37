/* Smooth changes of the analytic wind: a short history of parameter sets, each cross-faded
 * in over its blend time with a smoothstep weight. Changing a wave in place would make the
 * wind jump (seed 001, section 4.1); a cross-fade of two continuous fields cannot. */
#include "wind_internal.h"

#include <string.h>

void tsk_sines_history_reset(tsk_sines_history* h, const tsk_wind_sines_def* def) {
    memset(h, 0, sizeof *h);
    h->count = 1;
    h->sets[0] = *def;
    h->start[0] = -1e300;
    h->blend[0] = 0.0;
}

void tsk_sines_history_push(tsk_sines_history* h, const tsk_wind_sines_def* def, double start,
                            double blend) {
    if (h->count == TSK_WIND_BLEND_HISTORY) {
        /* drop the oldest: the next one becomes the base (documented in wind.h) */
        memmove(&h->sets[0], &h->sets[1], sizeof h->sets[0] * (TSK_WIND_BLEND_HISTORY - 1));
        memmove(&h->start[0], &h->start[1], sizeof h->start[0] * (TSK_WIND_BLEND_HISTORY - 1));
        memmove(&h->blend[0], &h->blend[1], sizeof h->blend[0] * (TSK_WIND_BLEND_HISTORY - 1));
        --h->count;
    }
    const int n = h->count++;
    h->sets[n] = *def;
    h->start[n] = start;
    h->blend[n] = blend;
}

/* weight of set i in [0, 1]: 0 before its start, smoothstep over its blend time */
static double fade_in(const tsk_sines_history* h, int i, double t) {
    if (t < h->start[i]) return 0.0;
    if (!(h->blend[i] > 0.0)) return 1.0;
    double a = (t - h->start[i]) / h->blend[i];
    if (a >= 1.0) return 1.0;
    return a * a * (3.0 - 2.0 * a);
}

void tsk_sines_history_eval(const tsk_sines_history* h, double t, tsk_sines_eval* ev) {
    memset(ev, 0, sizeof *ev);
    ev->t = t;
    /* W = lerp(...lerp(lerp(W0, W1, s1), W2, s2)..., Wn, sn): weight of set i is
     * s_i * prod_{j > i} (1 - s_j), with s_0 = 1. */
    double rest = 1.0;
    for (int i = h->count - 1; i >= 0; --i) {
        const double s = i == 0 ? 1.0 : fade_in(h, i, t);
        const double w = s * rest;
        if (w > 0.0) tsk_sines_eval_add(ev, &h->sets[i], (float)w, t);
        rest *= 1.0 - s;
        if (!(rest > 0.0)) break;
    }
}
