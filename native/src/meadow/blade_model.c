/* Blade models: a rest skeleton (knots root to tip, +z up, root at the origin) with a full
 * width per knot; the built-in default blade; arc-length resampling; the rest side vector. */
#include "meadow_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

tsk_status tsk_blade_model_set(tsk_blade_model* model, const float* xyz, const float* width,
                               int32_t knot_count) {
    if (model == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "model", "is NULL");
    if (knot_count > TSK_BLADE_MAX_KNOTS)
        return tsk_error_arg(TSK_ERR_LIMIT, "knot_count",
                             "%d knots exceed the limit of %d (refine the blade first)",
                             (int)knot_count, TSK_BLADE_MAX_KNOTS);
    if (knot_count < 2)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "knot_count",
                             "a blade needs at least 2 knots, got %d", (int)knot_count);
    if (xyz == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "is NULL");
    if (width == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "width", "is NULL");
    for (int32_t k = 0; k < knot_count; ++k) {
        for (int a = 0; a < 3; ++a)
            if (!isfinite(xyz[3 * k + a]))
                return tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "knot %d is not finite", (int)k);
        if (!isfinite(width[k]) || width[k] < 0.0f)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "width",
                                 "width of knot %d must be finite and >= 0, got %g", (int)k,
                                 (double)width[k]);
        if (fabsf(xyz[3 * k]) > 1e4f || fabsf(xyz[3 * k + 1]) > 1e4f ||
            fabsf(xyz[3 * k + 2]) > 1e4f || width[k] > 1e4f)
            return tsk_error_arg(TSK_ERR_LIMIT, "xyz", "knot %d is over 10 km away; not a blade",
                                 (int)k);
    }
    double length = 0.0;
    for (int32_t k = 1; k < knot_count; ++k) {
        double dx = (double)xyz[3 * k] - xyz[3 * k - 3],
               dy = (double)xyz[3 * k + 1] - xyz[3 * k - 2],
               dz = (double)xyz[3 * k + 2] - xyz[3 * k - 1];
        length += sqrt(dx * dx + dy * dy + dz * dz);
    }
    if (!(length > 1e-7))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "the blade has zero length");
    memset(model, 0, sizeof *model);
    model->knot_count = knot_count;
    const float r0 = xyz[0], r1 = xyz[1], r2 = xyz[2];
    for (int32_t k = 0; k < knot_count; ++k) {
        model->xyz[3 * k] = xyz[3 * k] - r0;
        model->xyz[3 * k + 1] = xyz[3 * k + 1] - r1;
        model->xyz[3 * k + 2] = xyz[3 * k + 2] - r2;
        model->width[k] = width[k];
    }
    return TSK_OK;
}

tsk_status tsk_blade_model_default(tsk_blade_model* model, int32_t knot_count) {
    if (model == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "model", "is NULL");
    if (knot_count < 2 || knot_count > TSK_BLADE_MAX_KNOTS)
        return tsk_error_arg(knot_count > TSK_BLADE_MAX_KNOTS ? TSK_ERR_LIMIT : TSK_ERR_ARGUMENT,
                             "knot_count", "must be 2..%d, got %d", TSK_BLADE_MAX_KNOTS,
                             (int)knot_count);
    memset(model, 0, sizeof *model);
    model->knot_count = knot_count;
    const double H = TSK_DEFAULT_BLADE_HEIGHT, W = TSK_DEFAULT_BLADE_WIDTH;
    for (int32_t k = 0; k < knot_count; ++k) {
        const double t = (double)k / (double)(knot_count - 1);
        model->xyz[3 * k] = (float)(0.25 * H * t * t);
        model->xyz[3 * k + 1] = 0.0f;
        model->xyz[3 * k + 2] = (float)(H * t);
        model->width[k] = (float)(W * (1.0 - t * t * t));
    }
    return TSK_OK;
}

