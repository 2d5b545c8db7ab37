/* Movement data from a captured sequence: knots of a reference skeleton tracked through
 * the frames by matching normalised arc length; and uniform arc-length resampling, the
 * simple alternative to Algorithm 1 that the quality benchmark compares against. */
#include "tussock/refine.h"

#include <math.h>
#include <string.h>

static double seg_len(const float* a, const float* b) {
    const double dx = (double)b[0] - (double)a[0], dy = (double)b[1] - (double)a[1],
                 dz = (double)b[2] - (double)a[2];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

/* Writes the points at arc-length fractions u[0..count) (non-decreasing, in [0, 1]) of the
 * polyline p (n knots, read in reverse when `reversed`) into out[count][3]; widths too when
 * w and out_w are given. `cum` is scratch of n doubles. Returns 0 if the length is 0. */
static int points_at_fractions(const float* p, const float* w, size_t n, int reversed,
                               const double* u, size_t count, double* cum, float* out,
                               float* out_w) {
#define P(i) (p + 3 * (reversed ? n - 1 - (i) : (i)))
#define W(i) (w[reversed ? n - 1 - (i) : (i)])
    cum[0] = 0.0;
    for (size_t i = 1; i < n; ++i) cum[i] = cum[i - 1] + seg_len(P(i - 1), P(i));
    const double total = cum[n - 1];
    if (!(total > 0.0) || !isfinite(total)) return 0;
    size_t s = 0; /* current segment [s, s+1] */
    for (size_t j = 0; j < count; ++j) {
        const double target = u[j] * total;
        while (s + 2 < n && cum[s + 1] < target) ++s;
        const double len = cum[s + 1] - cum[s];
        double a = len > 0.0 ? (target - cum[s]) / len : 0.0;
        if (a < 0.0) a = 0.0;
        if (a > 1.0) a = 1.0;
        const float* p0 = P(s);
        const float* p1 = P(s + 1);
        for (int c = 0; c < 3; ++c)
            out[3 * j + c] = (float)((1.0 - a) * (double)p0[c] + a * (double)p1[c]);
        if (out_w) out_w[j] = (float)((1.0 - a) * (double)W(s) + a * (double)W(s + 1));
    }
    /* the ends are exact */
    if (count > 0 && u[0] == 0.0) memcpy(out, P(0), 3 * sizeof(float));
    if (count > 0 && u[count - 1] == 1.0)
        memcpy(out + 3 * (count - 1), P(n - 1), 3 * sizeof(float));
    if (out_w && count > 0 && u[0] == 0.0) out_w[0] = W(0);
    if (out_w && count > 0 && u[count - 1] == 1.0) out_w[count - 1] = W(n - 1);
    return 1;
#undef P
#undef W
}

static tsk_status check_polyline(const float* p, size_t n, const char* name, int allow_dup) {
    for (size_t j = 0; j < n; ++j) {
        if (!isfinite(p[3 * j]) || !isfinite(p[3 * j + 1]) || !isfinite(p[3 * j + 2]))
            return tsk_error_arg(TSK_ERR_ARGUMENT, name, "knot %zu is not finite", j);
        if (!allow_dup && j > 0 && p[3 * j] == p[3 * j - 3] && p[3 * j + 1] == p[3 * j - 2] &&
            p[3 * j + 2] == p[3 * j - 1])
            return tsk_error_arg(TSK_ERR_ARGUMENT, name,
                                 "knots %zu and %zu are at the same place (duplicate knot)", j - 1,
                                 j);
    }
    return TSK_OK;
}

tsk_status tsk_refine_track(const float* ref_knots, size_t ref_count, const float* frame_knots,
                            const int32_t* frame_offsets, size_t frame_count,
                            float* out_trajectories) {
    if (ref_knots == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "ref_knots", "is NULL");
    if (ref_count < 2)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "ref_count",
                             "a blade needs at least 2 knots, got %zu", ref_count);
    if (ref_count > TSK_REFINE_MAX_KNOTS)
        return tsk_error_arg(TSK_ERR_LIMIT, "ref_count", "%zu knots exceed the limit of %d",
                             ref_count, TSK_REFINE_MAX_KNOTS);
    if (frame_count == 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "frame_count", "needs at least 1 frame, got 0");
    if (frame_count > TSK_REFINE_MAX_FRAMES || ref_count * frame_count > TSK_REFINE_MAX_SAMPLES)
        return tsk_error_arg(TSK_ERR_LIMIT, "frame_count", "%zu frames of %zu knots are too many",
                             frame_count, ref_count);
    if (frame_knots == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "frame_knots", "is NULL");
    if (frame_offsets == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "frame_offsets", "is NULL");
    if (out_trajectories == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "out_trajectories", "is NULL");
    tsk_status s = check_polyline(ref_knots, ref_count, "ref_knots", 0);
    if (s != TSK_OK) return s;
    if (frame_offsets[0] != 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "frame_offsets", "must start at 0, got %d",
                             (int)frame_offsets[0]);
    size_t max_n = 2;
    for (size_t fr = 0; fr < frame_count; ++fr) {
        const int32_t a = frame_offsets[fr], b = frame_offsets[fr + 1];
        if (b < a)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "frame_offsets",
                                 "decrease at frame %zu (%d then %d)", fr, (int)a, (int)b);
        if (b - a < 2)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "frame_knots",
                                 "frame %zu has %d knots, needs at least 2", fr, (int)(b - a));
        if ((size_t)(b - a) > max_n) max_n = (size_t)(b - a);
    }
    if (max_n > TSK_REFINE_MAX_KNOTS)
        return tsk_error_arg(TSK_ERR_LIMIT, "frame_knots", "a frame has %zu knots, limit %d", max_n,
                             TSK_REFINE_MAX_KNOTS);
    s = check_polyline(frame_knots, (size_t)frame_offsets[frame_count], "frame_knots", 1);
    if (s != TSK_OK) return s;

    double* u = tsk_alloc(ref_count * sizeof(double), "track fractions");
    double* cum =
        tsk_alloc((max_n > ref_count ? max_n : ref_count) * sizeof(double), "track lengths");
    if (u == NULL || cum == NULL) {
        tsk_free(u);
        tsk_free(cum);
        return TSK_ERR_MEMORY;
    }
    /* reference fractions u_j = s_j / L */
    cum[0] = 0.0;
    for (size_t j = 1; j < ref_count; ++j)
        cum[j] = cum[j - 1] + seg_len(ref_knots + 3 * (j - 1), ref_knots + 3 * j);
    const double total = cum[ref_count - 1];
    for (size_t j = 0; j < ref_count; ++j) u[j] = cum[j] / total;
    u[ref_count - 1] = 1.0;
    const float* root = ref_knots;
    const float* tip = ref_knots + 3 * (ref_count - 1);
    for (size_t fr = 0; fr < frame_count && s == TSK_OK; ++fr) {
        const float* p = frame_knots + 3 * (size_t)frame_offsets[fr];
        const size_t n = (size_t)(frame_offsets[fr + 1] - frame_offsets[fr]);
        const float* first = p;
        const float* last = p + 3 * (n - 1);
        const int reversed =
            seg_len(first, tip) + seg_len(last, root) < seg_len(first, root) + seg_len(last, tip);
        if (!points_at_fractions(p, NULL, n, reversed, u, ref_count, cum,
                                 out_trajectories + fr * ref_count * 3, NULL))
            s = tsk_error_arg(TSK_ERR_ARGUMENT, "frame_knots", "frame %zu has zero length", fr);
    }
    tsk_free(u);
    tsk_free(cum);
    return s;
}

