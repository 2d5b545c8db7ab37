/* The vegetation continuum of seed 004 (III-D, eq. 3-4): a damped 2D wave on the fluid
 * grid whose amplitude Vp is the vegetation's sway, pulled towards the fluid velocity by
 * a spring and integrated with the seed's Verlet form. Edges absorb outgoing waves with
 * Mur's first-order condition. */
#include "wind_internal.h"

#include <math.h>
#include <string.h>

/* rows per parallel chunk: see row_grain_of in fluid.c */
static size_t row_grain_of(int nx, int ny) {
    return (size_t)nx * (size_t)ny <= 20000u ? (size_t)ny + 1u : 16u;
}

/* For the scheme Vp+ = (1+g) Vp - g Vp- - mu Vp (mu = dt^2 (c^2 k^2 + drive) for a mode of
 * wave number k, at most dt^2 (8 c^2 / h^2 + drive) on the grid), both roots of
 * z^2 - (1 + g - mu) z + g = 0 lie inside the unit circle iff 0 <= mu < 2 (1 + g). */
tsk_status tsk_continuum_check(float c, float gamma, float drive, float h, float dt) {
    const double lim = 2.0 * (1.0 + (double)gamma);
    const double dt2 = (double)dt * dt;
    if (drive * dt2 >= lim)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "continuum.drive",
                             "%g 1/s^2 is unstable with dt = %g s and gamma = %g: need "
                             "drive * dt^2 < 2 (1 + gamma), i.e. drive < %g",
                             (double)drive, (double)dt, (double)gamma, lim / dt2);
    const double mu = dt2 * (8.0 * (double)c * c / ((double)h * h) + drive);
    if (!(mu < lim)) {
        const double cmax = sqrt((lim / dt2 - drive) * (double)h * h / 8.0);
        return tsk_error_arg(TSK_ERR_ARGUMENT, "continuum.c",
                             "%g m/s is unstable (CFL): c*dt/dx = %g with dt = %g s, cell %g m, "
                             "gamma = %g, drive = %g; this scheme needs "
                             "dt^2 (8 c^2/dx^2 + drive) < 2 (1 + gamma), so c < %g m/s "
                             "(c*dt/dx < %g)",
                             (double)c, (double)c * dt / h, (double)dt, (double)h, (double)gamma,
                             (double)drive, cmax, cmax * dt / h);
    }
    return TSK_OK;
}

tsk_status tsk_continuum_init(tsk_continuum* w, int nx, int ny, float h, float dt, float c,
                              float gamma, float drive) {
    memset(w, 0, sizeof *w);
    tsk_status s = tsk_continuum_check(c, gamma, drive, h, dt);
    if (s != TSK_OK) return s;
    w->nx = nx;
    w->ny = ny;
    w->h = h;
    w->dt = dt;
    w->c = c;
    w->gamma = gamma;
    w->drive = drive;
    const size_t n = (size_t)(nx + 2) * (size_t)(ny + 2);
    int ok = 1;
    for (int k = 0; k < 3; ++k) {
        w->x[k] = tsk_calloc(n, sizeof(float), "wind continuum");
        w->y[k] = tsk_calloc(n, sizeof(float), "wind continuum");
        ok = ok && w->x[k] && w->y[k];
    }
    if (!ok) {
        tsk_continuum_free(w);
        return TSK_ERR_MEMORY;
    }
    return TSK_OK;
}

void tsk_continuum_free(tsk_continuum* w) {
    for (int k = 0; k < 3; ++k) {
        tsk_free(w->x[k]);
        tsk_free(w->y[k]);
    }
    memset(w, 0, sizeof *w);
}

float* tsk_continuum_cur_x(tsk_continuum* w) { return w->x[w->cur]; }
float* tsk_continuum_cur_y(tsk_continuum* w) { return w->y[w->cur]; }
float* tsk_continuum_prev_x(tsk_continuum* w) { return w->x[(w->cur + 2) % 3]; }
float* tsk_continuum_prev_y(tsk_continuum* w) { return w->y[(w->cur + 2) % 3]; }

typedef struct step_ctx {
    const tsk_continuum* w;
    const float* wind[2];
    const float* cur[2];
    const float* prev[2];
    float* next[2];
} step_ctx;

