/* Tests of the tree module: Weber–Penn counts and attachment, determinism, the deformer's
 * closed forms (seed 001 eq. 2–10), the wind step (eq. 14–17) against a sum-of-sines
 * ground truth written here, OpenSubdiv refinement, and refusal of bad parameters. */
#include "test.h"
#include "tussock/tree.h"
#include "core/simd.h"
#include "tree/tree_internal.h"

#include <stdint.h>
#include <time.h>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TSK_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define TSK_ASAN 1
#endif

#define PI 3.14159265358979323846

/* ---- helpers ---------------------------------------------------------------------------- */

typedef struct tree_data {
    size_t n;
    int32_t *parent, *level, *depth;
    float *points, *rest, *attach, *radius, *length, *orient;
} tree_data;

static tree_data read_tree(const tsk_tree* t) {
    tree_data d;
    d.n = tsk_tree_branch_count(t);
    d.parent = malloc(d.n * sizeof(int32_t) + 4);
    d.level = malloc(d.n * sizeof(int32_t) + 4);
    d.depth = malloc(d.n * sizeof(int32_t) + 4);
    d.points = malloc(12 * d.n * sizeof(float) + 4);
    d.rest = malloc(12 * d.n * sizeof(float) + 4);
    d.attach = malloc(3 * d.n * sizeof(float) + 4);
    d.radius = malloc(2 * d.n * sizeof(float) + 4);
    d.length = malloc(d.n * sizeof(float) + 4);
    d.orient = malloc(3 * d.n * sizeof(float) + 4);
    tsk_tree_branches b = {d.parent, d.level,  d.depth,  d.points, d.rest,
                           d.attach, d.radius, d.length, d.orient};
    CHECK(tsk_tree_get_branches(t, &b) == TSK_OK);
    return d;
}

static void free_tree_data(tree_data* d) {
    free(d->parent), free(d->level), free(d->depth), free(d->points), free(d->rest);
    free(d->attach), free(d->radius), free(d->length), free(d->orient);
}

/* Cubic Bézier in double, written independently of the library. */
static void bez(const float* P, double u, double* out) {
    const double s = 1 - u;
    const double w[4] = {s * s * s, 3 * s * s * u, 3 * s * u * u, u * u * u};
    for (int c = 0; c < 3; ++c)
        out[c] = w[0] * P[c] + w[1] * P[3 + c] + w[2] * P[6 + c] + w[3] * P[9 + c];
}
static void bez_d(const float* P, double u, double* out) {
    const double s = 1 - u;
    for (int c = 0; c < 3; ++c)
        out[c] = 3 * s * s * (P[3 + c] - P[c]) + 6 * s * u * (P[6 + c] - P[3 + c]) +
                 3 * u * u * (P[9 + c] - P[6 + c]);
}
static double dist3(const double* a, const double* b) {
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                (a[2] - b[2]) * (a[2] - b[2]));
}
static double len3(const double* a) { return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }
static double dot3(const double* a, const double* b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

#define fnv tsk_test_fnv
#define FNV_START TSK_TEST_FNV_START

/* Mesh positions and normals of a tree's current pose, hashed (FNV-1a from h). */
static uint64_t pose_hash(const tsk_tree* t, uint64_t h) {
    tsk_tree_mesh_def m = tsk_default_tree_mesh_def();
    size_t nv = 0, nf = 0;
    CHECK(tsk_tree_mesh_count(t, &m, &nv, &nf) == TSK_OK);
    float* pos = malloc(3 * nv * sizeof(float) + 4);
    float* nrm = malloc(3 * nv * sizeof(float) + 4);
    CHECK(tsk_tree_mesh_deform(t, &m, pos, nrm) == TSK_OK);
    h = fnv(pos, 3 * nv * sizeof(float), h);
    h = fnv(nrm, 3 * nv * sizeof(float), h);
    free(pos), free(nrm);
    return h;
}

/* Sum of sines, seed 001 eq. 14, as ground-truth wind (horizontal): F = sum D_i A_i/l
 * ((sin(D_i.(x,y) w_i + t phi_i) + 1)/2)^k. The /l is applied by the tree itself. The +1
 * keeps the base of the power non-negative (GPU Gems ch. 1 form). */
static void sines_force(const float* tips, size_t n, double t, float* force) {
    const double A[2] = {0.6, 0.3}, w[2] = {0.5, 1.3}, phi[2] = {1.1, 2.3}, k = 2.0;
    const double D[2][2] = {{1, 0}, {0.6, 0.8}};
    for (size_t i = 0; i < n; ++i) {
        double fx = 0, fy = 0;
        for (int s = 0; s < 2; ++s) {
            const double arg =
                (D[s][0] * tips[3 * i] + D[s][1] * tips[3 * i + 1]) * w[s] + t * phi[s];
            const double a = A[s] * pow((sin(arg) + 1) / 2, k);
            fx += D[s][0] * a;
            fy += D[s][1] * a;
        }
        force[3 * i] = (float)fx;
        force[3 * i + 1] = (float)fy;
        force[3 * i + 2] = 0;
    }
}

/* A def with every variation off, for closed-form checks. */
static tsk_tree_def plain_def(int levels) {
    tsk_tree_def d = tsk_default_tree_def();
    d.levels = levels;
    d.scale_v = 0, d.z_scale_v = 0, d.scale0_v = 0, d.base_splits = 0;
    d.attraction_up = 0;
    for (int l = 0; l < TSK_TREE_MAX_LEVELS; ++l) {
        d.level[l].length_v = 0, d.level[l].seg_splits = 0, d.level[l].curve_v = 0;
        d.level[l].down_angle_v = 0, d.level[l].rotate_v = 0;
    }
    return d;
}

/* ---- generator ---------------------------------------------------------------------------- */

static uint64_t tree_hash(const tsk_tree_def* def, int threads, int steps) {
    CHECK(tsk_set_threads(threads) == TSK_OK);
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(def, &t) == TSK_OK);
    if (!t) return 0;
    tree_data d = read_tree(t);
    uint64_t h = FNV_START;
    h = fnv(d.parent, d.n * 4, h);
    h = fnv(d.points, d.n * 48, h);
    h = fnv(d.attach, d.n * 12, h);
    h = fnv(d.radius, d.n * 8, h);
    /* wind with the sum of sines, then the mesh */
    float* tips = malloc(3 * d.n * sizeof(float));
    float* force = malloc(3 * d.n * sizeof(float));
    tsk_tree_wind_def w = tsk_default_tree_wind_def();
    for (int s = 0; s < steps; ++s) {
        CHECK(tsk_tree_tip_positions(t, tips) == TSK_OK);
        sines_force(tips, d.n, 0.04 * s, force);
        w.mode = s & 1;
        CHECK(tsk_tree_wind_step(t, force, &w) == TSK_OK);
    }
    h = pose_hash(t, h);
    free(tips), free(force);
    free_tree_data(&d);
    tsk_tree_destroy(t);
    tsk_set_threads(0);
    return h;
}

/* Stems of a generation are placed on all threads and the tree's arrays filled in parallel:
 * the same bytes whatever the thread count, for a tree with splits and leaves on many
 * chunks (black tupelo: 10,097 branches, 41,103 leaves) as for a small one. */
TEST(test_tree_same_seed_same_bytes_1_and_2_threads) {
    const char* presets[] = {"quaking_aspen", "black_tupelo"};
    for (int p = 0; p < 2; ++p) {
        tsk_tree_def def;
        CHECK(tsk_tree_preset(presets[p], &def) == TSK_OK);
        def.seed = 7;
        uint64_t a = tree_hash(&def, 1, 3), b = tree_hash(&def, 2, 3), c = tree_hash(&def, 2, 3);
        CHECK(a == b);
        CHECK(b == c);
        def.seed = 8;
        CHECK(tree_hash(&def, 2, 3) != a);
    }
}

/* Expected Weber–Penn counts, recomputed here in double from the formulas of the paper:
 * level 1: Branches1; a level-1 stem of length L1 on a trunk L0 carries
 * round(Branches2 (0.2 + 0.8 (L1/L0)/Length1)) children; deeper stems at offset o on a
 * parent of length Lp carry round(Branches3 (1 - 0.5 o/Lp)). */
static double shape_ratio(int shape, double r) {
    switch (shape) {
        case 0:
            return 0.2 + 0.8 * r;
        case 1:
            return 0.2 + 0.8 * sin(PI * r);
        case 2:
            return 0.2 + 0.8 * sin(0.5 * PI * r);
        case 3:
            return 1.0;
        case 4:
            return 0.5 + 0.5 * r;
        case 5:
            return r <= 0.7 ? r / 0.7 : (1 - r) / 0.3;
        case 6:
            return 1 - 0.8 * r;
        default:
            return r <= 0.7 ? 0.5 + 0.5 * r / 0.7 : 0.5 + 0.5 * (1 - r) / 0.3;
    }
}