tsk_status tsk_refine_resample(const float* knots, const float* widths, size_t knot_count,
                               size_t out_count, float* out_knots, float* out_widths) {
    if (knots == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "is NULL");
    if (knot_count < 2)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "knot_count",
                             "a blade needs at least 2 knots, got %zu", knot_count);
    if (knot_count > TSK_REFINE_MAX_KNOTS)
        return tsk_error_arg(TSK_ERR_LIMIT, "knot_count", "%zu knots exceed the limit of %d",
                             knot_count, TSK_REFINE_MAX_KNOTS);
    if (out_count < 2 || out_count > TSK_REFINE_MAX_KNOTS)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "out_count", "must be from 2 to %d, got %zu",
                             TSK_REFINE_MAX_KNOTS, out_count);
    if (out_knots == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out_knots", "is NULL");
    if (out_widths != NULL && widths == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "widths", "is NULL but out_widths is not");
    tsk_status s = check_polyline(knots, knot_count, "knots", 0);
    if (s != TSK_OK) return s;
    if (widths)
        for (size_t j = 0; j < knot_count; ++j)
            if (!(widths[j] >= 0.0f) || !isfinite(widths[j]))
                return tsk_error_arg(TSK_ERR_ARGUMENT, "widths",
                                     "width %zu must be finite and >= 0", j);
    double* u = tsk_alloc(out_count * sizeof(double), "resample fractions");
    double* cum = tsk_alloc(knot_count * sizeof(double), "resample lengths");
    if (u == NULL || cum == NULL) {
        tsk_free(u);
        tsk_free(cum);
        return TSK_ERR_MEMORY;
    }
    for (size_t j = 0; j < out_count; ++j) u[j] = (double)j / (double)(out_count - 1);
    if (!points_at_fractions(knots, widths, knot_count, 0, u, out_count, cum, out_knots,
                             out_widths))
        s = tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "the blade has zero length");
    tsk_free(u);
    tsk_free(cum);
    return s;
}