TSK_WIND_CLONES
static void step_rows(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const step_ctx* s = vctx;
    const tsk_continuum* w = s->w;
    const size_t nx = (size_t)w->nx, stride = nx + 2;
    const float c2 = w->c * w->c / (w->h * w->h), dt2 = w->dt * w->dt;
    const float g1 = 1.0f + w->gamma, g = w->gamma, drive = w->drive;
    for (int comp = 0; comp < 2; ++comp) {
        for (size_t j = b; j < e; ++j) {
            const float* restrict p = s->cur[comp] + (j + 1) * stride + 1;
            const float* restrict pl = p - 1;
            const float* restrict pr = p + 1;
            const float* restrict pd = p - stride;
            const float* restrict pu = p + stride;
            const float* restrict q = s->prev[comp] + (j + 1) * stride + 1;
            float* restrict r = s->next[comp] + (j + 1) * stride + 1;
            const float* restrict f = s->wind[comp] ? s->wind[comp] + j * nx : NULL;
            if (f) {
                for (size_t i = 0; i < nx; ++i) {
                    /* seed 004, eq. 3 plus the drive spring towards the wind */
                    const float lap = ((pl[i] + pr[i]) + (pd[i] + pu[i])) - 4.0f * p[i];
                    const float a = c2 * lap + drive * (f[i] - p[i]);
                    /* seed 004, eq. 4 */
                    r[i] = (g1 * p[i] - g * q[i]) + a * dt2;
                }
            } else {
                for (size_t i = 0; i < nx; ++i) {
                    const float lap = ((pl[i] + pr[i]) + (pd[i] + pu[i])) - 4.0f * p[i];
                    const float a = c2 * lap - drive * p[i];
                    r[i] = (g1 * p[i] - g * q[i]) + a * dt2;
                }
            }
        }
    }
}

/* Mur's first-order absorbing edge: the ghost value follows the outgoing wave,
 * u_g^{n+1} = u_1^n + m (u_1^{n+1} - u_g^n), m = (c dt - h) / (c dt + h). */
static void mur_edges(const tsk_continuum* w, const float* p, float* r) {
    const int nx = w->nx, ny = w->ny;
    const size_t s = (size_t)nx + 2;
    const float m = (w->c * w->dt - w->h) / (w->c * w->dt + w->h);
    for (int j = 0; j < ny; ++j) {
        const size_t row = (size_t)(j + 1) * s;
        r[row] = p[row + 1] + m * (r[row + 1] - p[row]);
        r[row + nx + 1] = p[row + nx] + m * (r[row + nx] - p[row + nx + 1]);
    }
    const size_t top = (size_t)(ny + 1) * s, below_top = (size_t)ny * s;
    for (int i = 1; i <= nx; ++i) {
        r[i] = p[s + i] + m * (r[s + i] - p[i]);
        r[top + i] = p[below_top + i] + m * (r[below_top + i] - p[top + i]);
    }
}

void tsk_continuum_step(tsk_continuum* w, const float* wind_x, const float* wind_y) {
    const int next = (w->cur + 1) % 3, prev = (w->cur + 2) % 3;
    step_ctx s = {w,
                  {wind_x, wind_y},
                  {w->x[w->cur], w->y[w->cur]},
                  {w->x[prev], w->y[prev]},
                  {w->x[next], w->y[next]}};
    tsk_parallel_for((size_t)w->ny, row_grain_of(w->nx, w->ny), step_rows, &s);
    mur_edges(w, w->x[w->cur], w->x[next]);
    mur_edges(w, w->y[w->cur], w->y[next]);
    w->cur = next;
}

static inline float bilinear_cells(const float* q, int nx, int ny, float fx, float fy) {
    /* q is ghosted; sample the interior centres (cell i centre at i + 0.5) with
     * zero-gradient beyond the edge */
    fx -= 0.5f;
    fy -= 0.5f;
    fx = fx < 0.0f ? 0.0f : (fx > (float)(nx - 1) ? (float)(nx - 1) : fx);
    fy = fy < 0.0f ? 0.0f : (fy > (float)(ny - 1) ? (float)(ny - 1) : fy);
    int i0 = (int)fx, j0 = (int)fy;
    if (i0 > nx - 2) i0 = nx - 2;
    if (j0 > ny - 2) j0 = ny - 2;
    const float tx = fx - (float)i0, ty = fy - (float)j0;
    const size_t s = (size_t)nx + 2;
    const float* r0 = q + (size_t)(j0 + 1) * s + (size_t)(i0 + 1);
    const float* r1 = r0 + s;
    const float a = r0[0] + (r0[1] - r0[0]) * tx;
    const float b = r1[0] + (r1[1] - r1[0]) * tx;
    return a + (b - a) * ty;
}

void tsk_continuum_sample_cells(const tsk_continuum* w, float cx, float cy, float* px, float* py) {
    *px = bilinear_cells(w->x[w->cur], w->nx, w->ny, cx, cy);
    *py = bilinear_cells(w->y[w->cur], w->nx, w->ny, cx, cy);
}
