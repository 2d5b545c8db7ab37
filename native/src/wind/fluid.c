/* Stable fluids on the ground plane (seed 004, eq. 1-2; Stam 1999): semi-Lagrangian
 * advection, implicit viscosity and a pressure projection on a MAC grid, with open
 * boundaries (pressure 0 outside, zero-gradient velocity beyond the edge). Loops run over
 * rows with tsk_parallel_for; each row is written by one chunk only, so the bytes do not
 * depend on the thread count. */
#include "wind_internal.h"
#include "core/tmath.h"

#include <math.h>
#include <string.h>

/* Rows per parallel chunk. A grid of up to ~128^2 cells runs in one chunk on the calling
 * thread: each step runs ~50 parallel loops of a few microseconds, and below that size the
 * hand-offs to worker threads cost more than they save. Larger grids use chunks of 16 rows,
 * handed out dynamically, which also copes best with a busy machine. The chunking depends
 * only on the grid size, so the bytes never depend on the thread count. */
static size_t row_grain_of(int nx, int ny) {
    return (size_t)nx * (size_t)ny <= 20000u ? (size_t)ny + 1u : 16u;
}

tsk_status tsk_fluid_init(tsk_fluid* f, const tsk_wind_fluid_def* def) {
    memset(f, 0, sizeof *f);
    f->nx = def->nx;
    f->ny = def->ny;
    f->h = def->cell_size;
    f->dt = def->dt;
    f->speed = def->speed;
    f->viscosity = def->viscosity;
    f->decay = def->decay;
    f->tolerance = def->pressure_tolerance;
    f->iterations = def->pressure_iterations;
    f->diffusion_iterations = def->diffusion_iterations;
    const size_t nx = (size_t)f->nx, ny = (size_t)f->ny;
    const size_t nu = (nx + 1) * ny, nv = nx * (ny + 1), np = (nx + 2) * (ny + 2);
    f->u = tsk_calloc(nu, sizeof(float), "wind fluid u");
    f->v = tsk_calloc(nv, sizeof(float), "wind fluid v");
    f->u_tmp = tsk_calloc(nu, sizeof(float), "wind fluid u");
    f->v_tmp = tsk_calloc(nv, sizeof(float), "wind fluid v");
    f->phi = tsk_calloc(np, sizeof(float), "wind fluid pressure");
    f->phi_tmp = tsk_calloc(np, sizeof(float), "wind fluid pressure");
    f->div = tsk_calloc(nx * ny, sizeof(float), "wind fluid divergence");
    f->scratch = tsk_calloc(np, sizeof(float), "wind fluid scratch");
    f->cx = tsk_calloc(nx * ny, sizeof(float), "wind fluid centres");
    f->cy = tsk_calloc(nx * ny, sizeof(float), "wind fluid centres");
    if (!f->u || !f->v || !f->u_tmp || !f->v_tmp || !f->phi || !f->phi_tmp || !f->div ||
        !f->scratch || !f->cx || !f->cy) {
        tsk_fluid_free(f);
        return TSK_ERR_MEMORY;
    }
    return TSK_OK;
}

void tsk_fluid_free(tsk_fluid* f) {
    tsk_free(f->u);
    tsk_free(f->v);
    tsk_free(f->u_tmp);
    tsk_free(f->v_tmp);
    tsk_free(f->phi);
    tsk_free(f->phi_tmp);
    tsk_free(f->div);
    tsk_free(f->scratch);
    tsk_free(f->cx);
    tsk_free(f->cy);
    memset(f, 0, sizeof *f);
}

static inline int clampi(int a, int lo, int hi) { return a < lo ? lo : (a > hi ? hi : a); }

/* Bilinear value of a w x h row-major field at index coordinates (fx, fy); beyond the
 * edge the edge value repeats (zero gradient). */
static inline float bilinear(const float* restrict q, int w, int h, float fx, float fy) {
    fx = fx > 0.0f ? fx : 0.0f;
    fx = fx < (float)(w - 1) ? fx : (float)(w - 1);
    fy = fy > 0.0f ? fy : 0.0f;
    fy = fy < (float)(h - 1) ? fy : (float)(h - 1);
    int i0 = (int)fx, j0 = (int)fy;
    i0 = i0 < w - 2 ? i0 : w - 2;
    j0 = j0 < h - 2 ? j0 : h - 2;
    const float tx = fx - (float)i0, ty = fy - (float)j0;
    const int k = j0 * w + i0, k2 = k + w; /* grids <= 1025 wide: int fits */
    const float a = q[k] + (q[k + 1] - q[k]) * tx;
    const float b = q[k2] + (q[k2 + 1] - q[k2]) * tx;
    return a + (b - a) * ty;
}

