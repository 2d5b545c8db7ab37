/* Collider shapes fitted to meshes (tussock/collider.h): capsules per bone of an armature-
 * deformed mesh, fitted at rest and moved with the pose, and sphere sets over the surface of
 * any other mesh. Double arithmetic in a fixed order and no contraction (the build's
 * -ffp-contract=off), so a farm's nodes fit the same bytes. */
#include "tussock/collider.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846
/* the thinnest shape: the solver refuses a radius of 0, and a bone whose points lie on one
 * line still has a thickness of skin */
#define MIN_RADIUS 1.0e-4

/* rows 0..2 of a 4x4 matrix */
typedef struct affine {
    double m[3][4];
} affine;

/* ---- checks -------------------------------------------------------------------------------- */

static tsk_status check_coords(const char* name, const float* v, size_t n) {
    for (size_t i = 0; i < n; ++i)
        if (!(fabsf(v[i]) <= TSK_COLLIDER_FIT_MAX_COORD))
            return tsk_error_arg(TSK_ERR_ARGUMENT, name,
                                 "value %zu is %g: coordinates must be finite and within "
                                 "+-%g m",
                                 i, (double)v[i], (double)TSK_COLLIDER_FIT_MAX_COORD);
    return TSK_OK;
}

static tsk_status check_count(const char* name, int32_t n, int32_t most) {
    if (n < 0 || n > most)
        return tsk_error_arg(n < 0 ? TSK_ERR_ARGUMENT : TSK_ERR_LIMIT, name,
                             "must be 0..%d, got %d", (int)most, (int)n);
    return TSK_OK;
}

#define TRY(expr)                            \
    do {                                     \
        tsk_status try_s_ = (expr);          \
        if (try_s_ != TSK_OK) return try_s_; \
    } while (0)

/* ---- small affine algebra ------------------------------------------------------------------ */

static void load_affine(const float* m, affine* a) {
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) a->m[r][c] = (double)m[4 * r + c];
}

static void apply(const affine* a, const double p[3], double out[3]) {
    for (int r = 0; r < 3; ++r)
        out[r] = a->m[r][0] * p[0] + a->m[r][1] * p[1] + a->m[r][2] * p[2] + a->m[r][3];
}

static void compose(const affine* x, const affine* y, affine* out) { /* x @ y */
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 4; ++c) {
            double v = x->m[r][0] * y->m[0][c] + x->m[r][1] * y->m[1][c] + x->m[r][2] * y->m[2][c];
            out->m[r][c] = c == 3 ? v + x->m[r][3] : v;
        }
    }
}

/* The inverse of an affine map; 0 when its 3x3 part is singular. */
static int invert(const affine* a, affine* out) {
    const double(*m)[4] = a->m;
    double c[3][3];
    c[0][0] = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    c[0][1] = m[0][2] * m[2][1] - m[0][1] * m[2][2];
    c[0][2] = m[0][1] * m[1][2] - m[0][2] * m[1][1];
    c[1][0] = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    c[1][1] = m[0][0] * m[2][2] - m[0][2] * m[2][0];
    c[1][2] = m[0][2] * m[1][0] - m[0][0] * m[1][2];
    c[2][0] = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    c[2][1] = m[0][1] * m[2][0] - m[0][0] * m[2][1];
    c[2][2] = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    const double det = m[0][0] * c[0][0] + m[0][1] * c[1][0] + m[0][2] * c[2][0];
    if (!(fabs(det) > 1e-30) || !isfinite(det)) return 0;
    for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) out->m[r][k] = c[r][k] / det;
        out->m[r][3] = -(out->m[r][0] * m[0][3] + out->m[r][1] * m[1][3] + out->m[r][2] * m[2][3]);
    }
    return 1;
}

/* The largest length of a column of the 3x3 part: how much a radius grows. */
static double max_scale(const affine* a) {
    double best = 0.0;
    for (int c = 0; c < 3; ++c) {
        const double x = a->m[0][c], y = a->m[1][c], z = a->m[2][c];
        const double s = sqrt(x * x + y * y + z * z);
        if (s > best) best = s;
    }
    return best;
}

static double dot3(const double a[3], const double b[3]) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double out[3]) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static int normalize3(double v[3]) {
    const double n = sqrt(dot3(v, v));
    if (!(n > 1e-300)) return 0;
    for (int k = 0; k < 3; ++k) v[k] /= n;
    return 1;
}

