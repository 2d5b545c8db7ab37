/* Tree benchmarks (DESIGN.md): tree_wind_262k and tree_wind_65k, million branch updates per
 * second of the seed 001 wind step (eq. 15–17, attach-to-parent); tree_mesh, million deformed
 * vertices (with normals) per second of the seed 001 deformer; tree_mesh_edges, the mesh's
 * edges in closed form against derived from its faces; plus generation time per preset and
 * the OpenSubdiv stencil application. Medians over repeats. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime in bench.h */
#include "bench.h"
#include "tussock/tree.h"

#include <math.h>
#include <stdint.h>
#include <time.h>

/* A minimal sum of sines (seed 001 eq. 14, two waves) to give the branches a force. */
static void sines(const float* tips, size_t n, double t, float* force) {
    for (size_t i = 0; i < n; ++i) {
        const double x = tips[3 * i], y = tips[3 * i + 1];
        const double a = 0.6 * pow((sin(0.5 * x + 1.1 * t) + 1) / 2, 2);
        const double b = 0.3 * pow((sin((0.6 * x + 0.8 * y) * 1.3 + 2.3 * t) + 1) / 2, 2);
        force[3 * i] = (float)(a + 0.6 * b);
        force[3 * i + 1] = (float)(0.8 * b);
        force[3 * i + 2] = 0.0f;
    }
}

/* A 4-level tree with about `target` branches: cylindrical shape so that every level-1 stem
 * carries exactly level[2].branches children; level[3].branches chosen to reach the target. */
static tsk_tree* big_tree(size_t target, int b12) {
    tsk_tree_def d = tsk_default_tree_def();
    d.levels = 4, d.shape = 3, d.leaves = 0, d.max_branches = TSK_TREE_HARD_LIMIT;
    d.level[1].branches = b12, d.level[2].branches = b12;
    const double per3 = 0.75 * b12 * b12;
    int b3 = (int)floor(((double)target - 1 - b12 - (double)b12 * b12) / per3 + 0.5);
    tsk_tree* best = NULL;
    size_t best_err = SIZE_MAX;
    for (int k = b3 - 1; k <= b3 + 1; ++k) {
        d.level[3].branches = k;
        tsk_tree* t = NULL;
        if (tsk_tree_create(&d, &t) != TSK_OK) continue;
        size_t n = tsk_tree_branch_count(t);
        size_t err = n > target ? n - target : target - n;
        if (err < best_err) {
            tsk_tree_destroy(best);
            best = t, best_err = err;
        } else {
            tsk_tree_destroy(t);
        }
    }
    return best;
}

static void bench_wind(const char* name, size_t target, int b12, int repeats) {
    tsk_tree* t = big_tree(target, b12);
    if (t == NULL) {
        fprintf(stderr, "%s: %s\n", name, tsk_last_error());
        return;
    }
    const size_t n = tsk_tree_branch_count(t);
    float* tips = malloc(3 * n * sizeof(float));
    float* force = malloc(3 * n * sizeof(float));
    tsk_tree_tip_positions(t, tips);
    sines(tips, n, 0.0, force);
    /* mode 0 lagged, 1 exact, 2 lagged on one thread (what one core does, for scaling) */
    const int threads = tsk_get_threads();
    for (int mode = 0; mode < 3; ++mode) {
        tsk_tree_wind_def w = tsk_default_tree_wind_def();
        w.mode = mode == 1 ? TSK_TREE_WIND_EXACT : TSK_TREE_WIND_LAGGED;
        tsk_set_threads(mode == 2 ? 1 : threads);
        double samples[64];
        tsk_tree_wind_step(t, force, &w); /* warm up */
        const clock_t c0 = clock();
        for (int r = 0; r < repeats; ++r) {
            double t0 = bench_now_s();
            tsk_tree_wind_step(t, force, &w);
            samples[r] = bench_now_s() - t0;
        }
        /* CPU time of all threads per branch: what one core costs, whatever the load */
        const double cpu_ns = (double)(clock() - c0) / CLOCKS_PER_SEC / ((double)repeats * n) * 1e9;
        const double med = bench_median(samples, repeats);
        char params[256], full[96];
        snprintf(params, sizeof params,
                 "\"branches\": %zu, \"threads\": %d, \"mode\": \"%s\", \"repeats\": %d, "
                 "\"ms_per_step\": %.3f, \"cpu_ns_per_branch\": %.1f",
                 n, tsk_get_threads(), mode == 1 ? "exact" : "lagged", repeats, med * 1e3, cpu_ns);
        snprintf(full, sizeof full, "%s%s", name, mode == 1 ? "_exact" : mode == 2 ? "_1t" : "");
        bench_emit(full, (double)n / med * 1e-6, "million branch updates per second", params, NULL);
    }
    tsk_set_threads(0);
    free(tips), free(force);
    tsk_tree_destroy(t);
}

/* The black tupelo preset grown, or NULL with the error printed for benchmark `name`. */
static tsk_tree* tupelo(const char* name) {
    tsk_tree_def d;
    tsk_tree_preset("black_tupelo", &d);
    tsk_tree* t = NULL;
    if (tsk_tree_create(&d, &t) != TSK_OK) {
        fprintf(stderr, "%s: %s\n", name, tsk_last_error());
        return NULL;
    }
    return t;
}