/* ---- advection (Stam 1999: trace back along the velocity, interpolate) ---------------- */

/* One row of each advection. The row is built in a local buffer so that the compiler can
 * prove its gathers from the old field never see what is being written, and vectorises. */
TSK_WIND_CLONES
static void advect_u_row(const float* restrict u, const float* restrict vr0,
                         const float* restrict vr1, float* restrict out, int nx, int ny, int j,
                         float k) {
    const float* restrict ur = u + (size_t)j * (nx + 1);
    const float fj = (float)j; /* index coords of u: y - 0.5 */
    float row[TSK_WIND_MAX_GRID + 1];
    /* edge faces: the v average repeats the edge column (zero gradient) */
    {
        const float vv = 0.5f * (vr0[0] + vr1[0]);
        row[0] = bilinear(u, nx + 1, ny, 0.0f - k * ur[0], fj - k * vv);
    }
    for (int i = 1; i < nx; ++i) {
        const float vv = 0.25f * ((vr0[i - 1] + vr0[i]) + (vr1[i - 1] + vr1[i]));
        row[i] = bilinear(u, nx + 1, ny, (float)i - k * ur[i], fj - k * vv);
    }
    {
        const float vv = 0.5f * (vr0[nx - 1] + vr1[nx - 1]);
        row[nx] = bilinear(u, nx + 1, ny, (float)nx - k * ur[nx], fj - k * vv);
    }
    memcpy(out, row, (size_t)(nx + 1) * sizeof(float));
}

TSK_WIND_CLONES
static void advect_v_row(const float* restrict v, const float* restrict ur0,
                         const float* restrict ur1, float* restrict out, int nx, int ny, int j,
                         float k) {
    const float* restrict vr = v + (size_t)j * nx;
    const float fj = (float)j;
    float row[TSK_WIND_MAX_GRID];
    for (int i = 0; i < nx; ++i) {
        const float uu = 0.25f * ((ur0[i] + ur0[i + 1]) + (ur1[i] + ur1[i + 1]));
        /* index coords of v: x - 0.5 */
        row[i] = bilinear(v, nx, ny + 1, (float)i - k * uu, fj - k * vr[i]);
    }
    memcpy(out, row, (size_t)nx * sizeof(float));
}

static void advect_u_rows(size_t b, size_t e, size_t chunk, void* ctx) {
    (void)chunk;
    const tsk_fluid* f = ctx;
    const int nx = f->nx, ny = f->ny;
    const float k = f->dt * f->speed / f->h; /* cells per unit velocity */
    for (int j = (int)b; j < (int)e; ++j) {
        const float* vr0 = f->v + (size_t)j * nx;
        advect_u_row(f->u, vr0, vr0 + nx, f->u_tmp + (size_t)j * (nx + 1), nx, ny, j, k);
    }
}

static void advect_v_rows(size_t b, size_t e, size_t chunk, void* ctx) {
    (void)chunk;
    const tsk_fluid* f = ctx;
    const int nx = f->nx, ny = f->ny;
    const float k = f->dt * f->speed / f->h;
    for (int j = (int)b; j < (int)e; ++j) {
        const int jd = j > 0 ? j - 1 : 0, ju = j < ny ? j : ny - 1;
        advect_v_row(f->v, f->u + (size_t)jd * (nx + 1), f->u + (size_t)ju * (nx + 1),
                     f->v_tmp + (size_t)j * nx, nx, ny, j, k);
    }
}

void tsk_fluid_advect(tsk_fluid* f) {
    tsk_parallel_for((size_t)f->ny, row_grain_of(f->nx, f->ny), advect_u_rows, f);
    tsk_parallel_for((size_t)f->ny + 1, row_grain_of(f->nx, f->ny), advect_v_rows, f);
    float* t = f->u;
    f->u = f->u_tmp;
    f->u_tmp = t;
    t = f->v;
    f->v = f->v_tmp;
    f->v_tmp = t;
}

/* ---- viscosity: (1 + 4a) q - a sum(neighbours) = q0, a = nu dt / h^2, by Jacobi -------- */

typedef struct diffuse_ctx {
    const float* src; /* q0 */
    const float* in;
    float* out;
    int w, h;
    float a, inv;
} diffuse_ctx;

