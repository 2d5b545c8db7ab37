/* Benchmarks of the blade simulation: seed 000 Table 1 (6/14/150/709 active tiles of 64 blades
 * with 1/2/20/128 sphere objects; headline blade_sim_table1 = ms per step of the 709-tile case)
 * and blade_sim_1M (1,000,000 active blades, 16 knots, 4 iterations, 128 objects; ns per
 * blade-step). Blades are the meadow's default shape (0.3 m, leaning, random turn and scale);
 * wind is given per blade; objects move through the active tiles every step.
 * blade_sim_1M_block steps one block of the solver alone, over and over, for a figure steady
 * enough to compare kernels on a noisy host. */
#include "bench.h"
#include "sim/sim_internal.h"
#include "tussock/sim.h"

#include <math.h>
#include <stdint.h>

#define KNOTS 16
#define BLADES_PER_TILE 64

static void fill_tile(const tsk_blade_sim_def* d, int32_t t, float* knots, float* widths,
                      float* sides) {
    const int32_t i = t % d->tiles_x, j = t / d->tiles_x;
    for (int b = 0; b < BLADES_PER_TILE; ++b) {
        const float rx =
            d->origin[0] + d->tile_size * ((float)i + tsk_rand01(11, (uint64_t)t, (uint64_t)b, 0));
        const float ry =
            d->origin[1] + d->tile_size * ((float)j + tsk_rand01(11, (uint64_t)t, (uint64_t)b, 1));
        const float turn = 6.2831853f * tsk_rand01(11, (uint64_t)t, (uint64_t)b, 2);
        const float H = 0.3f * (0.8f + 0.4f * tsk_rand01(11, (uint64_t)t, (uint64_t)b, 3));
        const float c = cosf(turn), s = sinf(turn);
        for (int k = 0; k < KNOTS; ++k) {
            const float u = (float)k / (float)(KNOTS - 1);
            const float lx = 0.25f * H * u * u;
            float* p = knots + ((size_t)b * KNOTS + k) * 3;
            p[0] = rx + c * lx, p[1] = ry + s * lx, p[2] = H * u;
            widths[(size_t)b * KNOTS + k] = 0.008f * (1.0f - u * u * u);
        }
        sides[3 * b] = -s, sides[3 * b + 1] = c, sides[3 * b + 2] = 0.0f;
    }
}

/* Active tiles are the first `tiles` of a square-ish region; objects (spheres 0.15..0.3 m)
 * wander over that region. */
typedef struct scene {
    tsk_blade_sim* sim;
    int32_t tiles, objects, side;
    float* wind;
    tsk_blade_collider* cols;
    float* home; /* per object: centre x, y, phase */
    int64_t blades;
    float width, depth; /* metres of the region the tiles cover in x and y */
    int log; /* 1: instead of the objects, one log lying across the region */
} scene;