/* Squared distance from p to the segment h-t. */
static double segment_dist2(const double p[3], const double h[3], const double t[3]) {
    double d[3], q[3];
    for (int k = 0; k < 3; ++k) {
        d[k] = t[k] - h[k];
        q[k] = p[k] - h[k];
    }
    const double dd = dot3(d, d);
    double s = dd > 0.0 ? dot3(q, d) / dd : 0.0;
    s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
    double e = 0.0;
    for (int k = 0; k < 3; ++k) {
        const double r = q[k] - s * d[k];
        e += r * r;
    }
    return e;
}

/* ---- one capsule about a point set --------------------------------------------------------- */

typedef struct capsule_fit {
    double radius, lo, hi, cx, cz; /* along u: lo..hi; centre line at cx v + cz w */
    double u[3], v[3], w[3];
    double volume;
} capsule_fit;

/* A fixed shuffle of 0..n-1 (xorshift, seeded by n): the smallest enclosing circle below
 * takes expected linear time on points in random order, and the same order everywhere gives
 * the same bytes. */
static void shuffled(int32_t* order, size_t n) {
    uint64_t x = 0x9e3779b97f4a7c15ull ^ (uint64_t)n;
    for (size_t i = 0; i < n; ++i) order[i] = (int32_t)i;
    for (size_t i = n; i > 1; --i) {
        x ^= x >> 12, x ^= x << 25, x ^= x >> 27;
        const size_t j = (size_t)((x * 2685821657736338717ull) >> 33) % i;
        const int32_t t = order[i - 1];
        order[i - 1] = order[j];
        order[j] = t;
    }
}

typedef struct circle {
    double x, z, r2;
} circle;

static int outside(const circle* c, double x, double z) {
    const double dx = x - c->x, dz = z - c->z;
    return dx * dx + dz * dz > c->r2 * (1.0 + 1e-12) + 1e-24;
}

static circle circle2(double ax, double az, double bx, double bz) {
    circle c = {0.5 * (ax + bx), 0.5 * (az + bz), 0.0};
    c.r2 = (ax - c.x) * (ax - c.x) + (az - c.z) * (az - c.z);
    return c;
}

/* the circle through three points; the widest of the pair circles when they are collinear */
static circle circle3(double ax, double az, double bx, double bz, double cx, double cz) {
    const double bxr = bx - ax, bzr = bz - az, cxr = cx - ax, czr = cz - az;
    const double d = 2.0 * (bxr * czr - bzr * cxr);
    if (fabs(d) < 1e-300) {
        circle p = circle2(ax, az, bx, bz), q = circle2(ax, az, cx, cz),
               r = circle2(bx, bz, cx, cz);
        circle best = p.r2 > q.r2 ? p : q;
        return r.r2 > best.r2 ? r : best;
    }
    const double b2 = bxr * bxr + bzr * bzr, c2 = cxr * cxr + czr * czr;
    const double ux = (czr * b2 - bzr * c2) / d, uz = (bxr * c2 - cxr * b2) / d;
    circle c = {ax + ux, az + uz, ux * ux + uz * uz};
    return c;
}

/* The smallest circle holding the points (x[i], z[i]) (Welzl's incremental form, in the order
 * of `order`). */
static circle enclosing_circle(const double* x, const double* z, const int32_t* order, size_t n) {
    circle c = {x[order[0]], z[order[0]], 0.0};
    for (size_t i = 1; i < n; ++i) {
        const int32_t p = order[i];
        if (!outside(&c, x[p], z[p])) continue;
        c.x = x[p], c.z = z[p], c.r2 = 0.0;
        for (size_t j = 0; j < i; ++j) {
            const int32_t q = order[j];
            if (!outside(&c, x[q], z[q])) continue;
            c = circle2(x[p], z[p], x[q], z[q]);
            for (size_t k = 0; k < j; ++k) {
                const int32_t t = order[k];
                if (outside(&c, x[t], z[t])) c = circle3(x[p], z[p], x[q], z[q], x[t], z[t]);
            }
        }
    }
    return c;
}

/* The capsule along axis u (unit) that holds every point: its centre line through the centre
 * of the smallest circle holding the points seen along u, its radius that circle's (the
 * farthest point from the line), and its ends as close together as holding every point allows
 * (a point at distance d from the line needs an end within sqrt(r^2 - d^2) of its position
 * along u). scratch: 2 n doubles; order: n indices. */