TSK_WIND_CLONES
static void diffuse_rows(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const diffuse_ctx* c = vctx;
    for (int j = (int)b; j < (int)e; ++j) {
        const float* rd = c->in + (size_t)clampi(j - 1, 0, c->h - 1) * c->w;
        const float* rm = c->in + (size_t)j * c->w;
        const float* ru = c->in + (size_t)clampi(j + 1, 0, c->h - 1) * c->w;
        const float* s = c->src + (size_t)j * c->w;
        float* o = c->out + (size_t)j * c->w;
        for (int i = 0; i < c->w; ++i) {
            const float l = rm[i > 0 ? i - 1 : 0], r = rm[i < c->w - 1 ? i + 1 : i];
            o[i] = (s[i] + c->a * (l + r + rd[i] + ru[i])) * c->inv;
        }
    }
}

static void diffuse_field(tsk_fluid* f, float** field, float** tmp, int w, int h) {
    diffuse_ctx c;
    c.w = w;
    c.h = h;
    c.a = f->viscosity * f->dt / (f->h * f->h);
    c.inv = 1.0f / (1.0f + 4.0f * c.a);
    const size_t n = (size_t)w * (size_t)h;
    memcpy(f->scratch, *field, n * sizeof(float)); /* q0 */
    c.src = f->scratch;
    float* a = *field;
    float* b = *tmp;
    for (int it = 0; it < f->diffusion_iterations; ++it) {
        c.in = a;
        c.out = b;
        tsk_parallel_for((size_t)h, row_grain_of(f->nx, f->ny), diffuse_rows, &c);
        float* t = a;
        a = b;
        b = t;
    }
    *field = a;
    *tmp = b;
}

void tsk_fluid_diffuse(tsk_fluid* f) {
    if (!(f->viscosity > 0.0f)) return;
    diffuse_field(f, &f->u, &f->u_tmp, f->nx + 1, f->ny);
    diffuse_field(f, &f->v, &f->v_tmp, f->nx, f->ny + 1);
}

/* ---- projection: solve lap(phi) = div, subtract grad(phi) (seed 004, eq. 1) ---------- */

TSK_WIND_CLONES
static void divergence_rows(size_t b, size_t e, size_t chunk, void* ctx) {
    (void)chunk;
    tsk_fluid* f = ctx;
    const int nx = f->nx;
    for (int j = (int)b; j < (int)e; ++j) {
        const float* ur = f->u + (size_t)j * (nx + 1);
        const float* v0 = f->v + (size_t)j * nx;
        const float* v1 = v0 + nx;
        float* d = f->div + (size_t)j * nx;
        for (int i = 0; i < nx; ++i) d[i] = (ur[i + 1] - ur[i]) + (v1[i] - v0[i]);
    }
}

typedef struct jacobi_ctx {
    const tsk_fluid* f;
    const float* in;
    float* out;
    float* partial; /* per-chunk max |residual| when measuring */
} jacobi_ctx;

/* one Jacobi sweep: phi' = (sum of 4 neighbours - div) / 4, ghost ring 0 (p = 0 outside) */
TSK_WIND_CLONES
static void jacobi_rows(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const jacobi_ctx* c = vctx;
    const int nx = c->f->nx;
    const size_t w = (size_t)nx + 2;
    for (size_t j = b + 1; j < e + 1; ++j) {
        const float* restrict m = c->in + j * w;
        const float* restrict dn = m - w;
        const float* restrict up = m + w;
        const float* restrict d = c->f->div + (j - 1) * (size_t)nx;
        float* restrict o = c->out + j * w;
        for (size_t i = 1; i <= (size_t)nx; ++i)
            o[i] = 0.25f * (((m[i - 1] + m[i + 1]) + (dn[i] + up[i])) - d[i - 1]);
    }
}

/* max over cells of |lap(phi) - div|: exactly the divergence left after subtracting
 * grad(phi) */
TSK_WIND_CLONES
static void residual_rows(size_t b, size_t e, size_t chunk, void* vctx) {
    const jacobi_ctx* c = vctx;
    const int nx = c->f->nx;
    const size_t w = (size_t)nx + 2;
    float mx = 0.0f;
    for (size_t j = b + 1; j < e + 1; ++j) {
        const float* m = c->in + j * w;
        const float* dn = m - w;
        const float* up = m + w;
        const float* d = c->f->div + (j - 1) * (size_t)nx;
        for (size_t i = 1; i <= (size_t)nx; ++i) {
            const float r = ((m[i - 1] + m[i + 1]) + (dn[i] + up[i])) - 4.0f * m[i] - d[i - 1];
            const float a = fabsf(r);
            mx = a > mx ? a : mx;
        }
    }
    c->partial[chunk] = mx;
}