static int scene_make(scene* sc, int32_t tiles, int32_t objects) {
    memset(sc, 0, sizeof *sc);
    int32_t side = (int32_t)ceil(sqrt((double)tiles));
    tsk_blade_sim_def d = tsk_default_blade_sim_def();
    d.tiles_x = side, d.tiles_y = side;
    d.knot_count = KNOTS;
    d.iterations = 4;
    d.rest_frames = d.settle_frames = 1 << 30; /* keep every tile active for the benchmark */
    if (tsk_blade_sim_create(&d, &sc->sim) != TSK_OK) return 0;
    static float knots[BLADES_PER_TILE * KNOTS * 3], widths[BLADES_PER_TILE * KNOTS],
        sides[BLADES_PER_TILE * 3];
    for (int32_t t = 0; t < tiles; ++t) {
        fill_tile(&d, t, knots, widths, sides);
        if (tsk_blade_sim_activate_tile(sc->sim, t) != TSK_OK ||
            tsk_blade_sim_provide_tile(sc->sim, t, BLADES_PER_TILE, knots, widths, sides) != TSK_OK)
            return 0;
    }
    sc->tiles = tiles, sc->objects = objects, sc->side = side;
    sc->blades = (int64_t)tiles * BLADES_PER_TILE;
    sc->wind = malloc(sizeof(float) * 3 * (size_t)sc->blades);
    sc->cols = malloc(sizeof(tsk_blade_collider) * (size_t)objects);
    sc->home = malloc(sizeof(float) * 3 * (size_t)objects);
    const float rows = (float)((tiles + side - 1) / side) * d.tile_size,
                cols = (float)side * d.tile_size;
    sc->width = cols, sc->depth = rows;
    for (int32_t o = 0; o < objects; ++o) {
        sc->home[3 * o] = cols * tsk_rand01(5, (uint64_t)o, 0, 0);
        sc->home[3 * o + 1] = rows * tsk_rand01(5, (uint64_t)o, 1, 0);
        sc->home[3 * o + 2] = 6.2831853f * tsk_rand01(5, (uint64_t)o, 2, 0);
        sc->cols[o].kind = TSK_COLLIDER_SPHERE;
        sc->cols[o].radius = 0.15f + 0.15f * tsk_rand01(5, (uint64_t)o, 3, 0);
        sc->cols[o].b[0] = sc->cols[o].b[1] = sc->cols[o].b[2] = 0.0f;
    }
    for (int64_t b = 0; b < sc->blades; ++b) {
        sc->wind[3 * b] = 2.0f + tsk_rand01(9, (uint64_t)b, 0, 0);
        sc->wind[3 * b + 1] = 0.5f * tsk_rand01(9, (uint64_t)b, 1, 0);
        sc->wind[3 * b + 2] = 0.0f;
    }
    return 1;
}

static int scene_step(scene* sc, int step) {
    if (sc->log) { /* as in blade_playback: a 25 cm log lying on the blades, across the middle */
        tsk_blade_collider lg = {.kind = TSK_COLLIDER_CAPSULE, .radius = 0.25f};
        lg.a[0] = lg.b[0] = 0.5f * sc->width;
        lg.a[1] = -0.5f, lg.b[1] = sc->depth + 0.5f;
        lg.a[2] = lg.b[2] = 0.25f;
        if (tsk_blade_sim_set_colliders(sc->sim, &lg, 1) != TSK_OK) return 0;
        return tsk_blade_sim_step(sc->sim, 1.0f / 60.0f, sc->wind, TSK_WIND_PER_BLADE) == TSK_OK;
    }
    for (int32_t o = 0; o < sc->objects; ++o) {
        const float ph = sc->home[3 * o + 2] + 0.05f * (float)step;
        tsk_blade_collider* c = &sc->cols[o];
        c->a[0] = sc->home[3 * o] + 0.4f * cosf(ph);
        c->a[1] = sc->home[3 * o + 1] + 0.4f * sinf(ph);
        c->a[2] = c->radius + 0.02f;
    }
    if (tsk_blade_sim_set_colliders(sc->sim, sc->cols, sc->objects) != TSK_OK) return 0;
    /* tiles the objects touch outside the benchmark's set stay pending: not simulated */
    return tsk_blade_sim_step(sc->sim, 1.0f / 60.0f, sc->wind, TSK_WIND_PER_BLADE) == TSK_OK;
}

static void scene_free(scene* sc) {
    tsk_blade_sim_destroy(sc->sim);
    free(sc->wind);
    free(sc->cols);
    free(sc->home);
}

static double cpu_now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The 1-minute load average: other processes share the 2 cores, which inflates wall times. */
static double load_avg(void) {
    double l = -1;
    FILE* f = fopen("/proc/loadavg", "r");
    if (f) {
        if (fscanf(f, "%lf", &l) != 1) l = -1;
        fclose(f);
    }
    return l;
}

/* Median wall ms per step over `repeats` samples of `batch` steps; *cpu_ms gets the median CPU
 * time per step summed over all threads (less sensitive to other processes on the machine). */
