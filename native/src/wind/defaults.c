/* Default wind definitions and their validation: every limit of wind.h is checked here,
 * and every error names the field that broke it. */
#include "wind_internal.h"

#include <math.h>
#include <stdio.h>

tsk_wind_wave tsk_default_wind_wave(void) {
    tsk_wind_wave w = {0};
    w.amplitude = 1.0f;
    w.dir_x = 1.0f;
    w.dir_y = 0.0f;
    w.wavelength = 20.0f;
    w.speed = 4.0f;
    w.phase = 0.0f;
    w.power = 2.0f;
    return w;
}

tsk_wind_gust_def tsk_default_wind_gust_def(void) {
    tsk_wind_gust_def g = {0};
    g.strength = 1.5f;
    g.interval = 8.0f;
    g.duration = 3.0f;
    g.dir_x = 1.0f;
    g.dir_y = 0.0f;
    g.front_speed = 6.0f;
    g.seed = 1;
    return g;
}

tsk_wind_sines_def tsk_default_wind_sines_def(void) {
    tsk_wind_sines_def d = {0};
    d.base_x = 2.0f;
    d.base_y = 0.0f;
    d.wave_count = 2;
    d.waves[0] = tsk_default_wind_wave();
    d.waves[1] = tsk_default_wind_wave();
    d.waves[1].amplitude = 0.5f;
    d.waves[1].dir_x = 0.8f;
    d.waves[1].dir_y = 0.6f;
    d.waves[1].wavelength = 7.0f;
    d.waves[1].speed = 3.0f;
    d.waves[1].phase = 1.0f;
    d.waves[1].power = 1.0f;
    d.gust = tsk_default_wind_gust_def();
    return d;
}

tsk_wind_fluid_def tsk_default_wind_fluid_def(void) {
    tsk_wind_fluid_def f = {0};
    f.nx = 64;
    f.ny = 64;
    f.origin_x = -16.0f;
    f.origin_y = -16.0f;
    f.cell_size = 0.5f;
    f.dt = 1.0f / 60.0f;
    f.speed = 3.0f;
    f.viscosity = 0.0f;
    f.decay = 0.1f;
    f.pressure_iterations = 40;
    f.pressure_tolerance = 0.0f;
    f.diffusion_iterations = 20;
    return f;
}

tsk_wind_continuum_def tsk_default_wind_continuum_def(void) {
    tsk_wind_continuum_def c = {0};
    c.enabled = 1;
    c.c = 4.0f;
    c.gamma = 0.98f;
    c.drive = 9.8696044f; /* (2 pi 0.5 Hz)^2 */
    return c;
}

tsk_wind_def tsk_default_wind_def(void) {
    tsk_wind_def d;
    d.sines = tsk_default_wind_sines_def();
    d.fluid = tsk_default_wind_fluid_def();
    d.continuum = tsk_default_wind_continuum_def();
    return d;
}

tsk_wind_source tsk_default_wind_source(void) {
    tsk_wind_source s = {0};
    s.x = -14.0f;
    s.y = 0.0f;
    s.dir_x = 1.0f;
    s.dir_y = 0.0f;
    s.strength = 0.8f;
    s.radius = 3.0f;
    s.interval = 0.5f;
    s.start = 0.0f;
    return s;
}

/* value must be finite and in [lo, hi] */
static tsk_status check_range(const char* name, float value, float lo, float hi) {
    if (!isfinite(value))
        return tsk_error_arg(TSK_ERR_ARGUMENT, name, "must be a finite number, got %g",
                             (double)value);
    if (value < lo || value > hi)
        return tsk_error_arg(TSK_ERR_ARGUMENT, name, "must be in [%g, %g], got %g", (double)lo,
                             (double)hi, (double)value);
    return TSK_OK;
}

static tsk_status check_dir(const char* name, float dx, float dy) {
    if (!isfinite(dx) || !isfinite(dy))
        return tsk_error_arg(TSK_ERR_ARGUMENT, name, "must be finite, got (%g, %g)", (double)dx,
                             (double)dy);
    const double len = sqrt((double)dx * dx + (double)dy * dy);
    if (!(len > 1e-12) || !isfinite(len))
        return tsk_error_arg(TSK_ERR_ARGUMENT, name,
                             "must be a non-zero direction on the ground plane, got (%g, %g)",
                             (double)dx, (double)dy);
    return TSK_OK;
}

#define TRY(call)                    \
    do {                             \
        tsk_status s_ = (call);      \
        if (s_ != TSK_OK) return s_; \
    } while (0)

tsk_status tsk_wind_sines_def_validate(const tsk_wind_sines_def* d) {
    if (d == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "sines", "must not be NULL");
    TRY(check_range("sines.base_x", d->base_x, -100.0f, 100.0f));
    TRY(check_range("sines.base_y", d->base_y, -100.0f, 100.0f));
    if (d->wave_count < 0 || d->wave_count > TSK_WIND_MAX_WAVES)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "sines.wave_count", "must be 0..%d, got %d",
                             TSK_WIND_MAX_WAVES, d->wave_count);
    char name[64];
    for (int i = 0; i < d->wave_count; ++i) {
        const tsk_wind_wave* w = &d->waves[i];
#define FIELD(f) (snprintf(name, sizeof name, "sines.waves[%d]." f, i), name)
        TRY(check_range(FIELD("amplitude"), w->amplitude, 0.0f, 100.0f));
        TRY(check_dir(FIELD("dir"), w->dir_x, w->dir_y));
        TRY(check_range(FIELD("wavelength"), w->wavelength, 0.01f, 1e5f));
        TRY(check_range(FIELD("speed"), w->speed, -1000.0f, 1000.0f));
        TRY(check_range(FIELD("phase"), w->phase, -1e4f, 1e4f));
        TRY(check_range(FIELD("power"), w->power, 0.1f, 64.0f));
#undef FIELD
    }
    const tsk_wind_gust_def* g = &d->gust;
    TRY(check_range("sines.gust.strength", g->strength, 0.0f, 100.0f));
    TRY(check_range("sines.gust.interval", g->interval, 1e-3f, 1e6f));
    TRY(check_range("sines.gust.duration", g->duration, 1e-3f, g->interval));
    TRY(check_dir("sines.gust.dir", g->dir_x, g->dir_y));
    if (g->front_speed != 0.0f)
        TRY(check_range("sines.gust.front_speed", g->front_speed, 1e-3f, 1e4f));
    return TSK_OK;
}

