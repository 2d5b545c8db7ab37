/* Wind benchmarks: ms per fluid + continuum step at 64^2, 128^2 (headline wind_fluid) and
 * 256^2, and million wind samples per second (wind_sample). Medians over repeats. */
#include "bench.h"
#include "tussock/wind.h"

enum { REPEATS = 15 };

/* CPU time of the calling thread: with one worker thread it measures the work even when
 * other processes share the cores (the machine is shared), unlike wall time. */
static double cpu_now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void bench_fluid(const char* name, int n, int steps_per_repeat) {
    tsk_wind_def d = tsk_default_wind_def();
    d.fluid.nx = d.fluid.ny = n;
    d.fluid.cell_size = 32.0f / (float)n;
    d.continuum.c = 0.25f * d.fluid.cell_size / d.fluid.dt; /* c dt / dx = 0.25 */
    tsk_wind* w = NULL;
    if (tsk_wind_create(&d, &w) != TSK_OK) {
        fprintf(stderr, "%s: %s\n", name, tsk_last_error());
        return;
    }
    tsk_wind_source s[3] = {tsk_default_wind_source(), tsk_default_wind_source(),
                            tsk_default_wind_source()};
    s[1].y = 8.0f;
    s[1].interval = 0.0f;
    s[2].x = 0.0f;
    s[2].y = -14.0f;
    s[2].dir_x = 0.2f;
    s[2].dir_y = 1.0f;
    tsk_wind_set_sources(w, s, 3);
    tsk_wind_step(w, 30); /* warm up */
    double ms[REPEATS], cpu[REPEATS];
    for (int r = 0; r < REPEATS; ++r) {
        const double t0 = bench_now_s();
        tsk_wind_step(w, steps_per_repeat);
        ms[r] = 1e3 * (bench_now_s() - t0) / steps_per_repeat;
    }
    const int threads = tsk_get_threads();
    tsk_set_threads(1);
    for (int r = 0; r < REPEATS; ++r) {
        const double t0 = cpu_now_s();
        tsk_wind_step(w, steps_per_repeat);
        cpu[r] = 1e3 * (cpu_now_s() - t0) / steps_per_repeat;
    }
    tsk_set_threads(0);
    const double med = bench_median(ms, REPEATS);
    char params[320];
    snprintf(params, sizeof params,
             "\"grid\": %d, \"threads\": %d, \"pressure_iterations\": %d, \"steps_per_s\": %.1f, "
             "\"cpu_ms_1_thread\": %.4g, \"continuum\": true, \"sources\": 3",
             n, threads, d.fluid.pressure_iterations, 1e3 / med, bench_median(cpu, REPEATS));
    bench_emit(name, med,
               strcmp(name, "wind_fluid") == 0 ? "ms per 128² fluid + wave step" : "ms per step",
               params, NULL);
    tsk_wind_destroy(w);
}

static void bench_sample(const char* name, int xyz) {
    tsk_wind_def d = tsk_default_wind_def(); /* breeze, 2 waves (k = 2 and 1), gusts, 64^2 */
    tsk_wind* w = NULL;
    if (tsk_wind_create(&d, &w) != TSK_OK) return;
    tsk_wind_source s = tsk_default_wind_source();
    tsk_wind_set_sources(w, &s, 1);
    tsk_wind_step(w, 60);
    const size_t n = (size_t)1 << 21;
    float* x = malloc(n * sizeof(float) * 3);
    float* y = malloc(n * sizeof(float));
    float* vx = malloc(n * sizeof(float) * 3);
    float* vy = malloc(n * sizeof(float));
    for (size_t i = 0; i < n; ++i) {
        x[i] = 40.0f * tsk_rand01(1, 0, i, 0) - 20.0f;
        y[i] = 40.0f * tsk_rand01(1, 0, i, 1) - 20.0f;
    }
    if (xyz)
        for (size_t i = n; i-- > 0;) {
            x[3 * i + 2] = 0.0f;
            x[3 * i + 1] = y[i];
            x[3 * i] = x[i];
        }
    double rate[REPEATS], rate1[REPEATS];
    const int threads = tsk_get_threads();
    for (int pass = 0; pass < 2; ++pass) {
        if (pass == 1) tsk_set_threads(1);
        for (int r = 0; r < REPEATS; ++r) {
            const double t0 = pass ? cpu_now_s() : bench_now_s();
            if (xyz) tsk_wind_sample_xyz(w, 1.0 + r, n, x, vx, NULL);
            else tsk_wind_sample(w, 1.0 + r, n, x, y, vx, vy, NULL, NULL);
            const double sec = (pass ? cpu_now_s() : bench_now_s()) - t0;
            (pass ? rate1 : rate)[r] = (double)n / sec / 1e6;
        }
    }
    tsk_set_threads(0);
    char params[320];
    snprintf(params, sizeof params,
             "\"points\": %zu, \"threads\": %d, \"cpu_rate_1_thread\": %.4g, \"waves\": 2, "
             "\"gusts\": true, \"fluid_grid\": 64, \"layout\": \"%s\"",
             n, threads, bench_median(rate1, REPEATS), xyz ? "xyz" : "soa");
    bench_emit(name, bench_median(rate, REPEATS), "M points sampled per second", params, NULL);
    free(x);
    free(y);
    free(vx);
    free(vy);
    tsk_wind_destroy(w);
}

int main(int argc, char** argv) {
    if (bench_wanted(argc, argv, "wind_fluid")) bench_fluid("wind_fluid", 128, 40);
    if (bench_wanted(argc, argv, "wind_fluid_64")) bench_fluid("wind_fluid_64", 64, 100);
    if (bench_wanted(argc, argv, "wind_fluid_256")) bench_fluid("wind_fluid_256", 256, 10);
    if (bench_wanted(argc, argv, "wind_sample")) bench_sample("wind_sample", 0);
    if (bench_wanted(argc, argv, "wind_sample_xyz")) bench_sample("wind_sample_xyz", 1);
    return 0;
}