static double measure(scene* sc, int warm, int repeats, int batch, double* cpu_ms) {
    int step = 0;
    for (int i = 0; i < warm; ++i)
        if (!scene_step(sc, step++)) return -1;
    double v[64], c[64];
    for (int r = 0; r < repeats; ++r) {
        double t0 = bench_now_s(), c0 = cpu_now_s();
        for (int b = 0; b < batch; ++b)
            if (!scene_step(sc, step++)) return -1;
        v[r] = (bench_now_s() - t0) * 1e3 / batch;
        c[r] = (cpu_now_s() - c0) * 1e3 / batch;
    }
    *cpu_ms = bench_median(c, repeats);
    return bench_median(v, repeats);
}

/* The solver's kernel alone: four blocks of SIM_W blades of the first tiles (about 54 KB, in
 * L1 and L2) stepped in turn with wind and no collider, as tsk_blade_sim_step sets up a step
 * from the default definition (tsk_sim_step_params). Batches of 64 block steps; the least and the tenth percentile
 * of 600 batches, per blade-step: compute, without memory, threads or tile management, and
 * steady where the other lines spread by 15 %. */
static int bench_block(double* best, double* p10, double* median) {
    enum { NB = 4, BATCH = 64, BATCHES = 600 };
    const int32_t K = KNOTS;
    const size_t fl = SIM_BLOCK_FLOATS(K);
    const tsk_blade_sim_def d = tsk_default_blade_sim_def();
    float* blocks = tsk_alloc(fl * 4 * NB, "blocks"); /* 64-byte aligned, on Windows too */
    double* t = malloc(sizeof(double) * BATCHES);
    if (!blocks || !t) {
        tsk_free(blocks);
        free(t);
        return 0;
    }
    memset(blocks, 0, fl * 4 * NB);
    static float knots[BLADES_PER_TILE * KNOTS * 3], widths[BLADES_PER_TILE * KNOTS],
        sides[BLADES_PER_TILE * 3];
    for (int bi = 0; bi < NB; ++bi) {
        fill_tile(&d, bi, knots, widths, sides);
        for (int l = 0; l < SIM_W; ++l)
            tsk_sim_block_load_lane(K, blocks + fl * bi, l, knots + (size_t)l * K * 3,
                                    widths + (size_t)l * K, sides + 3 * l);
        tsk_sim_block_rest(K, blocks + fl * bi);
    }
    tsk_blade_sim_def dk = d;
    dk.knot_count = K, dk.iterations = 4;
    const sim_step_params p = tsk_sim_step_params(&dk, 1.0f / 60.0f);
    float wind[3 * SIM_W];
    for (int l = 0; l < SIM_W; ++l) {
        wind[l] = 2.0f + tsk_rand01(9, (uint64_t)l, 0, 0);
        wind[SIM_W + l] = 0.5f * tsk_rand01(9, (uint64_t)l, 1, 0);
        wind[2 * SIM_W + l] = 0.0f;
    }
    sim_block_stats st;
    for (int i = 0; i < 2000; ++i) /* into the wind's steady sway */
        tsk_sim_block_step(&p, blocks + fl * (size_t)(i % NB), wind, 0, NULL, 0, 0.0f, NULL, &st);
    for (int r = 0; r < BATCHES; ++r) {
        const double t0 = bench_now_s();
        for (int i = 0; i < BATCH; ++i)
            tsk_sim_block_step(&p, blocks + fl * (size_t)(i % NB), wind, 0, NULL, 0, 0.0f, NULL,
                               &st);
        t[r] = (bench_now_s() - t0) * 1e9 / ((double)BATCH * SIM_W);
    }
    const int finite = isfinite(blocks[fl - 1]) && isfinite(st.max_disp2);
    *median = bench_median(t, BATCHES); /* sorts t */
    *best = t[0], *p10 = t[BATCHES / 10];
    tsk_free(blocks);
    free(t);
    return finite;
}