TEST(test_tree_level_counts_follow_weber_penn) {
    tsk_tree_def def = plain_def(4);
    def.shape = 0;
    def.level[1].branches = 12, def.level[2].branches = 9, def.level[3].branches = 5;
    def.level[1].length = 0.35f, def.level[2].length = 0.45f, def.level[3].length = 0.5f;
    def.leaves = 4;
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&def, &t) == TSK_OK);
    if (!t) return;
    /* independent recursion in double */
    const double L0 = def.scale * def.level[0].length, b = def.base_size;
    long expect[4] = {1, 0, 0, 0}, expect_leaves = 0;
    const int n1 = def.level[1].branches;
    for (int i = 0; i < n1; ++i) {
        const double v1 = b + (1 - b) * (i + 0.5) / n1, o1 = v1 * L0;
        const double L1 = L0 * def.level[1].length * shape_ratio(0, (L0 - o1) / (L0 - b * L0));
        expect[1]++;
        const int n2 =
            (int)floor(def.level[2].branches * (0.2 + 0.8 * (L1 / L0) / def.level[1].length) + 0.5);
        for (int j = 0; j < n2; ++j) {
            const double o2 = (j + 0.5) / n2 * L1;
            const double L2 = def.level[2].length * (L1 - 0.6 * o2);
            expect[2]++;
            const int n3 = (int)floor(def.level[3].branches * (1 - 0.5 * o2 / L1) + 0.5);
            for (int k = 0; k < n3; ++k) {
                const double o3 = (k + 0.5) / n3 * L2;
                expect[3]++;
                expect_leaves += (long)floor(def.leaves * (0.5 + 0.5 * o3 / L2) + 0.5);
            }
        }
    }
    for (int l = 0; l < 4; ++l)
        CHECK_MSG((long)tsk_tree_level_branch_count(t, l) == expect[l], "level %d: %zu vs %ld", l,
                  tsk_tree_level_branch_count(t, l), expect[l]);
    CHECK_MSG((long)tsk_tree_leaf_count(t) == expect_leaves, "leaves %zu vs %ld",
              tsk_tree_leaf_count(t), expect_leaves);
    CHECK((long)tsk_tree_branch_count(t) == expect[0] + expect[1] + expect[2] + expect[3]);
    /* lengths of level-1 stems follow ShapeRatio */
    tree_data d = read_tree(t);
    for (size_t i = 0; i < d.n; ++i) {
        if (d.level[i] != 1) continue;
        const double v = d.attach[3 * i], o = v * L0;
        CHECK_NEAR(d.length[i], L0 * def.level[1].length * shape_ratio(0, (L0 - o) / (L0 - b * L0)),
                   1e-4 * L0);
        /* radius = r0 (L/L0)^RatioPower, capped by the trunk radius there */
        const double r0 = L0 * def.ratio * def.scale0;
        double r = r0 * pow(d.length[i] / L0, def.ratio_power);
        const double rp = r0 * (1 - def.level[0].taper * v);
        CHECK_NEAR(d.radius[2 * i], r < rp ? r : rp, 1e-5 * r0);
    }
    /* parents come first, depths never decrease */
    int ok = 1;
    for (size_t i = 1; i < d.n; ++i)
        ok &= d.parent[i] >= 0 && (size_t)d.parent[i] < i && d.depth[i] >= d.depth[i - 1] &&
              d.depth[i] == d.depth[d.parent[i]] + 1;
    CHECK(ok);
    free_tree_data(&d);
    tsk_tree_destroy(t);
}

TEST(test_tree_splits_add_clones_on_their_stem) {
    tsk_tree_def def = plain_def(2);
    def.base_splits = 2;
    def.level[1].seg_splits = 1.0f; /* one clone at every inner segment end */
    def.level[1].curve_res = 4;
    def.level[1].split_angle = 20;
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&def, &t) == TSK_OK);
    if (!t) return;
    tree_data d = read_tree(t);
    /* level 0: trunk + 2 base clones; every non-clone level-1 stem gets 3 clones */
    CHECK(tsk_tree_level_branch_count(t, 0) == 3);
    size_t originals = 0, clones = 0;
    for (size_t i = 0; i < d.n; ++i) {
        if (d.level[i] != 1) continue;
        if (d.level[d.parent[i]] == 1) {
            ++clones;
            CHECK_NEAR(d.attach[3 * i + 2], 20 * PI / 180, 1e-5);
        } else {
            ++originals;
        }
    }
    CHECK(clones == 3 * originals);
    free_tree_data(&d);
    tsk_tree_destroy(t);
}

TEST(test_tree_child_p0_on_parent_curve_at_v_with_alpha) {
    const char* presets[] = {"quaking_aspen", "ca_black_oak", "weeping_willow"};
    for (int p = 0; p < 3; ++p) {
        tsk_tree_def def;
        CHECK(tsk_tree_preset(presets[p], &def) == TSK_OK);
        if (p == 2) def.level[3].branches = 20, def.leaves = 3; /* keep the willow small */
        tsk_tree* t = NULL;
        CHECK(tsk_tree_create(&def, &t) == TSK_OK);
        if (!t) continue;
        tree_data d = read_tree(t);
        double worst = 0, worst_angle = 0;
        for (size_t i = 0; i < d.n; ++i) {
            if (d.parent[i] < 0) continue;
            const float* Pp = d.points + 12 * d.parent[i];
            double on[3], tan[3];
            bez(Pp, d.attach[3 * i], on);
            bez_d(Pp, d.attach[3 * i], tan);
            const double P0[3] = {d.points[12 * i], d.points[12 * i + 1], d.points[12 * i + 2]};
            const double g = dist3(P0, on);
            if (g > worst) worst = g;
            /* the start direction makes angle alpha with the parent's direction */
            const double dir[3] = {d.points[12 * i + 3] - P0[0], d.points[12 * i + 4] - P0[1],
                                   d.points[12 * i + 5] - P0[2]};
            if (len3(dir) < 1e-4) continue; /* pruned to nothing: no direction to measure */
            const double c = dot3(dir, tan) / (len3(dir) * len3(tan));
            const double ang = acos(c > 1 ? 1 : c < -1 ? -1 : c);
            const double err = fabs(ang - fabs((double)d.attach[3 * i + 2]));
            if (err > worst_angle) worst_angle = err;
        }
        CHECK_MSG(worst < 1e-5 * def.scale, "%s: P0 gap %g m", presets[p], worst);
        CHECK_MSG(worst_angle < 2e-3, "%s: alpha error %g rad", presets[p], worst_angle);
        double gap = -1;
        CHECK(tsk_tree_attachment_gap(t, &gap, NULL) == TSK_OK);
        CHECK(gap >= 0 && gap < 1e-3);
        free_tree_data(&d);
        tsk_tree_destroy(t);
    }
}

TEST(test_tree_leaves_sit_on_their_stems) {
    tsk_tree_def def = plain_def(2);
    def.leaves = 7;
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&def, &t) == TSK_OK);
    if (!t) return;
    tree_data d = read_tree(t);
    const size_t m = tsk_tree_leaf_count(t);
    CHECK(m > 0);
    float* pos = malloc(3 * m * sizeof(float));
    float* dir = malloc(3 * m * sizeof(float));
    float* nrm = malloc(3 * m * sizeof(float));
    float* size = malloc(2 * m * sizeof(float));
    int32_t* par = malloc(m * sizeof(int32_t));
    CHECK(tsk_tree_get_leaves(t, pos, dir, nrm, size, par) == TSK_OK);
    double worst = 1e9;
    int units = 1;
    for (size_t j = 0; j < m; ++j) {
        const float* P = d.points + 12 * par[j];
        double best = 1e9;
        for (int s = 0; s <= 2000; ++s) {
            double c[3];
            bez(P, s / 2000.0, c);
            const double p[3] = {pos[3 * j], pos[3 * j + 1], pos[3 * j + 2]};
            double dd = dist3(p, c);
            if (dd < best) best = dd;
        }
        if (j == 0 || best > worst) worst = best;
        const double dv[3] = {dir[3 * j], dir[3 * j + 1], dir[3 * j + 2]};
        const double nv[3] = {nrm[3 * j], nrm[3 * j + 1], nrm[3 * j + 2]};
        units &=
            fabs(len3(dv) - 1) < 1e-5 && fabs(len3(nv) - 1) < 1e-5 && fabs(dot3(dv, nv)) < 1e-5;
        units &= fabs(size[2 * j] - def.leaf_scale) < 1e-7 &&
                 fabs(size[2 * j + 1] - def.leaf_scale * def.leaf_scale_x) < 1e-7;
    }
    CHECK_MSG(worst < 2e-3, "leaf off its stem by %g m", worst);
    CHECK(units);
    free(pos), free(dir), free(nrm), free(size), free(par);
    free_tree_data(&d);
    tsk_tree_destroy(t);
}

TEST(test_tree_pruning_keeps_tips_in_envelope) {
    tsk_tree_def def = plain_def(2);
    def.shape = 3;
    def.level[1].length = 0.8f; /* long branches that stick out */
    def.prune_ratio = 1, def.prune_width = 0.25f, def.prune_width_peak = 0.5f;
    def.prune_power_low = 0.5f, def.prune_power_high = 0.5f;
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&def, &t) == TSK_OK);
    tsk_tree_def def0 = def;
    def0.prune_ratio = 0;
    tsk_tree* t0 = NULL;
    CHECK(tsk_tree_create(&def0, &t0) == TSK_OK);
    if (!t || !t0) return;
    tree_data d = read_tree(t), d0 = read_tree(t0);
    CHECK(d.n == d0.n);
    int shorter = 0, outside = 0;
    const double S = def.scale;
    for (size_t i = 0; i < d.n && i < d0.n; ++i) {
        if (d.level[i] != 1) continue;
        shorter += d.length[i] < d0.length[i] - 1e-6;
        const double x = d.points[12 * i + 9], y = d.points[12 * i + 10], z = d.points[12 * i + 11];
        const double ratio = (S - z) / (S * (1 - def.base_size));
        double env = ratio < 0.5 ? pow(ratio / 0.5, 0.5) : pow((1 - ratio) / 0.5, 0.5);
        /* pruning gives up after 24 shortenings by 0.85 (to 2.0 %) */
        const int in = ratio >= 0 && ratio <= 1 && sqrt(x * x + y * y) / S < def.prune_width * env;
        if (!in && d.length[i] > 0.021 * d0.length[i]) ++outside;
    }
    CHECK(shorter > 0);
    CHECK_MSG(outside == 0, "%d tips outside the envelope", outside);
    free_tree_data(&d), free_tree_data(&d0);
    tsk_tree_destroy(t), tsk_tree_destroy(t0);
}