tsk_status tsk_wind_fluid_def_validate(const tsk_wind_fluid_def* f) {
    if (f->nx == 0 && f->ny == 0) { /* no grid: the clock still advances by dt */
        TRY(check_range("fluid.dt", f->dt, 1e-4f, 1.0f));
        return TSK_OK;
    }
    if (f->nx < 0 || f->ny < 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, f->nx < 0 ? "fluid.nx" : "fluid.ny",
                             "must not be negative, got %d", f->nx < 0 ? f->nx : f->ny);
    if (f->nx > TSK_WIND_MAX_GRID || f->ny > TSK_WIND_MAX_GRID)
        return tsk_error_arg(TSK_ERR_LIMIT, f->nx > TSK_WIND_MAX_GRID ? "fluid.nx" : "fluid.ny",
                             "must be at most %d cells, got %d", TSK_WIND_MAX_GRID,
                             f->nx > TSK_WIND_MAX_GRID ? f->nx : f->ny);
    if (f->nx < TSK_WIND_MIN_GRID || f->ny < TSK_WIND_MIN_GRID)
        return tsk_error_arg(TSK_ERR_ARGUMENT, f->nx < TSK_WIND_MIN_GRID ? "fluid.nx" : "fluid.ny",
                             "must be at least %d cells (or nx = ny = 0 for no grid), got %d",
                             TSK_WIND_MIN_GRID, f->nx < TSK_WIND_MIN_GRID ? f->nx : f->ny);
    TRY(check_range("fluid.origin_x", f->origin_x, -1e6f, 1e6f));
    TRY(check_range("fluid.origin_y", f->origin_y, -1e6f, 1e6f));
    TRY(check_range("fluid.cell_size", f->cell_size, 1e-3f, 1e4f));
    TRY(check_range("fluid.dt", f->dt, 1e-4f, 1.0f));
    TRY(check_range("fluid.speed", f->speed, 0.0f, 100.0f));
    TRY(check_range("fluid.viscosity", f->viscosity, 0.0f, 1e6f));
    TRY(check_range("fluid.decay", f->decay, 0.0f, 1e4f));
    if (f->pressure_iterations < 1 || f->pressure_iterations > TSK_WIND_MAX_ITERATIONS)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "fluid.pressure_iterations", "must be 1..%d, got %d",
                             TSK_WIND_MAX_ITERATIONS, f->pressure_iterations);
    TRY(check_range("fluid.pressure_tolerance", f->pressure_tolerance, 0.0f, 1.0f));
    if (f->diffusion_iterations < 1 || f->diffusion_iterations > 1000)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "fluid.diffusion_iterations",
                             "must be 1..1000, got %d", f->diffusion_iterations);
    return TSK_OK;
}

tsk_status tsk_wind_continuum_def_validate(const tsk_wind_continuum_def* c,
                                           const tsk_wind_fluid_def* f) {
    if (c->enabled != 0 && c->enabled != 1)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "continuum.enabled", "must be 0 or 1, got %d",
                             c->enabled);
    if (!c->enabled) return TSK_OK;
    if (f->nx == 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "continuum.enabled",
                             "the continuum lives on the fluid grid: set fluid.nx, fluid.ny");
    TRY(check_range("continuum.c", c->c, 0.0f, 1e5f));
    TRY(check_range("continuum.gamma", c->gamma, 0.0f, 1.0f));
    TRY(check_range("continuum.drive", c->drive, 0.0f, 1e8f));
    return tsk_continuum_check(c->c, c->gamma, c->drive, f->cell_size, f->dt);
}

tsk_status tsk_wind_def_validate(const tsk_wind_def* def) {
    if (def == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "def", "must not be NULL");
    TRY(tsk_wind_sines_def_validate(&def->sines));
    TRY(tsk_wind_fluid_def_validate(&def->fluid));
    TRY(tsk_wind_continuum_def_validate(&def->continuum, &def->fluid));
    return TSK_OK;
}

tsk_status tsk_wind_source_validate(const tsk_wind_source* s, size_t index) {
    char name[64];
#define FIELD(f) (snprintf(name, sizeof name, "sources[%zu]." f, index), name)
    TRY(check_range(FIELD("x"), s->x, -1e6f, 1e6f));
    TRY(check_range(FIELD("y"), s->y, -1e6f, 1e6f));
    TRY(check_dir(FIELD("dir"), s->dir_x, s->dir_y));
    TRY(check_range(FIELD("strength"), s->strength, 0.0f, 1.0f));
    TRY(check_range(FIELD("radius"), s->radius, 1e-4f, 1e6f));
    TRY(check_range(FIELD("interval"), s->interval, 0.0f, 1e6f));
    TRY(check_range(FIELD("start"), s->start, -1e9f, 1e9f));
#undef FIELD
    return TSK_OK;
}
