/* Movement data for a still capture: a physically based bending model of the full-resolution
 * blade (an inextensible elastic rod clamped at the root, Verlet + length constraints) under
 * a standard gusting wind, until the blade solver of the simulation issue replaces it.
 * The model is documented in tussock/refine.h (tsk_refine_bend_def). */
#include "tussock/refine.h"
#include "core/tmath.h"

#include <math.h>
#include <string.h>

#define TSK_BEND_MAX_WORK 1.0e9 /* knots x steps: ~1 minute on one core */

static const double k_two_pi = 6.28318530717958647692;

tsk_refine_bend_def tsk_default_refine_bend_def(void) {
    tsk_refine_bend_def d;
    memset(&d, 0, sizeof d);
    d.youngs_modulus = 3.0e9f;
    d.thickness = 4.0e-4f;
    d.density = 900.0f;
    d.min_width_ratio = 0.05f;
    d.gravity[2] = -9.81f;
    d.gravity_prestress = 1;
    d.air_density = 1.2f;
    d.drag_coefficient = 1.2f;
    d.damping = 2.0f;
    d.wind_speed = 3.0f;
    d.wind_direction[0] = 1.0f;
    d.gust = 0.5f;
    d.fps = 24.0f;
    d.warmup = 1.0f;
    d.time_step = 0.0f;
    return d;
}

/* ---- small double vector helpers --------------------------------------------------------- */

typedef struct v3 {
    double x, y, z;
} v3;