static void fit_along(const double* pts, size_t n, const double u[3], double* scratch,
                      int32_t* order, capsule_fit* f) {
    double v[3], w[3], ref[3] = {1.0, 0.0, 0.0};
    if (fabs(u[0]) > 0.9) ref[0] = 0.0, ref[1] = 1.0;
    cross3(u, ref, v);
    normalize3(v);
    cross3(u, v, w);
    double *xs = scratch, *zs = scratch + n;
    for (size_t i = 0; i < n; ++i) xs[i] = dot3(pts + 3 * i, v), zs[i] = dot3(pts + 3 * i, w);
    shuffled(order, n);
    const circle c = enclosing_circle(xs, zs, order, n);
    const double cx = c.x, cz = c.z;
    double r2 = 0.0; /* the farthest point, measured again (the circle's test has a tolerance) */
    for (size_t i = 0; i < n; ++i) {
        const double d2 = (xs[i] - cx) * (xs[i] - cx) + (zs[i] - cz) * (zs[i] - cz);
        r2 = d2 > r2 ? d2 : r2;
    }
    double r = sqrt(r2);
    if (r < MIN_RADIUS) r = MIN_RADIUS, r2 = r * r;
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < n; ++i) {
        const double d2 = (xs[i] - cx) * (xs[i] - cx) + (zs[i] - cz) * (zs[i] - cz);
        const double y = dot3(pts + 3 * i, u);
        const double room2 = r2 - d2;
        const double room = room2 > 0.0 ? sqrt(room2) : 0.0;
        lo = y + room < lo ? y + room : lo;
        hi = y - room > hi ? y - room : hi;
    }
    if (lo >= hi) lo = hi = 0.5 * (lo + hi); /* a sphere anywhere in [hi, lo] holds them all */
    f->radius = r;
    f->lo = lo;
    f->hi = hi;
    f->cx = cx;
    f->cz = cz;
    memcpy(f->u, u, sizeof f->u);
    memcpy(f->v, v, sizeof f->v);
    memcpy(f->w, w, sizeof f->w);
    f->volume = PI * r2 * (hi - lo) + 4.0 / 3.0 * PI * r2 * r;
}

/* The principal axis of the points (power iteration on their covariance, from a fixed start):
 * 0 when they have no spread. */
static int principal_axis(const double* pts, size_t n, double axis[3]) {
    double mean[3] = {0, 0, 0};
    for (size_t i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) mean[k] += pts[3 * i + k];
    for (int k = 0; k < 3; ++k) mean[k] /= (double)n;
    double c[3][3] = {{0}};
    for (size_t i = 0; i < n; ++i) {
        double d[3];
        for (int k = 0; k < 3; ++k) d[k] = pts[3 * i + k] - mean[k];
        for (int r = 0; r < 3; ++r)
            for (int k = 0; k < 3; ++k) c[r][k] += d[r] * d[k];
    }
    double x[3] = {0.5773502691896258, 0.5773502691896258, 0.5773502691896258};
    for (int it = 0; it < 64; ++it) {
        double y[3];
        for (int r = 0; r < 3; ++r) y[r] = c[r][0] * x[0] + c[r][1] * x[1] + c[r][2] * x[2];
        if (!normalize3(y)) return 0;
        memcpy(x, y, sizeof x);
    }
    memcpy(axis, x, sizeof x);
    return 1;
}

/* The smaller of the capsules along the bone's y axis and along the points' principal axis,
 * as a row (8 floats) in the points' space. */
static void fit_capsule(const double* pts, size_t n, double* scratch, int32_t* order, float* row) {
    const double y_axis[3] = {0.0, 1.0, 0.0};
    capsule_fit best, other;
    fit_along(pts, n, y_axis, scratch, order, &best);
    double pa[3];
    if (n >= 2 && principal_axis(pts, n, pa)) {
        fit_along(pts, n, pa, scratch, order, &other);
        if (other.volume < best.volume) best = other;
    }
    row[0] = best.hi > best.lo ? 1.0f : 0.0f;
    row[1] = (float)best.radius;
    for (int k = 0; k < 3; ++k) {
        const double side = best.cx * best.v[k] + best.cz * best.w[k];
        row[2 + k] = (float)(side + best.lo * best.u[k]);
        row[5 + k] = (float)(side + best.hi * best.u[k]);
    }
}

/* ---- bones ---------------------------------------------------------------------------------- */

typedef struct bone_order {
    int32_t depth, index;
} bone_order;

static int by_value(const void* a, const void* b) {
    const double x = *(const double*)a, y = *(const double*)b;
    return (x > y) - (x < y);
}

static int deeper_first(const void* a, const void* b) {
    const bone_order *x = a, *y = b;
    if (x->depth != y->depth) return x->depth > y->depth ? -1 : 1;
    return (x->index > y->index) - (x->index < y->index);
}

