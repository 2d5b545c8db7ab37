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
 * generalized de Casteljau evaluation (seed 001, eq. 9). */
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
    float* trig; /* 4n: cos theta, sin theta, cos alpha, sin alpha */
    uint8_t* has_kids;
    sloan_frames* frames; /* current Sloan frames of branches with children */
    sloan_frames* prev_frames; /* those of the last step (lagged mode) */
    float* length;
    float* rest_seg; /* |Q3 - Q2| of the rest shape, the l of seed 001, eq. 14 */
    float* seg12; /* |Q2 - Q1| */
    float* inv_l; /* 1 / l^length_power (0 for l <= 1e-12): the divisor of seed 001, eq. 14 */
    float inv_l_power; /* the length_power inv_l was made for */
    tsk_branch_shape* shape;
    float* local; /* 9n: Q1, Q2, Q3 in the attachment frame (Q0 = 0) */
    float* root; /* 3n: P0 of a trunk (parent -1); unused otherwise */
    float* rest; /* 12n: rest P0..P3 */
    float* rest_O; /* 3n */
    float* cur; /* 12n: current pose */
    float* cur_O; /* 3n */
    int at_rest; /* cur, cur_O and frames hold the rest pose: a reset has nothing to do */
    float* prev; /* 12n: scratch for the lagged step (pose of the last step) */
    float* prev_O; /* 3n */
    /* leaves */
    int32_t* leaf_parent;
    float* leaf_attach; /* 3m: v, theta, alpha */
    float* leaf_size; /* 2m: length, width */
    float* leaf_trig; /* 4m: cos theta, sin theta, cos alpha, sin alpha (per-frame leaf pose) */
};

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

/* m^e for m > 0 through exp2(e log2 m), with series that the wind step's block kernel
 * (wind_kernel_impl.h) repeats operation for operation (so both give the same bytes); relative
 * error < 1e-5.
 * Used for the bend factor of seed 001, eq. 16, where powf was a third of the step. */
static inline float bend_pow(float m, float e) {
    union {
        float f;
        uint32_t u;
    } b = {m};
    const float ex = (float)((int32_t)((b.u >> 23) & 255u) - 127);
    b.u = (b.u & 0x7FFFFFu) | 0x3F800000u; /* mantissa in [1, 2) */
    const float s = (b.f - 1.0f) / (b.f + 1.0f), s2 = s * s;
    /* ln(mant) = 2 (s + s^3/3 + s^5/5 + s^7/7 + s^9/9) */
    const float ln =
        2.0f * s *
        (1.0f + s2 * (0.333333333f + s2 * (0.2f + s2 * (0.142857143f + s2 * 0.111111111f))));
    float y = e * (ex + ln * 1.44269504f);
    y = y < -126.0f ? -126.0f : (y > 126.0f ? 126.0f : y);
    float n = (float)(int32_t)y; /* truncation, then floor */
    if (n > y) n = n - 1.0f;
    const float f = (y - n) * 0.693147181f; /* 2^(y-n) = e^f, f in [0, ln 2) */
    const float p =
        1.0f +
        f * (1.0f + f * (0.5f + f * (0.166666667f +
                                     f * (0.0416666667f +
                                          f * (0.00833333333f +
                                               f * (0.00138888889f + f * 0.000198412698f))))));
    union {
        uint32_t u;
        float f;
    } sc = {(uint32_t)((int32_t)n + 127) << 23};
    return p * sc.f;
}

/* ---- posing a branch on its parent (seed 001 §4.2) and bending it (§4.3, eq. 15–17). The
 * generator, the wind step and the attachment checks all go through these functions, so a
 * zero wind reproduces the generated rest pose bit for bit. Inline: the wind step's loop. */

static inline void tree_attach_frame(const v3* P, const sloan_frames* f, float v, float ct,
                                     float st, v3* origin, v3* U, v3* V) {
    *origin = bez_point(P, v);
    /* U: the parent's direction at v (derivative of its Bézier) */
    v3 chord = v3_norm_or(v3_sub(P[3], P[0]), v3_make(0, 0, 1));
    *U = v3_norm_or(bez_deriv(P, v), chord);
    /* the point of the parent's de Casteljau sweep surface at (v, theta) gives the radial
     * direction the branch grows toward (seed 001, eq. 1 and 9 with unit radius) */
    v3 S, T;
    sloan_at(f, v, &S, &T);
    v3 D = v3_comb(S, st, T, ct);
    D = v3_sub(D, v3_scale(*U, v3_dot(D, *U)));
    *V = v3_norm_or(D, v3_any_perp(*U));
}

/* The largest |f| (force over length^power, seed 001, eq. 14) that bends a branch further: a
 * bend vector of TREE_BEND_MAX^power (at most 1e16 m) already points the segment along f. The
 * wind step's vector paths hand a block with a larger one to the scalar path. */
