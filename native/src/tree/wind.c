/* The branch wind step of seed 001 §4: every branch is re-attached to its parent and bent
 * by the force sampled at its tip (eq. 14–17). Lagged mode is the seed's (parents from the
 * last step, all branches in parallel); exact mode walks the depths in order. */
#include <math.h>
#include <string.h>

#include "tree/wind_kernel.h"
#include "core/tmath.h"

enum { WIND_GRAIN = 2048 };

tsk_tree_wind_def tsk_default_tree_wind_def(void) {
    tsk_tree_wind_def w;
    w.mode = TSK_TREE_WIND_LAGGED;
    w.strength = 1.0f;
    w.bend_power = 1.8f;
    w.length_power = 1.0f;
    return w;
}

void tree_set_length_power(tsk_tree* t, float power) {
    for (size_t i = 0; i < t->n; ++i) {
        const float l = t->rest_seg[i];
        float inv = l > 1e-12f ? (power == 1.0f ? 1.0f / l : 1.0f / tsk_powf(l, power)) : 0.0f;
        t->inv_l[i] = inv <= 1e12f ? inv : 1e12f; /* a micrometre twig, power 3: still finite */
    }
    t->inv_l_power = power;
}

/* One branch at a time: the reference path (trunks, degenerate frames, array tails). */
static void step_scalar(const tree_wind_ctx* c, size_t b, size_t e) {
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

int tree_wind_force_scalar = 0;

/* The portable block kernel (4 branches per call), also the fallback of the wider ones. */
#define TREE_KFN(name) name##_portable
#include "tree/wind_kernel_impl.h"
#undef TREE_KFN

/* Branches [b, e) of the range: blocks of 4, then one at a time. */
static void step_portable(const tree_wind_ctx* c, size_t b, size_t e) {
    size_t k = b;
    for (; k + 4 <= e; k += 4)
        if (!tree_wind_block_portable(c, c->base + k)) step_scalar(c, k, k + 4);
    step_scalar(c, k, e);
}

/* Blocks of the widest kernel the CPU runs (core/simd.h); a block one of whose branches needs
 * the one-branch path, and the range's tail, go through the portable kernel. Blocks never
 * straddle chunks, and every path gives the same bytes. */
static void step_range(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const tree_wind_ctx* c = vctx;
    if (tree_wind_force_scalar) {
        step_scalar(c, b, e);
        return;
    }
    size_t k = b;
    switch (tsk_simd_isa()) {
#if TSK_SIMD_X86_PATHS
        case TSK_ISA_AVX512:
            for (; k + 16 <= e; k += 16)
                if (!tree_wind_block_avx512(c, c->base + k)) step_portable(c, k, k + 16);
            break;
        case TSK_ISA_AVX2:
            for (; k + 8 <= e; k += 8)
                if (!tree_wind_block_avx2(c, c->base + k)) step_portable(c, k, k + 8);
            break;
#endif
        default:
            break;
    }
    step_portable(c, k, e);
}

tsk_status tsk_tree_wind_step(tsk_tree* t, const float* force, const tsk_tree_wind_def* wind) {
    if (t == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "tree", "is NULL");
    if (force == NULL && t->n > 0) return tsk_error_arg(TSK_ERR_ARGUMENT, "force", "is NULL");
    tsk_tree_wind_def w = wind ? *wind : tsk_default_tree_wind_def();
    if (w.mode != TSK_TREE_WIND_LAGGED && w.mode != TSK_TREE_WIND_EXACT)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "wind.mode",
                             "must be 0 (lagged) or 1 (exact), got %d", w.mode);
    if (!isfinite(w.strength) || w.strength < 0.0f || w.strength > 1e6f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "wind.strength", "must be in [0, 1e6], got %g",
                             (double)w.strength);
    if (!isfinite(w.bend_power) || w.bend_power < 0.5f || w.bend_power > 4.0f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "wind.bend_power", "must be in [0.5, 4], got %g",
                             (double)w.bend_power);
    if (!isfinite(w.length_power) || w.length_power < 0.0f || w.length_power > 3.0f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "wind.length_power", "must be in [0, 3], got %g",
                             (double)w.length_power);
    /* one branch-free pass that vectorizes (NaN fails the comparison); the message search
     * only runs on bad input */
    int bad = 0;
    for (size_t i = 0; i < 3 * t->n; ++i) bad |= !(fabsf(force[i]) <= 1e6f);
    for (size_t i = 0; bad && i < 3 * t->n; ++i) {
        if (!(fabsf(force[i]) <= 1e6f))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "force",
                                 "component %zu of branch %zu is %g (must be finite, |F| <= 1e6)",
                                 i % 3, i / 3, (double)force[i]);
    }
    if (w.length_power != t->inv_l_power) tree_set_length_power(t, w.length_power);
    t->at_rest = 0;
    tree_wind_ctx c = {
        t, force, NULL, NULL, w.strength, w.bend_power, tsk_powf(1.0f / 3.0f, w.bend_power), 0};
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
    if (t != NULL && !t->at_rest) tree_pose_rest(t); /* else new, or reset since its last step */
}

tsk_status tsk_tree_attachment_gap(const tsk_tree* t, double* max_relative_gap,
                                   double* max_metres) {
    if (t == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "tree", "is NULL");
    double worst = 0.0, worst_m = 0.0;
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
        const double floor_r = 0.1 * (double)t->shape[p].radius;
        if (r < floor_r) r = floor_r;
        if (r < 1e-9) r = 1e-9;
        if (gap / r > worst) worst = gap / r;
        if (gap > worst_m) worst_m = gap;
    }
    if (max_relative_gap) *max_relative_gap = worst;
    if (max_metres) *max_metres = worst_m;
    return TSK_OK;
}
