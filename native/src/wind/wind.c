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

/* ---- saved states ----------------------------------------------------------------------- */

/* A state is this header, then the sines history and the sources as their structs, then
 * the float arrays: fluid u, v, phi (warm start), continuum current x, y and previous x, y.
 * The centre velocities are not stored: they are a function of u and v, remade on load.
 * The continuum's third level is not stored either: the next step overwrites it, all but
 * its four corners, which no step writes or reads (they stay 0 from creation). */
enum { STATE_MAGIC = 0x574B5354u /* "TSKW" */, STATE_VERSION = 1u };

typedef struct state_header {
    uint32_t magic, version;
    int32_t nx, ny, has_fluid, has_continuum;
    uint64_t def_hash; /* of the fluid and continuum definitions */
    uint64_t steps;
    int32_t source_count, cur;
    int32_t last_iterations;
    float last_divergence;
} state_header;

static uint64_t fnv(const void* p, size_t n, uint64_t h) {
    const unsigned char* b = p;
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
    return h;
}

/* both definitions are plain 4-byte fields: no padding bytes enter the hash */
static uint64_t def_hash(const tsk_wind* w) {
    uint64_t h = fnv(&w->def.fluid, sizeof w->def.fluid, 1469598103934665603ull);
    const tsk_wind_continuum_def c =
        w->has_continuum ? w->def.continuum : (tsk_wind_continuum_def){0, 0, 0, 0};
    return fnv(&c, sizeof c, h);
}

typedef struct state_layout {
    size_t nu, nv, np, nc; /* floats of u, v, phi, one continuum level component */
} state_layout;

static state_layout layout_of(const tsk_wind* w) {
    state_layout l = {0, 0, 0, 0};
    if (w->has_fluid) {
        const size_t nx = (size_t)w->fluid.nx, ny = (size_t)w->fluid.ny;
        l.nu = (nx + 1) * ny;
        l.nv = nx * (ny + 1);
        l.np = (nx + 2) * (ny + 2);
        if (w->has_continuum) l.nc = (nx + 2) * (ny + 2);
    }
    return l;
}

size_t tsk_wind_state_size(const tsk_wind* w) {
    if (w == NULL) return 0;
    const state_layout l = layout_of(w);
    return sizeof(state_header) + sizeof(tsk_sines_history) +
           sizeof(tsk_wind_source) * TSK_WIND_MAX_SOURCES +
           sizeof(float) * (l.nu + l.nv + l.np + 4 * l.nc);
}

static unsigned char* put(unsigned char* p, const void* src, size_t n) {
    memcpy(p, src, n);
    return p + n;
}

tsk_status tsk_wind_save_state(const tsk_wind* w, void* buf, size_t size) {
    if (w == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "wind", "must not be NULL");
    if (buf == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "buf", "must not be NULL");
    const size_t need = tsk_wind_state_size(w);
    if (size != need)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "size", "must be the state size %zu, got %zu", need,
                             size);
    state_header hd;
    memset(&hd, 0, sizeof hd);
    hd.magic = STATE_MAGIC;
    hd.version = STATE_VERSION;
    hd.nx = w->has_fluid ? w->fluid.nx : 0;
    hd.ny = w->has_fluid ? w->fluid.ny : 0;
    hd.has_fluid = w->has_fluid;
    hd.has_continuum = w->has_continuum;
    hd.def_hash = def_hash(w);
    hd.steps = w->steps;
    hd.source_count = w->source_count;
    hd.cur = w->has_continuum ? w->continuum.cur : 0;
    hd.last_iterations = w->has_fluid ? w->fluid.last_iterations : 0;
    hd.last_divergence = w->has_fluid ? w->fluid.last_divergence : 0.0f;
    unsigned char* p = put(buf, &hd, sizeof hd);
    p = put(p, &w->sines, sizeof w->sines);
    p = put(p, w->sources, sizeof w->sources);
    const state_layout l = layout_of(w);
    if (w->has_fluid) {
        p = put(p, w->fluid.u, l.nu * sizeof(float));
        p = put(p, w->fluid.v, l.nv * sizeof(float));
        p = put(p, w->fluid.phi, l.np * sizeof(float));
    }
    if (w->has_continuum) {
        const tsk_continuum* c = &w->continuum;
        const int prev = (c->cur + 2) % 3;
        p = put(p, c->x[c->cur], l.nc * sizeof(float));
        p = put(p, c->y[c->cur], l.nc * sizeof(float));
        p = put(p, c->x[prev], l.nc * sizeof(float));
        p = put(p, c->y[prev], l.nc * sizeof(float));
    }
    return TSK_OK;
}

/* 1 if all n floats at p (unaligned) are finite and |v| <= bound */
static int floats_ok(const unsigned char* p, size_t n, float bound) {
    for (size_t i = 0; i < n; ++i) {
        float v;
        memcpy(&v, p + i * sizeof v, sizeof v);
        if (!(fabsf(v) <= bound)) return 0;
    }
    return 1;
}