tsk_status tsk_collider_fit_bones(const float* points, int32_t point_count,
                                  const float* to_armature, const float* heads, const float* tails,
                                  const float* rest, const int32_t* parent, const uint8_t* deforms,
                                  int32_t bone_count, float min_size, float* out, int32_t* group) {
    TRY(check_count("points", point_count, TSK_COLLIDER_FIT_MAX_POINTS));
    TRY(check_count("bones", bone_count, TSK_COLLIDER_FIT_MAX_SHAPES));
    if (point_count > 0 && points == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "points", "is NULL");
    if (to_armature == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "to_armature", "is NULL");
    if (bone_count > 0 && (heads == NULL || tails == NULL || rest == NULL || parent == NULL ||
                           deforms == NULL || out == NULL))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "bones", "an array of the bones is NULL");
    if (!(min_size >= 0.0f && min_size <= TSK_COLLIDER_FIT_MAX_COORD))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "min_size", "must be 0..%g m, got %g",
                             (double)TSK_COLLIDER_FIT_MAX_COORD, (double)min_size);
    TRY(check_coords("points", points, (size_t)point_count * 3));
    TRY(check_coords("to_armature", to_armature, 16));
    TRY(check_coords("heads", heads, (size_t)bone_count * 3));
    TRY(check_coords("tails", tails, (size_t)bone_count * 3));
    TRY(check_coords("rest", rest, (size_t)bone_count * 16));
    for (int32_t b = 0; b < bone_count; ++b)
        if (parent[b] < -1 || parent[b] >= bone_count || parent[b] == b)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "parent",
                                 "bone %d has parent %d: must be another bone or -1", (int)b,
                                 (int)parent[b]);
    for (int32_t i = 0; i < bone_count * 8; ++i) out[i] = 0.0f;
    for (int32_t b = 0; b < bone_count; ++b) out[8 * b] = -1.0f;
    if (group != NULL)
        for (int32_t i = 0; i < point_count; ++i) group[i] = -1;
    if (bone_count == 0) return TSK_OK;

    tsk_status s = TSK_OK;
    const size_t nb = (size_t)bone_count, np = (size_t)point_count;
    bone_order* order = tsk_calloc(nb, sizeof *order, "bone order");
    affine* to_bone = tsk_calloc(nb, sizeof *to_bone, "bone inverses");
    int32_t* owner = tsk_calloc(np ? np : 1, sizeof *owner, "point owners");
    int32_t* first = tsk_calloc(nb, sizeof *first, "bone members");
    int32_t* next = tsk_calloc(nb, sizeof *next, "bone members");
    int32_t* last = tsk_calloc(nb, sizeof *last, "bone members");
    int32_t* count = tsk_calloc(nb, sizeof *count, "bone point counts");
    int32_t* start = tsk_calloc(nb + 1, sizeof *start, "bone point starts");
    int32_t* sorted = tsk_calloc(np ? np : 1, sizeof *sorted, "points by bone");
    double* arm = tsk_calloc(np ? 3 * np : 1, sizeof *arm, "points in armature space");
    double* local = tsk_calloc(np ? 3 * np : 1, sizeof *local, "points in bone space");
    double* scratch = tsk_calloc(np ? 2 * np : 1, sizeof *scratch, "capsule fit");
    int32_t* shuffle = tsk_calloc(np ? np : 1, sizeof *shuffle, "capsule fit");
    double* seg = tsk_calloc(6 * nb, sizeof *seg, "bone segments");
    double* thick = tsk_calloc(nb, sizeof *thick, "limb thicknesses");
    if (!order || !to_bone || !owner || !first || !next || !last || !count || !start || !sorted ||
        !arm || !local || !scratch || !shuffle || !seg || !thick) {
        s = TSK_ERR_MEMORY;
        goto done;
    }
    /* depths (a chain longer than the bone count is a cycle) */
    for (int32_t b = 0; b < bone_count; ++b) {
        int32_t d = 0, p = parent[b];
        while (p >= 0 && d <= bone_count) p = parent[p], ++d;
        if (d > bone_count) {
            s = tsk_error_arg(TSK_ERR_ARGUMENT, "parent", "bone %d is its own ancestor", (int)b);
            goto done;
        }
        order[b].depth = d;
        order[b].index = b;
        affine r;
        load_affine(rest + 16 * b, &r);
        if (!invert(&r, &to_bone[b])) {
            s = tsk_error_arg(TSK_ERR_ARGUMENT, "rest", "the rest matrix of bone %d is singular",
                              (int)b);
            goto done;
        }
        first[b] = last[b] = b;
        next[b] = -1;
        for (int k = 0; k < 3; ++k) {
            seg[6 * b + k] = heads[3 * b + k];
            seg[6 * b + 3 + k] = tails[3 * b + k];
        }
    }
    qsort(order, nb, sizeof *order, deeper_first);

    /* Every point to the deforming bone whose limb it lies on, at rest in armature space, in
     * two rounds. First the bone whose segment is nearest; but at a joint a point of one limb
     * is often nearer another bone's segment (the end of a thigh's tube is nearer the hips'
     * bone than its own), and taking it would widen that bone's capsule by the whole limb.
     * So the limbs' thicknesses are measured, the median distance of each bone's first points
     * from its segment (most of a limb's skin is at its thickness: a few strays do not move
     * it), and each point goes to the bone whose limb's surface it is deepest inside or
     * nearest outside of. */
    affine m;
    load_affine(to_armature, &m);
    for (size_t i = 0; i < np; ++i) {
        const double p[3] = {points[3 * i], points[3 * i + 1], points[3 * i + 2]};
        apply(&m, p, arm + 3 * i);
        double best = INFINITY;
        int32_t who = -1;
        for (int32_t b = 0; b < bone_count; ++b) {
            if (!deforms[b]) continue;
            const double d = segment_dist2(arm + 3 * i, seg + 6 * b, seg + 6 * b + 3);
            if (d < best) best = d, who = b;
        }
        owner[i] = who;
        if (who >= 0) ++count[who];
    }
    for (int32_t b = 0; b < bone_count; ++b) start[b + 1] = start[b] + count[b];
    memset(count, 0, nb * sizeof *count);
    for (size_t i = 0; i < np; ++i)
        if (owner[i] >= 0) {
            const int32_t b = owner[i];
            scratch[start[b] + count[b]++] =
                sqrt(segment_dist2(arm + 3 * i, seg + 6 * b, seg + 6 * b + 3));
        }
    for (int32_t b = 0; b < bone_count; ++b) {
        thick[b] = 0.0;
        if (count[b] == 0) continue;
        qsort(scratch + start[b], (size_t)count[b], sizeof *scratch, by_value);
        thick[b] = scratch[start[b] + (count[b] - 1) / 2];
    }
    memset(count, 0, nb * sizeof *count);
    for (size_t i = 0; i < np; ++i) {
        if (owner[i] < 0) continue;
        double best = INFINITY;
        int32_t who = -1;
        for (int32_t b = 0; b < bone_count; ++b) {
            if (!deforms[b]) continue;
            const double d =
                sqrt(segment_dist2(arm + 3 * i, seg + 6 * b, seg + 6 * b + 3)) - thick[b];
            if (d < best) best = d, who = b;
        }
        owner[i] = who;
        ++count[who];
    }
    for (int32_t b = 0; b < bone_count; ++b) start[b + 1] = start[b] + count[b];
    memset(count, 0, nb * sizeof *count);
    for (size_t i = 0; i < np; ++i)
        if (owner[i] >= 0) sorted[start[owner[i]] + count[owner[i]]++] = (int32_t)i;

    /* deepest bones first: each bone's points, with those its children gave it, in its space;
     * a bone too small gives them all to its parent, a big enough one fits its capsule */
    for (size_t k = 0; k < nb; ++k) {
        const int32_t b = order[k].index;
        size_t n = 0;
        for (int32_t g = first[b]; g >= 0; g = next[g])
            for (int32_t j = start[g]; j < start[g + 1]; ++j)
                apply(&to_bone[b], arm + 3 * (size_t)sorted[j], local + 3 * n++);
        if (n == 0) continue;
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (size_t i = 0; i < n; ++i)
            for (int q = 0; q < 3; ++q) {
                const double x = local[3 * i + q];
                lo[q] = x < lo[q] ? x : lo[q];
                hi[q] = x > hi[q] ? x : hi[q];
            }
        const double span = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
        const int32_t p = parent[b];
        if (p >= 0 && span < (double)min_size) {
            next[last[p]] = first[b];
            last[p] = last[b];
            continue;
        }
        fit_capsule(local, n, scratch, shuffle, out + 8 * (size_t)b);
        if (group != NULL)
            for (int32_t g = first[b]; g >= 0; g = next[g])
                for (int32_t j = start[g]; j < start[g + 1]; ++j) group[sorted[j]] = b;
    }
