/* Posing a branch on its parent (seed 001 §4.2) and bending it (§4.3, eq. 15–17). The
 * generator, the wind step and the attachment checks all go through these functions, so a
 * zero wind reproduces the generated rest pose bit for bit. */
#include "tree_internal.h"

void tree_attach_frame(const v3* P, v3 O, float v, float theta, v3* origin, v3* U, v3* V) {
    *origin = bez_point(P, v);
    /* U: the parent's direction at v (derivative of its Bézier) */
    v3 chord = v3_norm_or(v3_sub(P[3], P[0]), v3_make(0, 0, 1));
    *U = v3_norm_or(bez_deriv(P, v), chord);
    /* the point of the parent's de Casteljau sweep surface at (v, theta) gives the radial
     * direction the branch grows toward (seed eq. 1 and 9 with unit radius) */
    sloan_frames f;
    sloan_build(P, O, &f);
    v3 S, T;
    sloan_at(&f, v, &S, &T);
    v3 D = v3_comb(S, sinf(theta), T, cosf(theta));
    D = v3_sub(D, v3_scale(*U, v3_dot(D, *U)));
    *V = v3_norm_or(D, v3_any_perp(*U));
}

void tree_pose_branch(const struct tsk_tree* t, size_t i, const v3* Pp, v3 Op, v3 force,
                      float bend_power, v3* P_out, v3* O_out) {
    v3 origin, U, V;
    if (t->parent[i] < 0) {
        origin = tree_load3(t->root, i);
        U = v3_make(0, 0, 1);
        V = v3_make(1, 0, 0);
    } else {
        tree_attach_frame(Pp, Op, t->attach_v[i], t->attach_theta[i], &origin, &U, &V);
    }
    /* rotate "down" by alpha in the plane of U and V (seed Fig. 4) */
    const float ca = cosf(t->attach_alpha[i]), sa = sinf(t->attach_alpha[i]);
    const v3 axis = v3_comb(U, ca, V, sa);
    const v3 side = v3_comb(U, -sa, V, ca);
    const v3 W = v3_cross(U, V);
    v3 Q[4];
    Q[0] = v3_make(0, 0, 0);
    for (int k = 0; k < 3; ++k)
        Q[k + 1] = v3_make(t->local[9 * i + 3 * k], t->local[9 * i + 3 * k + 1],
                           t->local[9 * i + 3 * k + 2]);
    if (force.x != 0.0f || force.y != 0.0f || force.z != 0.0f) {
        /* seed eq. 14: the force is divided by the length l between control points */
        const float inv_l = t->rest_seg[i] > 1e-12f ? 1.0f / t->rest_seg[i] : 0.0f;
        v3 f = v3_make(v3_dot(force, axis), v3_dot(force, side), v3_dot(force, W));
        f = v3_scale(f, inv_l);
        const float m = v3_len(f);
        /* seed eq. 16: b3 = F^1.8 (magnitude raised, direction kept), b2 = F (1/3)^1.8 */
        const float mag = m > 0.0f ? powf(m, bend_power - 1.0f) : 0.0f;
        const v3 b3 = v3_scale(f, mag);
        const v3 b2 = v3_scale(b3, powf(1.0f / 3.0f, bend_power));
        /* seed eq. 17, read as Shrek's bend: P_i' = P_{i-1}' + |d| normalize(d + b_i),
         * d = P_i - P_{i-1}; segment lengths are kept, P0 and P1 stay */
        v3 d2 = v3_sub(Q[2], Q[1]), d3 = v3_sub(Q[3], Q[2]);
        const float l2 = v3_len(d2), l3 = v3_len(d3);
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
    /* O of seed eq. 8: the parent's direction, made perpendicular to the branch's start so
     * that S0 = L0 x O never degenerates (for alpha > 0 it is parallel to L0 x U) */
    *O_out = v3_scale(side, -1.0f);
}