TEST(test_tree_presets_all_grow) {
    for (int i = 0; i < tsk_tree_preset_count(); ++i) {
        tsk_tree_def def;
        CHECK(tsk_tree_preset(tsk_tree_preset_name(i), &def) == TSK_OK);
        CHECK(tsk_tree_validate(&def) == TSK_OK);
#ifdef TSK_ASAN
        if (def.levels > 3) continue;
#endif
        tsk_tree* t = NULL;
        CHECK_MSG(tsk_tree_create(&def, &t) == TSK_OK, "%s: %s", tsk_tree_preset_name(i),
                  tsk_last_error());
        CHECK(t && tsk_tree_level_branch_count(t, 1) > 0);
        tsk_tree_destroy(t);
    }
    CHECK(tsk_tree_preset_name(-1) == NULL && tsk_tree_preset_name(99) == NULL);
    tsk_tree_def def;
    CHECK_STATUS(tsk_tree_preset("baobab", &def), TSK_ERR_ARGUMENT, "baobab");
}

/* ---- deformer --------------------------------------------------------------------------- */

static tsk_branch_shape plain_shape(float r) {
    tsk_branch_shape s;
    memset(&s, 0, sizeof s);
    s.radius = r;
    s.taper_power = 1;
    return s;
}

TEST(test_deformer_straight_branch_is_exact_cylinder) {
    /* straight, evenly spaced Bézier along an oblique axis */
    const float d[3] = {0.3f, -0.5f, 0.8f}, o[3] = {1.0f, 2.0f, -0.5f};
    float P[12];
    for (int k = 0; k < 4; ++k)
        for (int c = 0; c < 3; ++c) P[3 * k + c] = o[c] + d[c] * (float)k;
    const float O[3] = {0, 0, 1};
    tsk_branch_shape s = plain_shape(0.25f);
    double worst = 0, worst_axial = 0;
    const double dl = sqrt(0.09 + 0.25 + 0.64);
    for (int i = 0; i <= 20; ++i) {
        for (int k = 0; k < 24; ++k) {
            float x[3];
            const float v = (float)i / 20, th = (float)(2 * PI * k / 24);
            tsk_branch_surface(P, O, &s, v, th, x, NULL);
            /* distance from the axis line o + d t */
            double w[3] = {x[0] - o[0], x[1] - o[1], x[2] - o[2]};
            const double t = (w[0] * d[0] + w[1] * d[1] + w[2] * d[2]) / (dl * dl);
            const double r[3] = {w[0] - t * d[0], w[1] - t * d[1], w[2] - t * d[2]};
            const double e = fabs(len3(r) - 0.25);
            if (e > worst) worst = e;
            const double ea = fabs(t - 3.0 * v); /* lies at parameter v along the axis */
            if (ea > worst_axial) worst_axial = ea;
        }
    }
    CHECK_MSG(worst < 1e-5, "radius error %g", worst);
    CHECK_MSG(worst_axial < 1e-5, "axial error %g", worst_axial);

    /* the same through a whole tree: one straight trunk, no taper/flare/lobes */
    tsk_tree_def def = plain_def(1);
    def.level[0].taper = 0, def.flare = 0, def.level[0].curve = 0, def.leaves = 0;
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&def, &t) == TSK_OK);
    if (!t) return;
    tsk_tree_mesh_def m = tsk_default_tree_mesh_def();
    size_t nv = 0, nf = 0;
    CHECK(tsk_tree_mesh_count(t, &m, &nv, &nf) == TSK_OK);
    CHECK(nv == (size_t)(m.along[0] + 1) * m.around[0] && nf == (size_t)m.along[0] * m.around[0]);
    float* pos = malloc(3 * nv * sizeof(float));
    float* nrm = malloc(3 * nv * sizeof(float));
    CHECK(tsk_tree_mesh_deform(t, &m, pos, nrm) == TSK_OK);
    const double r0 = def.scale * def.ratio;
    worst = 0;
    double worst_n = 0;
    for (size_t i = 0; i < nv; ++i) {
        const double e = fabs(hypot(pos[3 * i], pos[3 * i + 1]) - r0);
        if (e > worst) worst = e;
        /* normal = radial unit vector */
        const double h = hypot(pos[3 * i], pos[3 * i + 1]);
        const double en = fabs(nrm[3 * i] - pos[3 * i] / h) +
                          fabs(nrm[3 * i + 1] - pos[3 * i + 1] / h) + fabs(nrm[3 * i + 2]);
        if (en > worst_n) worst_n = en;
    }
    CHECK_MSG(worst < 1e-5, "mesh radius error %g", worst);
    CHECK_MSG(worst_n < 1e-5, "mesh normal error %g", worst_n);
    free(pos), free(nrm);
    tsk_tree_destroy(t);
}

TEST(test_deformer_radius_matches_eq_2_to_5) {
    tsk_branch_shape s = plain_shape(0.4f);
    s.taper = 0.8f, s.taper_power = 2.5f, s.flare = 0.33f, s.bulges = 5, s.bulge_depth = 0.07f;
    s.lobes = 7, s.lobe_depth = 0.2f, s.lobe_fade = 1;
    double worst = 0;
    for (int i = 0; i <= 50; ++i) {
        for (int k = 0; k < 13; ++k) {
            const double v = i / 50.0, th = 2 * PI * k / 13 + 0.1;
            const double taper = 0.4 * (1 - 0.8 * pow(v, 2.5)); /* eq. 2 */
            const double flare = 0.33 / 100 * pow(100, 1 - 8 * v) + 1; /* eq. 3 */
            const double bulge = 1 + 0.07 * sin(5 * 2 * PI * v); /* eq. 4 */
            const double lobe = 1 + 0.2 * sin(7 * th) * (1 - v * 1); /* eq. 5 */
            const double want = taper * flare * bulge * lobe;
            const double got = tsk_branch_radius(&s, (float)v, (float)th);
            const double e = fabs(got - want) / (fabs(want) + 1e-3);
            if (e > worst) worst = e;
        }
    }
    CHECK_MSG(worst < 2e-5, "relative radius error %g", worst);

    /* on a straight branch the surface's distance from the axis is that radius */
    float P[12] = {0, 0, 0, 0, 0, 1, 0, 0, 2, 0, 0, 3};
    const float O[3] = {1, 0, 0};
    worst = 0;
    for (int i = 0; i <= 40; ++i) {
        for (int k = 0; k < 17; ++k) {
            const float v = (float)i / 40, th = (float)(2 * PI * k / 17);
            float x[3];
            tsk_branch_surface(P, O, &s, v, th, x, NULL);
            const double want = fabs((double)tsk_branch_radius(&s, v, th));
            const double e = fabs(hypot(x[0], x[1]) - want);
            if (e > worst) worst = e;
        }
    }
    CHECK_MSG(worst < 1e-5, "surface radius error %g", worst);
}

/* Normals: unit, perpendicular to the finite-difference tangents, outward. */
TEST(test_deformer_normals_unit_perpendicular_outward) {
    float P[12] = {0, 0, 0, 0.1f, 0.2f, 1.0f, 0.6f, 0.1f, 1.9f, 1.4f, -0.3f, 2.5f};
    const float O[3] = {1, 0, 0};
    tsk_branch_shape s = plain_shape(0.2f);
    s.taper = 0.6f, s.flare = 0.5f, s.bulges = 3, s.bulge_depth = 0.05f;
    s.lobes = 5, s.lobe_depth = 0.1f, s.lobe_fade = 0.5f;
    double worst_unit = 0, worst_perp = 0;
    int inward = 0;
    const double h = 1e-3;
    for (int i = 1; i < 20; ++i) {
        for (int k = 0; k < 16; ++k) {
            const double v = i / 20.0, th = 2 * PI * k / 16 + 0.05;
            float x[3], n[3], a[3], b[3], c[3], e[3];
            tsk_branch_surface(P, O, &s, (float)v, (float)th, x, n);
            tsk_branch_surface(P, O, &s, (float)(v + h), (float)th, a, NULL);
            tsk_branch_surface(P, O, &s, (float)(v - h), (float)th, b, NULL);
            tsk_branch_surface(P, O, &s, (float)v, (float)(th + h), c, NULL);
            tsk_branch_surface(P, O, &s, (float)v, (float)(th - h), e, NULL);
            double tv[3], tt[3], nn[3] = {n[0], n[1], n[2]};
            for (int q = 0; q < 3; ++q)
                tv[q] = (a[q] - b[q]) / (2 * h), tt[q] = (c[q] - e[q]) / (2 * h);
            const double un = fabs(len3(nn) - 1);
            if (un > worst_unit) worst_unit = un;
            const double p1 = fabs(dot3(nn, tv)) / len3(tv), p2 = fabs(dot3(nn, tt)) / len3(tt);
            if (p1 > worst_perp) worst_perp = p1;
            if (p2 > worst_perp) worst_perp = p2;
            double centre[3];
            bez(P, v, centre);
            const double out[3] = {x[0] - centre[0], x[1] - centre[1], x[2] - centre[2]};
            inward += dot3(out, nn) <= 0;
        }
    }
    CHECK_MSG(worst_unit < 1e-5, "|n| - 1 = %g", worst_unit);
    CHECK_MSG(worst_perp < 5e-3, "n . t / |t| = %g", worst_perp);
    CHECK(inward == 0);
}

