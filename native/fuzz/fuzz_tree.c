/* Fuzz target: tree definitions, wind steps and meshes. The bytes pick the default tree or
 * a preset, replace fields (every level's too) with edge values, then grow the tree
 * (max_branches at most 2000 and max_leaves at most 4000 unless the fuzzed value itself is
 * invalid: cost only), read branches and leaves, take wind steps with fuzzed forces in both
 * modes, measure the attachment gap, and mesh it with a fuzzed tsk_tree_mesh_def (sizes
 * capped at 12: cost), checking that every face index is a vertex, that the closed-form
 * edges join each corner to the next and every position is finite; small cages are also
 * smoothed once. */
#include "fuzz.h"
#include "tussock/tree.h"

int LLVMFuzzerInitialize(int* argc, char*** argv) {
    (void)argc;
    (void)argv;
    fz_init();
    return 0;
}

static void fuzz_def(fz* r, tsk_tree_def* d) {
    const int np = tsk_tree_preset_count();
    const int pick = fz_u8(r) % (np + 1);
    *d = tsk_default_tree_def();
    if (pick < np) (void)tsk_tree_preset(tsk_tree_preset_name(pick), d);
    d->seed = fz_u64(r);
    if (fz_u8(r) % 4 == 0) return;
    d->shape = fz_int(r, d->shape);
    d->base_size = fz_float(r, d->base_size);
    d->scale = fz_float(r, d->scale);
    d->scale_v = fz_float(r, d->scale_v);
    d->z_scale = fz_float(r, d->z_scale);
    d->z_scale_v = fz_float(r, d->z_scale_v);
    d->levels = fz_int(r, d->levels);
    d->ratio = fz_float(r, d->ratio);
    d->ratio_power = fz_float(r, d->ratio_power);
    d->lobes = fz_int(r, d->lobes);
    d->lobe_depth = fz_float(r, d->lobe_depth);
    d->flare = fz_float(r, d->flare);
    d->scale0 = fz_float(r, d->scale0);
    d->scale0_v = fz_float(r, d->scale0_v);
    d->base_splits = fz_int(r, d->base_splits);
    for (int l = 0; l < TSK_TREE_MAX_LEVELS; ++l) {
        tsk_tree_level_def* v = &d->level[l];
        if (fz_u8(r) & 1) continue;
        v->length = fz_float(r, v->length);
        v->length_v = fz_float(r, v->length_v);
        v->taper = fz_float(r, v->taper);
        v->seg_splits = fz_float(r, v->seg_splits);
        v->split_angle = fz_float(r, v->split_angle);
        v->split_angle_v = fz_float(r, v->split_angle_v);
        v->curve_res = fz_int(r, v->curve_res);
        v->curve = fz_float(r, v->curve);
        v->curve_back = fz_float(r, v->curve_back);
        v->curve_v = fz_float(r, v->curve_v);
        v->down_angle = fz_float(r, v->down_angle);
        v->down_angle_v = fz_float(r, v->down_angle_v);
        v->rotate = fz_float(r, v->rotate);
        v->rotate_v = fz_float(r, v->rotate_v);
        v->branches = fz_int(r, v->branches);
    }
    d->leaves = fz_int(r, d->leaves);
    d->leaf_shape = fz_int(r, d->leaf_shape);
    d->leaf_scale = fz_float(r, d->leaf_scale);
    d->leaf_scale_x = fz_float(r, d->leaf_scale_x);
    d->attraction_up = fz_float(r, d->attraction_up);
    d->prune_ratio = fz_float(r, d->prune_ratio);
    d->prune_width = fz_float(r, d->prune_width);
    d->prune_width_peak = fz_float(r, d->prune_width_peak);
    d->prune_power_low = fz_float(r, d->prune_power_low);
    d->prune_power_high = fz_float(r, d->prune_power_high);
    d->taper_power = fz_float(r, d->taper_power);
    d->lobe_fade = fz_float(r, d->lobe_fade);
    d->bulges = fz_int(r, d->bulges);
    d->bulge_depth = fz_float(r, d->bulge_depth);
    d->max_branches = (uint32_t)fz_int(r, 2000);
    d->max_leaves = (uint32_t)fz_int(r, 4000);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fz r = {data, size};
    tsk_tree_def d;
    fuzz_def(&r, &d);
    (void)tsk_tree_validate(&d);
    if (d.max_branches > 2000 && d.max_branches <= (1u << 22)) d.max_branches = 2000;
    if (d.max_leaves > 4000 && d.max_leaves <= (1u << 22)) d.max_leaves = 4000;
    tsk_tree* t = NULL;
    if (tsk_tree_create(&d, &t) != TSK_OK) {
        if (t != NULL) abort();
        fz_check_leaks("tree (refused)");
        return 0;
    }
    const size_t nb = tsk_tree_branch_count(t), nl = tsk_tree_leaf_count(t);
    if (nb < 1 || nb > d.max_branches || nl > d.max_leaves) abort();
    size_t sum = 0;
    for (int l = 0; l < TSK_TREE_MAX_LEVELS; ++l) sum += tsk_tree_level_branch_count(t, l);
    if (sum != nb) abort();
    int32_t* parent = malloc(nb * sizeof *parent);
    float* points = malloc(nb * 12 * sizeof *points);
    float* radius = malloc(nb * 2 * sizeof *radius);
    tsk_tree_branches br = {0};
    br.parent = parent;
    br.points = points;
    br.radius = radius;
    if (tsk_tree_get_branches(t, &br) != TSK_OK) abort();
    for (size_t i = 0; i < nb; ++i) {
        if (parent[i] >= (int32_t)i || parent[i] < -1) abort();
        for (int k = 0; k < 12; ++k)
            if (!isfinite(points[12 * i + k])) abort();
    }
    float* lp = malloc((nl + 1) * 3 * sizeof *lp);
    float* ls = malloc((nl + 1) * 2 * sizeof *ls);
    if (tsk_tree_get_leaves(t, lp, NULL, NULL, ls, NULL) != TSK_OK) abort();
    float* force = malloc(nb * 3 * sizeof *force);
    float* tips = malloc(nb * 3 * sizeof *tips);
    tsk_tree_wind_def wd = tsk_default_tree_wind_def();
    wd.mode = fz_u8(&r) % 3;
    wd.strength = fz_float(&r, wd.strength);
    wd.bend_power = fz_float(&r, wd.bend_power);
    wd.length_power = fz_float(&r, wd.length_power);
    const int steps = fz_u8(&r) % 4;
    for (int s = 0; s < steps; ++s) {
        for (size_t i = 0; i < nb * 3; ++i) force[i] = (i < 24) ? fz_float(&r, 2.0f) : 2.0f;
        if (tsk_tree_wind_step(t, force, &wd) == TSK_OK) {
            if (tsk_tree_tip_positions(t, tips) != TSK_OK) abort();
            for (size_t i = 0; i < nb * 3; ++i)
                if (!isfinite(tips[i])) abort();
        }
    }
    double gap = 0, metres = 0;
    (void)tsk_tree_attachment_gap(t, &gap, &metres);
    tsk_tree_mesh_def md = tsk_default_tree_mesh_def();
    for (int l = 0; l < TSK_TREE_MAX_LEVELS; ++l) {
        md.along[l] = fz_int(&r, md.along[l]);
        md.around[l] = fz_int(&r, md.around[l]);
        if (md.along[l] > 12) md.along[l] = 1 + md.along[l] % 12;
        if (md.around[l] > 12) md.around[l] = 3 + md.around[l] % 10;
    }
    md.leaves = fz_u8(&r) % 3;
    size_t nv = 0, nf = 0;
    if (tsk_tree_mesh_count(t, &md, &nv, &nf) == TSK_OK && nv <= 2000000) {
        int32_t* faces = malloc((nf + 1) * 4 * sizeof *faces);
        float* cuv = malloc((nf + 1) * 8 * sizeof *cuv);
        float* pos = malloc((nv + 1) * 3 * sizeof *pos);
        float* nor = malloc((nv + 1) * 3 * sizeof *nor);
        if (tsk_tree_mesh_topology(t, &md, faces, cuv) != TSK_OK) abort();
        for (size_t i = 0; i < nf * 4; ++i)
            if (faces[i] < 0 || (size_t)faces[i] >= nv) abort();
        /* the closed-form edges: each corner's edge joins it to the next corner */
        int32_t* edges = malloc((nf + 1) * 8 * sizeof *edges);
        int32_t* corner_edges = malloc((nf + 1) * 4 * sizeof *corner_edges);
        size_t ne = 0;
        if (tsk_tree_mesh_edges(t, &md, edges, corner_edges, &ne) != TSK_OK) abort();
        if (ne > nf * 4) abort();
        for (size_t c = 0; c < nf * 4; ++c) {
            const int32_t e = corner_edges[c];
            if (e < 0 || (size_t)e >= ne) abort();
            const int32_t a = faces[c], b = faces[c % 4 == 3 ? c - 3 : c + 1];
            if (!((edges[2 * e] == a && edges[2 * e + 1] == b) ||
                  (edges[2 * e] == b && edges[2 * e + 1] == a)))
                abort();
        }
        free(edges);
        free(corner_edges);
        if (tsk_tree_mesh_deform(t, &md, pos, nor) != TSK_OK) abort();
        for (size_t i = 0; i < nv * 3; ++i)
            if (!isfinite(pos[i])) abort();
        if (nf > 0 && nf <= 2000 && !md.leaves) {
            tsk_subdiv* sd = NULL;
            if (tsk_subdiv_create(faces, nf, nv, 1, &sd) == TSK_OK) {
                const size_t rv = tsk_subdiv_vertex_count(sd);
                float* ref = malloc(rv * 3 * sizeof *ref);
                if (tsk_subdiv_apply(sd, pos, ref) != TSK_OK) abort();
                free(ref);
                tsk_subdiv_destroy(sd);
            }
        }
        free(faces);
        free(cuv);
        free(pos);
        free(nor);
    }
    tsk_tree_reset_pose(t);
    free(parent);
    free(points);
    free(radius);
    free(lp);
    free(ls);
    free(force);
    free(tips);
    tsk_tree_destroy(t);
    fz_check_leaks("tree");
    return 0;
}
