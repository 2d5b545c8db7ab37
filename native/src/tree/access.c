/* Reading a tree out into caller-owned arrays: branches, leaves (posed on their stems) and
 * branch tips for wind sampling. */
#include <string.h>

#include "tree_internal.h"

tsk_status tsk_tree_get_branches(const tsk_tree* t, const tsk_tree_branches* out) {
    if (t == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "tree", "is NULL");
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    const size_t n = t->n;
    if (out->parent) memcpy(out->parent, t->parent, n * sizeof(int32_t));
    if (out->level) memcpy(out->level, t->level, n * sizeof(int32_t));
    if (out->depth) memcpy(out->depth, t->depth, n * sizeof(int32_t));
    if (out->points) memcpy(out->points, t->cur, 12 * n * sizeof(float));
    if (out->rest) memcpy(out->rest, t->rest, 12 * n * sizeof(float));
    if (out->orient) memcpy(out->orient, t->cur_O, 3 * n * sizeof(float));
    if (out->length) memcpy(out->length, t->length, n * sizeof(float));
    for (size_t i = 0; i < n; ++i) {
        if (out->attach) {
            out->attach[3 * i] = t->attach_v[i];
            out->attach[3 * i + 1] = t->attach_theta[i];
            out->attach[3 * i + 2] = t->attach_alpha[i];
        }
        if (out->radius) {
            out->radius[2 * i] = t->shape[i].radius;
            out->radius[2 * i + 1] = t->shape[i].radius * (1.0f - t->shape[i].taper);
        }
    }
    return TSK_OK;
}

tsk_status tsk_tree_tip_positions(const tsk_tree* t, float* xyz) {
    if (t == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "tree", "is NULL");
    if (xyz == NULL && t->n > 0) return tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "is NULL");
    for (size_t i = 0; i < t->n; ++i) memcpy(xyz + 3 * i, t->cur + 12 * i + 9, 3 * sizeof(float));
    return TSK_OK;
}

/* Pose of leaf j on its stem's current curve: like a child stem (seed §4.2). */
static void leaf_pose(const tsk_tree* t, size_t j, v3* pos, v3* dir, v3* nrm, v3* wid) {
    const size_t p = (size_t)t->leaf_parent[j];
    v3 P[4];
    tree_load_points(t->cur, p, P);
    v3 U, V;
    const float* trig = t->leaf_trig + 4 * j; /* cos/sin of theta and alpha, made once */
    tree_attach_frame(P, &t->frames[p], t->leaf_attach[3 * j], trig[0], trig[1], pos, &U, &V);
    *dir = v3_comb(U, trig[2], V, trig[3]);
    *wid = v3_cross(U, V);
    *nrm = v3_norm_or(v3_cross(*dir, *wid), V);
}

tsk_status tsk_tree_get_leaves(const tsk_tree* t, float* position, float* direction, float* normal,
                               float* size, int32_t* parent) {
    if (t == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "tree", "is NULL");
    for (size_t j = 0; j < t->leaf_n; ++j) {
        v3 pos, dir, nrm, wid;
        leaf_pose(t, j, &pos, &dir, &nrm, &wid);
        if (position) tree_store3(position, j, pos);
        if (direction) tree_store3(direction, j, dir);
        if (normal) tree_store3(normal, j, nrm);
        if (size) size[2 * j] = t->leaf_size[2 * j], size[2 * j + 1] = t->leaf_size[2 * j + 1];
        if (parent) parent[j] = t->leaf_parent[j];
    }
    return TSK_OK;
}

/* Used by the mesh: the four corners of leaf card j (base-left, base-right, tip-right,
 * tip-left) and its normal. */
void tree_leaf_card(const tsk_tree* t, size_t j, v3* corners, v3* normal);
void tree_leaf_card(const tsk_tree* t, size_t j, v3* corners, v3* normal) {
    v3 pos, dir, nrm, wid;
    leaf_pose(t, j, &pos, &dir, &nrm, &wid);
    const float len = t->leaf_size[2 * j], hw = 0.5f * t->leaf_size[2 * j + 1];
    const v3 tip = v3_add(pos, v3_scale(dir, len));
    corners[0] = v3_sub(pos, v3_scale(wid, hw));
    corners[1] = v3_add(pos, v3_scale(wid, hw));
    corners[2] = v3_add(tip, v3_scale(wid, hw));
    corners[3] = v3_sub(tip, v3_scale(wid, hw));
    *normal = nrm;
}