done:
    tsk_free(order);
    tsk_free(to_bone);
    tsk_free(owner);
    tsk_free(first);
    tsk_free(next);
    tsk_free(last);
    tsk_free(count);
    tsk_free(start);
    tsk_free(sorted);
    tsk_free(arm);
    tsk_free(local);
    tsk_free(scratch);
    tsk_free(shuffle);
    tsk_free(seg);
    tsk_free(thick);
    return s;
}

tsk_status tsk_collider_fit_groups(const float* points, int32_t point_count, const int32_t* tris,
                                   int32_t tri_count, const int32_t* group, const float* to_world,
                                   const float* armature_world, const float* pose,
                                   int32_t bone_count, float* rows) {
    TRY(check_count("points", point_count, TSK_COLLIDER_FIT_MAX_POINTS));
    TRY(check_count("bones", bone_count, TSK_COLLIDER_FIT_MAX_SHAPES));
    if (to_world == NULL || armature_world == NULL ||
        (point_count > 0 && (points == NULL || group == NULL)) ||
        (bone_count > 0 && (pose == NULL || rows == NULL)))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "bones", "an array is NULL");
    TRY(check_coords("points", points, (size_t)point_count * 3));
    TRY(check_coords("to_world", to_world, 16));
    TRY(check_coords("armature_world", armature_world, 16));
    TRY(check_coords("pose", pose, (size_t)bone_count * 16));
    TRY(check_count("triangles", tri_count, TSK_COLLIDER_FIT_MAX_POINTS));
    if (tri_count > 0 && tris == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "triangles", "is NULL");
    for (int32_t i = 0; i < point_count; ++i)
        if (group[i] < -1 || group[i] >= bone_count)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "group", "point %d has bone %d: must be -1..%d",
                                 (int)i, (int)group[i], (int)bone_count - 1);
    for (size_t i = 0; i < (size_t)tri_count * 3; ++i)
        if (tris[i] < 0 || tris[i] >= point_count)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "triangles", "index %zu is %d: must be 0..%d", i,
                                 (int)tris[i], (int)point_count - 1);
    for (int32_t i = 0; i < bone_count * 8; ++i) rows[i] = 0.0f;
    for (int32_t b = 0; b < bone_count; ++b) rows[8 * b] = -1.0f;
    if (bone_count == 0 || point_count == 0) return TSK_OK;

    /* Each bone's points: its own, and the corners of every triangle that has one of its
     * own as a corner. Every triangle then lies inside the capsule of each bone it touches
     * (a convex capsule holds the hull of what it holds), so the whole surface is held, also
     * where a triangle joins two bones' limbs. `entries` bounds the entries: each point once for
     * its bone, and at most nine per triangle for the other bones among its corners. */
    tsk_status s = TSK_OK;
    const size_t nb = (size_t)bone_count, np = (size_t)point_count, nt = (size_t)tri_count;
    const size_t entries = np + 9 * nt;
    int32_t* start = tsk_calloc(nb + 1, sizeof *start, "bone point starts");
    int32_t* fill = tsk_calloc(nb, sizeof *fill, "bone point counts");
    int32_t* sorted = tsk_calloc(entries, sizeof *sorted, "points by bone");
    double* local = tsk_calloc(3 * entries, sizeof *local, "points in bone space");
    double* scratch = tsk_calloc(2 * entries, sizeof *scratch, "capsule fit");
    int32_t* shuffle = tsk_calloc(entries, sizeof *shuffle, "capsule fit");
    if (!start || !fill || !sorted || !local || !scratch || !shuffle) {
        s = TSK_ERR_MEMORY;
        goto done;
    }
    for (int pass = 0; pass < 2; ++pass) { /* count, then place */
        for (size_t i = 0; i < np; ++i) {
            const int32_t g = group[i];
            if (g < 0) continue;
            if (pass == 0) ++start[g + 1];
            else sorted[start[g] + fill[g]++] = (int32_t)i;
        }
        for (size_t t = 0; t < nt; ++t) {
            const int32_t* c = tris + 3 * t;
            for (int k = 0; k < 3; ++k) {
                const int32_t g = group[c[k]];
                /* each other bone among the corners, once per triangle */
                if (g < 0 || (k > 0 && g == group[c[0]]) || (k > 1 && g == group[c[1]])) continue;
                if (group[c[0]] == g && group[c[1]] == g && group[c[2]] == g) continue;
                for (int q = 0; q < 3; ++q) {
                    if (group[c[q]] == g) continue; /* (its own points are there already) */
                    if (pass == 0) ++start[g + 1];
                    else sorted[start[g] + fill[g]++] = c[q];
                }
            }
        }
        if (pass == 0)
            for (size_t b = 0; b < nb; ++b) start[b + 1] += start[b];
    }
    affine tw, aw;
    load_affine(to_world, &tw);
    load_affine(armature_world, &aw);
    for (size_t b = 0; b < nb; ++b) {
        const size_t n = (size_t)(start[b + 1] - start[b]);
        if (n == 0) continue;
        /* the bone's frame now: points in it, fitted as at rest, and the shape put back */
        affine pb, m, inv, to_local;
        load_affine(pose + 16 * b, &pb);
        compose(&aw, &pb, &m);
        if (!invert(&m, &inv)) {
            s = tsk_error_arg(TSK_ERR_ARGUMENT, "pose", "the pose of bone %d is singular", (int)b);
            goto done;
        }
        compose(&inv, &tw, &to_local);
        for (size_t k = 0; k < n; ++k) {
            const size_t i = (size_t)sorted[(size_t)start[b] + k];
            const double p[3] = {points[3 * i], points[3 * i + 1], points[3 * i + 2]};
            apply(&to_local, p, local + 3 * k);
        }
        float row[8];
        fit_capsule(local, n, scratch, shuffle, row);
        float* out = rows + 8 * b;
        out[0] = row[0];
        out[1] = (float)((double)row[1] * max_scale(&m));
        for (int e = 0; e < 2; ++e) {
            const double q[3] = {row[2 + 3 * e], row[3 + 3 * e], row[4 + 3 * e]};
            double o[3];
            apply(&m, q, o);
            for (int k = 0; k < 3; ++k) out[2 + 3 * e + k] = (float)o[k];
        }
    }
