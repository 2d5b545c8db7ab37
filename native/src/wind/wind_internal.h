/* Private parts of the wind module shared by its files and the tests: the fluid grid, the
 * continuum, the evaluated sines set and the handle. Not a public interface. */
#ifndef TSK_WIND_INTERNAL_H
#define TSK_WIND_INTERNAL_H

#include "tussock/wind.h"

#include <string.h>

/* ---- stable fluids on a MAC grid (fluid.c) ------------------------------------------- */

/* u lives on vertical faces ((nx+1) x ny, index j*(nx+1)+i, world x = i*h), v on
 * horizontal faces (nx x (ny+1), index j*nx+i, world y = j*h); the pressure-like phi
 * lives at cell centres in an (nx+2) x (ny+2) array whose ghost ring stays 0 (open
 * boundary: Dirichlet p = 0 outside the grid). Velocities are normalised (1 = speed). */
typedef struct tsk_fluid {
    int nx, ny;
    float h, dt, speed, viscosity, decay, tolerance;
    int iterations, diffusion_iterations;
    float *u, *v, *u_tmp, *v_tmp;
    float *phi, *phi_tmp, *div, *scratch;
    float *cx, *cy; /* centre velocities, |v| <= 1, refreshed after each step */
    int last_iterations; /* iterations run by the last projection */
    float last_divergence; /* max |div| after the last projection (when measured) */
} tsk_fluid;

tsk_status tsk_fluid_init(tsk_fluid* f, const tsk_wind_fluid_def* def);
void tsk_fluid_free(tsk_fluid* f);
/* Semi-Lagrangian advection of u, v by themselves over dt (Stam 1999). */
void tsk_fluid_advect(tsk_fluid* f);
/* Implicit viscosity by Jacobi iterations (no-op when viscosity is 0). */
void tsk_fluid_diffuse(tsk_fluid* f);
/* Pressure projection: makes the face velocities divergence-free up to the solver's
 * residual; returns the number of Jacobi iterations run. */
int tsk_fluid_project(tsk_fluid* f);
/* Max |divergence| over cells (normalised velocity per cell). */
float tsk_fluid_max_divergence(const tsk_fluid* f);
/* Velocity decay and the component clamp |u|, |v| <= 1. */
void tsk_fluid_finish(tsk_fluid* f);
/* Pushes of the sources whose push time lies in the step [t0, t1). */
void tsk_fluid_apply_sources(tsk_fluid* f, float origin_x, float origin_y,
                             const tsk_wind_source* sources, int count, double t0, double t1);
/* 1 if source s pushes in the step [t0, t1). */
int tsk_fluid_source_pushes(const tsk_wind_source* s, double t0, double t1);
/* Bilinear velocity of the centre grid (cx, cy) at a point in cell units (x = world
 * offset / h); a convex mix of vectors with |v| <= 1, so |v| <= 1. */
void tsk_fluid_sample_cells(const tsk_fluid* f, float cx, float cy, float* vx, float* vy);
/* Cell-centre velocities (nx*ny each), magnitude clamped to 1. */
void tsk_fluid_centres(const tsk_fluid* f, float* vx, float* vy);
/* Refreshes f->cx, f->cy (the centre velocities that sampling reads). */
void tsk_fluid_update_centres(tsk_fluid* f);

/* ---- wave continuum (continuum.c) ---------------------------------------------------- */

/* Vp at cell centres in (nx+2) x (ny+2) arrays; the ghost ring carries Mur's absorbing
 * edge. Three time levels rotate: prev, cur, next. */
typedef struct tsk_continuum {
    int nx, ny;
    float h, dt, c, gamma, drive;
    float* x[3];
    float* y[3];
    int cur; /* index of the current level; prev = (cur+2)%3 */
} tsk_continuum;

/* Checks stability: dt^2 (8 c^2 / h^2 + drive) < 2 (1 + gamma). */
tsk_status tsk_continuum_check(float c, float gamma, float drive, float h, float dt);
tsk_status tsk_continuum_init(tsk_continuum* w, int nx, int ny, float h, float dt, float c,
                              float gamma, float drive);
void tsk_continuum_free(tsk_continuum* w);
/* One Verlet step (seed 004, eq. 3-4) driven by wind_x/wind_y at centres (NULL: still). */
void tsk_continuum_step(tsk_continuum* w, const float* wind_x, const float* wind_y);
/* Pointer to cell (i, j) of the current / previous level (i in -1..nx, j in -1..ny). */
static inline size_t tsk_continuum_index(const tsk_continuum* w, int i, int j) {
    return (size_t)(j + 1) * (size_t)(w->nx + 2) + (size_t)(i + 1);
}
float* tsk_continuum_cur_x(tsk_continuum* w);
float* tsk_continuum_cur_y(tsk_continuum* w);
float* tsk_continuum_prev_x(tsk_continuum* w);
float* tsk_continuum_prev_y(tsk_continuum* w);
/* Bilinear Vp at a point in cell units. */
void tsk_continuum_sample_cells(const tsk_continuum* w, float cx, float cy, float* px, float* py);

