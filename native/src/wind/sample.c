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

/* Bilinear sampling of two centre grids qa, qb (rows of `stride` floats from cell (0, 0))
 * at cell coordinates (x - ox) / h; beyond the edge the edge value repeats.
 * oa[i] += scale * a, ob[i] += scale * b. Branch-free so that the loop vectorises. */
TSK_WIND_CLONES
static void bilinear2_add(const float* qa, const float* qb, int nx, int ny, size_t stride, float ox,
                          float oy, float inv_h, float scale, size_t n, const float* restrict x,
                          const float* restrict y, float* restrict oa, float* restrict ob) {
    const float mx = (float)(nx - 1), my = (float)(ny - 1);
    const int lx = nx - 2, ly = ny - 2, st = (int)stride; /* grids <= 1026 wide: int fits */
    for (int i = 0; i < (int)n; ++i) {
        float fx = (x[i] - ox) * inv_h - 0.5f, fy = (y[i] - oy) * inv_h - 0.5f;
        fx = fx > 0.0f ? fx : 0.0f;
        fx = fx < mx ? fx : mx;
        fy = fy > 0.0f ? fy : 0.0f;
        fy = fy < my ? fy : my;
        int i0 = (int)fx, j0 = (int)fy;
        i0 = i0 < lx ? i0 : lx;
        j0 = j0 < ly ? j0 : ly;
        const float tx = fx - (float)i0, ty = fy - (float)j0;
        const int k = j0 * st + i0, k2 = k + st;
        const float a0 = qa[k] + (qa[k + 1] - qa[k]) * tx;
        const float a1 = qa[k2] + (qa[k2 + 1] - qa[k2]) * tx;
        const float b0 = qb[k] + (qb[k + 1] - qb[k]) * tx;
        const float b1 = qb[k2] + (qb[k2 + 1] - qb[k2]) * tx;
        oa[i] += scale * (a0 + (a1 - a0) * ty);
        ob[i] += scale * (b0 + (b1 - b0) * ty);
    }
}

static void sample_block(const sample_ctx* c, size_t n, const float* x, const float* y, float* vx,
                         float* vy, float* sx, float* sy) {
    const tsk_wind* w = c->w;
    const tsk_sines_eval* ev = c->ev;
    for (size_t i = 0; i < n; ++i) {
        vx[i] = ev->base_x;
        vy[i] = ev->base_y;
    }
    tsk_sines_accumulate(ev, n, x, y, vx, vy);
    if (ev->gust_count > 0) tsk_gust_accumulate(ev, n, x, y, vx, vy);
    if (sx)
        for (size_t i = 0; i < n; ++i) sx[i] = sy[i] = 0.0f;
    if (!w->has_fluid) return;
    const tsk_fluid* f = &w->fluid;
    const float ox = w->def.fluid.origin_x, oy = w->def.fluid.origin_y, inv_h = 1.0f / f->h;
    bilinear2_add(f->cx, f->cy, f->nx, f->ny, (size_t)f->nx, ox, oy, inv_h, f->speed, n, x, y, vx,
                  vy);
    if (sx && w->has_continuum) {
        const tsk_continuum* k = &w->continuum;
        const size_t s = (size_t)k->nx + 2;
        bilinear2_add(k->x[k->cur] + s + 1, k->y[k->cur] + s + 1, k->nx, k->ny, s, ox, oy, inv_h,
                      1.0f, n, x, y, sx, sy);
    }
}

static int finite_block(const float* a, size_t n) {
    int ok = 1;
    for (size_t i = 0; i < n; ++i) ok &= fabsf(a[i]) <= 1e7f; /* false for NaN and inf */
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