#define TREE_BEND_MAX 1e4f

static inline void tree_pose_branch(const struct tsk_tree* t, size_t i, const v3* Pp,
                                    const sloan_frames* fp, v3 force, float bend_power,
                                    float b2_scale, v3* P_out, v3* O_out) {
    const float* trig = t->trig + 4 * i;
    v3 origin, U, V;
    if (t->parent[i] < 0) {
        origin = tree_load3(t->root, i);
        U = v3_make(0, 0, 1);
        V = v3_make(1, 0, 0);
    } else {
        tree_attach_frame(Pp, fp, t->attach_v[i], trig[0], trig[1], &origin, &U, &V);
    }
    /* rotate "down" by alpha in the plane of U and V (seed Fig. 4) */
    const float ca = trig[2], sa = trig[3];
    const v3 axis = v3_comb(U, ca, V, sa);
    const v3 side = v3_comb(U, -sa, V, ca);
    const v3 W = v3_cross(U, V);
    v3 Q[4];
    Q[0] = v3_make(0, 0, 0);
    for (int k = 0; k < 3; ++k)
        Q[k + 1] = v3_make(t->local[9 * i + 3 * k], t->local[9 * i + 3 * k + 1],
                           t->local[9 * i + 3 * k + 2]);
    if (force.x != 0.0f || force.y != 0.0f || force.z != 0.0f) {
        /* seed 001, eq. 14: the force is divided by the length l between control points */
        const float inv_l = t->inv_l[i];
        v3 f = v3_make(v3_dot(force, axis), v3_dot(force, side), v3_dot(force, W));
        f = v3_scale(f, inv_l);
        float m = v3_len(f);
        if (!(m <= TREE_BEND_MAX)) {
            /* beyond this the bend only turns the segment further toward f, and m^power
             * would leave float range (inf - inf: NaN points). f / its largest component is
             * finite whatever m is (inv_l <= 1e12, |force| <= 1e12). */
            const float a = fmaxf(fabsf(f.x), fmaxf(fabsf(f.y), fabsf(f.z)));
            f = v3_scale(f, 1.0f / a);
            f = v3_scale(f, TREE_BEND_MAX / v3_len(f));
            m = TREE_BEND_MAX;
        }
        /* seed 001, eq. 16: b3 = F^1.8 (magnitude raised, direction kept), b2 = F (1/3)^1.8 */
        const float mag = m > 0.0f ? bend_pow(m, bend_power - 1.0f) : 0.0f;
        const v3 b3 = v3_scale(f, mag);
        const v3 b2 = v3_scale(b3, b2_scale);
        /* seed 001, eq. 17, read as Shrek's bend: P_i' = P_{i-1}' + |d| normalize(d + b_i),
         * d = P_i - P_{i-1}; segment lengths are kept, P0 and P1 stay */
        v3 d2 = v3_sub(Q[2], Q[1]), d3 = v3_sub(Q[3], Q[2]);
        const float l2 = t->seg12[i], l3 = t->rest_seg[i];
        v3 q2 = v3_add(Q[1], v3_scale(v3_norm_or(v3_add(d2, b2), v3_make(0, 0, 0)), l2));
        v3 q3 = v3_add(q2, v3_scale(v3_norm_or(v3_add(d3, b3), v3_make(0, 0, 0)), l3));
        Q[2] = q2;
        Q[3] = q3;
    }
    for (int k = 0; k < 4; ++k) {
        const v3 q = Q[k];
        P_out[k] = v3_make(origin.x + axis.x * q.x + side.x * q.y + W.x * q.z,
                           origin.y + axis.y * q.x + side.y * q.y + W.y * q.z,
                           origin.z + axis.z * q.x + side.z * q.y + W.z * q.z);
    }
    /* O of seed 001, eq. 8: the parent's direction, made perpendicular to the branch's start so
     * that S0 = L0 x O never degenerates (for alpha > 0 it is parallel to L0 x U) */
    *O_out = v3_scale(side, -1.0f);
}

/* Tests set these to 1 to run the wind step / the deformer one branch (one vertex) at a time;
 * which vector kernel runs otherwise is tsk_simd_force's (core/simd.h). */
extern int tree_wind_force_scalar;
extern int tree_mesh_force_scalar;

/* Makes t->inv_l for a length power (seed 001, eq. 14: power 1). */
void tree_set_length_power(struct tsk_tree* t, float power);

/* Puts the tree in its rest pose: points, orientations and the Sloan frames of branches with
 * children or leaves; sets at_rest. */
void tree_pose_rest(struct tsk_tree* t);

/* Weber–Penn ShapeRatio (shape 0..7). */
float tree_shape_ratio(int shape, float ratio);

#endif
