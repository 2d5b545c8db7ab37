/* The branch wind step of seed 001 §4: every branch is re-attached to its parent and bent
 * by the force sampled at its tip (eq. 14–17). Lagged mode is the seed's (parents from the
 * last step, all branches in parallel); exact mode walks the depths in order. */
#include <math.h>
#include <string.h>

#include "tree_internal.h"

enum { WIND_GRAIN = 2048 };

tsk_tree_wind_def tsk_default_tree_wind_def(void) {
    tsk_tree_wind_def w;
    w.mode = TSK_TREE_WIND_LAGGED;
    w.strength = 1.0f;
    w.bend_power = 1.8f;
    return w;
}

typedef struct step_ctx {
    tsk_tree* t;
    const float* force;
    const float* parent_pts; /* where parents are read */
    const sloan_frames* parent_frames;
    float strength, power, b2_scale;
    size_t base; /* first branch of the range */
} step_ctx;

static void step_range(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const step_ctx* c = vctx;
    tsk_tree* t = c->t;
    for (size_t k = b; k < e; ++k) {
        const size_t i = c->base + k;
        v3 Pp[4] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
        const sloan_frames* fp = NULL;
        const int32_t p = t->parent[i];
        if (p >= 0) {
            tree_load_points(c->parent_pts, (size_t)p, Pp);
            fp = &c->parent_frames[p];
        }
        v3 F = tree_load3(c->force, i);
        if (c->strength != 1.0f) F = v3_scale(F, c->strength);
        v3 P[4], O;
        tree_pose_branch(t, i, Pp, fp, F, c->power, c->b2_scale, P, &O);
        tree_store_points(t->cur, i, P);
        tree_store3(t->cur_O, i, O);
        /* the frames children and leaves attach to (seed 001, eq. 8), once per parent */
        if (t->has_kids[i]) sloan_build(P, O, &t->frames[i]);
    }
}

tsk_status tsk_tree_wind_step(tsk_tree* t, const float* force, const tsk_tree_wind_def* wind) {
    if (t == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "tree", "is NULL");
    if (force == NULL && t->n > 0) return tsk_error_arg(TSK_ERR_ARGUMENT, "force", "is NULL");
    tsk_tree_wind_def w = wind ? *wind : tsk_default_tree_wind_def();
    if (w.mode != TSK_TREE_WIND_LAGGED && w.mode != TSK_TREE_WIND_EXACT)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "wind.mode", "must be 0 (lagged) or 1 (exact), got %d",
                             w.mode);
    if (!isfinite(w.strength) || w.strength < 0.0f || w.strength > 1e6f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "wind.strength", "must be in [0, 1e6], got %g",
                             (double)w.strength);
    if (!isfinite(w.bend_power) || w.bend_power < 0.5f || w.bend_power > 4.0f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "wind.bend_power", "must be in [0.5, 4], got %g",
                             (double)w.bend_power);
    for (size_t i = 0; i < 3 * t->n; ++i) {
        if (!isfinite(force[i]) || fabsf(force[i]) > 1e6f)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "force",
                                 "component %zu of branch %zu is %g (must be finite, |F| <= 1e6)",
                                 i % 3, i / 3, (double)force[i]);
    }
    step_ctx c = {t, force, NULL, NULL, w.strength, w.bend_power,
                  powf(1.0f / 3.0f, w.bend_power), 0};
    if (w.mode == TSK_TREE_WIND_LAGGED) {
        /* seed §4: parents from the last step; swap so that prev holds the last pose */
        float* tmp = t->prev;
        t->prev = t->cur;
        t->cur = tmp;
        tmp = t->prev_O;
        t->prev_O = t->cur_O;
        t->cur_O = tmp;
        sloan_frames* ftmp = t->prev_frames;
        t->prev_frames = t->frames;
        t->frames = ftmp;
        c.parent_pts = t->prev;
        c.parent_frames = t->prev_frames;
        tsk_parallel_for(t->n, WIND_GRAIN, step_range, &c);
    } else {
        /* exact: depth by depth, parents of this step (earlier depths are already done) */
        c.parent_pts = t->cur;
        c.parent_frames = t->frames;
        for (int d = 0; d < t->depth_count; ++d) {
            c.base = t->depth_start[d];
            tsk_parallel_for(t->depth_start[d + 1] - t->depth_start[d], WIND_GRAIN, step_range, &c);
        }
    }
    return TSK_OK;
}

void tsk_tree_reset_pose(tsk_tree* t) {
    if (t == NULL) return;
    memcpy(t->cur, t->rest, 12 * t->n * sizeof(float));
    memcpy(t->cur_O, t->rest_O, 3 * t->n * sizeof(float));
    tree_rest_frames(t);
}

tsk_status tsk_tree_attachment_gap(const tsk_tree* t, double* max_relative_gap) {
    if (t == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "tree", "is NULL");
    if (max_relative_gap == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "max_relative_gap", "is NULL");
    double worst = 0.0;
    for (size_t i = 0; i < t->n; ++i) {
        const int32_t p = t->parent[i];
        if (p < 0) continue;
        v3 Pp[4];
        tree_load_points(t->cur, (size_t)p, Pp);
        const float v = t->attach_v[i];
        const v3 on = bez_point(Pp, v);
        const v3 P0 = tree_load3(t->cur + 12 * i, 0);
        const double gap = v3_len(v3_sub(P0, on));
        double r = tsk_branch_radius(&t->shape[p], v, 0.0f);
        if (r < 1e-6) r = 1e-6;
        if (gap / r > worst) worst = gap / r;
    }
    *max_relative_gap = worst;
    return TSK_OK;
}