/* A bent branch of constant radius: every surface point is `radius` from the centreline. */
TEST(test_deformer_bent_branch_follows_bezier) {
    /* a gentle 60-degree arc */
    float P[12] = {0, 0, 0, 0, 0, 1.0f, 0.25f, 0, 1.9f, 0.85f, 0, 2.45f};
    const float O[3] = {0, 1, 0};
    tsk_branch_shape s = plain_shape(0.1f);
    double worst = 0;
    double curve[2001][3];
    for (int q = 0; q <= 2000; ++q) bez(P, q / 2000.0, curve[q]);
    for (int i = 0; i <= 20; ++i) {
        for (int k = 0; k < 12; ++k) {
            float x[3];
            tsk_branch_surface(P, O, &s, (float)i / 20, (float)(2 * PI * k / 12), x, NULL);
            const double p[3] = {x[0], x[1], x[2]};
            double best = 1e9;
            for (int q = 0; q <= 2000; ++q) {
                double dd = dist3(p, curve[q]);
                if (dd < best) best = dd;
            }
            const double e = fabs(best - 0.1) / 0.1;
            if (e > worst) worst = e;
        }
    }
    /* the de Casteljau blend of unit handles is not exactly unit on a bend: a few % */
    CHECK_MSG(worst < 0.05, "relative distance error %g", worst);
}

TEST(test_mesh_topology_faces_outward_and_uvs) {
    tsk_tree_def def;
    CHECK(tsk_tree_preset("quaking_aspen", &def) == TSK_OK);
    def.level[1].branches = 8, def.level[2].branches = 4, def.leaves = 3;
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&def, &t) == TSK_OK);
    if (!t) return;
    tsk_tree_mesh_def m = tsk_default_tree_mesh_def();
    size_t nv = 0, nf = 0;
    CHECK(tsk_tree_mesh_count(t, &m, &nv, &nf) == TSK_OK);
    size_t want_v = 4 * tsk_tree_leaf_count(t), want_f = tsk_tree_leaf_count(t);
    for (int l = 0; l < 4; ++l) {
        want_v += tsk_tree_level_branch_count(t, l) * (m.along[l] + 1) * m.around[l];
        want_f += tsk_tree_level_branch_count(t, l) * m.along[l] * m.around[l];
    }
    CHECK(nv == want_v && nf == want_f);
    int32_t* faces = malloc(4 * nf * sizeof(int32_t));
    float* uv = malloc(8 * nf * sizeof(float));
    float* pos = malloc(3 * nv * sizeof(float));
    float* nrm = malloc(3 * nv * sizeof(float));
    CHECK(tsk_tree_mesh_topology(t, &m, faces, uv) == TSK_OK);
    CHECK(tsk_tree_mesh_deform(t, &m, pos, nrm) == TSK_OK);
    int in_range = 1;
    size_t agree = 0, checked = 0;
    for (size_t f = 0; f < nf; ++f) {
        for (int c = 0; c < 4; ++c)
            in_range &= faces[4 * f + c] >= 0 && (size_t)faces[4 * f + c] < nv;
        if (!in_range) break;
        const float *a = pos + 3 * faces[4 * f], *b = pos + 3 * faces[4 * f + 1],
                    *c3 = pos + 3 * faces[4 * f + 3];
        const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const double e2[3] = {c3[0] - a[0], c3[1] - a[1], c3[2] - a[2]};
        const double fn[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                              e1[0] * e2[1] - e1[1] * e2[0]};
        if (len3(fn) < 1e-12) continue; /* collapsed tip quads */
        const float* n0 = nrm + 3 * faces[4 * f];
        const double nd[3] = {n0[0], n0[1], n0[2]};
        ++checked;
        agree += dot3(fn, nd) > 0;
    }
    CHECK(in_range);
    CHECK_MSG(agree >= checked * 99 / 100 && checked > 0, "%zu of %zu faces agree", agree, checked);
    /* u runs 0..1 around, v grows along */
    int uv_ok = 1;
    for (size_t f = 0; f < nf; ++f)
        uv_ok &= uv[8 * f] >= 0 && uv[8 * f] <= 1 && uv[8 * f + 2] <= 1.0f;
    CHECK(uv_ok);
    free(faces), free(uv), free(pos), free(nrm);
    tsk_tree_destroy(t);
}

/* The closed-form edges of the tree mesh are exactly the edges tsk_mesh_edges derives from
 * its faces (as Blender would): as many, each corner's edge joins that corner and the next,
 * and every edge is some corner's. Over presets with leaves and uneven meshing. */
TEST(test_mesh_edges_closed_form_equal_derived_edges) {
    const char* names[] = {"quaking_aspen", "ca_black_oak", "weeping_willow"};
    for (int p = 0; p < 3; ++p) {
        tsk_tree_def def;
        CHECK(tsk_tree_preset(names[p], &def) == TSK_OK);
        def.leaves = p == 1 ? 0 : 5;
        if (def.levels > 3) def.levels = 3;
        tsk_tree* t = NULL;
        CHECK(tsk_tree_create(&def, &t) == TSK_OK);
        if (!t) return;
        tsk_tree_mesh_def m = tsk_default_tree_mesh_def();
        m.along[1] = 3 + p, m.around[0] = 7, m.around[2] = 3;
        size_t nv = 0, nf = 0;
        CHECK(tsk_tree_mesh_count(t, &m, &nv, &nf) == TSK_OK);
        const size_t n = 4 * nf;
        int32_t* faces = malloc(n * sizeof(int32_t));
        int32_t* e1 = malloc(2 * n * sizeof(int32_t));
        int32_t* c1 = malloc(n * sizeof(int32_t));
        int32_t* e2 = malloc(2 * n * sizeof(int32_t));
        int32_t* c2 = malloc(n * sizeof(int32_t));
        uint8_t* used = calloc(n + 1, 1);
        size_t ne1 = 0, ne2 = 0;
        CHECK(tsk_tree_mesh_topology(t, &m, faces, NULL) == TSK_OK);
        CHECK(tsk_tree_mesh_edges(t, &m, e1, c1, &ne1) == TSK_OK);
        CHECK(tsk_mesh_edges(faces, nf, 4, (int32_t)nv, e2, c2, &ne2) == TSK_OK);
        CHECK_MSG(ne1 == ne2 && ne1 > 0, "%s: %zu closed-form edges, %zu derived", names[p], ne1,
                  ne2);
        size_t bad = 0;
        for (size_t c = 0; c < n && ne1 == ne2; ++c) {
            const int32_t a = faces[c], b = faces[c % 4 == 3 ? c - 3 : c + 1];
            const int32_t e = c1[c];
            if (e < 0 || (size_t)e >= ne1) {
                ++bad;
                continue;
            }
            used[e] = 1;
            const int32_t x = e1[2 * e], y = e1[2 * e + 1];
            bad += !((x == a && y == b) || (x == b && y == a));
        }
        size_t unused = 0;
        for (size_t e = 0; e < ne1; ++e) unused += !used[e];
        CHECK_MSG(bad == 0 && unused == 0, "%s: %zu corners with a wrong edge, %zu edges unused",
                  names[p], bad, unused);
        /* written in parallel, branch by branch: the same bytes with one thread */
        int32_t* faces1 = malloc(n * sizeof(int32_t));
        float* uv1 = malloc(2 * n * sizeof(float));
        float* uv2 = malloc(2 * n * sizeof(float));
        size_t ne3 = 0;
        CHECK(tsk_tree_mesh_topology(t, &m, faces, uv2) == TSK_OK);
        CHECK(tsk_set_threads(1) == TSK_OK);
        CHECK(tsk_tree_mesh_topology(t, &m, faces1, uv1) == TSK_OK);
        CHECK(tsk_tree_mesh_edges(t, &m, e2, c2, &ne3) == TSK_OK);
        tsk_set_threads(0);
        CHECK(ne3 == ne1 && memcmp(e1, e2, 2 * ne1 * sizeof(int32_t)) == 0 &&
              memcmp(c1, c2, n * sizeof(int32_t)) == 0);
        CHECK(memcmp(faces, faces1, n * sizeof(int32_t)) == 0 &&
              memcmp(uv1, uv2, 2 * n * sizeof(float)) == 0);
        free(faces1), free(uv1), free(uv2);
        /* misuse is refused, not written through */
        size_t count = 99;
        CHECK(tsk_tree_mesh_edges(t, &m, NULL, c1, &count) == TSK_ERR_ARGUMENT && count == 0);
        CHECK(tsk_tree_mesh_edges(t, &m, e1, c1, NULL) == TSK_ERR_ARGUMENT);
        m.around[1] = 2;
        CHECK(tsk_tree_mesh_edges(t, &m, e1, c1, &count) == TSK_ERR_ARGUMENT);
        free(faces), free(e1), free(c1), free(e2), free(c2), free(used);
        tsk_tree_destroy(t);
    }
}

/* The 4-vertex SSE deformer and the one-vertex path give the same bytes. */
TEST(test_mesh_simd_path_equals_scalar_path) {
    tsk_tree_def def;
    CHECK(tsk_tree_preset("ca_black_oak", &def) == TSK_OK);
    def.level[2].branches = 10;
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&def, &t) == TSK_OK);
    if (!t) return;
    tsk_tree_mesh_def m = tsk_default_tree_mesh_def();
    m.around[1] = 7; /* a ring that is not a multiple of 4 */
    size_t nv = 0, nf = 0;
    CHECK(tsk_tree_mesh_count(t, &m, &nv, &nf) == TSK_OK);
    float *p[2], *n[2];
    for (int path = 0; path < 2; ++path) {
        tree_mesh_force_scalar = path;
        p[path] = malloc(3 * nv * sizeof(float));
        n[path] = malloc(3 * nv * sizeof(float));
        CHECK(tsk_tree_mesh_deform(t, &m, p[path], n[path]) == TSK_OK);
    }
    tree_mesh_force_scalar = 0;
    CHECK(memcmp(p[0], p[1], 3 * nv * sizeof(float)) == 0);
    CHECK(memcmp(n[0], n[1], 3 * nv * sizeof(float)) == 0);
    for (int path = 0; path < 2; ++path) free(p[path]), free(n[path]);
    tsk_tree_destroy(t);
}