/* Hot point loops are compiled twice, for AVX2 and for the x86-64 baseline, and picked at
 * load time. Both versions do the same IEEE operations in the same order (no FMA: the
 * build uses -ffp-contract=off), so they give the same bytes. Windows has no ifunc, which GCC
 * picks the clone with: its build runs the baseline. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_ADDRESS__) && !defined(TSK_NO_CLONES) && !defined(_WIN32)
#define TSK_WIND_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define TSK_WIND_CLONES
#endif

/* ---- sines (sines.c, gust.c, blend.c) ------------------------------------------------- */

enum { TSK_SINES_MAX_EVAL = TSK_WIND_MAX_WAVES * TSK_WIND_BLEND_HISTORY };

/* A sines set evaluated for one time t: blend weights folded into amplitudes, the time
 * term folded into the phase (in double, then reduced to [-pi, pi)). */
typedef struct tsk_sines_eval {
    int wave_count;
    float amp_x[TSK_SINES_MAX_EVAL], amp_y[TSK_SINES_MAX_EVAL]; /* A * weight * D */
    float kx[TSK_SINES_MAX_EVAL], ky[TSK_SINES_MAX_EVAL]; /* (2 pi / L) D */
    float phase[TSK_SINES_MAX_EVAL];
    float power[TSK_SINES_MAX_EVAL];
    float base_x, base_y;
    int gust_count;
    tsk_wind_gust_def gust[TSK_WIND_BLEND_HISTORY]; /* normalised dir, strength * weight */
    double t;
} tsk_sines_eval;

/* Adds one parameter set with weight `weight` at time t to `ev`. */
void tsk_sines_eval_add(tsk_sines_eval* ev, const tsk_wind_sines_def* def, float weight, double t);
/* Adds the sines at count points to vx, vy (vectorisable loops). */
void tsk_sines_accumulate(const tsk_sines_eval* ev, size_t count, const float* x, const float* y,
                          float* vx, float* vy);
/* Adds the gusts at count points to vx, vy. */
void tsk_gust_accumulate(const tsk_sines_eval* ev, size_t count, const float* x, const float* y,
                         float* vx, float* vy);
/* Gust speed factor (0..1 times strength) of one gust def at local time tau. */
float tsk_gust_envelope(const tsk_wind_gust_def* g, double tau);
/* Fast sin and pow used by the sines (deterministic, pure float arithmetic). */
float tsk_wind_sin(float x);
float tsk_wind_pow01(float u, float k);

typedef struct tsk_sines_history {
    int count;
    tsk_wind_sines_def sets[TSK_WIND_BLEND_HISTORY];
    double start[TSK_WIND_BLEND_HISTORY];
    double blend[TSK_WIND_BLEND_HISTORY];
} tsk_sines_history;

void tsk_sines_history_reset(tsk_sines_history* h, const tsk_wind_sines_def* def);
void tsk_sines_history_push(tsk_sines_history* h, const tsk_wind_sines_def* def, double start,
                            double blend);
/* The blended wind of the history at time t. */
void tsk_sines_history_eval(const tsk_sines_history* h, double t, tsk_sines_eval* ev);

/* sin(x), accurate for |x| < 1e7: reduce by the nearest multiple of pi (Cody-Waite, three
 * parts), then a degree-11 Taylor polynomial on [-pi/2, pi/2] (error < 1e-7). */
static inline float tsk_fast_sin(float x) {
    /* beyond 1e7 rad a float carries no phase at all; clamp so that the result stays a
     * bounded value in [-1, 1] instead of a polynomial far outside its range */
    {
        int32_t b;
        memcpy(&b, &x, sizeof b);
        int32_t a = b & 0x7FFFFFFF; /* |x| as bits: ordered like |x| (NaN: above inf) */
        a = a < 0x4B189680 ? a : 0x4B189680; /* 1e7f */
        b = (b & (int32_t)0x80000000) | a;
        memcpy(&x, &b, sizeof x);
    }
    const float inv_pi = 0.318309886183790671f;
    const float magic = 12582912.0f; /* 1.5 * 2^23: adding it rounds to an integer */
    float q = (x * inv_pi + magic) - magic;
    int qi = (int)q;
    float r = x - q * 3.140625f;
    r = r - q * 9.67502593994140625e-4f;
    r = r - q * 1.509957990978376432e-7f;
    const float r2 = r * r;
    float p = -2.50521084e-8f;
    p = p * r2 + 2.75573192e-6f;
    p = p * r2 - 1.98412698e-4f;
    p = p * r2 + 8.33333333e-3f;
    p = p * r2 - 1.66666667e-1f;
    float s = r + r * r2 * p;
    const float sign = 1.0f - 2.0f * (float)(qi & 1);
    return s * sign;
}

/* ---- the handle (wind.c) -------------------------------------------------------------- */

struct tsk_wind {
    tsk_wind_def def;
    tsk_sines_history sines;
    tsk_wind_source sources[TSK_WIND_MAX_SOURCES];
    int source_count;
    int has_fluid, has_continuum;
    tsk_fluid fluid;
    tsk_continuum continuum;
    uint64_t steps;
    double dt;
};

tsk_status tsk_wind_fluid_def_validate(const tsk_wind_fluid_def* def);
tsk_status tsk_wind_continuum_def_validate(const tsk_wind_continuum_def* def,
                                           const tsk_wind_fluid_def* fluid);
tsk_status tsk_wind_source_validate(const tsk_wind_source* s, size_t index);

#endif
