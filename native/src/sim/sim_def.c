/* Defaults and validation of the blade simulation's definition (tsk_blade_sim_def). */
#include "sim/sim_internal.h"
#include "core/tmath.h"

#include <math.h>

tsk_blade_sim_def tsk_default_blade_sim_def(void) {
    tsk_blade_sim_def d;
    d.origin[0] = d.origin[1] = d.origin[2] = 0.0f;
    d.tile_size = 0.5f;
    d.tiles_x = d.tiles_y = 20;
    d.knot_count = 16;
    d.gravity[0] = d.gravity[1] = 0.0f;
    d.gravity[2] = -9.81f;
    d.gravity_preload = 1.0f;
    d.damping = 4.0f;
    d.wind_drag = 0.2f;
    d.linear_density = 1e-3f;
    d.global_stiffness_root = 30.0f;
    d.global_stiffness_tip = 1.0f;
    d.local_stiffness = 120.0f;
    d.iterations = 4;
    d.ground_height = 0.0f;
    d.collision_margin = 0.002f;
    d.activation_margin = 0.1f;
    d.max_blade_height = 1.0f;
    d.rest_distance = 0.002f;
    d.rest_speed = 0.02f;
    d.rest_frames = 30;
    d.blend_frames = 8;
    d.settle_frames = 120;
    d.settle_blend_frames = 48;
    return d;
}