TSK_WIND_CLONES
static void gradient_rows(size_t b, size_t e, size_t chunk, void* ctx) {
    (void)chunk;
    tsk_fluid* f = ctx;
    const int nx = f->nx, ny = f->ny;
    const size_t w = (size_t)nx + 2;
    for (int j = (int)b; j < (int)e; ++j) {
        if (j < ny) { /* u faces of row j: phi(i, j) - phi(i - 1, j) */
            const float* p = f->phi + (size_t)(j + 1) * w;
            float* ur = f->u + (size_t)j * (nx + 1);
            for (int i = 0; i <= nx; ++i) ur[i] -= p[i + 1] - p[i];
        }
        { /* v faces of row j (0..ny): phi(i, j) - phi(i, j - 1) */
            const float* p1 = f->phi + (size_t)(j + 1) * w + 1;
            const float* p0 = p1 - w;
            float* vr = f->v + (size_t)j * nx;
            for (int i = 0; i < nx; ++i) vr[i] -= p1[i] - p0[i];
        }
    }
}

static float measure_residual(tsk_fluid* f) {
    float partial[TSK_WIND_MAX_GRID / 16 + 1];
    jacobi_ctx c = {f, f->phi, NULL, partial};
    tsk_parallel_for((size_t)f->ny, row_grain_of(f->nx, f->ny), residual_rows, &c);
    const size_t n = tsk_chunk_count((size_t)f->ny, row_grain_of(f->nx, f->ny));
    float mx = 0.0f;
    for (size_t i = 0; i < n; ++i) mx = partial[i] > mx ? partial[i] : mx;
    return mx;
}

int tsk_fluid_project(tsk_fluid* f) {
    tsk_parallel_for((size_t)f->ny, row_grain_of(f->nx, f->ny), divergence_rows, f);
    int it = 0;
    f->last_divergence = -1.0f;
    /* warm start: phi keeps the last step's solution */
    while (it < f->iterations) {
        jacobi_ctx c = {f, f->phi, f->phi_tmp, NULL};
        tsk_parallel_for((size_t)f->ny, row_grain_of(f->nx, f->ny), jacobi_rows, &c);
        float* t = f->phi;
        f->phi = f->phi_tmp;
        f->phi_tmp = t;
        ++it;
        if (f->tolerance > 0.0f && (it % 8 == 0 || it == f->iterations)) {
            f->last_divergence = measure_residual(f);
            if (f->last_divergence < f->tolerance) break;
        }
    }
    tsk_parallel_for((size_t)f->ny + 1, row_grain_of(f->nx, f->ny), gradient_rows, f);
    f->last_iterations = it;
    return it;
}

float tsk_fluid_max_divergence(const tsk_fluid* f) {
    const int nx = f->nx, ny = f->ny;
    float mx = 0.0f;
    for (int j = 0; j < ny; ++j) {
        const float* ur = f->u + (size_t)j * (nx + 1);
        const float* v0 = f->v + (size_t)j * nx;
        const float* v1 = v0 + nx;
        for (int i = 0; i < nx; ++i) {
            const float d = fabsf((ur[i + 1] - ur[i]) + (v1[i] - v0[i]));
            mx = d > mx ? d : mx;
        }
    }
    return mx;
}

/* ---- decay and the bound |v| <= 1 of seed 004 ------------------------------------------ */

TSK_WIND_CLONES
static void finish_range(float* restrict q, size_t n, float keep) {
    for (size_t i = 0; i < n; ++i) {
        const float a = q[i] * keep;
        const float b = a < 1.0f ? a : 1.0f;
        q[i] = b > -1.0f ? b : -1.0f;
    }
}

static void finish_rows(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    tsk_fluid* f = vctx;
    const float keep = tsk_expf(-f->decay * f->dt);
    const size_t nu = (size_t)(f->nx + 1) * (size_t)f->ny;
    if (b < nu) finish_range(f->u + b, (e < nu ? e : nu) - b, keep);
    if (e > nu) {
        const size_t vb = b > nu ? b - nu : 0;
        finish_range(f->v + vb, e - nu - vb, keep);
    }
}

void tsk_fluid_finish(tsk_fluid* f) {
    const size_t n = (size_t)(f->nx + 1) * (size_t)f->ny + (size_t)f->nx * (size_t)(f->ny + 1);
    /* one chunk for small grids (as row_grain_of), else 16 rows' worth of faces */
    const size_t grain = (size_t)f->nx * (size_t)f->ny <= 20000u ? n : 16u * (size_t)f->nx;
    tsk_parallel_for(n, grain, finish_rows, f);
}