done:
    tsk_free(start);
    tsk_free(fill);
    tsk_free(sorted);
    tsk_free(local);
    tsk_free(scratch);
    tsk_free(shuffle);
    return s;
}

/* ---- sphere sets ---------------------------------------------------------------------------- */

typedef struct keyed {
    double key;
    int32_t prim;
} keyed;

static int by_key(const void* a, const void* b) {
    const keyed *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return (x->prim > y->prim) - (x->prim < y->prim);
}

typedef struct leaf {
    int32_t begin, end;
    double c[3], r;
} leaf;

typedef struct sphere_ctx {
    const float* points;
    const int32_t* tris; /* NULL: every primitive is a point */
    int32_t* prim; /* the primitives, grouped by leaf */
} sphere_ctx;

static int prim_corners(const sphere_ctx* x, int32_t p, double v[3][3]) {
    const int corners = x->tris ? 3 : 1;
    for (int k = 0; k < corners; ++k) {
        const int32_t i = x->tris ? x->tris[3 * (size_t)p + k] : p;
        for (int q = 0; q < 3; ++q) v[k][q] = x->points[3 * (size_t)i + q];
    }
    return corners;
}

/* The leaf's sphere: about the centre of its corners' box, holding every corner. */
static void leaf_sphere(const sphere_ctx* x, leaf* l) {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double v[3][3];
    for (int32_t j = l->begin; j < l->end; ++j) {
        const int n = prim_corners(x, x->prim[j], v);
        for (int k = 0; k < n; ++k)
            for (int q = 0; q < 3; ++q) {
                lo[q] = v[k][q] < lo[q] ? v[k][q] : lo[q];
                hi[q] = v[k][q] > hi[q] ? v[k][q] : hi[q];
            }
    }
    for (int q = 0; q < 3; ++q) l->c[q] = 0.5 * (lo[q] + hi[q]);
    double r2 = 0.0;
    for (int32_t j = l->begin; j < l->end; ++j) {
        const int n = prim_corners(x, x->prim[j], v);
        for (int k = 0; k < n; ++k) {
            double d2 = 0.0;
            for (int q = 0; q < 3; ++q) d2 += (v[k][q] - l->c[q]) * (v[k][q] - l->c[q]);
            r2 = d2 > r2 ? d2 : r2;
        }
    }
    l->r = sqrt(r2) > MIN_RADIUS ? sqrt(r2) : MIN_RADIUS;
}