#define CHECK_FINITE(field)    \
    if (!isfinite(def->field)) \
    return tsk_error_arg(TSK_ERR_ARGUMENT, #field, "must be finite, got %g", (double)def->field)
#define CHECK_RANGE(field, lo, hi)                                                              \
    if (!(def->field >= (lo) && def->field <= (hi)))                                            \
    return tsk_error_arg(TSK_ERR_ARGUMENT, #field, "must be in [%g, %g], got %g", (double)(lo), \
                         (double)(hi), (double)def->field)
#define CHECK_POSITIVE(field)                                                             \
    if (!(isfinite(def->field) && def->field > 0))                                        \
    return tsk_error_arg(TSK_ERR_ARGUMENT, #field, "must be positive and finite, got %g", \
                         (double)def->field)
#define CHECK_NONNEG(field)                                                           \
    if (!(isfinite(def->field) && def->field >= 0))                                   \
    return tsk_error_arg(TSK_ERR_ARGUMENT, #field, "must be >= 0 and finite, got %g", \
                         (double)def->field)

/* |field| <= bound (a finite field is checked first) */
#define CHECK_ABS(field, bound)                                                                    \
    if (!(fabsf(def->field) <= (bound)))                                                           \
    return tsk_error_arg(TSK_ERR_ARGUMENT, #field, "must be within +-%g, got %g", (double)(bound), \
                         (double)def->field)

tsk_status tsk_sim_check_def(const tsk_blade_sim_def* def) {
    if (!def) return tsk_error_arg(TSK_ERR_ARGUMENT, "def", "is NULL");
    for (int c = 0; c < 3; ++c) {
        CHECK_FINITE(origin[c]);
        CHECK_ABS(origin[c], TSK_BLADE_SIM_MAX_COORD);
        CHECK_FINITE(gravity[c]);
        CHECK_ABS(gravity[c], TSK_BLADE_SIM_MAX_ACCEL);
    }
    CHECK_POSITIVE(tile_size);
    CHECK_ABS(tile_size, TSK_BLADE_SIM_MAX_COORD);
    if (def->tiles_x < 1)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "tiles_x", "must be >= 1, got %d", def->tiles_x);
    if (def->tiles_y < 1)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "tiles_y", "must be >= 1, got %d", def->tiles_y);
    if ((int64_t)def->tiles_x * def->tiles_y > TSK_BLADE_SIM_MAX_TILES)
        return tsk_error_arg(TSK_ERR_LIMIT, "tiles_x", "tiles_x * tiles_y = %lld exceeds %d",
                             (long long)def->tiles_x * def->tiles_y, TSK_BLADE_SIM_MAX_TILES);
    if (def->knot_count > TSK_BLADE_SIM_MAX_KNOTS)
        return tsk_error_arg(TSK_ERR_LIMIT, "knot_count", "must be at most %d, got %d",
                             TSK_BLADE_SIM_MAX_KNOTS, def->knot_count);
    if (def->knot_count < TSK_BLADE_SIM_MIN_KNOTS)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "knot_count", "must be at least %d, got %d",
                             TSK_BLADE_SIM_MIN_KNOTS, def->knot_count);
    CHECK_RANGE(gravity_preload, 0.0f, 1.0f);
    CHECK_NONNEG(damping);
    CHECK_NONNEG(wind_drag);
    CHECK_POSITIVE(linear_density);
    /* the drag rate per metre of width; beyond, drag * dt overflows to inf and a knot of zero
       width gets inf * 0 = NaN (fuzz_sim: wind_drag 3.4e38) */
    if (!((double)def->wind_drag / def->linear_density <= TSK_BLADE_SIM_MAX_DRAG))
        return tsk_error_arg(
            TSK_ERR_ARGUMENT, "wind_drag", "wind_drag / linear_density must be at most %g, got %g",
            (double)TSK_BLADE_SIM_MAX_DRAG, (double)def->wind_drag / def->linear_density);
    CHECK_NONNEG(global_stiffness_root);
    CHECK_NONNEG(global_stiffness_tip);
    CHECK_NONNEG(local_stiffness);
    if (def->iterations > TSK_BLADE_SIM_MAX_ITERATIONS)
        return tsk_error_arg(TSK_ERR_LIMIT, "iterations", "must be at most %d, got %d",
                             TSK_BLADE_SIM_MAX_ITERATIONS, def->iterations);
    if (def->iterations < 1)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "iterations", "must be >= 1, got %d",
                             def->iterations);
    CHECK_FINITE(ground_height);
    CHECK_ABS(ground_height, TSK_BLADE_SIM_MAX_COORD);
    CHECK_NONNEG(collision_margin);
    CHECK_ABS(collision_margin, TSK_BLADE_SIM_MAX_COORD);
    CHECK_NONNEG(activation_margin);
    CHECK_ABS(activation_margin, TSK_BLADE_SIM_MAX_COORD);
    CHECK_POSITIVE(max_blade_height);
    CHECK_ABS(max_blade_height, TSK_BLADE_SIM_MAX_COORD);
    CHECK_POSITIVE(rest_distance);
    CHECK_POSITIVE(rest_speed);
    if (def->rest_frames < 1)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "rest_frames", "must be >= 1, got %d",
                             def->rest_frames);
    if (def->blend_frames < 1)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "blend_frames", "must be >= 1, got %d",
                             def->blend_frames);
    if (def->settle_frames < 1)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "settle_frames", "must be >= 1, got %d",
                             def->settle_frames);
    if (def->settle_blend_frames < 1)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "settle_blend_frames", "must be >= 1, got %d",
                             def->settle_blend_frames);
    return TSK_OK;
}

sim_step_params tsk_sim_step_params(const tsk_blade_sim_def* d, float dt) {
    sim_step_params p;
    memset(&p, 0, sizeof p);
    p.K = d->knot_count;
    p.iterations = d->iterations;
    p.dt = dt;
    p.dt2 = dt * dt;
    p.damp = (float)tsk_exp(-(double)d->damping * dt);
    for (int c = 0; c < 3; ++c) p.gravity[c] = d->gravity[c];
    p.preload = d->gravity_preload;
    p.drag = (float)((double)d->wind_drag / d->linear_density * dt);
    p.alpha_root = (float)(1.0 - tsk_exp(-(double)d->global_stiffness_root * dt));
    p.alpha_tip = (float)(1.0 - tsk_exp(-(double)d->global_stiffness_tip * dt));
    const double al = 1.0 - tsk_exp(-(double)d->local_stiffness * dt);
    p.alpha_local = (float)(al < 0.95 ? al : 0.95); /* above ~0.95 the sweep overshoots */
    p.ground = d->ground_height;
    return p;
}