/* ---- wind ---------------------------------------------------------------------------------- */

/* The black tupelo preset with fewer twigs: four levels, a few hundred branches. */
static tsk_tree_def small_tupelo(void) {
    tsk_tree_def def;
    CHECK(tsk_tree_preset("black_tupelo", &def) == TSK_OK);
    def.level[2].branches = 6, def.level[3].branches = 4;
    return def;
}

TEST(test_wind_zero_force_keeps_rest_pose_exactly) {
    const tsk_tree_def def = small_tupelo();
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&def, &t) == TSK_OK);
    if (!t) return;
    tree_data d = read_tree(t);
    float* zero = calloc(3 * d.n, sizeof(float));
    float* now = malloc(12 * d.n * sizeof(float));
    tsk_tree_wind_def w = tsk_default_tree_wind_def();
    for (int mode = 0; mode < 2; ++mode) {
        w.mode = mode;
        for (int s = 0; s < 3; ++s) CHECK(tsk_tree_wind_step(t, zero, &w) == TSK_OK);
        tsk_tree_branches b = {0};
        b.points = now;
        CHECK(tsk_tree_get_branches(t, &b) == TSK_OK);
        CHECK(memcmp(now, d.rest, 12 * d.n * sizeof(float)) == 0);
        CHECK(memcmp(now, d.points, 12 * d.n * sizeof(float)) == 0);
    }
    free(zero), free(now);
    free_tree_data(&d);
    tsk_tree_destroy(t);
}

static void check_bend(float length_power, float bend_power) {
    tsk_tree_def def = plain_def(1);
    def.leaves = 0, def.level[0].curve = 30; /* a bent trunk */
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&def, &t) == TSK_OK);
    if (!t) return;
    tree_data d = read_tree(t);
    const float F[3] = {1.5f, -0.7f, 0.2f};
    tsk_tree_wind_def w = tsk_default_tree_wind_def();
    w.length_power = length_power, w.bend_power = bend_power;
    CHECK(tsk_tree_wind_step(t, F, &w) == TSK_OK);
    float now[12];
    tsk_tree_branches b = {0};
    b.points = now;
    CHECK(tsk_tree_get_branches(t, &b) == TSK_OK);
    const float* R = d.rest;
    double d2[3], d3[3], l2, l3, P2[3], P3[3];
    for (int c = 0; c < 3; ++c) d2[c] = R[6 + c] - R[3 + c], d3[c] = R[9 + c] - R[6 + c];
    l2 = len3(d2), l3 = len3(d3);
    const double div = pow(l3, length_power);
    const double f[3] = {F[0] / div, F[1] / div, F[2] / div};
    const double m = pow(len3(f), bend_power - 1), s2 = pow(1.0 / 3.0, bend_power);
    double n2[3], n3[3];
    for (int c = 0; c < 3; ++c) n2[c] = d2[c] + s2 * m * f[c];
    const double ln2 = len3(n2);
    for (int c = 0; c < 3; ++c) P2[c] = R[3 + c] + l2 * n2[c] / ln2;
    for (int c = 0; c < 3; ++c) n3[c] = d3[c] + m * f[c];
    const double ln3 = len3(n3);
    for (int c = 0; c < 3; ++c) P3[c] = P2[c] + l3 * n3[c] / ln3;
    for (int c = 0; c < 3; ++c) {
        CHECK_NEAR(now[c], R[c], 1e-6);
        CHECK_NEAR(now[3 + c], R[3 + c], 1e-5);
        CHECK_NEAR(now[6 + c], P2[c], 1e-4);
        CHECK_NEAR(now[9 + c], P3[c], 1e-4);
    }
    /* the tip moved downwind */
    const double moved[3] = {now[9] - R[9], now[10] - R[10], now[11] - R[11]};
    const double Fd[3] = {F[0], F[1], F[2]};
    CHECK(dot3(moved, Fd) > 0.01);
    free_tree_data(&d);
    tsk_tree_destroy(t);
}

/* Eq. 16–17 on a single trunk, recomputed here: P0, P1 stay; P2' = P1 + |d2| n(d2 + b2),
 * P3' = P2' + |d3| n(d3 + b3), b3 = f |f|^(p-1), b2 = (1/3)^p b3, f = F / l^e,
 * l = |P3 - P2| (seed: p = 1.8, e = 1). */
TEST(test_wind_bend_matches_eq_16_17) {
    check_bend(1.0f, 1.8f);
    check_bend(0.0f, 1.5f);
    check_bend(2.0f, 2.2f);
}

TEST(test_wind_children_stay_attached) {
    tsk_tree_def def;
    CHECK(tsk_tree_preset("quaking_aspen", &def) == TSK_OK);
    def.level[1].branches = 20, def.level[2].branches = 10;
    tsk_tree *lag = NULL, *ex = NULL;
    CHECK(tsk_tree_create(&def, &lag) == TSK_OK);
    CHECK(tsk_tree_create(&def, &ex) == TSK_OK);
    if (!lag || !ex) return;
    const size_t n = tsk_tree_branch_count(ex);
    float* tips = malloc(3 * n * sizeof(float));
    float* force = malloc(3 * n * sizeof(float));
    tsk_tree_wind_def wl = tsk_default_tree_wind_def(), we = wl;
    we.mode = TSK_TREE_WIND_EXACT;
    double gap_lag = 0, gap_ex = 0, worst_ex = 0;
    for (int s = 0; s < 8; ++s) {
        CHECK(tsk_tree_tip_positions(ex, tips) == TSK_OK);
        sines_force(tips, n, 0.3 * s, force);
        CHECK(tsk_tree_wind_step(ex, force, &we) == TSK_OK);
        CHECK(tsk_tree_wind_step(lag, force, &wl) == TSK_OK);
        CHECK(tsk_tree_attachment_gap(ex, &gap_ex, NULL) == TSK_OK);
        CHECK(tsk_tree_attachment_gap(lag, &gap_lag, NULL) == TSK_OK);
        if (gap_ex > worst_ex) worst_ex = gap_ex;
    }
    /* exact mode: every child's P0 on its moved parent's curve (< 1 % of parent radius) */
    CHECK_MSG(worst_ex < 0.01, "exact gap %g", worst_ex);
    /* lagged (seed) mode: the lag error is measurable */
    CHECK_MSG(gap_lag > worst_ex, "lagged gap %g vs exact %g", gap_lag, worst_ex);
    /* independently: P0 of each child on the parent's moved curve at v (exact mode) */
    tree_data d = read_tree(ex);
    double worst = 0;
    for (size_t i = 0; i < d.n; ++i) {
        if (d.parent[i] < 0) continue;
        double on[3];
        bez(d.points + 12 * d.parent[i], d.attach[3 * i], on);
        const double p0[3] = {d.points[12 * i], d.points[12 * i + 1], d.points[12 * i + 2]};
        const double g = dist3(p0, on);
        if (g > worst) worst = g;
    }
    CHECK_MSG(worst < 1e-5 * def.scale, "P0 off the moved parent by %g m", worst);
    /* a constant force: after as many lagged steps as depths, lagged == exact, bit for bit */
    for (size_t i = 0; i < 3 * n; ++i) force[i] = (i % 3 == 0) ? 0.8f : 0.0f;
    tsk_tree_reset_pose(ex);
    tsk_tree_reset_pose(lag);
    CHECK(tsk_tree_wind_step(ex, force, &we) == TSK_OK);
    int depths = 0;
    for (size_t i = 0; i < d.n; ++i) depths = d.depth[i] + 1 > depths ? d.depth[i] + 1 : depths;
    for (int s = 0; s < depths; ++s) CHECK(tsk_tree_wind_step(lag, force, &wl) == TSK_OK);
    tree_data a = read_tree(ex), b = read_tree(lag);
    CHECK(memcmp(a.points, b.points, 12 * n * sizeof(float)) == 0);
    free_tree_data(&a), free_tree_data(&b), free_tree_data(&d);
    free(tips), free(force);
    tsk_tree_destroy(lag), tsk_tree_destroy(ex);
}

/* The wind step's paths: 0 one branch at a time, 1 the portable kernel, 2 at most AVX2, 3 the
 * widest the CPU has (core/simd.h). */
enum { WIND_PATHS = 4 };
static const char* const WIND_PATH_NAMES[WIND_PATHS] = {"one branch", "portable", "at most AVX2",
                                                        "best"};
static void set_wind_path(int path) {
    static const int simd[WIND_PATHS] = {TSK_SIMD_BEST, TSK_SIMD_PORTABLE, TSK_SIMD_AT_MOST_AVX2,
                                         TSK_SIMD_BEST};
    tree_wind_force_scalar = path == 0;
    tsk_simd_force(simd[path]);
}

/* The strongest wind the step accepts (|F| 1e6, strength 1e6, bend power 4, length power 3)
 * on every path (each kernel the CPU has, one branch at a time), and a force on a branch only
 * a micrometre long: every point stays finite and each moved segment keeps its rest length (found by
 * fuzz_tree: the bend vector overflowed to infinity and its normalisation gave NaN). */
