/* Batch sampling of the one wind at ground points: breeze + sines + gusts at time t, plus
 * the fluid (scaled to m/s) and the continuum sway at their current state. Points are
 * split into fixed chunks with tsk_parallel_for; each point is computed alone, so the
 * bytes never depend on the thread count. */
#include "wind_internal.h"

#include <math.h>
#include <stdatomic.h>
#include <string.h>

enum { BLOCK = 256, POINT_GRAIN = 8192 };

typedef struct sample_ctx {
    const tsk_wind* w;
    const tsk_sines_eval* ev;
    const float *x, *y, *xyz;
    float *vx, *vy, *sx, *sy, *vel_xyz, *sway_xyz;
    atomic_int bad; /* set by any chunk that saw a non-finite point */
} sample_ctx;

static void sample_block(const sample_ctx* c, size_t n, const float* x, const float* y,
                         float* vx, float* vy, float* sx, float* sy) {
    const tsk_wind* w = c->w;
    const tsk_sines_eval* ev = c->ev;
    for (size_t i = 0; i < n; ++i) {
        vx[i] = ev->base_x;
        vy[i] = ev->base_y;
    }
    tsk_sines_accumulate(ev, n, x, y, vx, vy);
    if (ev->gust_count > 0) tsk_gust_accumulate(ev, n, x, y, vx, vy);
    if (w->has_fluid) {
        const float ox = w->def.fluid.origin_x, oy = w->def.fluid.origin_y;
        const float inv_h = 1.0f / w->fluid.h, speed = w->fluid.speed;
        for (size_t i = 0; i < n; ++i) {
            const float cx = (x[i] - ox) * inv_h, cy = (y[i] - oy) * inv_h;
            float fx, fy;
            tsk_fluid_sample_cells(&w->fluid, cx, cy, &fx, &fy);
            vx[i] += speed * fx;
            vy[i] += speed * fy;
            if (sx) {
                if (w->has_continuum) {
                    tsk_continuum_sample_cells(&w->continuum, cx, cy, &sx[i], &sy[i]);
                } else {
                    sx[i] = 0.0f;
                    sy[i] = 0.0f;
                }
            }
        }
    } else if (sx) {
        for (size_t i = 0; i < n; ++i) sx[i] = sy[i] = 0.0f;
    }
}

static int finite_block(const float* a, size_t n) {
    int ok = 1;
    for (size_t i = 0; i < n; ++i) ok &= isfinite(a[i]) && fabsf(a[i]) <= 1e7f;
    return ok;
}

static void sample_chunk(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    sample_ctx* c = vctx;
    float bx[BLOCK], by[BLOCK], bvx[BLOCK], bvy[BLOCK], bsx[BLOCK], bsy[BLOCK];
    for (size_t s = b; s < e; s += BLOCK) {
        const size_t n = e - s < BLOCK ? e - s : BLOCK;
        if (c->xyz) {
            for (size_t i = 0; i < n; ++i) {
                bx[i] = c->xyz[3 * (s + i)];
                by[i] = c->xyz[3 * (s + i) + 1];
            }
        } else {
            memcpy(bx, c->x + s, n * sizeof(float));
            memcpy(by, c->y + s, n * sizeof(float));
        }
        if (!finite_block(bx, n) || !finite_block(by, n)) {
            atomic_store_explicit(&c->bad, 1, memory_order_relaxed);
            for (size_t i = 0; i < n; ++i) bvx[i] = bvy[i] = bsx[i] = bsy[i] = 0.0f;
        } else {
            const int want_sway = c->sx != NULL || c->sway_xyz != NULL;
            sample_block(c, n, bx, by, bvx, bvy, want_sway ? bsx : NULL, want_sway ? bsy : NULL);
        }
        if (c->vel_xyz) {
            for (size_t i = 0; i < n; ++i) {
                c->vel_xyz[3 * (s + i)] = bvx[i];
                c->vel_xyz[3 * (s + i) + 1] = bvy[i];
                c->vel_xyz[3 * (s + i) + 2] = 0.0f;
            }
            if (c->sway_xyz)
                for (size_t i = 0; i < n; ++i) {
                    c->sway_xyz[3 * (s + i)] = bsx[i];
                    c->sway_xyz[3 * (s + i) + 1] = bsy[i];
                    c->sway_xyz[3 * (s + i) + 2] = 0.0f;
                }
        } else {
            memcpy(c->vx + s, bvx, n * sizeof(float));
            memcpy(c->vy + s, bvy, n * sizeof(float));
            if (c->sx) {
                memcpy(c->sx + s, bsx, n * sizeof(float));
                memcpy(c->sy + s, bsy, n * sizeof(float));
            }
        }
    }
}

static tsk_status run(sample_ctx* c, double t, size_t count) {
    if (c->w == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "wind", "must not be NULL");
    if (!isfinite(t) || fabs(t) > 1e12)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "t", "must be finite, |t| <= 1e12 s, got %g", t);
    if (count > ((size_t)1 << 40))
        return tsk_error_arg(TSK_ERR_LIMIT, "count", "at most 2^40 points, got %zu", count);
    tsk_sines_eval ev;
    tsk_sines_history_eval(&c->w->sines, t, &ev);
    c->ev = &ev;
    atomic_init(&c->bad, 0);
    tsk_parallel_for(count, POINT_GRAIN, sample_chunk, c);
    if (atomic_load(&c->bad))
        return tsk_error_arg(TSK_ERR_ARGUMENT, c->xyz ? "xyz" : "x/y",
                             "points must be finite with |coordinate| <= 1e7 m (their outputs "
                             "were set to 0)");
    return TSK_OK;
}

tsk_status tsk_wind_sample(const tsk_wind* w, double t, size_t count, const float* x,
                           const float* y, float* vx, float* vy, float* sway_x, float* sway_y) {
    if (count > 0) {
        if (x == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "x", "must not be NULL");
        if (y == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "y", "must not be NULL");
        if (vx == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "vx", "must not be NULL");
        if (vy == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "vy", "must not be NULL");
    }
    if ((sway_x == NULL) != (sway_y == NULL))
        return tsk_error_arg(TSK_ERR_ARGUMENT, sway_x ? "sway_y" : "sway_x",
                             "sway_x and sway_y must both be given or both be NULL");
    sample_ctx c;
    memset(&c, 0, sizeof c);
    c.w = w;
    c.x = x;
    c.y = y;
    c.vx = vx;
    c.vy = vy;
    c.sx = sway_x;
    c.sy = sway_y;
    return run(&c, t, count);
}

tsk_status tsk_wind_sample_xyz(const tsk_wind* w, double t, size_t count, const float* xyz,
                               float* vel_xyz, float* sway_xyz) {
    if (count > 0) {
        if (xyz == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "must not be NULL");
        if (vel_xyz == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "vel_xyz", "must not be NULL");
    }
    sample_ctx c;
    memset(&c, 0, sizeof c);
    c.w = w;
    c.xyz = xyz;
    c.vel_xyz = vel_xyz;
    c.sway_xyz = sway_xyz;
    return run(&c, t, count);
}