static void bench_mesh(int repeats) {
    tsk_tree* t = tupelo("tree_mesh");
    if (t == NULL) return;
    tsk_tree_mesh_def m = tsk_default_tree_mesh_def();
    m.leaves = 0; /* branches only: leaf cards are a copy, not the deformer */
    size_t nv = 0, nf = 0;
    tsk_tree_mesh_count(t, &m, &nv, &nf);
    float* pos = malloc(3 * nv * sizeof(float));
    float* nrm = malloc(3 * nv * sizeof(float));
    double samples[64], med = 0;
    char params[256];
    /* all threads, then one thread (what one core does, for scaling) */
    const int threads = tsk_get_threads();
    for (int pass = 0; pass < 2; ++pass) {
        tsk_set_threads(pass ? 1 : threads);
        tsk_tree_mesh_deform(t, &m, pos, nrm);
        const clock_t c0 = clock();
        for (int r = 0; r < repeats; ++r) {
            double t0 = bench_now_s();
            tsk_tree_mesh_deform(t, &m, pos, nrm);
            samples[r] = bench_now_s() - t0;
        }
        const double cpu_ns =
            (double)(clock() - c0) / CLOCKS_PER_SEC / ((double)repeats * nv) * 1e9;
        med = bench_median(samples, repeats);
        snprintf(
            params, sizeof params,
            "\"preset\": \"black_tupelo\", \"branches\": %zu, \"vertices\": %zu, \"threads\": %d, "
            "\"normals\": true, \"ms_per_frame\": %.3f, \"cpu_ns_per_vertex\": %.1f",
            tsk_tree_branch_count(t), nv, tsk_get_threads(), med * 1e3, cpu_ns);
        bench_emit(pass ? "tree_mesh_1t" : "tree_mesh", (double)nv / med * 1e-6,
                   "million deformed vertices per second", params, NULL);
    }
    tsk_set_threads(0);

    /* the smooth option: one Catmull–Clark level through the OpenSubdiv stencils */
    int32_t* faces = malloc(4 * nf * sizeof(int32_t));
    tsk_tree_mesh_topology(t, &m, faces, NULL);
    tsk_subdiv* sd = NULL;
    double t0 = bench_now_s();
    if (tsk_subdiv_create(faces, nf, nv, 1, &sd) == TSK_OK) {
        const double build = bench_now_s() - t0;
        const size_t rn = tsk_subdiv_vertex_count(sd);
        float* rp = malloc(3 * rn * sizeof(float));
        for (int r = 0; r < repeats; ++r) {
            double t1 = bench_now_s();
            tsk_subdiv_apply(sd, pos, rp);
            samples[r] = bench_now_s() - t1;
        }
        med = bench_median(samples, repeats);
        snprintf(params, sizeof params,
                 "\"preset\": \"black_tupelo\", \"refined_vertices\": %zu, \"levels\": 1, "
                 "\"threads\": %d, \"stencil_build_ms\": %.1f",
                 rn, tsk_get_threads(), build * 1e3);
        bench_emit("tree_mesh_smooth", (double)rn / med * 1e-6,
                   "million refined vertices per second", params, NULL);
        free(rp);
        tsk_subdiv_destroy(sd);
    }
    free(faces), free(pos), free(nrm);
    tsk_tree_destroy(t);
}

/* A frame of playback for a tree with ~50k leaves (ca_black_oak): tips, wind forces (sum
 * of sines), wind step, bark and leaf-card mesh with normals. Also the lag error of the
 * seed's lagged mode after 48 frames of that wind (largest gap / parent radius). */