TEST(test_wind_at_the_limits_stays_finite) {
    const tsk_tree_def def = small_tupelo();
    for (int path = 0; path < WIND_PATHS; ++path)
        for (int mode = 0; mode < 2; ++mode) {
            set_wind_path(path);
            tsk_tree* t = NULL;
            CHECK(tsk_tree_create(&def, &t) == TSK_OK);
            if (!t) continue;
            const size_t n = tsk_tree_branch_count(t);
            float* force = malloc(3 * n * sizeof(float));
            for (size_t i = 0; i < 3 * n; ++i) force[i] = (i % 3 == 1) ? -1e6f : 1e6f;
            tsk_tree_wind_def w = tsk_default_tree_wind_def();
            w.mode = mode, w.strength = 1e6f, w.bend_power = 4.0f, w.length_power = 3.0f;
            for (int s = 0; s < 2; ++s) CHECK(tsk_tree_wind_step(t, force, &w) == TSK_OK);
            tree_data d = read_tree(t);
            int finite = 1;
            double worst = 0;
            for (size_t i = 0; i < n; ++i) {
                for (int k = 0; k < 12; ++k) finite &= isfinite(d.points[12 * i + k]) != 0;
                /* |P3 - P2| is kept (seed 001, eq. 17) */
                double a[3], b[3];
                for (int k = 0; k < 3; ++k)
                    a[k] = d.points[12 * i + 9 + k] - d.points[12 * i + 6 + k],
                    b[k] = d.rest[12 * i + 9 + k] - d.rest[12 * i + 6 + k];
                const double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
                const double lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
                if (fabs(la - lb) > worst) worst = fabs(la - lb);
            }
            CHECK_MSG(finite, "path %d mode %d: a point is not finite", path, mode);
            CHECK_MSG(worst < 1e-4, "path %d mode %d: a segment changed length by %g m", path, mode,
                      worst);
            free_tree_data(&d);
            free(force);
            tsk_tree_destroy(t);
        }
    set_wind_path(3);
}

/* A reset skips its work when the tree is already at rest (new, or reset since its last
 * step): the pose it leaves, and the steps after it, are the same bytes either way, in both
 * wind modes; a refused step leaves the pose as it was. */
TEST(test_wind_reset_of_a_resting_tree_changes_nothing) {
    const tsk_tree_def def = small_tupelo();
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&def, &t) == TSK_OK);
    if (!t) return;
    const size_t n = tsk_tree_branch_count(t);
    float* tips = malloc(3 * n * sizeof(float));
    float* force = malloc(3 * n * sizeof(float));
    CHECK(tsk_tree_tip_positions(t, tips) == TSK_OK);
    sines_force(tips, n, 0.7, force);
    const uint64_t rest = pose_hash(t, FNV_START);
    tsk_tree_reset_pose(t); /* new tree: nothing to do */
    CHECK(pose_hash(t, FNV_START) == rest);
    for (int mode = 0; mode < 2; ++mode) {
        tsk_tree_wind_def w = tsk_default_tree_wind_def();
        w.mode = mode;
        CHECK(tsk_tree_wind_step(t, force, &w) == TSK_OK);
        const uint64_t bent = pose_hash(t, FNV_START);
        CHECK_MSG(bent != rest, "mode %d: the wind moved nothing", mode);
        force[5] = NAN;
        CHECK_STATUS(tsk_tree_wind_step(t, force, &w), TSK_ERR_ARGUMENT, "force");
        force[5] = 0.25f;
        CHECK(pose_hash(t, FNV_START) == bent);
        tsk_tree_reset_pose(t);
        CHECK(pose_hash(t, FNV_START) == rest);
        tsk_tree_reset_pose(t); /* already at rest */
        CHECK(pose_hash(t, FNV_START) == rest);
        CHECK(tsk_tree_wind_step(t, force, &w) == TSK_OK);
        const uint64_t again = pose_hash(t, FNV_START);
        tsk_tree_reset_pose(t);
        tsk_tree* fresh = NULL; /* the same step from a new tree */
        CHECK(tsk_tree_create(&def, &fresh) == TSK_OK);
        if (fresh) {
            CHECK(tsk_tree_wind_step(fresh, force, &w) == TSK_OK);
            CHECK_MSG(pose_hash(fresh, FNV_START) == again, "mode %d: a step after a reset differs",
                      mode);
            tsk_tree_destroy(fresh);
        }
    }
    free(tips), free(force);
    tsk_tree_destroy(t);
}

/* Every path of the wind step (the AVX-512, AVX2 and portable kernels the CPU has, one branch
 * at a time), with 1 and 2 threads, gives one fixed set of bytes per mode. */
/* The pose's golden hash per wind mode (see tsk_test_fnv). */
static const uint64_t WIND_GOLDEN[2] = {0x0e9d709821543b6cull, 0xc1e403cedda2c387ull};

TEST(test_wind_simd_path_equals_scalar_path) {
    tsk_tree_def def;
    CHECK(tsk_tree_preset("black_tupelo", &def) == TSK_OK);
    def.level[2].branches = 7, def.level[3].branches = 5;
    for (int mode = 0; mode < 2; ++mode)
        for (int path = 0; path < WIND_PATHS; ++path)
            for (int threads = 1; threads <= 2; ++threads) {
                set_wind_path(path);
                CHECK(tsk_set_threads(threads) == TSK_OK);
                tsk_tree* t = NULL;
                CHECK(tsk_tree_create(&def, &t) == TSK_OK);
                if (!t) continue;
                const size_t n = tsk_tree_branch_count(t);
                float* tips = malloc(3 * n * sizeof(float));
                float* force = malloc(3 * n * sizeof(float));
                tsk_tree_wind_def w = tsk_default_tree_wind_def();
                w.mode = mode;
                for (int s = 0; s < 4; ++s) {
                    CHECK(tsk_tree_tip_positions(t, tips) == TSK_OK);
                    sines_force(tips, n, 0.25 * s, force);
                    if (s == 2)
                        for (size_t i = 0; i < 3 * n; i += 7) force[i] = 0; /* mixed lanes */
                    CHECK(tsk_tree_wind_step(t, force, &w) == TSK_OK);
                }
                tree_data d = read_tree(t);
                const uint64_t h = fnv(d.points, 48 * n, fnv(d.orient, 12 * n, FNV_START));
                CHECK_MSG(h == WIND_GOLDEN[mode],
                          "mode %d, %s path (kernel %d), %d threads: the wind's bytes changed: "
                          "hash %#018llx",
                          mode, WIND_PATH_NAMES[path], tsk_simd_isa(), threads,
                          (unsigned long long)h);
                free_tree_data(&d);
                free(tips), free(force);
                tsk_tree_destroy(t);
            }
    set_wind_path(3);
    tsk_set_threads(0);
}

TEST(test_wind_rejects_bad_force) {
    tsk_tree_def def = plain_def(1);
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&def, &t) == TSK_OK);
    if (!t) return;
    float F[3] = {0, NAN, 0};
    CHECK_STATUS(tsk_tree_wind_step(t, F, NULL), TSK_ERR_ARGUMENT, "force");
    CHECK_STATUS(tsk_tree_wind_step(t, NULL, NULL), TSK_ERR_ARGUMENT, "force");
    tsk_tree_wind_def w = tsk_default_tree_wind_def();
    w.mode = 5;
    F[1] = 0;
    CHECK_STATUS(tsk_tree_wind_step(t, F, &w), TSK_ERR_ARGUMENT, "wind.mode");
    tsk_tree_destroy(t);
}

/* ---- bad parameters ----------------------------------------------------------------------- */

TEST(test_tree_bad_parameters_are_named) {
    tsk_tree* t = NULL;
    tsk_tree_def d = tsk_default_tree_def();
    d.scale = NAN;
    CHECK_STATUS(tsk_tree_create(&d, &t), TSK_ERR_ARGUMENT, "scale");
    d = tsk_default_tree_def();
    d.levels = -1;
    CHECK_STATUS(tsk_tree_create(&d, &t), TSK_ERR_ARGUMENT, "levels");
    d.levels = 5;
    CHECK_STATUS(tsk_tree_create(&d, &t), TSK_ERR_ARGUMENT, "levels");
    d = tsk_default_tree_def();
    d.level[1].branches = 1000000;
    CHECK_STATUS(tsk_tree_create(&d, &t), TSK_ERR_LIMIT, "level[1].branches");
    d = tsk_default_tree_def();
    d.level[1].down_angle = INFINITY;
    CHECK_STATUS(tsk_tree_create(&d, &t), TSK_ERR_ARGUMENT, "level[1].down_angle");
    d = tsk_default_tree_def();
    d.level[2].length_v = NAN; /* unused level, still refused */
    CHECK_STATUS(tsk_tree_create(&d, &t), TSK_ERR_ARGUMENT, "level[2].length_v");
    d = tsk_default_tree_def();
    d.level[0].curve_res = 0;
    CHECK_STATUS(tsk_tree_create(&d, &t), TSK_ERR_ARGUMENT, "level[0].curve_res");
    d = tsk_default_tree_def();
    d.leaves = -3;
    CHECK_STATUS(tsk_tree_create(&d, &t), TSK_ERR_ARGUMENT, "leaves");
    d = tsk_default_tree_def();
    d.ratio = -0.1f;
    CHECK_STATUS(tsk_tree_create(&d, &t), TSK_ERR_ARGUMENT, "ratio");
    d = tsk_default_tree_def();
    d.max_branches = 0;
    CHECK_STATUS(tsk_tree_create(&d, &t), TSK_ERR_LIMIT, "max_branches");
    CHECK_STATUS(tsk_tree_create(NULL, &t), TSK_ERR_ARGUMENT, "def");
    CHECK(t == NULL);
    /* many branches per level: refused at max_branches, quickly and without the memory */
    d = tsk_default_tree_def();
    d.levels = 4;
    d.level[1].branches = 10000, d.level[2].branches = 10000, d.level[3].branches = 10000;
    d.max_branches = 50000;
    const size_t before = tsk_allocated_bytes();
    clock_t c0 = clock();
    CHECK_STATUS(tsk_tree_create(&d, &t), TSK_ERR_LIMIT, "max_branches");
    CHECK((double)(clock() - c0) / CLOCKS_PER_SEC < 5.0);
    CHECK(tsk_allocated_bytes() == before);
    CHECK(t == NULL);
}