tsk_status tsk_blade_model_resample(const tsk_blade_model* in, int32_t knot_count,
                                    tsk_blade_model* out) {
    if (in == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "in", "is NULL");
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    if (in->knot_count < 2 || in->knot_count > TSK_BLADE_MAX_KNOTS)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "in", "has %d knots (2..%d)", (int)in->knot_count,
                             TSK_BLADE_MAX_KNOTS);
    if (knot_count < 2 || knot_count > TSK_BLADE_MAX_KNOTS)
        return tsk_error_arg(knot_count > TSK_BLADE_MAX_KNOTS ? TSK_ERR_LIMIT : TSK_ERR_ARGUMENT,
                             "knot_count", "must be 2..%d, got %d", TSK_BLADE_MAX_KNOTS,
                             (int)knot_count);
    if (knot_count == in->knot_count) {
        if (out != in) *out = *in;
        return TSK_OK;
    }
    const int32_t n = in->knot_count;
    double cum[TSK_BLADE_MAX_KNOTS];
    cum[0] = 0.0;
    for (int32_t k = 1; k < n; ++k) {
        double dx = (double)in->xyz[3 * k] - in->xyz[3 * k - 3];
        double dy = (double)in->xyz[3 * k + 1] - in->xyz[3 * k - 2];
        double dz = (double)in->xyz[3 * k + 2] - in->xyz[3 * k - 1];
        cum[k] = cum[k - 1] + sqrt(dx * dx + dy * dy + dz * dz);
    }
    const double total = cum[n - 1];
    tsk_blade_model res;
    memset(&res, 0, sizeof res);
    res.knot_count = knot_count;
    int32_t seg = 0;
    for (int32_t k = 0; k < knot_count; ++k) {
        int32_t src;
        double f;
        if (k == knot_count - 1 || !(total > 0.0)) {
            src = k == 0 ? 0 : n - 2;
            f = k == 0 ? 0.0 : 1.0;
        } else {
            const double s = total * (double)k / (double)(knot_count - 1);
            while (seg < n - 2 && cum[seg + 1] <= s) ++seg;
            const double len = cum[seg + 1] - cum[seg];
            src = seg;
            f = len > 0.0 ? (s - cum[seg]) / len : 0.0;
        }
        for (int a = 0; a < 3; ++a) {
            const double p0 = in->xyz[3 * src + a], p1 = in->xyz[3 * (src + 1) + a];
            res.xyz[3 * k + a] = (float)(p0 + (p1 - p0) * f);
        }
        res.width[k] = (float)(in->width[src] + (in->width[src + 1] - in->width[src]) * f);
    }
    /* keep root and tip exactly */
    for (int a = 0; a < 3; ++a) {
        res.xyz[a] = in->xyz[a];
        res.xyz[3 * (knot_count - 1) + a] = in->xyz[3 * (n - 1) + a];
    }
    res.width[0] = in->width[0];
    res.width[knot_count - 1] = in->width[n - 1];
    *out = res;
    return TSK_OK;
}

void tsk_blade_model_side(const tsk_blade_model* model, float side[3]) {
    side[0] = 0.0f;
    side[1] = 1.0f;
    side[2] = 0.0f;
    if (model == NULL || model->knot_count < 2) return;
    const int32_t t = model->knot_count - 1;
    const double dx = (double)model->xyz[3 * t] - model->xyz[0];
    const double dy = (double)model->xyz[3 * t + 1] - model->xyz[1];
    const double len = sqrt(dx * dx + dy * dy);
    if (len < 1e-6) return; /* straight up: any horizontal side works, keep +y */
    side[0] = (float)(-dy / len); /* +z x lean */
    side[1] = (float)(dx / len);
}

tsk_status tsk_blade_models_set(tsk_blade_model* models, int32_t model_count, const float* xyz,
                                const float* width, const int32_t* knot_counts,
                                size_t total_knots) {
    if (model_count < 0 || model_count > TSK_PATCH_MAX_MODELS)
        return tsk_error_arg(model_count < 0 ? TSK_ERR_ARGUMENT : TSK_ERR_LIMIT, "model_count",
                             "must be 0..%d, got %d", TSK_PATCH_MAX_MODELS, (int)model_count);
    if (model_count == 0) return TSK_OK;
    if (models == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "models", "is NULL");
    if (knot_counts == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "knot_counts", "is NULL");
    size_t first = 0;
    for (int32_t m = 0; m < model_count; ++m) {
        const int32_t n = knot_counts[m];
        if (n < 0 || (size_t)n > total_knots - first)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "knot_counts",
                                 "model %d has %d knots but only %zu remain of %zu", (int)m, (int)n,
                                 total_knots - first, total_knots);
        tsk_status s = tsk_blade_model_set(&models[m], xyz ? xyz + 3 * first : NULL,
                                           width ? width + first : NULL, n);
        if (s != TSK_OK) {
            char why[256];
            snprintf(why, sizeof why, "%s", tsk_last_error());
            return tsk_error_arg(s, "models", "model %d: %s", (int)m, why);
        }
        first += (size_t)n;
    }
    if (first != total_knots)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "knot_counts", "sum to %zu knots but %zu were given",
                             first, total_knots);
    return TSK_OK;
}