static void bench_frame(int repeats) {
    tsk_tree_def d;
    tsk_tree_preset("ca_black_oak", &d);
    tsk_tree* t = NULL;
    if (tsk_tree_create(&d, &t) != TSK_OK) return;
    const size_t n = tsk_tree_branch_count(t);
    tsk_tree_mesh_def m = tsk_default_tree_mesh_def();
    size_t nv = 0, nf = 0;
    tsk_tree_mesh_count(t, &m, &nv, &nf);
    float* tips = malloc(3 * n * sizeof(float));
    float* force = malloc(3 * n * sizeof(float));
    float* pos = malloc(3 * nv * sizeof(float));
    float* nrm = malloc(3 * nv * sizeof(float));
    tsk_tree_wind_def w = tsk_default_tree_wind_def();
    double samples[64];
    for (int r = 0; r < repeats; ++r) {
        double t0 = bench_now_s();
        tsk_tree_tip_positions(t, tips);
        sines(tips, n, r / 24.0, force);
        tsk_tree_wind_step(t, force, &w);
        tsk_tree_mesh_deform(t, &m, pos, nrm);
        samples[r] = bench_now_s() - t0;
    }
    const double med = bench_median(samples, repeats);
    char params[240];
    snprintf(params, sizeof params,
             "\"preset\": \"ca_black_oak\", \"branches\": %zu, \"leaves\": %zu, \"vertices\": %zu, "
             "\"threads\": %d, \"fps\": %.1f",
             n, tsk_tree_leaf_count(t), nv, tsk_get_threads(), 1.0 / med);
    bench_emit("tree_frame_50k_leaves", med * 1e3, "ms per frame", params, NULL);
    for (int mode = 0; mode < 2; ++mode) {
        tsk_tree_reset_pose(t);
        w.mode = mode;
        double worst = 0, gap = 0, metres = 0, worst_m = 0;
        /* from rest the first frame jumps straight to the bent pose (the step has no
         * inertia), so measure after one second of warm-up, over the next two seconds */
        for (int f = 0; f < 72; ++f) {
            tsk_tree_tip_positions(t, tips);
            sines(tips, n, f / 24.0, force);
            tsk_tree_wind_step(t, force, &w);
            if (f < 24) continue;
            tsk_tree_attachment_gap(t, &gap, &metres);
            if (gap > worst) worst = gap;
            if (metres > worst_m) worst_m = metres;
        }
        snprintf(
            params, sizeof params,
            "\"preset\": \"ca_black_oak\", \"frames\": \"24-72\", \"fps\": 24, \"mode\": \"%s\", "
            "\"largest_gap_m\": %.4g",
            mode ? "exact" : "lagged", worst_m);
        bench_emit(mode ? "tree_wind_gap_exact" : "tree_wind_gap_lagged", worst,
                   "largest child gap / parent radius", params, NULL);
    }
    free(tips), free(force), free(pos), free(nrm);
    tsk_tree_destroy(t);
}

static void bench_generate(int repeats) {
    for (int p = 0; p < tsk_tree_preset_count(); ++p) {
        const char* name = tsk_tree_preset_name(p);
        tsk_tree_def d;
        tsk_tree_preset(name, &d);
        double samples[64];
        size_t n = 0, leaves = 0;
        for (int r = 0; r < repeats; ++r) {
            tsk_tree* t = NULL;
            double t0 = bench_now_s();
            tsk_tree_create(&d, &t);
            samples[r] = bench_now_s() - t0;
            n = tsk_tree_branch_count(t), leaves = tsk_tree_leaf_count(t);
            tsk_tree_destroy(t);
        }
        char params[160], full[96];
        snprintf(params, sizeof params, "\"branches\": %zu, \"leaves\": %zu", n, leaves);
        snprintf(full, sizeof full, "tree_generate_%s", name);
        bench_emit(full, bench_median(samples, repeats) * 1e3, "ms per tree", params, NULL);
    }
}

/* tree_mesh_edges: the edges of a tree mesh (black tupelo, branches and leaves) in closed form
 * (tsk_tree_mesh_edges) against deriving them from its faces (tsk_mesh_edges, the way Blender
 * would), in the same run. */
static void bench_mesh_edges(int repeats) {
    tsk_tree* t = tupelo("tree_mesh_edges");
    if (t == NULL) return;
    tsk_tree_mesh_def m = tsk_default_tree_mesh_def();
    size_t nv = 0, nf = 0, ne = 0;
    tsk_tree_mesh_count(t, &m, &nv, &nf);
    int32_t* faces = malloc(4 * nf * sizeof(int32_t));
    int32_t* edges = malloc(8 * nf * sizeof(int32_t));
    int32_t* ce = malloc(4 * nf * sizeof(int32_t));
    tsk_tree_mesh_topology(t, &m, faces, NULL);
    double closed[64], derived[64];
    for (int r = 0; r < repeats; ++r) {
        double t0 = bench_now_s();
        tsk_tree_mesh_edges(t, &m, edges, ce, &ne);
        closed[r] = bench_now_s() - t0;
        t0 = bench_now_s();
        tsk_mesh_edges(faces, nf, 4, (int32_t)nv, edges, ce, &ne);
        derived[r] = bench_now_s() - t0;
    }
    char params[256];
    snprintf(params, sizeof params,
             "\"preset\": \"black_tupelo\", \"quads\": %zu, \"edges\": %zu, "
             "\"derived_ms\": %.3f",
             nf, ne, bench_median(derived, repeats) * 1e3);
    bench_emit("tree_mesh_edges", bench_median(closed, repeats) * 1e3, "ms", params, NULL);
    free(faces), free(edges), free(ce);
    tsk_tree_destroy(t);
}

int main(int argc, char** argv) {
    if (bench_wanted(argc, argv, "tree_wind_262k")) bench_wind("tree_wind_262k", 262144, 64, 21);
    if (bench_wanted(argc, argv, "tree_wind_65k")) bench_wind("tree_wind_65k", 65536, 32, 31);
    if (bench_wanted(argc, argv, "tree_mesh")) bench_mesh(15);
    if (bench_wanted(argc, argv, "tree_mesh_edges")) bench_mesh_edges(15);
    if (bench_wanted(argc, argv, "tree_frame") || bench_wanted(argc, argv, "tree_wind_gap"))
        bench_frame(15);
    if (bench_wanted(argc, argv, "tree_generate")) bench_generate(5);
    return 0;
}
