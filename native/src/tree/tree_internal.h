/* Private layout of a tsk_tree and the small vector and Bézier helpers that the generator,
 * the wind step and the deformer share (so that all three evaluate curves and frames the
 * same way, bit for bit). */
#ifndef TSK_TREE_INTERNAL_H
#define TSK_TREE_INTERNAL_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "tussock/tree.h"

typedef struct v3 {
    float x, y, z;
} v3;

static inline v3 v3_make(float x, float y, float z) {
    v3 r = {x, y, z};
    return r;
}
static inline v3 v3_add(v3 a, v3 b) { return v3_make(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline v3 v3_sub(v3 a, v3 b) { return v3_make(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline v3 v3_scale(v3 a, float s) { return v3_make(a.x * s, a.y * s, a.z * s); }
static inline float v3_dot(v3 a, v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline v3 v3_cross(v3 a, v3 b) {
    return v3_make(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float v3_len(v3 a) { return sqrtf(v3_dot(a, a)); }
/* Unit vector; `fallback` when a is (nearly) zero. */
static inline v3 v3_norm_or(v3 a, v3 fallback) {
    float l = v3_len(a);
    return l > 1e-20f ? v3_scale(a, 1.0f / l) : fallback;
}
static inline v3 v3_lerp(v3 a, v3 b, float t) { return v3_add(a, v3_scale(v3_sub(b, a), t)); }
/* a*s + b*t */
static inline v3 v3_comb(v3 a, float s, v3 b, float t) {
    return v3_make(a.x * s + b.x * t, a.y * s + b.y * t, a.z * s + b.z * t);
}

/* Any unit vector perpendicular to unit n. */
static inline v3 v3_any_perp(v3 n) {
    v3 a = fabsf(n.x) < 0.9f ? v3_make(1, 0, 0) : v3_make(0, 1, 0);
    return v3_norm_or(v3_cross(n, a), v3_make(0, 0, 1));
}

/* Cubic Bézier point and derivative. */
static inline v3 bez_point(const v3* P, float u) {
    const float s = 1.0f - u;
    const float b0 = s * s * s, b1 = 3.0f * s * s * u, b2 = 3.0f * s * u * u, b3 = u * u * u;
    return v3_make(P[0].x * b0 + P[1].x * b1 + P[2].x * b2 + P[3].x * b3,
                   P[0].y * b0 + P[1].y * b1 + P[2].y * b2 + P[3].y * b3,
                   P[0].z * b0 + P[1].z * b1 + P[2].z * b2 + P[3].z * b3);
}
static inline v3 bez_deriv(const v3* P, float u) {
    const float s = 1.0f - u;
    const float d0 = 3.0f * s * s, d1 = 6.0f * s * u, d2 = 3.0f * u * u;
    v3 a = v3_sub(P[1], P[0]), b = v3_sub(P[2], P[1]), c = v3_sub(P[3], P[2]);
    return v3_make(a.x * d0 + b.x * d1 + c.x * d2, a.y * d0 + b.y * d1 + c.y * d2,
                   a.z * d0 + b.z * d1 + c.z * d2);
}

/* Sloan's moving frame at P0, P1, P2 (seed 001, eq. 8), every vector normalized. */
typedef struct sloan_frames {
    v3 S[3], T[3];
} sloan_frames;

static inline void sloan_build(const v3* P, v3 O, sloan_frames* f) {
    v3 L0 = v3_norm_or(v3_sub(P[1], P[0]), v3_norm_or(v3_sub(P[3], P[0]), v3_make(0, 0, 1)));
    v3 L1 = v3_norm_or(v3_sub(P[2], P[1]), L0);
    v3 L2 = v3_norm_or(v3_sub(P[3], P[2]), L1);
    f->S[0] = v3_norm_or(v3_cross(L0, O), v3_any_perp(L0));
    f->T[0] = v3_cross(f->S[0], L0);
    f->T[1] = v3_norm_or(v3_cross(f->S[0], L1), f->T[0]);
    f->S[1] = v3_norm_or(v3_cross(L1, f->T[1]), f->S[0]);
    f->T[2] = v3_norm_or(v3_cross(f->S[1], L2), f->T[1]);
    f->S[2] = v3_norm_or(v3_cross(L2, f->T[2]), f->S[1]);
}

/* Quadratic Bernstein weights: how the three handles blend at parameter u in the
 * generalized de Casteljau evaluation (seed eq. 9). */
static inline void bern2(float u, float* q) {
    const float s = 1.0f - u;
    q[0] = s * s;
    q[1] = 2.0f * s * u;
    q[2] = u * u;
}
static inline void bern2_deriv(float u, float* dq) {
    dq[0] = -2.0f * (1.0f - u);
    dq[1] = 2.0f - 4.0f * u;
    dq[2] = 2.0f * u;
}

/* Blended handles at u: S(u) = sum q_i S_i, T(u) = sum q_i T_i. */
static inline void sloan_at(const sloan_frames* f, float u, v3* S, v3* T) {
    float q[3];
    bern2(u, q);
    *S = v3_add(v3_add(v3_scale(f->S[0], q[0]), v3_scale(f->S[1], q[1])), v3_scale(f->S[2], q[2]));
    *T = v3_add(v3_add(v3_scale(f->T[0], q[0]), v3_scale(f->T[1], q[1])), v3_scale(f->T[2], q[2]));
}

/* ---- the tree --------------------------------------------------------------------------- */

/* Per-branch data, structure of arrays. Branch i's parent has a smaller index; depths are
 * non-decreasing with the index, depth_start[d] is the first branch of depth d. */
struct tsk_tree {
    size_t n, leaf_n;
    int depth_count;
    size_t depth_start[66]; /* depth_count + 1 entries */
    size_t level_count[TSK_TREE_MAX_LEVELS];
    int32_t* parent;
    int32_t* level;
    int32_t* depth;
    float* attach_v;
    float* attach_theta;
    float* attach_alpha;
    float* length;
    float* rest_seg; /* |Q3 - Q2| of the rest shape, the l of seed eq. 14 */
    tsk_branch_shape* shape;
    float* local;    /* 9n: Q1, Q2, Q3 in the attachment frame (Q0 = 0) */
    float* root;     /* 3n: P0 of a trunk (parent -1); unused otherwise */
    float* rest;     /* 12n: rest P0..P3 */
    float* rest_O;   /* 3n */
    float* cur;      /* 12n: current pose */
    float* cur_O;    /* 3n */
    float* prev;     /* 12n: scratch for the lagged step (pose of the last step) */
    float* prev_O;   /* 3n */
    /* leaves */
    int32_t* leaf_parent;
    float* leaf_attach; /* 3m: v, theta, alpha */
    float* leaf_size;   /* 2m: length, width */
};

/* Attachment frame of a child of parent points P / orientation O at (v, theta): origin on
 * the parent's curve, U along the parent, V toward theta (seed §4.2). */
void tree_attach_frame(const v3* P, v3 O, float v, float theta, v3* origin, v3* U, v3* V);

/* Poses branch i from its parent's points (Pp, Op; ignored for a trunk) and a bend given
 * in world space (force already scaled; zero = rest shape): writes 4 points and O. */
void tree_pose_branch(const struct tsk_tree* t, size_t i, const v3* Pp, v3 Op, v3 force,
                      float bend_power, v3* P_out, v3* O_out);

static inline void tree_load_points(const float* a, size_t i, v3* P) {
    const float* p = a + 12 * i;
    for (int k = 0; k < 4; ++k) P[k] = v3_make(p[3 * k], p[3 * k + 1], p[3 * k + 2]);
}
static inline void tree_store_points(float* a, size_t i, const v3* P) {
    float* p = a + 12 * i;
    for (int k = 0; k < 4; ++k) {
        p[3 * k] = P[k].x;
        p[3 * k + 1] = P[k].y;
        p[3 * k + 2] = P[k].z;
    }
}
static inline v3 tree_load3(const float* a, size_t i) {
    return v3_make(a[3 * i], a[3 * i + 1], a[3 * i + 2]);
}
static inline void tree_store3(float* a, size_t i, v3 v) {
    a[3 * i] = v.x;
    a[3 * i + 1] = v.y;
    a[3 * i + 2] = v.z;
}

/* Weber–Penn ShapeRatio (shape 0..7). */
float tree_shape_ratio(int shape, float ratio);

#endif