int main(int argc, char** argv) {
    /* TSK_BENCH_THREADS=n runs with n worker threads (default: all cores) */
    const char* env = getenv("TSK_BENCH_THREADS");
    if (env && tsk_set_threads(atoi(env)) != TSK_OK) return 1;
    const int threads = tsk_get_threads();
    if (bench_wanted(argc, argv, "blade_sim_table1")) {
        static const int32_t tiles[4] = {6, 14, 150, 709}, objects[4] = {1, 2, 20, 128};
        /* TSK_BENCH_CASE=c runs only case c (0..3) of the table */
        const char* only = getenv("TSK_BENCH_CASE");
        static const double gpu_ms[4] = {0.176, 0.183, 0.952, 4.67};
        static const double gpu_ns[4] = {0.458, 0.204, 0.099, 0.103};
        double ms709 = -1, ns709 = 0;
        for (int c = 0; c < 4; ++c) {
            if (only && atoi(only) != c) continue;
            scene sc;
            if (!scene_make(&sc, tiles[c], objects[c])) {
                fprintf(stderr, "blade_sim_table1: setup failed: %s\n", tsk_last_error());
                return 1;
            }
            const int batch = c < 2 ? 200 : (c == 2 ? 20 : 5);
            double cpu = 0;
            double ms = measure(&sc, 30, 15, batch, &cpu);
            if (ms < 0) {
                fprintf(stderr, "blade_sim_table1: step failed: %s\n", tsk_last_error());
                return 1;
            }
            const double ns = ms * 1e6 / (double)sc.blades;
            char name[64], params[512];
            snprintf(name, sizeof name, "blade_sim_table1_%d", tiles[c]);
            snprintf(params, sizeof params,
                     "\"tiles\": %d, \"blades\": %lld, \"objects\": %d, \"knots\": %d, "
                     "\"iterations\": 4, \"threads\": %d, \"ns_per_blade\": %.4g, "
                     "\"cpu_ms_per_step\": %.4g, \"load_avg\": %.2f, "
                     "\"seed_gpu_ms\": %.4g, \"seed_gpu_ns_per_blade\": %.4g, "
                     "\"seed_gpu_hardware\": \"AMD Radeon R9-270\"",
                     tiles[c], (long long)sc.blades, objects[c], KNOTS, threads, ns, cpu,
                     load_avg(), gpu_ms[c], gpu_ns[c]);
            bench_emit(name, ms, "ms per step", params, NULL);
            if (c == 3) ms709 = ms, ns709 = ns;
            scene_free(&sc);
        }
        char params[256];
        snprintf(params, sizeof params,
                 "\"tiles\": 709, \"objects\": 128, \"blades\": 45376, \"threads\": %d, "
                 "\"ns_per_blade\": %.4g, \"seed_gpu_ms\": 4.67",
                 threads, ns709);
        bench_emit("blade_sim_table1", ms709, "ms per step, 709 tiles and 128 objects", params,
                   NULL);
    }
    if (bench_wanted(argc, argv, "blade_sim_1M_cache") ||
        bench_wanted(argc, argv, "blade_sim_1M_contact")) {
        /* The solver alone, in cache, on one thread: 2,048 blades (870 KB of state, inside one
           core's L2) and one object, so the figure is compute, not memory or scheduling. */
        const int saved = tsk_get_threads();
        scene sc;
        if (tsk_set_threads(1) != TSK_OK || !scene_make(&sc, 32, 1)) {
            fprintf(stderr, "blade_sim_1M_cache: setup failed: %s\n", tsk_last_error());
            return 1;
        }
        double cpu = 0, ms = measure(&sc, 50, 15, 100, &cpu);
        if (ms < 0) {
            fprintf(stderr, "blade_sim_1M_cache: step failed: %s\n", tsk_last_error());
            return 1;
        }
        char params[256];
        snprintf(params, sizeof params,
                 "\"blades\": %lld, \"knots\": %d, \"iterations\": 4, \"objects\": 1, "
                 "\"threads\": 1, \"load_avg\": %.2f",
                 (long long)sc.blades, KNOTS, load_avg());
        bench_emit("blade_sim_1M_cache", ms * 1e6 / (double)sc.blades, "ns per blade-step", params,
                   NULL);
        /* the same blades in contact: the log of blade_playback lying across them (a third of
           the blocks have it near) */
        sc.log = 1;
        ms = measure(&sc, 50, 15, 100, &cpu);
        if (ms < 0) {
            fprintf(stderr, "blade_sim_1M_contact: step failed: %s\n", tsk_last_error());
            return 1;
        }
        snprintf(params, sizeof params,
                 "\"blades\": %lld, \"knots\": %d, \"iterations\": 4, "
                 "\"collider\": \"capsule r 0.25 m lying across the tiles\", \"threads\": 1, "
                 "\"load_avg\": %.2f",
                 (long long)sc.blades, KNOTS, load_avg());
        bench_emit("blade_sim_1M_contact", ms * 1e6 / (double)sc.blades, "ns per blade-step",
                   params, NULL);
        scene_free(&sc);
        if (tsk_set_threads(saved) != TSK_OK) return 1;
    }
    if (bench_wanted(argc, argv, "blade_sim_1M_block")) {
        double best = 0, p10 = 0, med = 0;
        if (!bench_block(&best, &p10, &med)) {
            fprintf(stderr, "blade_sim_1M_block: setup failed or a knot went non-finite\n");
            return 1;
        }
        char params[512];
        snprintf(params, sizeof params,
                 "\"blades\": %d, \"knots\": %d, \"iterations\": 4, \"objects\": 0, "
                 "\"threads\": 1, \"p10_ns\": %.4g, \"median_ns\": %.4g, \"load_avg\": %.2f, "
                 "\"avx512_step\": \"%s\"",
                 SIM_W, KNOTS, p10, med, load_avg(), tsk_sim_avx512_step_running());
        bench_emit("blade_sim_1M_block", best, "ns per blade-step, least of 600 batches", params,
                   NULL);
    }
    if (bench_wanted(argc, argv, "blade_sim_1M")) {
        scene sc;
        if (!scene_make(&sc, 15625, 128)) {
            fprintf(stderr, "blade_sim_1M: setup failed: %s\n", tsk_last_error());
            return 1;
        }
        double cpu = 0;
        double ms = measure(&sc, 3, 7, 1, &cpu);
        if (ms < 0) {
            fprintf(stderr, "blade_sim_1M: step failed: %s\n", tsk_last_error());
            return 1;
        }
        tsk_blade_sim_info info;
        tsk_blade_sim_get_info(sc.sim, &info);
        const double ns = ms * 1e6 / (double)sc.blades;
        char params[640];
        snprintf(params, sizeof params,
                 "\"blades\": %lld, \"tiles\": 15625, \"knots\": %d, \"iterations\": 4, "
                 "\"objects\": 128, \"threads\": %d, \"ms_per_step\": %.4g, "
                 "\"cpu_ns_per_blade_step\": %.4g, \"load_avg\": %.2f, \"state_mb\": %.1f, "
                 "\"state_bytes_per_blade\": %.1f, \"avx512_step\": \"%s\", "
                 "\"target_ns\": 40, \"blender_hair_ns_reference\": 220000, "
                 "\"blender_hair_ratio\": %.4g, \"blender_hair_note\": \"quoted in issue 7 "
                 "(15 segments, this machine), not measured in this run\"",
                 (long long)sc.blades, KNOTS, threads, ms, cpu * 1e6 / (double)sc.blades,
                 load_avg(), (double)info.state_bytes / 1048576.0,
                 (double)info.state_bytes / (double)sc.blades, tsk_sim_avx512_step_running(),
                 220000.0 / ns);
        bench_emit("blade_sim_1M", ns, "ns per blade-step", params, NULL);
        scene_free(&sc);
    }
    return 0;
}