/* ---- sources (seed 004, III-C: pushes of strength 0..1 every `interval` seconds) ------ */

/* 1 if a push time start + n * interval (n >= 0) lies in the step [t0, t1) */
int tsk_fluid_source_pushes(const tsk_wind_source* s, double t0, double t1) {
    if (t1 <= s->start) return 0;
    if (!(s->interval > 0.0f)) return 1;
    double n = ceil((t0 - s->start) / s->interval);
    if (n < 0.0) n = 0.0;
    return s->start + n * s->interval < t1;
}

/* v <- v + falloff (target - v) on the faces of one component inside the radius */
static void push_faces(float* q, int w, int h, float off_x, float off_y, float cell, float ox,
                       float oy, const tsk_wind_source* s, float target) {
    const float R = s->radius;
    /* face (i, j) lies at origin + cell * (i + off_x, j + off_y) */
    int i0 = (int)floorf((s->x - R - ox) / cell - off_x),
        i1 = (int)ceilf((s->x + R - ox) / cell - off_x);
    int j0 = (int)floorf((s->y - R - oy) / cell - off_y),
        j1 = (int)ceilf((s->y + R - oy) / cell - off_y);
    i0 = clampi(i0, 0, w - 1);
    i1 = clampi(i1, 0, w - 1);
    j0 = clampi(j0, 0, h - 1);
    j1 = clampi(j1, 0, h - 1);
    const float inv_r2 = 1.0f / (R * R);
    for (int j = j0; j <= j1; ++j) {
        const float dy = oy + cell * ((float)j + off_y) - s->y;
        for (int i = i0; i <= i1; ++i) {
            const float dx = ox + cell * ((float)i + off_x) - s->x;
            const float r2 = (dx * dx + dy * dy) * inv_r2;
            if (r2 >= 1.0f) continue;
            const float fall = (1.0f - r2) * (1.0f - r2);
            float* p = q + (size_t)j * (size_t)w + (size_t)i;
            *p += fall * (target - *p);
        }
    }
}

void tsk_fluid_apply_sources(tsk_fluid* f, float origin_x, float origin_y,
                             const tsk_wind_source* sources, int count, double t0, double t1) {
    for (int k = 0; k < count; ++k) {
        const tsk_wind_source* s = &sources[k];
        if (!tsk_fluid_source_pushes(s, t0, t1)) continue;
        const double len = sqrt((double)s->dir_x * s->dir_x + (double)s->dir_y * s->dir_y);
        const float tx = (float)(s->strength * s->dir_x / len);
        const float ty = (float)(s->strength * s->dir_y / len);
        push_faces(f->u, f->nx + 1, f->ny, 0.0f, 0.5f, f->h, origin_x, origin_y, s, tx);
        push_faces(f->v, f->nx, f->ny + 1, 0.5f, 0.0f, f->h, origin_x, origin_y, s, ty);
    }
}

/* ---- read-out -------------------------------------------------------------------------- */

static inline void clamp_unit(float* x, float* y) {
    const float m2 = *x * *x + *y * *y;
    if (m2 > 1.0f) {
        const float s = 1.0f / sqrtf(m2);
        *x *= s;
        *y *= s;
    }
}

void tsk_fluid_sample_cells(const tsk_fluid* f, float cx, float cy, float* vx, float* vy) {
    /* centre (i, j) sits at cell coordinates (i + 0.5, j + 0.5) */
    *vx = bilinear(f->cx, f->nx, f->ny, cx - 0.5f, cy - 0.5f);
    *vy = bilinear(f->cy, f->nx, f->ny, cx - 0.5f, cy - 0.5f);
}

void tsk_fluid_update_centres(tsk_fluid* f) { tsk_fluid_centres(f, f->cx, f->cy); }

TSK_WIND_CLONES
void tsk_fluid_centres(const tsk_fluid* f, float* vx, float* vy) {
    const int nx = f->nx, ny = f->ny;
    for (int j = 0; j < ny; ++j) {
        const float* ur = f->u + (size_t)j * (nx + 1);
        const float* v0 = f->v + (size_t)j * nx;
        const float* v1 = v0 + nx;
        for (int i = 0; i < nx; ++i) {
            float a = 0.5f * (ur[i] + ur[i + 1]), b = 0.5f * (v0[i] + v1[i]);
            clamp_unit(&a, &b);
            vx[(size_t)j * nx + i] = a;
            vy[(size_t)j * nx + i] = b;
        }
    }
}