static tsk_status bad_state(const char* why) {
    return tsk_error_arg(TSK_ERR_ARGUMENT, "state", "%s", why);
}

tsk_status tsk_wind_load_state(tsk_wind* w, const void* buf, size_t size) {
    if (w == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "wind", "must not be NULL");
    if (buf == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "buf", "must not be NULL");
    const size_t need = tsk_wind_state_size(w);
    if (size != need)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "size",
                             "must be this wind's state size %zu, got %zu (a state of another "
                             "grid?)",
                             need, size);
    /* everything is checked before anything changes */
    const unsigned char* p = buf;
    state_header hd;
    memcpy(&hd, p, sizeof hd);
    p += sizeof hd;
    if (hd.magic != STATE_MAGIC || hd.version != STATE_VERSION)
        return bad_state("is not a saved wind state of this version");
    const int nx = w->has_fluid ? w->fluid.nx : 0, ny = w->has_fluid ? w->fluid.ny : 0;
    if (hd.nx != nx || hd.ny != ny || hd.has_fluid != w->has_fluid ||
        hd.has_continuum != w->has_continuum || hd.def_hash != def_hash(w))
        return bad_state("was saved by a wind of another fluid or continuum definition");
    if (hd.source_count < 0 || hd.source_count > TSK_WIND_MAX_SOURCES)
        return bad_state("has a source count outside 0..64");
    if (hd.cur < 0 || hd.cur > 2) return bad_state("has a continuum level outside 0..2");
    if (hd.steps > (uint64_t)1 << 53) return bad_state("has a step count beyond 2^53");
    tsk_sines_history h;
    memcpy(&h, p, sizeof h);
    p += sizeof h;
    if (h.count < 1 || h.count > TSK_WIND_BLEND_HISTORY)
        return bad_state("has a sines history count outside 1..4");
    for (int i = 0; i < h.count; ++i) {
        tsk_status s = tsk_wind_sines_def_validate(&h.sets[i]);
        if (s != TSK_OK) return s;
        if (i > 0 && !(isfinite(h.start[i]) && isfinite(h.blend[i]) && h.blend[i] >= 0.0))
            return bad_state("has a sines history with a non-finite start or blend time");
    }
    tsk_wind_source src[TSK_WIND_MAX_SOURCES];
    memcpy(src, p, sizeof src);
    p += sizeof src;
    for (int i = 0; i < hd.source_count; ++i) {
        tsk_status s = tsk_wind_source_validate(&src[i], (size_t)i);
        if (s != TSK_OK) return s;
    }
    const state_layout l = layout_of(w);
    const unsigned char* grids = p;
    if (!floats_ok(grids, l.nu + l.nv, 1.0f))
        return bad_state("has fluid velocities that are not finite or beyond 1");
    /* bounds far above what a wind reaches (|v| <= 1 drives everything: the pressure of a
     * 1024^2 grid stays below ~1e6, the continuum near 1), low enough that no sum of them
     * overflows in a step */
    if (!floats_ok(grids + (l.nu + l.nv) * sizeof(float), l.np, 1e9f))
        return bad_state("has a pressure that is not finite or beyond 1e9");
    if (!floats_ok(grids + (l.nu + l.nv + l.np) * sizeof(float), 4 * l.nc, 1e4f))
        return bad_state("has a continuum value that is not finite or beyond 1e4");
    if (hd.has_fluid && !(isfinite(hd.last_divergence)))
        return bad_state("has a non-finite divergence");

    w->steps = hd.steps;
    w->sines = h;
    w->def.sines = h.sets[h.count - 1];
    memcpy(w->sources, src, sizeof src);
    w->source_count = hd.source_count;
    if (w->has_fluid) {
        tsk_fluid* f = &w->fluid;
        memcpy(f->u, p, l.nu * sizeof(float));
        p += l.nu * sizeof(float);
        memcpy(f->v, p, l.nv * sizeof(float));
        p += l.nv * sizeof(float);
        memcpy(f->phi, p, l.np * sizeof(float));
        p += l.np * sizeof(float);
        f->last_iterations = hd.last_iterations;
        f->last_divergence = hd.last_divergence;
        tsk_fluid_update_centres(f);
    }
    if (w->has_continuum) {
        tsk_continuum* c = &w->continuum;
        c->cur = hd.cur;
        const int prev = (c->cur + 2) % 3;
        float* dst[4] = {c->x[c->cur], c->y[c->cur], c->x[prev], c->y[prev]};
        for (int k = 0; k < 4; ++k) {
            memcpy(dst[k], p, l.nc * sizeof(float));
            p += l.nc * sizeof(float);
        }
    }
    return TSK_OK;
}
