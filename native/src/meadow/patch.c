/* The grass patch (seed 000 §4.5): a list of blades, each a model, a random scale, a random
 * turn about the vertical and a random position in the unit tile square, all keyed by
 * (seed, blade) so the patch is the same bytes whatever the thread count. */
#include "meadow_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static const double TSK_TWO_PI = 6.283185307179586476925286766559;

tsk_patch_def tsk_default_patch_def(void) {
    tsk_patch_def d;
    memset(&d, 0, sizeof d);
    d.blade_count = 16384;
    d.scale_min = 0.8f;
    d.scale_max = 1.2f;
    d.seed = 1;
    d.knot_count = 0;
    d.models = NULL;
    d.model_count = 0;
    d.model_weights = NULL;
    return d;
}

void tsk_patch_destroy(tsk_patch* p) {
    if (p == NULL) return;
    tsk_free(p->x);
    tsk_free(p->y);
    tsk_free(p->turn);
    tsk_free(p->scale);
    tsk_free(p->model);
    tsk_free(p->models);
    tsk_free(p->model_side);
    tsk_free(p);
}

typedef struct fill_ctx {
    tsk_patch* p;
    uint64_t seed;
    float smin, smax;
    const double* cdf; /* cumulative model weights, normalised, [model_count] */
} fill_ctx;

static void fill_blades(size_t begin, size_t end, size_t chunk, void* vctx) {
    (void)chunk;
    const fill_ctx* c = vctx;
    tsk_patch* p = c->p;
    const float two_pi_below = nextafterf((float)TSK_TWO_PI, 0.0f);
    for (size_t b = begin; b < end; ++b) {
        const double rm = tsk_rand01(c->seed, TSK_PATCH_STREAM, b, 0);
        int32_t m = 0;
        while (m < p->model_count - 1 && rm >= c->cdf[m]) ++m;
        p->model[b] = m;
        const double rs = tsk_rand01(c->seed, TSK_PATCH_STREAM, b, 1);
        p->scale[b] = (float)((double)c->smin + ((double)c->smax - (double)c->smin) * rs);
        float turn = (float)(TSK_TWO_PI * (double)tsk_rand01(c->seed, TSK_PATCH_STREAM, b, 2));
        p->turn[b] = turn < two_pi_below ? turn : two_pi_below;
        p->x[b] = tsk_rand01(c->seed, TSK_PATCH_STREAM, b, 3);
        p->y[b] = tsk_rand01(c->seed, TSK_PATCH_STREAM, b, 4);
    }
}

