/* The wind handle: one definition, one clock, the sines history, the fluid grid with its
 * sources and the continuum, stepped together and read out for debug images. */
#include "wind_internal.h"

#include <math.h>
#include <string.h>

tsk_status tsk_wind_create(const tsk_wind_def* def, tsk_wind** out) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "must not be NULL");
    *out = NULL;
    tsk_status s = tsk_wind_def_validate(def);
    if (s != TSK_OK) return s;
    /* memory budget: fluid (velocity, scratch, pressure, divergence) and continuum grids */
    s = tsk_memory_check((double)def->fluid.nx * (double)def->fluid.ny * 24.0 * sizeof(float),
                         "fluid.nx");
    if (s != TSK_OK) return s;
    tsk_wind* w = tsk_calloc(1, sizeof *w, "wind handle");
    if (w == NULL) return TSK_ERR_MEMORY;
    w->def = *def;
    w->dt = def->fluid.dt;
    tsk_sines_history_reset(&w->sines, &def->sines);
    if (def->fluid.nx > 0) {
        s = tsk_fluid_init(&w->fluid, &def->fluid);
        if (s != TSK_OK) {
            tsk_wind_destroy(w);
            return s;
        }
        w->has_fluid = 1;
        if (def->continuum.enabled) {
            s = tsk_continuum_init(&w->continuum, def->fluid.nx, def->fluid.ny,
                                   def->fluid.cell_size, def->fluid.dt, def->continuum.c,
                                   def->continuum.gamma, def->continuum.drive);
            if (s != TSK_OK) {
                tsk_wind_destroy(w);
                return s;
            }
            w->has_continuum = 1;
        }
    }
    *out = w;
    return TSK_OK;
}

void tsk_wind_destroy(tsk_wind* w) {
    if (w == NULL) return;
    if (w->has_fluid) tsk_fluid_free(&w->fluid);
    if (w->has_continuum) tsk_continuum_free(&w->continuum);
    tsk_free(w);
}

tsk_status tsk_wind_set_sines(tsk_wind* w, const tsk_wind_sines_def* def, double start_time,
                              double blend_time) {
    if (w == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "wind", "must not be NULL");
    tsk_status s = tsk_wind_sines_def_validate(def);
    if (s != TSK_OK) return s;
    if (!isfinite(start_time) || fabs(start_time) > 1e12)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "start_time", "must be finite, |t| <= 1e12, got %g",
                             start_time);
    if (!isfinite(blend_time) || blend_time < 0.0 || blend_time > 1e6)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "blend_time", "must be in [0, 1e6] s, got %g",
                             blend_time);
    tsk_sines_history_push(&w->sines, def, start_time, blend_time);
    w->def.sines = *def;
    return TSK_OK;
}

tsk_status tsk_wind_set_sources(tsk_wind* w, const tsk_wind_source* sources, size_t count) {
    if (w == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "wind", "must not be NULL");
    if (count > TSK_WIND_MAX_SOURCES)
        return tsk_error_arg(TSK_ERR_LIMIT, "count", "at most %d sources, got %zu",
                             TSK_WIND_MAX_SOURCES, count);
    if (count > 0 && sources == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "sources", "must not be NULL when count > 0");
    for (size_t i = 0; i < count; ++i) {
        tsk_status s = tsk_wind_source_validate(&sources[i], i);
        if (s != TSK_OK) return s;
    }
    if (count > 0) memcpy(w->sources, sources, count * sizeof *sources);
    w->source_count = (int)count;
    return TSK_OK;
}

tsk_status tsk_wind_step(tsk_wind* w, int steps) {
    if (w == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "wind", "must not be NULL");
    if (steps < 0 || steps > 1000000)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "steps", "must be 0..1000000, got %d", steps);
    for (int n = 0; n < steps; ++n) {
        const double t0 = (double)w->steps * w->dt, t1 = (double)(w->steps + 1) * w->dt;
        if (w->has_fluid) {
            tsk_fluid* f = &w->fluid;
            tsk_fluid_apply_sources(f, w->def.fluid.origin_x, w->def.fluid.origin_y, w->sources,
                                    w->source_count, t0, t1);
            tsk_fluid_diffuse(f);
            tsk_fluid_advect(f);
            tsk_fluid_project(f);
            tsk_fluid_finish(f);
            tsk_fluid_update_centres(f);
            /* seed 004, III-D: the continuum is driven by the fluid at its cell centres */
            if (w->has_continuum) tsk_continuum_step(&w->continuum, f->cx, f->cy);
        }
        ++w->steps;
    }
    return TSK_OK;
}

double tsk_wind_time(const tsk_wind* w) { return w ? (double)w->steps * w->dt : 0.0; }

void tsk_wind_grid_size(const tsk_wind* w, int* nx, int* ny) {
    int a = 0, b = 0;
    if (w && w->has_fluid) {
        a = w->fluid.nx;
        b = w->fluid.ny;
    }
    if (nx) *nx = a;
    if (ny) *ny = b;
}

static tsk_status check_grid_out(const tsk_wind* w, const float* a, const float* b, size_t count,
                                 const char* na, const char* nb) {
    if (w == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "wind", "must not be NULL");
    if (!w->has_fluid)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "wind", "has no fluid grid (fluid.nx = 0)");
    const size_t n = (size_t)w->fluid.nx * (size_t)w->fluid.ny;
    if (count != n)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "count", "must be nx*ny = %zu, got %zu", n, count);
    if (a == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, na, "must not be NULL");
    if (b == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, nb, "must not be NULL");
    return TSK_OK;
}

tsk_status tsk_wind_read_fluid(const tsk_wind* w, float* vx, float* vy, size_t count) {
    tsk_status s = check_grid_out(w, vx, vy, count, "vx", "vy");
    if (s != TSK_OK) return s;
    memcpy(vx, w->fluid.cx, count * sizeof(float));
    memcpy(vy, w->fluid.cy, count * sizeof(float));
    return TSK_OK;
}

tsk_status tsk_wind_read_continuum(const tsk_wind* w, float* px, float* py, size_t count) {
    tsk_status s = check_grid_out(w, px, py, count, "px", "py");
    if (s != TSK_OK) return s;
    const int nx = w->fluid.nx, ny = w->fluid.ny;
    if (!w->has_continuum) {
        memset(px, 0, count * sizeof(float));
        memset(py, 0, count * sizeof(float));
        return TSK_OK;
    }
    const tsk_continuum* c = &w->continuum;
    for (int j = 0; j < ny; ++j) {
        memcpy(px + (size_t)j * nx, c->x[c->cur] + tsk_continuum_index(c, 0, j),
               (size_t)nx * sizeof(float));
        memcpy(py + (size_t)j * nx, c->y[c->cur] + tsk_continuum_index(c, 0, j),
               (size_t)nx * sizeof(float));
    }
    return TSK_OK;
}
