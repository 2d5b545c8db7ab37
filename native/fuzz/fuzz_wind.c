/* Fuzz target: wind definitions, sources and saved states. The bytes give a tsk_wind_def
 * (breeze, up to 8 waves, gusts, fluid grid, continuum) and sources, validated at full
 * range; for creation the harness shrinks a valid grid above 32 cells per side and
 * iteration counts above 20 (cost only), then steps, samples at fuzzed points and times
 * (both sample calls), cross-fades to fuzzed sines, reads the grids and loads its own saved
 * state with fuzzed bytes flipped. Every sampled value must be finite. */
#include "fuzz.h"
#include "tussock/wind.h"

int LLVMFuzzerInitialize(int* argc, char*** argv) {
    (void)argc;
    (void)argv;
    fz_init();
    return 0;
}

static void fuzz_sines(fz* r, tsk_wind_sines_def* s) {
    *s = tsk_default_wind_sines_def();
    if (fz_u8(r) & 1) return;
    s->base_x = fz_float(r, s->base_x);
    s->base_y = fz_float(r, s->base_y);
    s->wave_count = fz_int(r, s->wave_count);
    for (int i = 0; i < TSK_WIND_MAX_WAVES; ++i) {
        tsk_wind_wave* w = &s->waves[i];
        if (i >= 2) *w = tsk_default_wind_wave();
        if (fz_u8(r) & 1) continue;
        w->amplitude = fz_float(r, w->amplitude);
        w->dir_x = fz_float(r, w->dir_x);
        w->dir_y = fz_float(r, w->dir_y);
        w->wavelength = fz_float(r, w->wavelength);
        w->speed = fz_float(r, w->speed);
        w->phase = fz_float(r, w->phase);
        w->power = fz_float(r, w->power);
    }
    tsk_wind_gust_def* g = &s->gust;
    g->strength = fz_float(r, g->strength);
    g->interval = fz_float(r, g->interval);
    g->duration = fz_float(r, g->duration);
    g->dir_x = fz_float(r, g->dir_x);
    g->dir_y = fz_float(r, g->dir_y);
    g->front_speed = fz_float(r, g->front_speed);
    g->seed = fz_u64(r);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fz r = {data, size};
    tsk_wind_def d = tsk_default_wind_def();
    fuzz_sines(&r, &d.sines);
    tsk_wind_fluid_def* f = &d.fluid;
    f->nx = fz_int(&r, 16);
    f->ny = fz_int(&r, 16);
    if (fz_u8(&r) % 8 == 0) f->nx = f->ny = 0;
    f->origin_x = fz_float(&r, -4.0f);
    f->origin_y = fz_float(&r, -4.0f);
    f->cell_size = fz_float(&r, 0.5f);
    f->dt = fz_float(&r, f->dt);
    f->speed = fz_float(&r, f->speed);
    f->viscosity = fz_float(&r, f->viscosity);
    f->decay = fz_float(&r, f->decay);
    f->pressure_iterations = fz_int(&r, 10);
    f->pressure_tolerance = fz_float(&r, f->pressure_tolerance);
    f->diffusion_iterations = fz_int(&r, 5);
    d.continuum.enabled = fz_u8(&r) % 3;
    d.continuum.c = fz_float(&r, d.continuum.c);
    d.continuum.gamma = fz_float(&r, d.continuum.gamma);
    d.continuum.drive = fz_float(&r, d.continuum.drive);
    (void)tsk_wind_def_validate(&d);
    /* cost only: a valid large grid or iteration count is shrunk before creating */
    if (f->nx > 32) f->nx = 4 + f->nx % 29;
    if (f->ny > 32) f->ny = 4 + f->ny % 29;
    if (f->pressure_iterations > 20) f->pressure_iterations = 1 + f->pressure_iterations % 20;
    if (f->diffusion_iterations > 20) f->diffusion_iterations = 1 + f->diffusion_iterations % 20;
    tsk_wind* w = NULL;
    if (tsk_wind_create(&d, &w) != TSK_OK) {
        if (w != NULL) abort();
        fz_check_leaks("wind (refused)");
        return 0;
    }
    tsk_wind_source src[8];
    const int ns = fz_u8(&r) % 9;
    for (int i = 0; i < ns; ++i) {
        src[i] = tsk_default_wind_source();
        src[i].x = fz_float(&r, 0.0f);
        src[i].y = fz_float(&r, 0.0f);
        src[i].dir_x = fz_float(&r, 1.0f);
        src[i].dir_y = fz_float(&r, 0.0f);
        src[i].strength = fz_float(&r, src[i].strength);
        src[i].radius = fz_float(&r, src[i].radius);
        src[i].interval = fz_float(&r, src[i].interval);
        src[i].start = fz_float(&r, src[i].start);
    }
    (void)tsk_wind_set_sources(w, ns ? src : NULL, (fz_u8(&r) % 16) ? (size_t)ns : 65);
    (void)tsk_wind_step(w, fz_u8(&r) % 4);
    if (fz_u8(&r) % 16 == 0) (void)tsk_wind_step(w, fz_int(&r, -1) < 0 ? -1 : 0);
    tsk_wind_sines_def s2;
    fuzz_sines(&r, &s2);
    (void)tsk_wind_set_sines(w, &s2, (double)fz_float(&r, 0.1f), (double)fz_float(&r, 0.5f));
    (void)tsk_wind_step(w, fz_u8(&r) % 3);
    enum { N = 8 };
    float x[N], y[N], vx[N], vy[N], sx[N], sy[N], xyz[3 * N], v3[3 * N], s3[3 * N];
    for (int i = 0; i < N; ++i) {
        x[i] = fz_float(&r, (float)i);
        y[i] = fz_float(&r, (float)-i);
        xyz[3 * i] = x[i];
        xyz[3 * i + 1] = y[i];
        xyz[3 * i + 2] = fz_float(&r, 0.0f);
    }
    const double t = (fz_u8(&r) % 8) ? fz_u8(&r) * 0.37 : (double)fz_float(&r, 1.0f);
    if (tsk_wind_sample(w, t, N, x, y, vx, vy, sx, sy) == TSK_OK) {
        for (int i = 0; i < N; ++i)
            if (!isfinite(vx[i]) || !isfinite(vy[i]) || !isfinite(sx[i]) || !isfinite(sy[i]))
                abort();
    }
    if (tsk_wind_sample_xyz(w, t, N, xyz, v3, s3) == TSK_OK) {
        for (int i = 0; i < 3 * N; ++i)
            if (!isfinite(v3[i]) || !isfinite(s3[i])) abort();
    }
    int nx = 0, ny = 0;
    tsk_wind_grid_size(w, &nx, &ny);
    if (nx > 0) {
        const size_t n = (size_t)nx * ny;
        float* a = malloc(n * sizeof *a);
        float* b = malloc(n * sizeof *b);
        if (tsk_wind_read_fluid(w, a, b, n) != TSK_OK) abort();
        for (size_t i = 0; i < n; ++i)
            if (!isfinite(a[i]) || !isfinite(b[i])) abort();
        (void)tsk_wind_read_continuum(w, a, b, n);
        (void)tsk_wind_read_fluid(w, a, b, n + 1);
        free(a);
        free(b);
    }
    /* a saved state with fuzzed bytes: refused, or loaded and then stepping and sampling
     * stay finite */
    const size_t state_size = tsk_wind_state_size(w);
    unsigned char* state = malloc(state_size);
    if (tsk_wind_save_state(w, state, state_size) != TSK_OK) abort();
    const int flips = fz_u8(&r) % 6;
    for (int i = 0; i < flips; ++i) {
        const size_t at = (size_t)fz_u64(&r) % state_size;
        state[at] ^= fz_u8(&r);
    }
    const size_t load_size = (fz_u8(&r) % 32) ? state_size : state_size - 1;
    if (tsk_wind_load_state(w, state, load_size) == TSK_OK) {
        (void)tsk_wind_step(w, 1);
        if (tsk_wind_sample(w, tsk_wind_time(w), N, x, y, vx, vy, sx, sy) == TSK_OK) {
            for (int i = 0; i < N; ++i)
                if (!isfinite(vx[i]) || !isfinite(vy[i]) || !isfinite(sx[i]) || !isfinite(sy[i])) {
                    fprintf(stderr, "non-finite wind after loading a fuzzed state\n");
                    abort();
                }
        }
    }
    free(state);
    if (!isfinite(tsk_wind_time(w))) {
        fprintf(stderr, "wind time %g (dt %g)\n", tsk_wind_time(w), (double)f->dt);
        abort();
    }
    tsk_wind_destroy(w);
    fz_check_leaks("wind");
    return 0;
}