tsk_status tsk_patch_create(const tsk_patch_def* def, tsk_patch** out) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    if (def == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "def", "is NULL");
    if (def->blade_count > TSK_PATCH_MAX_BLADES)
        return tsk_error_arg(TSK_ERR_LIMIT, "blade_count", "%d blades exceed the patch limit of %d",
                             (int)def->blade_count, TSK_PATCH_MAX_BLADES);
    if (def->blade_count < 1)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "blade_count", "must be at least 1, got %d",
                             (int)def->blade_count);
    if (!isfinite(def->scale_min) || !(def->scale_min > 0.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "scale_min", "must be finite and > 0, got %g",
                             (double)def->scale_min);
    if (!isfinite(def->scale_max) || def->scale_max < def->scale_min)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "scale_max",
                             "must be finite and >= scale_min (%g), got %g", (double)def->scale_min,
                             (double)def->scale_max);
    if (def->scale_max > 1000.0f)
        return tsk_error_arg(TSK_ERR_LIMIT, "scale_max", "%g is over the limit of 1000",
                             (double)def->scale_max);
    if (def->model_count < 0 || def->model_count > TSK_PATCH_MAX_MODELS)
        return tsk_error_arg(def->model_count < 0 ? TSK_ERR_ARGUMENT : TSK_ERR_LIMIT, "model_count",
                             "must be 0..%d, got %d", TSK_PATCH_MAX_MODELS, (int)def->model_count);
    if (def->model_count > 0 && def->models == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "models", "is NULL but model_count is %d",
                             (int)def->model_count);
    if (def->knot_count != 0 && (def->knot_count < 2 || def->knot_count > TSK_BLADE_MAX_KNOTS))
        return tsk_error_arg(
            def->knot_count > TSK_BLADE_MAX_KNOTS ? TSK_ERR_LIMIT : TSK_ERR_ARGUMENT, "knot_count",
            "must be 0 (automatic) or 2..%d, got %d", TSK_BLADE_MAX_KNOTS, (int)def->knot_count);

    const int32_t nm = def->model_count > 0 ? def->model_count : 1;
    int32_t knots = def->knot_count;
    for (int32_t m = 0; m < def->model_count; ++m) {
        const tsk_blade_model* bm = &def->models[m];
        if (bm->knot_count < 2 || bm->knot_count > TSK_BLADE_MAX_KNOTS)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "models", "model %d has %d knots (2..%d)",
                                 (int)m, (int)bm->knot_count, TSK_BLADE_MAX_KNOTS);
        /* re-validate through the setter: finite, widths >= 0, non-zero length */
        tsk_blade_model check;
        tsk_status s = tsk_blade_model_set(&check, bm->xyz, bm->width, bm->knot_count);
        if (s != TSK_OK) {
            char why[256];
            snprintf(why, sizeof why, "%s", tsk_last_error());
            return tsk_error_arg(s, "models", "model %d: %s", (int)m, why);
        }
        if (def->knot_count == 0 && bm->knot_count > knots) knots = bm->knot_count;
    }
    if (knots == 0) knots = 16; /* the default blade */
    {
        /* memory budget: per-blade data and the expanded patch mesh the caller asks for
         * (2K vertices: position, normal, uv, blade index; 2(K-1) triangles) */
        const double nb = (double)def->blade_count;
        const double mesh = nb * (2.0 * knots * (12 + 12 + 8 + 4) + 2.0 * (knots - 1) * 12);
        tsk_status s = tsk_memory_check(nb * 20.0 + mesh, "blade_count");
        if (s != TSK_OK) return s;
    }

    double cdf[TSK_PATCH_MAX_MODELS];
    double wsum = 0.0;
    for (int32_t m = 0; m < nm; ++m) {
        double w = 1.0;
        if (def->model_count > 0 && def->model_weights != NULL) {
            w = def->model_weights[m];
            if (!isfinite(w) || w < 0.0)
                return tsk_error_arg(TSK_ERR_ARGUMENT, "model_weights",
                                     "weight %d must be finite and >= 0, got %g", (int)m, w);
        }
        wsum += w;
        cdf[m] = wsum;
    }
    if (!(wsum > 0.0))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "model_weights", "all weights are zero");
    for (int32_t m = 0; m < nm; ++m) cdf[m] /= wsum;

    tsk_patch* p = tsk_calloc(1, sizeof *p, "patch");
    if (p == NULL) return TSK_ERR_MEMORY;
    const size_t n = (size_t)def->blade_count;
    p->blade_count = def->blade_count;
    p->knot_count = knots;
    p->model_count = nm;
    p->x = tsk_alloc(n * sizeof(float), "patch x");
    p->y = tsk_alloc(n * sizeof(float), "patch y");
    p->turn = tsk_alloc(n * sizeof(float), "patch turn");
    p->scale = tsk_alloc(n * sizeof(float), "patch scale");
    p->model = tsk_alloc(n * sizeof(int32_t), "patch model");
    p->models = tsk_alloc((size_t)nm * sizeof(tsk_blade_model), "patch models");
    p->model_side = tsk_alloc((size_t)nm * 3 * sizeof(float), "patch model sides");
    if (!p->x || !p->y || !p->turn || !p->scale || !p->model || !p->models || !p->model_side) {
        tsk_patch_destroy(p);
        return TSK_ERR_MEMORY;
    }
    for (int32_t m = 0; m < nm; ++m) {
        tsk_blade_model src;
        tsk_status s;
        if (def->model_count > 0)
            s = tsk_blade_model_set(&src, def->models[m].xyz, def->models[m].width,
                                    def->models[m].knot_count);
        else s = tsk_blade_model_default(&src, knots);
        if (s == TSK_OK) s = tsk_blade_model_resample(&src, knots, &p->models[m]);
        if (s != TSK_OK) {
            tsk_patch_destroy(p);
            return s;
        }
        tsk_blade_model_side(&p->models[m], &p->model_side[3 * m]);
    }
    fill_ctx ctx = {p, def->seed, def->scale_min, def->scale_max, cdf};
    tsk_parallel_for(n, 4096, fill_blades, &ctx);
    *out = p;
    return TSK_OK;
}

int32_t tsk_patch_blade_count(const tsk_patch* p) { return p ? p->blade_count : 0; }
int32_t tsk_patch_knot_count(const tsk_patch* p) { return p ? p->knot_count : 0; }
int32_t tsk_patch_model_count(const tsk_patch* p) { return p ? p->model_count : 0; }

tsk_status tsk_patch_get_blades(const tsk_patch* p, float* xy, float* turn, float* scale,
                                int32_t* model) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "patch", "is NULL");
    const size_t n = (size_t)p->blade_count;
    if (xy != NULL)
        for (size_t b = 0; b < n; ++b) {
            xy[2 * b] = p->x[b];
            xy[2 * b + 1] = p->y[b];
        }
    if (turn != NULL) memcpy(turn, p->turn, n * sizeof(float));
    if (scale != NULL) memcpy(scale, p->scale, n * sizeof(float));
    if (model != NULL) memcpy(model, p->model, n * sizeof(int32_t));
    return TSK_OK;
}

tsk_status tsk_patch_get_model(const tsk_patch* p, int32_t index, tsk_blade_model* out) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "patch", "is NULL");
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    if (index < 0 || index >= p->model_count)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "index", "must be 0..%d, got %d",
                             (int)p->model_count - 1, (int)index);
    *out = p->models[index];
    return TSK_OK;
}

void tsk_meadow_place_knots(const tsk_blade_model* model, float c, float s, float scale,
                            const float root[3], float* knots) {
    for (int32_t k = 0; k < model->knot_count; ++k) {
        const float mx = model->xyz[3 * k], my = model->xyz[3 * k + 1], mz = model->xyz[3 * k + 2];
        knots[3 * k] = root[0] + scale * (c * mx - s * my);
        knots[3 * k + 1] = root[1] + scale * (s * mx + c * my);
        knots[3 * k + 2] = root[2] + scale * mz;
    }
}
