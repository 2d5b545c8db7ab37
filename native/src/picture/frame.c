/* Frames of a built picture: one layer's warp (root line from its mask) and the composite
 * of all layers over the inpainted background. */
#include "picture_internal.h"

#include <math.h>

tsk_status tsk_picture_layer_frame(const tsk_picture* p, int layer, const tsk_warp_def* def,
                                   const tsk_picture_field* field, const float* scale_map,
                                   size_t scale_count, float* rgba, size_t rgba_count, float* uv,
                                   size_t uv_count, int uv_bottom_up) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "picture", "is NULL");
    if (def == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "def", "is NULL");
    if (!p->built)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "picture",
                             "layers are not built yet (call tsk_picture_build first)");
    if (layer < 0 || layer >= p->layer_count)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "layer", "%d is not in 0..%d", layer,
                             p->layer_count - 1);
    const tsk_picture_layer* L = &p->layers[layer];
    tsk_warp_def d = *def;
    if (d.auto_root && d.root != TSK_ROOT_NONE) {
        d.root_y = (float)(d.root == TSK_ROOT_BOTTOM ? L->box_y1 : L->box_y0);
        d.height = (float)(L->box_y1 - L->box_y0);
    }
    int cx, cy;
    tsk_status s = tsk_warp_grid_size(p->width, p->height, d.cell_x, d.cell_y, &cx, &cy);
    if (s != TSK_OK) return s;
    const size_t nc = (size_t)cx * (size_t)cy;
    float* dx = tsk_alloc(2 * nc * sizeof(float), "warp corners");
    if (dx == NULL) return TSK_ERR_MEMORY;
    float* dy = dx + nc;
    s = tsk_warp_corners(&d, p->width, p->height, field, scale_map, scale_count, dx, dy, nc);
    if (s == TSK_OK)
        s = tsk_warp_apply(p->width, p->height, L->rgba, (size_t)p->width * p->height * 4, d.cell_x,
                           d.cell_y, dx, dy, nc, d.sampling, rgba, rgba_count, uv, uv_count,
                           uv_bottom_up);
    tsk_free(dx);
    return s;
}

typedef struct over_ctx {
    const tsk_picture* p;
    const float* const* layers;
    float* out;
} over_ctx;

static void over_rows(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const over_ctx* c = vctx;
    const size_t W = (size_t)c->p->width;
    for (size_t k = b * W * 4; k < e * W * 4; k += 4) {
        float r = c->p->background[k], g = c->p->background[k + 1];
        float bl = c->p->background[k + 2], a = c->p->background[k + 3];
        for (int li = 0; li < c->p->layer_count; ++li) {
            const float* L = (c->layers && c->layers[li]) ? c->layers[li] : c->p->layers[li].rgba;
            const float t = 1.0f - L[k + 3];
            r = L[k] + t * r;
            g = L[k + 1] + t * g;
            bl = L[k + 2] + t * bl;
            a = L[k + 3] + t * a;
        }
        c->out[k] = r;
        c->out[k + 1] = g;
        c->out[k + 2] = bl;
        c->out[k + 3] = a;
    }
}

tsk_status tsk_picture_composite(const tsk_picture* p, const float* const* layers,
                                 size_t layer_count, float* out, size_t count) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "picture", "is NULL");
    if (!p->built)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "picture",
                             "layers are not built yet (call tsk_picture_build first)");
    if (layer_count != (size_t)p->layer_count)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "layers", "must list %d layers, got %zu",
                             p->layer_count, layer_count);
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    const size_t n4 = (size_t)p->width * (size_t)p->height * 4;
    if (count != n4)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "must have 4*%d*%d = %zu values, got %zu",
                             p->width, p->height, n4, count);
    if (layers != NULL)
        for (size_t i = 0; i < layer_count; ++i)
            if (layers[i] == out)
                return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "must not be one of the layers");
    over_ctx c = {p, layers, out};
    tsk_parallel_for((size_t)p->height, 8, over_rows, &c);
    return TSK_OK;
}