tsk_status tsk_collider_fit_spheres(const float* points, int32_t point_count, const int32_t* tris,
                                    int32_t tri_count, const float* world, int32_t max_spheres,
                                    float* rows, int32_t* count) {
    TRY(check_count("points", point_count, TSK_COLLIDER_FIT_MAX_POINTS));
    TRY(check_count("triangles", tri_count, TSK_COLLIDER_FIT_MAX_POINTS));
    if (max_spheres < 1 || max_spheres > TSK_COLLIDER_FIT_MAX_SHAPES)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "max_spheres", "must be 1..%d, got %d",
                             TSK_COLLIDER_FIT_MAX_SHAPES, (int)max_spheres);
    if (count == NULL || world == NULL || rows == NULL || (point_count > 0 && points == NULL) ||
        (tri_count > 0 && tris == NULL))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "spheres", "an array is NULL");
    *count = 0;
    TRY(check_coords("points", points, (size_t)point_count * 3));
    TRY(check_coords("world", world, 16));
    for (size_t i = 0; i < (size_t)tri_count * 3; ++i)
        if (tris[i] < 0 || tris[i] >= point_count)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "triangles", "index %zu is %d: must be 0..%d", i,
                                 (int)tris[i], (int)point_count - 1);
    const int32_t prims = tri_count > 0 ? tri_count : point_count;
    if (prims == 0) return TSK_OK;

    tsk_status s = TSK_OK;
    sphere_ctx x = {points, tri_count > 0 ? tris : NULL, NULL};
    leaf* leaves = tsk_calloc((size_t)max_spheres, sizeof *leaves, "sphere leaves");
    keyed* keys = tsk_calloc((size_t)prims, sizeof *keys, "sphere split keys");
    x.prim = tsk_calloc((size_t)prims, sizeof *x.prim, "sphere primitives");
    if (!leaves || !keys || !x.prim) {
        s = TSK_ERR_MEMORY;
        goto done;
    }
    for (int32_t i = 0; i < prims; ++i) x.prim[i] = i;
    int32_t n = 1;
    leaves[0].begin = 0;
    leaves[0].end = prims;
    leaf_sphere(&x, &leaves[0]);
    while (n < max_spheres) {
        int32_t pick = -1; /* the widest leaf that can be split */
        for (int32_t i = 0; i < n; ++i)
            if (leaves[i].end - leaves[i].begin >= 2 && (pick < 0 || leaves[i].r > leaves[pick].r))
                pick = i;
        if (pick < 0) break;
        leaf* l = &leaves[pick];
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        double v[3][3];
        for (int32_t j = l->begin; j < l->end; ++j) { /* box of the primitives' centres */
            const int c = prim_corners(&x, x.prim[j], v);
            for (int q = 0; q < 3; ++q) {
                double m = 0.0;
                for (int k = 0; k < c; ++k) m += v[k][q];
                m /= c;
                lo[q] = m < lo[q] ? m : lo[q];
                hi[q] = m > hi[q] ? m : hi[q];
            }
        }
        int axis = 0;
        for (int q = 1; q < 3; ++q)
            if (hi[q] - lo[q] > hi[axis] - lo[axis]) axis = q;
        for (int32_t j = l->begin; j < l->end; ++j) {
            const int c = prim_corners(&x, x.prim[j], v);
            double m = 0.0;
            for (int k = 0; k < c; ++k) m += v[k][axis];
            keys[j - l->begin].key = m / c;
            keys[j - l->begin].prim = x.prim[j];
        }
        const int32_t size = l->end - l->begin;
        qsort(keys, (size_t)size, sizeof *keys, by_key);
        for (int32_t j = 0; j < size; ++j) x.prim[l->begin + j] = keys[j].prim;
        const int32_t mid = l->begin + size / 2;
        leaves[n].begin = mid;
        leaves[n].end = l->end;
        l->end = mid;
        leaf_sphere(&x, l);
        leaf_sphere(&x, &leaves[n]);
        ++n;
    }
    affine w;
    load_affine(world, &w);
    const double scale = max_scale(&w);
    for (int32_t i = 0; i < n; ++i) {
        double o[3];
        apply(&w, leaves[i].c, o);
        float* row = rows + 8 * (size_t)i;
        row[0] = 0.0f;
        row[1] = (float)(leaves[i].r * scale);
        for (int k = 0; k < 3; ++k) row[2 + k] = row[5 + k] = (float)o[k];
    }
    *count = n;