static inline v3 v3_make(double x, double y, double z) { return (v3){x, y, z}; }
static inline v3 v3_load(const double* p) { return (v3){p[0], p[1], p[2]}; }
static inline void v3_store(double* p, v3 a) { p[0] = a.x, p[1] = a.y, p[2] = a.z; }
static inline v3 add(v3 a, v3 b) { return (v3){a.x + b.x, a.y + b.y, a.z + b.z}; }
static inline v3 sub(v3 a, v3 b) { return (v3){a.x - b.x, a.y - b.y, a.z - b.z}; }
static inline v3 scale(v3 a, double s) { return (v3){a.x * s, a.y * s, a.z * s}; }
static inline double dot(v3 a, v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline v3 cross(v3 a, v3 b) {
    return (v3){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static inline double norm(v3 a) { return sqrt(dot(a, a)); }

/* Parallel transport of v by the minimal rotation taking unit a to unit b. */
static inline v3 transport(v3 a, v3 b, v3 v) {
    const v3 c = cross(a, b);
    double cs = dot(a, b);
    if (cs < -1.0 + 1e-12) cs = -1.0 + 1e-12; /* folded back: any axis will do */
    return add(add(scale(v, cs), cross(c, v)), scale(c, dot(c, v) / (1.0 + cs)));
}

/* Rotation of v by angle phi about unit axis n (Rodrigues). */
static inline v3 rotate(v3 v, v3 n, double phi) {
    const double c = tsk_cos(phi), s = tsk_sin(phi);
    return add(add(scale(v, c), scale(cross(n, v), s)), scale(n, dot(n, v) * (1.0 - c)));
}

/* ---- the standard wind ------------------------------------------------------------------ */

static void wind_axes(const tsk_refine_bend_def* def, v3* along, v3* across) {
    v3 d = v3_make(def->wind_direction[0], def->wind_direction[1], def->wind_direction[2]);
    double n = norm(d);
    *along = n > 0.0 && isfinite(n) ? scale(d, 1.0 / n) : v3_make(1, 0, 0);
    v3 h = cross(v3_make(0, 0, 1), *along); /* horizontal perpendicular (z up) */
    double hn = norm(h);
    *across = hn > 1e-9 ? scale(h, 1.0 / hn) : v3_make(0, 1, 0);
}

static v3 wind_at(double speed, double gust, v3 along, v3 across, double t) {
    const double a = speed * (1.0 + gust * (0.6 * tsk_sin(k_two_pi * 0.31 * t) +
                                            0.3 * tsk_sin(k_two_pi * 0.87 * t + 1.1) +
                                            0.1 * tsk_sin(k_two_pi * 2.3 * t + 2.3)));
    const double c = speed * gust * 0.25 * tsk_sin(k_two_pi * 0.53 * t + 0.4);
    return add(scale(along, a), scale(across, c));
}

void tsk_refine_wind_at(const tsk_refine_bend_def* def, double t, float out[3]) {
    if (def == NULL || out == NULL) return;
    v3 along, across;
    wind_axes(def, &along, &across);
    v3 w = wind_at(def->wind_speed, def->gust, along, across, t);
    out[0] = (float)w.x, out[1] = (float)w.y, out[2] = (float)w.z;
}

/* ---- validation ----------------------------------------------------------------------- */

static tsk_status check_positive(float v, const char* name) {
    if (!(v > 0.0f) || !isfinite(v))
        return tsk_error_arg(TSK_ERR_ARGUMENT, name, "must be finite and > 0, got %g", (double)v);
    return TSK_OK;
}
static tsk_status check_nonneg(float v, const char* name) {
    if (!(v >= 0.0f) || !isfinite(v))
        return tsk_error_arg(TSK_ERR_ARGUMENT, name, "must be finite and >= 0, got %g", (double)v);
    return TSK_OK;
}

static tsk_status check_def(const tsk_refine_bend_def* d) {
    if (d == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "def", "is NULL");
    tsk_status s;
    if ((s = check_positive(d->youngs_modulus, "youngs_modulus"))) return s;
    if ((s = check_positive(d->thickness, "thickness"))) return s;
    if ((s = check_positive(d->density, "density"))) return s;
    if ((s = check_positive(d->min_width_ratio, "min_width_ratio"))) return s;
    if (d->min_width_ratio > 1.0f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "min_width_ratio", "must be <= 1, got %g",
                             (double)d->min_width_ratio);
    for (int c = 0; c < 3; ++c)
        if (!isfinite(d->gravity[c]) || !isfinite(d->wind_direction[c]))
            return tsk_error_arg(TSK_ERR_ARGUMENT,
                                 !isfinite(d->gravity[c]) ? "gravity" : "wind_direction",
                                 "must be finite");
    if ((s = check_nonneg(d->air_density, "air_density"))) return s;
    if ((s = check_nonneg(d->drag_coefficient, "drag_coefficient"))) return s;
    if ((s = check_nonneg(d->damping, "damping"))) return s;
    if ((s = check_nonneg(d->wind_speed, "wind_speed"))) return s;
    if ((s = check_nonneg(d->gust, "gust"))) return s;
    if (d->gust > 1.0f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "gust", "must be in [0, 1], got %g",
                             (double)d->gust);
    if ((s = check_positive(d->fps, "fps"))) return s;
    if ((s = check_nonneg(d->warmup, "warmup"))) return s;
    if ((s = check_nonneg(d->time_step, "time_step"))) return s;
    if (d->time_step > 1.0f / d->fps)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "time_step", "%g s is longer than a frame",
                             (double)d->time_step);
    return TSK_OK;
}

/* ---- the simulation --------------------------------------------------------------------- */

typedef struct rod {
    size_t k; /* knots */
    double* x; /* [k][3] positions */
    double* xp; /* [k][3] previous positions */
    double* xn; /* [k][3] next positions */
    double* force; /* [k][3] */
    double* len; /* [k-1] rest segment lengths */
    double* mass; /* [k] */
    double* inv_mass; /* [k], 0 at the root */
    double* drag; /* [k] 0.5 rho_air C_d width * arc length owned by the knot */
    double* stiff; /* [k-1] joint stiffness k_j = EI_j / l_j, N m */
    double* local; /* [k-1][3] rest direction of segment j in the frame of segment j-1 */
    double* tan; /* [k-1][3] current unit tangents */
    double* moment; /* [k][3] joint moments; moment[k-1] = 0 */
    double* dir; /* [k-1][3] projection scratch: segment directions */
    double *diag, *off, *rhs; /* [k-1] projection scratch: the tridiagonal system */
    v3 root_t, root_u; /* the clamped root frame */
} rod;

static void rod_free(rod* r) {
    tsk_free(r->x);
    tsk_free(r->xp);
    tsk_free(r->xn);
    tsk_free(r->force);
    tsk_free(r->len);
    tsk_free(r->mass);
    tsk_free(r->inv_mass);
    tsk_free(r->drag);
    tsk_free(r->stiff);
    tsk_free(r->local);
    tsk_free(r->tan);
    tsk_free(r->moment);
    tsk_free(r->dir);
    tsk_free(r->diag);
    tsk_free(r->off);
    tsk_free(r->rhs);
}

/* Builds masses, stiffnesses and the rest directions (with the gravity prestress). */
static tsk_status rod_init(rod* r, const tsk_refine_bend_def* d, const float* knots,
                           const float* widths, size_t k, double* min_step) {
    memset(r, 0, sizeof *r);
    r->k = k;
    r->x = tsk_alloc(k * 3 * sizeof(double), "bend positions");
    r->xp = tsk_alloc(k * 3 * sizeof(double), "bend positions");
    r->xn = tsk_alloc(k * 3 * sizeof(double), "bend positions");
    r->force = tsk_alloc(k * 3 * sizeof(double), "bend forces");
    r->len = tsk_alloc(k * sizeof(double), "bend lengths");
    r->mass = tsk_alloc(k * sizeof(double), "bend masses");
    r->inv_mass = tsk_alloc(k * sizeof(double), "bend masses");
    r->drag = tsk_alloc(k * sizeof(double), "bend drag");
    r->stiff = tsk_alloc(k * sizeof(double), "bend stiffness");
    r->local = tsk_alloc(k * 3 * sizeof(double), "bend rest directions");
    r->tan = tsk_alloc(k * 3 * sizeof(double), "bend tangents");
    r->moment = tsk_calloc(k * 3, sizeof(double), "bend moments");
    r->dir = tsk_alloc(k * 3 * sizeof(double), "bend projection");
    r->diag = tsk_alloc(k * sizeof(double), "bend projection");
    r->off = tsk_alloc(k * sizeof(double), "bend projection");
    r->rhs = tsk_alloc(k * sizeof(double), "bend projection");
    if (!r->x || !r->xp || !r->xn || !r->force || !r->len || !r->mass || !r->inv_mass || !r->drag ||
        !r->stiff || !r->local || !r->tan || !r->moment || !r->dir || !r->diag || !r->off ||
        !r->rhs)
        return TSK_ERR_MEMORY;

    double wmax = 0.0;
    for (size_t i = 0; i < k; ++i) {
        for (int c = 0; c < 3; ++c) r->x[3 * i + c] = r->xp[3 * i + c] = knots[3 * i + c];
        if (widths[i] > wmax) wmax = widths[i];
    }
    const double wmin = wmax * (double)d->min_width_ratio;
    const double t = d->thickness, t3 = t * t * t, E = d->youngs_modulus;
    const double rho_t = (double)d->density * t;
    const double half_drag = 0.5 * (double)d->air_density * (double)d->drag_coefficient;
    for (size_t i = 0; i < k; ++i) r->mass[i] = 0.0, r->drag[i] = 0.0;
    double step = INFINITY;
    for (size_t s = 0; s + 1 < k; ++s) {
        const v3 e = sub(v3_load(r->x + 3 * (s + 1)), v3_load(r->x + 3 * s));
        r->len[s] = norm(e);
        v3_store(r->tan + 3 * s, scale(e, 1.0 / r->len[s]));
        const double wa = widths[s] > wmin ? widths[s] : wmin;
        const double wb = widths[s + 1] > wmin ? widths[s + 1] : wmin;
        const double seg_mass = rho_t * 0.5 * (wa + wb) * r->len[s];
        r->mass[s] += 0.5 * seg_mass;
        r->mass[s + 1] += 0.5 * seg_mass;
        r->drag[s] += half_drag * wa * 0.5 * r->len[s];
        r->drag[s + 1] += half_drag * wb * 0.5 * r->len[s];
        /* stability: omega_max ~ 4 sqrt(EI / mu) / l^2 for the discrete beam; the width
         * cancels, so this is sqrt(12 rho / E) / t * l^2 */
        const double st = r->len[s] * r->len[s] * sqrt(12.0 * (double)d->density / E) / t;
        if (st < step) step = st;
    }
    *min_step = step;
    for (size_t i = 0; i < k; ++i) r->inv_mass[i] = i == 0 ? 0.0 : 1.0 / r->mass[i];
    /* joint stiffness: joint j (at knot j) joins segment j-1 (the clamp for j = 0) and j */
    for (size_t j = 0; j + 1 < k; ++j) {
        const double w = widths[j] > wmin ? widths[j] : wmin;
        const double EI = E * w * t3 / 12.0;
        const double lbar = j == 0 ? 0.5 * r->len[0] : 0.5 * (r->len[j - 1] + r->len[j]);
        r->stiff[j] = EI / lbar;
    }

    /* the clamped root frame */
    r->root_t = v3_load(r->tan);
    {
        const v3 a = r->root_t;
        v3 axis = fabs(a.x) <= fabs(a.y) && fabs(a.x) <= fabs(a.z) ? v3_make(1, 0, 0)
                  : fabs(a.y) <= fabs(a.z)                         ? v3_make(0, 1, 0)
                                                                   : v3_make(0, 0, 1);
        v3 u = cross(a, axis);
        r->root_u = scale(u, 1.0 / norm(u));
    }

    /* gravity moment about each knot j of the knots beyond it, by suffix sums:
     * G_j = (sum_{i>j} m_i x_i - x_j sum_{i>j} m_i) x g */
    const v3 g = v3_make(d->gravity[0], d->gravity[1], d->gravity[2]);
    v3 mx = v3_make(0, 0, 0);
    double msum = 0.0;
    /* G_j goes into moment[] (scratch here), from the tip down */
    for (size_t jj = k - 1; jj-- > 0;) {
        const size_t i = jj + 1;
        mx = add(mx, scale(v3_load(r->x + 3 * i), r->mass[i]));
        msum += r->mass[i];
        const v3 arm = sub(mx, scale(v3_load(r->x + 3 * jj), msum));
        v3_store(r->moment + 3 * jj, d->gravity_prestress ? cross(arm, g) : v3_make(0, 0, 0));
    }
    v3 ft = r->root_t, fu = r->root_u; /* frame of segment j-1; at j = 0 the clamp's */
    for (size_t j = 0; j + 1 < k; ++j) {
        const v3 tj = v3_load(r->tan + 3 * j);
        /* target (moment-free) direction of segment j: its rest direction rotated back by
         * the angle whose discrete curvature 2 tan(theta/2) balances the gravity moment */
        v3 G = v3_load(r->moment + 3 * j);
        G = sub(G, scale(tj, dot(G, tj)));
        const double gn = norm(G);
        v3 target = tj;
        if (gn > 0.0) {
            const double theta = 2.0 * tsk_atan(gn / (2.0 * r->stiff[j]));
            target = rotate(tj, scale(G, 1.0 / gn), -theta);
        }
        const v3 fw = cross(ft, fu);
        v3_store(r->local + 3 * j, v3_make(dot(target, ft), dot(target, fu), dot(target, fw)));
        fu = transport(ft, tj, fu); /* frame of segment j */
        ft = tj;
    }
    memset(r->moment, 0, k * 3 * sizeof(double));
    return TSK_OK;
}

/* Bending moments M_j = k_j * 2 (tau_j x t_j) / (1 + tau_j . t_j) from the current tangents,
 * tau_j the rest direction carried by the parallel-transported frame of segment j-1. */
static void rod_moments(rod* r) {
    const size_t k = r->k;
    for (size_t s = 0; s + 1 < k; ++s) {
        const v3 e = sub(v3_load(r->x + 3 * (s + 1)), v3_load(r->x + 3 * s));
        v3_store(r->tan + 3 * s, scale(e, 1.0 / norm(e)));
    }
    v3 ft = r->root_t, fu = r->root_u;
    for (size_t j = 0; j + 1 < k; ++j) {
        const v3 tj = v3_load(r->tan + 3 * j);
        const v3 fw = cross(ft, fu);
        const double* d = r->local + 3 * j;
        const v3 tau = add(add(scale(ft, d[0]), scale(fu, d[1])), scale(fw, d[2]));
        double den = 1.0 + dot(tau, tj);
        if (den < 1e-6) den = 1e-6; /* folded back on itself */
        v3_store(r->moment + 3 * j, scale(cross(tau, tj), 2.0 * r->stiff[j] / den));
        fu = transport(ft, tj, fu);
        ft = tj;
    }
}

/* Inextensible segments by fast projection (Goldenthal et al. 2007): Newton iterations that
 * solve the tridiagonal system (J M^-1 J^T) lambda = C for the segment tensions exactly
 * (Thomas algorithm), moving knots by M^-1 J^T lambda, so the corrections act as true
 * constraint forces (equal and opposite, along the segments). A final root-to-tip pass
 * removes the tiny remaining error exactly. */
static void rod_project(rod* r) {
    const size_t k = r->k, n = k - 1;
    double* x = r->xn;
    for (int it = 0; it < 3; ++it) {
        for (size_t s = 0; s < n; ++s) {
            const v3 e = sub(v3_load(x + 3 * (s + 1)), v3_load(x + 3 * s));
            const double l = norm(e);
            v3_store(r->dir + 3 * s, scale(e, 1.0 / l));
            r->rhs[s] = l - r->len[s];
        }
        /* A[s][s] = w_s + w_{s+1}, A[s][s+1] = A[s+1][s] = -w_{s+1} n_s . n_{s+1} */
        for (size_t s = 0; s < n; ++s) {
            r->diag[s] = r->inv_mass[s] + r->inv_mass[s + 1];
            r->off[s] = s + 1 < n ? -r->inv_mass[s + 1] *
                                        dot(v3_load(r->dir + 3 * s), v3_load(r->dir + 3 * (s + 1)))
                                  : 0.0;
        }
        /* Thomas algorithm: forward elimination, back substitution (into rhs) */
        for (size_t s = 1; s < n; ++s) {
            const double m = r->off[s - 1] / r->diag[s - 1];
            r->diag[s] -= m * r->off[s - 1];
            r->rhs[s] -= m * r->rhs[s - 1];
        }
        r->rhs[n - 1] /= r->diag[n - 1];
        for (size_t s = n - 1; s-- > 0;)
            r->rhs[s] = (r->rhs[s] - r->off[s] * r->rhs[s + 1]) / r->diag[s];
        /* x_i -= w_i (lambda_{i-1} n_{i-1} - lambda_i n_i) */
        for (size_t i = 1; i < k; ++i) {
            v3 g = scale(v3_load(r->dir + 3 * (i - 1)), r->rhs[i - 1]);
            if (i < n) g = sub(g, scale(v3_load(r->dir + 3 * i), r->rhs[i]));
            v3_store(x + 3 * i, sub(v3_load(x + 3 * i), scale(g, r->inv_mass[i])));
        }
    }
    for (size_t s = 0; s < n; ++s) {
        const v3 a = v3_load(x + 3 * s), b = v3_load(x + 3 * (s + 1));
        const v3 e = sub(b, a);
        v3_store(x + 3 * (s + 1), add(a, scale(e, r->len[s] / norm(e))));
    }
}

static void rod_step(rod* r, const tsk_refine_bend_def* d, v3 g, v3 wind, double dt) {
    const size_t k = r->k;
    rod_moments(r);
    const double inv_dt = 1.0 / dt, keep = 1.0 - (double)d->damping * dt;
    /* external forces: gravity and drag */
    for (size_t i = 1; i < k; ++i) {
        const v3 x = v3_load(r->x + 3 * i);
        const v3 v = scale(sub(x, v3_load(r->xp + 3 * i)), inv_dt);
        v3 t = v3_load(r->tan + 3 * (i - 1));
        if (i + 1 < k) {
            t = add(t, v3_load(r->tan + 3 * i));
            const double tn = norm(t);
            t = tn > 1e-12 ? scale(t, 1.0 / tn) : v3_load(r->tan + 3 * i);
        }
        const v3 vr = sub(wind, v);
        const v3 vn = sub(vr, scale(t, dot(vr, t)));
        v3 f = scale(g, r->mass[i]);
        f = add(f, scale(vn, r->drag[i] * norm(vn)));
        v3_store(r->force + 3 * i, f);
    }
    /* bending: the torque on segment s, -M_s + M_{s+1}, as a force pair normal to it */
    for (size_t s = 0; s + 1 < k; ++s) {
        const v3 T = sub(v3_load(r->moment + 3 * (s + 1)), v3_load(r->moment + 3 * s));
        const v3 e = sub(v3_load(r->x + 3 * (s + 1)), v3_load(r->x + 3 * s));
        const v3 fb = scale(cross(T, e), 1.0 / dot(e, e));
        v3_store(r->force + 3 * (s + 1), add(v3_load(r->force + 3 * (s + 1)), fb));
        if (s > 0) v3_store(r->force + 3 * s, sub(v3_load(r->force + 3 * s), fb));
    }
    /* Verlet with mass-proportional damping */
    const double dt2 = dt * dt;
    for (int c = 0; c < 3; ++c) r->xn[c] = r->x[c];
    for (size_t i = 1; i < k; ++i)
        for (int c = 0; c < 3; ++c) {
            const size_t q = 3 * i + c;
            r->xn[q] = r->x[q] + (r->x[q] - r->xp[q]) * keep + r->force[q] * r->inv_mass[i] * dt2;
        }
    rod_project(r);
    double* tmp = r->xp;
    r->xp = r->x;
    r->x = r->xn;
    r->xn = tmp;
}

tsk_status tsk_refine_simulate(const tsk_refine_bend_def* def, const float* knots,
                               const float* widths, size_t knot_count, size_t frame_count,
                               float* out_trajectories) {
    tsk_status s = check_def(def);
    if (s != TSK_OK) return s;
    if (knots == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "is NULL");
    if (widths == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "widths", "is NULL");
    if (out_trajectories == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "out_trajectories", "is NULL");
    if (knot_count < 2)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "knot_count",
                             "a blade needs at least 2 knots, got %zu", knot_count);
    if (knot_count > TSK_REFINE_MAX_KNOTS)
        return tsk_error_arg(TSK_ERR_LIMIT, "knot_count", "%zu knots exceed the limit of %d",
                             knot_count, TSK_REFINE_MAX_KNOTS);
    if (frame_count == 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "frame_count", "needs at least 1 frame, got 0");
    if (frame_count > TSK_REFINE_MAX_FRAMES || knot_count * frame_count > TSK_REFINE_MAX_SAMPLES)
        return tsk_error_arg(TSK_ERR_LIMIT, "frame_count", "%zu frames of %zu knots are too many",
                             frame_count, knot_count);
    double wmax = 0.0;
    for (size_t i = 0; i < knot_count; ++i) {
        for (int c = 0; c < 3; ++c)
            if (!isfinite(knots[3 * i + c]))
                return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "knot %zu is not finite", i);
        if (i > 0 && knots[3 * i] == knots[3 * i - 3] && knots[3 * i + 1] == knots[3 * i - 2] &&
            knots[3 * i + 2] == knots[3 * i - 1])
            return tsk_error_arg(TSK_ERR_ARGUMENT, "knots",
                                 "knots %zu and %zu are at the same place (duplicate knot)", i - 1,
                                 i);
        if (!(widths[i] >= 0.0f) || !isfinite(widths[i]))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "widths",
                                 "width %zu must be finite and >= 0, got %g", i, (double)widths[i]);
        if (widths[i] > wmax) wmax = widths[i];
    }
    if (!(wmax > 0.0)) return tsk_error_arg(TSK_ERR_ARGUMENT, "widths", "are all zero");

    rod r;
    double stable = 0.0;
    s = rod_init(&r, def, knots, widths, knot_count, &stable);
    if (s != TSK_OK) {
        rod_free(&r);
        return s;
    }
    /* whole steps per frame, the step at most 0.4 of the stability limit */
    const double frame_dt = 1.0 / (double)def->fps;
    const double dt_max = def->time_step > 0.0f ? (double)def->time_step : 0.4 * stable;
    double spf_d = ceil(frame_dt / dt_max - 1e-9);
    if (spf_d < 1.0) spf_d = 1.0;
    const double warm_frames = floor((double)def->warmup * (double)def->fps + 0.5);
    const double steps_total = spf_d * (warm_frames + (double)(frame_count - 1)) + 1.0;
    /* the steps of one frame must fit the limit too (also keeps the size_t casts below
     * defined when the stable step is tiny and only one frame is asked for) */
    if (!(steps_total * (double)knot_count <= TSK_BEND_MAX_WORK) ||
        !(spf_d * (double)knot_count <= TSK_BEND_MAX_WORK)) {
        rod_free(&r);
        return tsk_error_arg(TSK_ERR_LIMIT, "knot_count",
                             "%zu knots x %.3g time steps exceed the limit of %.3g (fewer "
                             "knots, frames or warmup, or a thicker blade, make it cheaper)",
                             knot_count, steps_total > spf_d ? steps_total : spf_d,
                             TSK_BEND_MAX_WORK);
    }
    const size_t spf = (size_t)spf_d;
    const double dt = frame_dt / spf_d;
    v3 along, across;
    wind_axes(def, &along, &across);
    const v3 g = v3_make(def->gravity[0], def->gravity[1], def->gravity[2]);
    const size_t first = (size_t)warm_frames * spf;
    const size_t last = first + (frame_count - 1) * spf;
    size_t f = 0;
    for (size_t step = 0; step <= last; ++step) {
        if (step >= first && (step - first) % spf == 0) {
            float* o = out_trajectories + f * knot_count * 3;
            int finite = 1;
            for (size_t q = 0; q < knot_count * 3; ++q) {
                o[q] = (float)r.x[q];
                finite &= isfinite(o[q]);
            }
            if (!finite) {
                rod_free(&r);
                return tsk_error(TSK_ERR_INTERNAL,
                                 "bending simulation became unstable at frame %zu (time_step "
                                 "too long?)",
                                 f);
            }
            ++f;
        }
        if (step == last) break;
        const v3 wind = wind_at(def->wind_speed, def->gust, along, across, (double)step * dt);
        rod_step(&r, def, g, wind, dt);
    }
    rod_free(&r);
    return TSK_OK;
}
