/* Benchmarks of the core: counter-based random numbers and the parallel-for overhead. */
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

int main(int argc, char** argv) {
    bench_rand(argc, argv);
    return 0;
}
