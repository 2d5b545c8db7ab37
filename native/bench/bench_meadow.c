/* Benchmarks of the meadow: building and expanding the default 16,384-blade patch
 * (meadow_patch) and laying out the tiles of a 10-million-blade meadow (meadow_tiles).
 * The headline meadow_10M (Blender's peak memory) is measured in Blender, not here. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime in bench.h under strict C17 */
#include "bench.h"
#include "tussock/core.h"
#include "tussock/meadow.h"

#include <stdint.h>

enum { REPEATS = 9 };

static void bench_patch(int threads) {
    tsk_set_threads(threads);
    double create_ms[REPEATS], expand_ms[REPEATS], total_ms[REPEATS];
    size_t nv = 0, nt = 0;
    int knots = 0;
    for (int r = 0; r < REPEATS; ++r) {
        tsk_patch_def d = tsk_default_patch_def();
        d.seed = 1 + (uint64_t)r;
        tsk_patch* p = NULL;
        const double t0 = bench_now_s();
        if (tsk_patch_create(&d, &p) != TSK_OK) {
            fprintf(stderr, "patch: %s\n", tsk_last_error());
            exit(1);
        }
        const double t1 = bench_now_s();
        tsk_patch_mesh_counts(p, &nv, &nt);
        knots = tsk_patch_knot_count(p);
        float* pos = malloc(nv * 3 * sizeof(float));
        float* nrm = malloc(nv * 3 * sizeof(float));
        float* uv = malloc(nv * 2 * sizeof(float));
        int32_t* tris = malloc(nt * 3 * sizeof(int32_t));
        /* touch the buffers first so page faults are not timed as expansion */
        memset(pos, 0, nv * 12);
        memset(nrm, 0, nv * 12);
        memset(uv, 0, nv * 8);
        memset(tris, 0, nt * 12);
        const double t2 = bench_now_s();
        tsk_patch_expand(p, 0.5f, pos, nrm, uv, tris, NULL);
        const double t3 = bench_now_s();
        create_ms[r] = 1e3 * (t1 - t0);
        expand_ms[r] = 1e3 * (t3 - t2);
        total_ms[r] = create_ms[r] + expand_ms[r];
        free(pos);
        free(nrm);
        free(uv);
        free(tris);
        tsk_patch_destroy(p);
    }
    char params[256];
    snprintf(params, sizeof params,
             "\"blades\": 16384, \"knots\": %d, \"vertices\": %zu, \"triangles\": %zu, "
             "\"threads\": %d, \"repeats\": %d",
             knots, nv, nt, tsk_get_threads(), REPEATS);
    const char* suffix = threads == 1 ? "_1thread" : "";
    char name[64];
    snprintf(name, sizeof name, "meadow_patch%s", suffix);
    bench_emit(name, bench_median(total_ms, REPEATS), "ms", params, NULL);
    snprintf(name, sizeof name, "meadow_patch_create%s", suffix);
    bench_emit(name, bench_median(create_ms, REPEATS), "ms", params, NULL);
    snprintf(name, sizeof name, "meadow_patch_expand%s", suffix);
    bench_emit(name, bench_median(expand_ms, REPEATS), "ms", params, NULL);
}

static void bench_tiles(int threads) {
    tsk_set_threads(threads);
    /* noise density with threshold 0 averages 1/2, so 64 blades per 0.5 m tile on
     * 280 x 280 m (313,600 tiles) give about 10 M blades */
    tsk_meadow_def d = tsk_default_meadow_def();
    d.size[0] = d.size[1] = 280.0f;
    d.tile_size = 0.5f;
    d.blades_per_tile = 64;
    d.noise_threshold = 0.0f;
    d.noise_scale = 20.0f;
    d.noise_octaves = 3;
    double ms[REPEATS], chunk_ms[REPEATS];
    tsk_meadow_info info = {0};
    for (int r = 0; r < REPEATS; ++r) {
        d.seed = 1 + (uint64_t)r;
        tsk_meadow* m = NULL;
        const double t0 = bench_now_s();
        if (tsk_meadow_create(&d, &m) != TSK_OK) {
            fprintf(stderr, "meadow: %s\n", tsk_last_error());
            exit(1);
        }
        const double t1 = bench_now_s();
        tsk_meadow_get_info(m, &info);
        const size_t T = (size_t)info.tile_count;
        float* org = malloc(T * 3 * sizeof(float));
        int32_t* off = malloc(T * sizeof(int32_t));
        int32_t* cnt = malloc(T * sizeof(int32_t));
        memset(org, 0, T * 12);
        memset(off, 0, T * 4);
        memset(cnt, 0, T * 4);
        const double t2 = bench_now_s();
        tsk_meadow_instances(m, org, off, cnt);
        const double t3 = bench_now_s();
        ms[r] = 1e3 * (t1 - t0);
        chunk_ms[r] = 1e3 * (t3 - t2);
        free(org);
        free(off);
        free(cnt);
        tsk_meadow_destroy(m);
    }
    char params[320];
    snprintf(params, sizeof params,
             "\"tiles\": %lld, \"blades\": %lld, \"blades_per_tile\": 64, \"tile_size_m\": 0.5, "
             "\"density\": \"noise\", \"octaves\": 3, \"threads\": %d, \"repeats\": %d",
             (long long)info.tile_count, (long long)info.blade_count, tsk_get_threads(), REPEATS);
    const char* suffix = threads == 1 ? "_1thread" : "";
    char name[64];
    snprintf(name, sizeof name, "meadow_tiles%s", suffix);
    bench_emit(name, bench_median(ms, REPEATS), "ms", params, NULL);
    snprintf(name, sizeof name, "meadow_tiles_instances%s", suffix);
    bench_emit(name, bench_median(chunk_ms, REPEATS), "ms", params, NULL);
}

int main(int argc, char** argv) {
    if (bench_wanted(argc, argv, "meadow_patch")) {
        bench_patch(0);
        bench_patch(1);
    }
    if (bench_wanted(argc, argv, "meadow_tiles")) {
        bench_tiles(0);
        bench_tiles(1);
    }
    tsk_set_threads(0);
    return 0;
}