/* Random parameters, in and out of range: every call returns a status with a message or a
 * tree whose wind step and mesh are finite. */
TEST(test_tree_random_parameters_never_crash) {
#ifdef TSK_ASAN
    const int trials = 60;
#else
    const int trials = 200;
#endif
    int made = 0, refused = 0, finite = 1, messages = 1;
    for (int k = 0; k < trials; ++k) {
#define R(lo, hi) ((lo) + ((hi) - (lo)) * tsk_rand01(99, (uint64_t)k, __LINE__, 0))
        tsk_tree_def d = tsk_default_tree_def();
        d.seed = (uint64_t)k;
        d.shape = (int)R(-1, 9);
        d.levels = (int)R(0, 6);
        d.base_size = R(-0.2f, 1.1f);
        d.scale = R(-1, 40), d.scale_v = R(0, 10);
        d.ratio = R(-0.01f, 0.1f), d.ratio_power = R(0, 3);
        d.flare = R(0, 2), d.lobes = (int)R(0, 8), d.lobe_depth = R(0, 0.5f);
        d.base_splits = (int)R(0, 4), d.attraction_up = R(-4, 4);
        d.leaves = (int)R(-2, 20), d.leaf_scale = R(0, 0.5f);
        d.prune_ratio = R(0, 1), d.prune_width = R(0.05f, 1);
        d.bulges = (int)R(0, 6), d.bulge_depth = R(0, 0.2f), d.taper_power = R(0.2f, 3);
        for (int l = 0; l < 4; ++l) {
            tsk_tree_level_def* L = &d.level[l];
            L->length = R(-0.1f, 1.2f), L->length_v = R(0, 0.3f), L->taper = R(0, 1.1f);
            L->seg_splits = R(0, 1.5f), L->split_angle = R(-40, 60), L->split_angle_v = R(0, 20);
            L->curve_res = (int)R(0, 12), L->curve = R(-200, 200), L->curve_back = R(-100, 100);
            L->curve_v = R(-100, 200), L->down_angle = R(-90, 120), L->down_angle_v = R(-60, 60);
            L->rotate = R(-200, 200), L->rotate_v = R(0, 90), L->branches = (int)R(-2, 25);
        }
        if (k % 17 == 0) d.level[1].curve = NAN;
        d.max_branches = 20000, d.max_leaves = 40000;
#undef R
        tsk_tree* t = NULL;
        tsk_clear_error();
        tsk_status st = tsk_tree_create(&d, &t);
        if (st != TSK_OK) {
            ++refused;
            messages &= t == NULL && tsk_last_error()[0] != '\0';
            continue;
        }
        ++made;
        const size_t n = tsk_tree_branch_count(t);
        float* f = malloc(3 * n * sizeof(float));
        for (size_t i = 0; i < 3 * n; ++i) f[i] = (i % 3 == 1) ? 0.7f : 0.2f;
        tsk_tree_wind_def w = tsk_default_tree_wind_def();
        w.mode = k & 1;
        finite &= tsk_tree_wind_step(t, f, &w) == TSK_OK;
        tsk_tree_mesh_def m = tsk_default_tree_mesh_def();
        size_t nv = 0, nf = 0;
        finite &= tsk_tree_mesh_count(t, &m, &nv, &nf) == TSK_OK;
        float* pos = malloc(3 * nv * sizeof(float) + 4);
        float* nrm = malloc(3 * nv * sizeof(float) + 4);
        finite &= tsk_tree_mesh_deform(t, &m, pos, nrm) == TSK_OK;
        for (size_t i = 0; i < 3 * nv; ++i) finite &= isfinite(pos[i]) && isfinite(nrm[i]);
        free(f), free(pos), free(nrm);
        tsk_tree_destroy(t);
    }
    CHECK_MSG(made > 5 && refused > 5, "made %d, refused %d", made, refused);
    CHECK(finite);
    CHECK(messages);
}

/* ---- OpenSubdiv ----------------------------------------------------------------------------- */

static const float cube_v[8 * 3] = {-1, -1, -1, 1, -1, -1, 1, 1, -1, -1, 1, -1,
                                    -1, -1, 1,  1, -1, 1,  1, 1, 1,  -1, 1, 1};
static const int32_t cube_f[6 * 4] = {0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4,
                                      1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7};

static int has_point(const float* p, size_t n, double x, double y, double z, double tol) {
    for (size_t i = 0; i < n; ++i)
        if (fabs(p[3 * i] - x) < tol && fabs(p[3 * i + 1] - y) < tol &&
            fabs(p[3 * i + 2] - z) < tol)
            return 1;
    return 0;
}

TEST(test_subdiv_cube_once_gives_catmull_clark_points) {
    tsk_subdiv* sd = NULL;
    CHECK(tsk_subdiv_create(cube_f, 6, 8, 1, &sd) == TSK_OK);
    if (!sd) return;
    CHECK(tsk_subdiv_vertex_count(sd) == 26);
    CHECK(tsk_subdiv_face_count(sd) == 24);
    float out[26 * 3];
    CHECK(tsk_subdiv_apply(sd, cube_v, out) == TSK_OK);
    /* Catmull–Clark by hand: face points at face centres (±1,0,0)..., edge points
     * (e.g. (0.75, 0.75, 0)), corners (Q + 2R + (n-3)S)/n = ±5/9 */
    int faces_ok = 1, edges_ok = 1, corners_ok = 1;
    for (int a = 0; a < 3; ++a)
        for (int s = -1; s <= 1; s += 2) {
            double p[3] = {0, 0, 0};
            p[a] = s;
            faces_ok &= has_point(out, 26, p[0], p[1], p[2], 1e-6);
            double e[3] = {0.75 * s, 0.75 * s, 0.75 * s};
            e[a] = 0;
            edges_ok &= has_point(out, 26, e[0], e[1], e[2], 1e-6);
        }
    for (int i = 0; i < 8; ++i)
        corners_ok &= has_point(out, 26, cube_v[3 * i] * 5.0 / 9, cube_v[3 * i + 1] * 5.0 / 9,
                                cube_v[3 * i + 2] * 5.0 / 9, 1e-6);
    CHECK(faces_ok);
    CHECK(edges_ok);
    CHECK(corners_ok);
    int32_t q[24 * 4];
    CHECK(tsk_subdiv_faces(sd, q) == TSK_OK);
    int range = 1;
    for (int i = 0; i < 96; ++i) range &= q[i] >= 0 && q[i] < 26;
    CHECK(range);
    tsk_subdiv_destroy(sd);
}

/* One Catmull–Clark step of a closed quad mesh, by the textbook rules, for ground truth:
 * face points, edge points (ends + adjacent face points)/4, vertex points
 * (Q + 2R + (n-3)V)/n. Writes all new points into out (count returned). */
static int catmull_clark_by_hand(const float* v, int nv, const int32_t* f, int nf, double* out) {
    double fp[16][3];
    int edges[64][4], ne = 0; /* a, b, face1, face2 */
    for (int i = 0; i < nf; ++i) {
        for (int c = 0; c < 3; ++c) {
            fp[i][c] = 0;
            for (int k = 0; k < 4; ++k) fp[i][c] += v[3 * f[4 * i + k] + c] / 4.0;
        }
        for (int k = 0; k < 4; ++k) {
            int a = f[4 * i + k], b = f[4 * i + (k + 1) % 4], found = -1;
            for (int e = 0; e < ne; ++e)
                if ((edges[e][0] == a && edges[e][1] == b) ||
                    (edges[e][0] == b && edges[e][1] == a))
                    found = e;
            if (found < 0)
                edges[ne][0] = a, edges[ne][1] = b, edges[ne][2] = i, edges[ne][3] = -1, ++ne;
            else edges[found][3] = i;
        }
    }
    int n = 0;
    for (int i = 0; i < nf; ++i, ++n)
        for (int c = 0; c < 3; ++c) out[3 * n + c] = fp[i][c];
    for (int e = 0; e < ne; ++e, ++n)
        for (int c = 0; c < 3; ++c)
            out[3 * n + c] = (v[3 * edges[e][0] + c] + v[3 * edges[e][1] + c] + fp[edges[e][2]][c] +
                              fp[edges[e][3]][c]) /
                             4.0;
    for (int p = 0; p < nv; ++p, ++n) {
        double Q[3] = {0, 0, 0}, R[3] = {0, 0, 0};
        int nfaces = 0, nedges = 0;
        for (int i = 0; i < nf; ++i)
            for (int k = 0; k < 4; ++k)
                if (f[4 * i + k] == p) {
                    for (int c = 0; c < 3; ++c) Q[c] += fp[i][c];
                    ++nfaces;
                }
        for (int e = 0; e < ne; ++e)
            if (edges[e][0] == p || edges[e][1] == p) {
                for (int c = 0; c < 3; ++c)
                    R[c] += (v[3 * edges[e][0] + c] + v[3 * edges[e][1] + c]) / 2.0;
                ++nedges;
            }
        const double val = nedges;
        for (int c = 0; c < 3; ++c)
            out[3 * n + c] = (Q[c] / nfaces + 2 * R[c] / nedges + (val - 3) * v[3 * p + c]) / val;
    }
    return n;
}