done:
    tsk_free(leaves);
    tsk_free(keys);
    tsk_free(x.prim);
    return s;
}

tsk_status tsk_collider_mesh_volume(const float* points, int32_t point_count, const int32_t* tris,
                                    int32_t tri_count, double* volume) {
    TRY(check_count("points", point_count, TSK_COLLIDER_FIT_MAX_POINTS));
    TRY(check_count("triangles", tri_count, TSK_COLLIDER_FIT_MAX_POINTS));
    if (volume == NULL || (point_count > 0 && points == NULL) || (tri_count > 0 && tris == NULL))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "volume", "an array is NULL");
    TRY(check_coords("points", points, (size_t)point_count * 3));
    double sum = 0.0;
    for (int32_t t = 0; t < tri_count; ++t) {
        double p[3][3];
        for (int k = 0; k < 3; ++k) {
            const int32_t i = tris[3 * (size_t)t + k];
            if (i < 0 || i >= point_count)
                return tsk_error_arg(TSK_ERR_ARGUMENT, "triangles",
                                     "triangle %d has index %d: must be 0..%d", (int)t, (int)i,
                                     (int)point_count - 1);
            for (int q = 0; q < 3; ++q) p[k][q] = points[3 * (size_t)i + q];
        }
        double c[3];
        cross3(p[1], p[2], c);
        sum += dot3(p[0], c);
    }
    *volume = fabs(sum) / 6.0;
    return TSK_OK;
}
