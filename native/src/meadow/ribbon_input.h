/* What good input for a blade's ribbon is, shared by tsk_blades_expand (expand.c) and
 * tsk_blade_sim_get_ribbons (sim/tiles.c and its kernels), so that both accept the same
 * blades and name a bad one the same way. Not part of the public API. */
#ifndef TSK_RIBBON_INPUT_H
#define TSK_RIBBON_INPUT_H

#include "tussock/core.h"

#include <float.h>
#include <math.h>
#include <stddef.h>

/* Written without branches (NaN fails every comparison), so that passes over whole chunks
 * vectorize. */
static inline int tsk_ribbon_coord_ok(float x) { return fabsf(x) <= FLT_MAX; }
static inline int tsk_ribbon_width_ok(float w) { return (w >= 0.0f) & (w <= FLT_MAX); }
static inline int tsk_ribbon_side_ok(const float* side) {
    const float l2 = side[0] * side[0] + side[1] * side[1] + side[2] * side[2];
    return (l2 > 1e-20f) & (l2 <= FLT_MAX);
}

/* The error for one blade's bad input (K knots xyz, K widths, its side), checked knot by knot
 * (position, then width) and then the side, naming it blade `b`; TSK_OK when all is good. */
tsk_status tsk_ribbon_report_bad(const float* knots, const float* widths, const float* side,
                                 size_t K, size_t b);

#endif