TEST(test_subdiv_stencils_on_moved_cage_equal_refining_it) {
    /* stencils built once for the cube's topology, applied to a moved cage, give the
     * Catmull–Clark points of the moved cage computed by hand */
    {
        tsk_subdiv* sd1 = NULL;
        CHECK(tsk_subdiv_create(cube_f, 6, 8, 1, &sd1) == TSK_OK);
        float mv[24];
        for (int i = 0; i < 24; ++i)
            mv[i] = cube_v[i] * (1.0f + 0.1f * (float)(i % 5)) + 0.3f * (float)(i % 3);
        float got[26 * 3];
        double want[26 * 3];
        CHECK(sd1 && tsk_subdiv_apply(sd1, cube_v, got) == TSK_OK); /* built on the rest cube */
        CHECK(sd1 && tsk_subdiv_apply(sd1, mv, got) == TSK_OK); /* applied to the moved one */
        CHECK(catmull_clark_by_hand(mv, 8, cube_f, 6, want) == 26);
        int all = 1;
        for (int k = 0; k < 26; ++k)
            all &= has_point(got, 26, want[3 * k], want[3 * k + 1], want[3 * k + 2], 1e-5);
        CHECK(all);
        tsk_subdiv_destroy(sd1);
    }
    /* stencils built once for the cube, applied to a moved cage == a refiner built for the
     * moved cage (topology only is shared, so this checks the stencils are linear in the cage) */
    tsk_subdiv* sd = NULL;
    CHECK(tsk_subdiv_create(cube_f, 6, 8, 2, &sd) == TSK_OK);
    if (!sd) return;
    float moved[24];
    for (int i = 0; i < 24; ++i)
        moved[i] = cube_v[i] * (1.0f + 0.1f * (float)(i % 5)) + 0.3f * (float)(i % 3);
    const size_t n = tsk_subdiv_vertex_count(sd);
    CHECK(n == 98);
    float* a = malloc(3 * n * sizeof(float));
    float* b = malloc(3 * n * sizeof(float));
    float* base = malloc(3 * n * sizeof(float));
    CHECK(tsk_subdiv_apply(sd, moved, a) == TSK_OK);
    tsk_subdiv* sd2 = NULL;
    CHECK(tsk_subdiv_create(cube_f, 6, 8, 2, &sd2) == TSK_OK);
    CHECK(sd2 && tsk_subdiv_apply(sd2, moved, b) == TSK_OK);
    CHECK(memcmp(a, b, 3 * n * sizeof(float)) == 0);
    /* linearity: refine(base + delta) - refine(base) depends on delta alone (translation) */
    float shifted[24];
    for (int i = 0; i < 24; ++i) shifted[i] = moved[i] + (i % 3 == 2 ? 2.0f : 0.0f);
    CHECK(tsk_subdiv_apply(sd, shifted, base) == TSK_OK);
    double worst = 0;
    for (size_t i = 0; i < n; ++i) {
        worst = fmax(worst, fabs(base[3 * i] - a[3 * i]));
        worst = fmax(worst, fabs(base[3 * i + 2] - a[3 * i + 2] - 2.0));
    }
    CHECK(worst < 1e-5);
    free(a), free(b), free(base);
    tsk_subdiv_destroy(sd);
    tsk_subdiv_destroy(sd2);
    CHECK_STATUS(tsk_subdiv_create(cube_f, 6, 8, 9, &sd), TSK_ERR_ARGUMENT, "levels");
    int32_t bad[24];
    memcpy(bad, cube_f, sizeof bad);
    bad[5] = 99;
    CHECK_STATUS(tsk_subdiv_create(bad, 6, 8, 1, &sd), TSK_ERR_ARGUMENT, "quads");
}

TEST(test_tree_smoothed_mesh_through_stencils) {
    tsk_tree_def def = plain_def(2);
    def.level[1].branches = 5, def.leaves = 0;
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&def, &t) == TSK_OK);
    if (!t) return;
    tsk_tree_mesh_def m = tsk_default_tree_mesh_def();
    m.leaves = 0;
    size_t nv = 0, nf = 0;
    CHECK(tsk_tree_mesh_count(t, &m, &nv, &nf) == TSK_OK);
    int32_t* faces = malloc(4 * nf * sizeof(int32_t));
    float* pos = malloc(3 * nv * sizeof(float));
    CHECK(tsk_tree_mesh_topology(t, &m, faces, NULL) == TSK_OK);
    CHECK(tsk_tree_mesh_deform(t, &m, pos, NULL) == TSK_OK);
    tsk_subdiv* sd = NULL;
    CHECK(tsk_subdiv_create(faces, nf, nv, 1, &sd) == TSK_OK);
    if (sd) {
        const size_t rn = tsk_subdiv_vertex_count(sd), rf = tsk_subdiv_face_count(sd);
        CHECK(rf == 4 * nf);
        float* rp = malloc(3 * rn * sizeof(float));
        float* rnrm = malloc(3 * rn * sizeof(float));
        int32_t* rq = malloc(4 * rf * sizeof(int32_t));
        CHECK(tsk_subdiv_apply(sd, pos, rp) == TSK_OK);
        CHECK(tsk_subdiv_faces(sd, rq) == TSK_OK);
        CHECK(tsk_quad_normals(rp, rn, rq, rf, rnrm) == TSK_OK);
        /* the smoothed trunk stays within the cage's radius band */
        int finite = 1, unit = 1;
        for (size_t i = 0; i < rn; ++i) {
            finite &= isfinite(rp[3 * i]) && isfinite(rp[3 * i + 1]) && isfinite(rp[3 * i + 2]);
            const double nn[3] = {rnrm[3 * i], rnrm[3 * i + 1], rnrm[3 * i + 2]};
            unit &= fabs(len3(nn) - 1) < 1e-4;
        }
        CHECK(finite);
        CHECK(unit);
        free(rp), free(rnrm), free(rq);
        tsk_subdiv_destroy(sd);
    }
    free(faces), free(pos);
    tsk_tree_destroy(t);
}

/* Growing past the memory budget stops with TSK_ERR_LIMIT (naming max_branches) instead of
 * allocating; a mesh whose buffers exceed it is refused by tsk_tree_mesh_count. */
TEST(test_tree_and_mesh_over_memory_budget_are_refused) {
    tsk_tree_def d = tsk_default_tree_def();
    tsk_tree* t = NULL;
    CHECK(tsk_tree_create(&d, &t) == TSK_OK);
    tsk_tree_mesh_def md = tsk_default_tree_mesh_def();
    size_t nv = 0, nf = 0;
    CHECK(tsk_tree_mesh_count(t, &md, &nv, &nf) == TSK_OK);
    const size_t need = nv * 24 + nf * 48;
    tsk_set_memory_budget(need - 1);
    CHECK_STATUS(tsk_tree_mesh_count(t, &md, &nv, &nf), TSK_ERR_LIMIT, "mesh: needs about");
    tsk_set_memory_budget(need);
    CHECK(tsk_tree_mesh_count(t, &md, &nv, &nf) == TSK_OK);
    tsk_tree_destroy(t);
    t = NULL;
    tsk_set_memory_budget(4096); /* not even the first 256 stems fit */
    CHECK_STATUS(tsk_tree_create(&d, &t), TSK_ERR_LIMIT, "max_branches: needs about");
    CHECK(t == NULL);
    tsk_set_memory_budget(0);
    CHECK(tsk_allocated_bytes() == 0);
}

TEST_MAIN(TEST_ENTRY(test_tree_and_mesh_over_memory_budget_are_refused),
          TEST_ENTRY(test_tree_same_seed_same_bytes_1_and_2_threads),
          TEST_ENTRY(test_tree_level_counts_follow_weber_penn),
          TEST_ENTRY(test_tree_splits_add_clones_on_their_stem),
          TEST_ENTRY(test_tree_child_p0_on_parent_curve_at_v_with_alpha),
          TEST_ENTRY(test_tree_leaves_sit_on_their_stems),
          TEST_ENTRY(test_tree_pruning_keeps_tips_in_envelope),
          TEST_ENTRY(test_tree_presets_all_grow),
          TEST_ENTRY(test_deformer_straight_branch_is_exact_cylinder),
          TEST_ENTRY(test_deformer_radius_matches_eq_2_to_5),
          TEST_ENTRY(test_deformer_normals_unit_perpendicular_outward),
          TEST_ENTRY(test_deformer_bent_branch_follows_bezier),
          TEST_ENTRY(test_mesh_topology_faces_outward_and_uvs),
          TEST_ENTRY(test_mesh_edges_closed_form_equal_derived_edges),
          TEST_ENTRY(test_mesh_simd_path_equals_scalar_path),
          TEST_ENTRY(test_wind_zero_force_keeps_rest_pose_exactly),
          TEST_ENTRY(test_wind_bend_matches_eq_16_17), TEST_ENTRY(test_wind_children_stay_attached),
          TEST_ENTRY(test_wind_reset_of_a_resting_tree_changes_nothing),
          TEST_ENTRY(test_wind_at_the_limits_stays_finite),
          TEST_ENTRY(test_wind_simd_path_equals_scalar_path),
          TEST_ENTRY(test_wind_rejects_bad_force), TEST_ENTRY(test_tree_bad_parameters_are_named),
          TEST_ENTRY(test_tree_random_parameters_never_crash),
          TEST_NEEDS(test_subdiv_cube_once_gives_catmull_clark_points, OpenSubdiv),
          TEST_NEEDS(test_subdiv_stencils_on_moved_cage_equal_refining_it, OpenSubdiv),
          TEST_NEEDS(test_tree_smoothed_mesh_through_stencils, OpenSubdiv))
