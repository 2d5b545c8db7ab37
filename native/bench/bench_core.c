/* Benchmarks of the core: counter-based random numbers, mesh edges. */
#include "bench.h"
#include "tussock/core.h"

#include <stdio.h>

static void bench_rand(int argc, char** argv) {
    if (!bench_wanted(argc, argv, "core_rand")) return;
    enum { N = 1 << 22, REPS = 15 };
    float* v = tsk_alloc(N * sizeof(float), "bench");
    if (v == NULL) return;
    for (int threads = 1; threads <= 2; ++threads) {
        tsk_set_threads(threads);
        double t[REPS];
        for (int r = 0; r < REPS; ++r) {
            double t0 = bench_now_s();
            tsk_rand_fill(1, 2, v, N);
            t[r] = bench_now_s() - t0;
        }
        char params[96];
        snprintf(params, sizeof params, "\"threads\": %d, \"count\": %d", threads, N);
        bench_emit(threads == 1 ? "core_rand" : "core_rand_2t", N / bench_median(t, REPS) * 1e-6,
                   "M numbers/s", params, NULL);
    }
    tsk_set_threads(0);
    tsk_free(v);
}

/* mesh_edges: the edges of a tree-like quad mesh (tubes of 8 sides), as Blender derives them
 * in Mesh.update() when a mesh comes without edges. */
static void bench_mesh_edges(int argc, char** argv) {
    if (!bench_wanted(argc, argv, "mesh_edges")) return;
    enum { S = 8, R = 18000, NF = S * (R - 1), REPS = 15 };
    int32_t* quads = tsk_alloc((size_t)NF * 4 * sizeof(int32_t), "bench");
    int32_t* edges = tsk_alloc((size_t)NF * 8 * sizeof(int32_t), "bench");
    int32_t* ce = tsk_alloc((size_t)NF * 4 * sizeof(int32_t), "bench");
    if (quads == NULL || edges == NULL || ce == NULL) return;
    for (int r = 0; r < R - 1; ++r)
        for (int k = 0; k < S; ++k) {
            int32_t* q = quads + 4 * (r * S + k);
            q[0] = r * S + k;
            q[1] = r * S + (k + 1) % S;
            q[2] = q[1] + S;
            q[3] = q[0] + S;
        }
    double t[REPS];
    size_t ne = 0;
    for (int i = 0; i < REPS; ++i) {
        double t0 = bench_now_s();
        tsk_mesh_edges(quads, NF, 4, S * R, edges, ce, &ne);
        t[i] = bench_now_s() - t0;
    }
    char params[128];
    snprintf(params, sizeof params, "\"quads\": %d, \"edges\": %zu", NF, ne);
    bench_emit("mesh_edges", bench_median(t, REPS) * 1e3, "ms", params, NULL);
    tsk_free(quads);
    tsk_free(edges);
    tsk_free(ce);
}

int main(int argc, char** argv) {
    bench_rand(argc, argv);
    bench_mesh_edges(argc, argv);
    return 0;
}
