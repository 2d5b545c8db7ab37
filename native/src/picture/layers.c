/* Vegetation layers (seed 004, §III-B): masks from the caller or a GrabCut proposal, the
 * background behind the layers filled by inpainting front to back, and soft mattes from
 * the mask edges by an exact signed distance. */
#include "picture_internal.h"

#include <math.h>
#include <string.h>

#include "bridge/opencv_picture_bridge.h"

tsk_grabcut_def tsk_default_grabcut_def(void) {
    tsk_grabcut_def d = {0, 0, 0, 0, 5};
    return d;
}

tsk_layers_def tsk_default_layers_def(void) {
    tsk_layers_def d = {TSK_INPAINT_TELEA, 5.0f, 3.0f, 4.0f};
    return d;
}

tsk_status tsk_picture_propose_mask(const tsk_picture* p, const tsk_grabcut_def* def,
                                    const uint8_t* strokes, size_t stroke_count, uint8_t* mask,
                                    size_t mask_count) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "picture", "is NULL");
    if (def == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "def", "is NULL");
    if (mask == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "mask", "is NULL");
    const size_t n = (size_t)p->width * (size_t)p->height;
    if (mask_count != n)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "mask", "must have %d*%d = %zu values, got %zu",
                             p->width, p->height, n, mask_count);
    if (strokes != NULL && stroke_count != n)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "strokes", "must have %d*%d = %zu values, got %zu",
                             p->width, p->height, n, stroke_count);
    if (def->rect_width < 1 || def->rect_height < 1 || def->rect_x < 0 || def->rect_y < 0 ||
        def->rect_x > p->width - def->rect_width || def->rect_y > p->height - def->rect_height)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "rect",
                             "(%d, %d, %d, %d) must be a non-empty rectangle inside the %dx%d "
                             "picture",
                             def->rect_x, def->rect_y, def->rect_width, def->rect_height, p->width,
                             p->height);
    if (def->iterations < 1 || def->iterations > 50)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "iterations", "must be 1..50, got %d",
                             def->iterations);
    if (strokes != NULL)
        for (size_t i = 0; i < n; ++i)
            if (strokes[i] > 2)
                return tsk_error_arg(TSK_ERR_ARGUMENT, "strokes",
                                     "value %u at pixel %zu is not 0 (none), 1 (foreground) or "
                                     "2 (background)",
                                     strokes[i], i);
    return tsk_cvp_grabcut(p->rgba, p->width, p->height, def->rect_x, def->rect_y, def->rect_width,
                           def->rect_height, def->iterations, strokes, mask);
}

/* Takes ownership of `bin` (W*H, 0/1) as a new layer. */
static tsk_status add_layer(tsk_picture* p, uint8_t* bin, int* index) {
    tsk_picture_layer* L = &p->layers[p->layer_count];
    memset(L, 0, sizeof *L);
    L->mask = bin;
    int x0 = p->width, y0 = p->height, x1 = 0, y1 = 0;
    for (int y = 0; y < p->height; ++y)
        for (int x = 0; x < p->width; ++x)
            if (bin[(size_t)y * p->width + x]) {
                if (x < x0) x0 = x;
                if (x + 1 > x1) x1 = x + 1;
                if (y < y0) y0 = y;
                if (y + 1 > y1) y1 = y + 1;
            }
    L->box_x0 = x0;
    L->box_y0 = y0;
    L->box_x1 = x1;
    L->box_y1 = y1;
    /* a rebuild is needed: drop what the last build made */
    for (int i = 0; i < p->layer_count; ++i) {
        tsk_free(p->layers[i].matte);
        tsk_free(p->layers[i].rgba);
        p->layers[i].matte = NULL;
        p->layers[i].rgba = NULL;
    }
    tsk_free(p->background);
    p->background = NULL;
    p->built = 0;
    if (index) *index = p->layer_count;
    ++p->layer_count;
    return TSK_OK;
}

static const char full_mask_message[] =
    "covers the whole picture: nothing is left to fill the background from";

static tsk_status check_add(tsk_picture* p, const void* mask, size_t count) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "picture", "is NULL");
    if (mask == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "mask", "is NULL");
    const size_t n = (size_t)p->width * (size_t)p->height;
    if (count != n)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "mask",
                             "size %zu does not match the %dx%d picture (%zu values)", count,
                             p->width, p->height, n);
    if (p->layer_count >= TSK_PICTURE_MAX_LAYERS)
        return tsk_error_arg(TSK_ERR_LIMIT, "mask", "a picture has at most %d layers",
                             TSK_PICTURE_MAX_LAYERS);
    /* memory budget once built: per layer RGBA, matte and mask; the picture, background and
     * the build's scratch images */
    const double px = (double)p->width * (double)p->height;
    return tsk_memory_check(px * (p->layer_count + 1) * 21.0 + px * 48.0 + px * 25.0, "mask");
}

tsk_status tsk_picture_add_layer_u8(tsk_picture* p, const uint8_t* mask, size_t count, int* index) {
    tsk_status s = check_add(p, mask, count);
    if (s != TSK_OK) return s;
    uint8_t* bin = tsk_alloc(count, "layer mask");
    if (bin == NULL) return TSK_ERR_MEMORY;
    size_t on = 0;
    for (size_t i = 0; i < count; ++i) on += (bin[i] = mask[i] >= 128);
    if (on == 0) {
        tsk_free(bin);
        return tsk_error_arg(TSK_ERR_ARGUMENT, "mask",
                             "is empty: no pixel is >= 128 (vegetation is 255, not 1)");
    }
    if (on == count) {
        tsk_free(bin);
        return tsk_error_arg(TSK_ERR_ARGUMENT, "mask", "%s", full_mask_message);
    }
    return add_layer(p, bin, index);
}

tsk_status tsk_picture_add_layer_f32(tsk_picture* p, const float* mask, size_t count, int* index) {
    tsk_status s = check_add(p, mask, count);
    if (s != TSK_OK) return s;
    for (size_t i = 0; i < count; ++i)
        if (!isfinite(mask[i]))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "mask", "value %zu is not finite", i);
    uint8_t* bin = tsk_alloc(count, "layer mask");
    if (bin == NULL) return TSK_ERR_MEMORY;
    size_t on = 0;
    for (size_t i = 0; i < count; ++i) on += (bin[i] = mask[i] >= 0.5f);
    if (on == 0) {
        tsk_free(bin);
        return tsk_error_arg(TSK_ERR_ARGUMENT, "mask", "is empty: no value is >= 0.5");
    }
    if (on == count) {
        tsk_free(bin);
        return tsk_error_arg(TSK_ERR_ARGUMENT, "mask", "%s", full_mask_message);
    }
    return add_layer(p, bin, index);
}

static tsk_status check_layers_def(const tsk_layers_def* d) {
    if (d->method != TSK_INPAINT_TELEA && d->method != TSK_INPAINT_NS)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "method", "must be Telea (0) or NS (1), got %d",
                             (int)d->method);
    if (!(d->inpaint_radius >= 1.0f && d->inpaint_radius <= 100.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "inpaint_radius", "must be 1..100 pixels, got %g",
                             (double)d->inpaint_radius);
    if (!(d->grow >= 0.0f && d->grow <= 64.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "grow", "must be 0..64 pixels, got %g",
                             (double)d->grow);
    if (!(d->feather >= 0.0f && d->feather <= 256.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "feather", "must be 0..256 pixels, got %g",
                             (double)d->feather);
    return TSK_OK;
}

/* Matte from the signed distance to the mask edge (see tsk_picture_build). The distance
 * transform measures centre to centre; the edge lies half a pixel before the nearest
 * pixel of the other side, hence the 0.5. */
static void make_matte(const uint8_t* mask, const float* din, const float* dout, size_t n,
                       float feather, float* matte) {
    for (size_t i = 0; i < n; ++i) {
        const float sd = mask[i] ? din[i] - 0.5f : -(dout[i] - 0.5f);
        float a;
        if (feather > 0.0f) a = 0.5f + sd / feather;
        else a = mask[i] ? 1.0f : 0.0f;
        matte[i] = a < 0.0f ? 0.0f : a > 1.0f ? 1.0f : a;
    }
}

tsk_status tsk_picture_build(tsk_picture* p, const tsk_layers_def* def) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "picture", "is NULL");
    if (def == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "def", "is NULL");
    tsk_status s = check_layers_def(def);
    if (s != TSK_OK) return s;
    if (p->layer_count == 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "picture", "has no layer (add a mask first)");
    const size_t n = (size_t)p->width * (size_t)p->height;
    float* din = tsk_alloc(n * sizeof(float), "distances");
    float* dout = tsk_alloc(n * sizeof(float), "distances");
    uint8_t* region = tsk_alloc(n, "inpaint region");
    float* current = tsk_alloc(n * 4 * sizeof(float), "background");
    if (!din || !dout || !region || !current) {
        s = TSK_ERR_MEMORY;
        goto done;
    }
    p->built = 0;
    memcpy(current, p->rgba, n * 4 * sizeof(float));
    memset(region, 0, n);
    int has_alpha = 0, removed = 0;
    for (size_t i = 0; i < n; ++i) has_alpha |= p->rgba[4 * i + 3] != 1.0f;
    /* front to back: layer i's colour is the picture with the layers in front of it
     * inpainted away, always from the original picture so that only true background and
     * the layers behind feed the fill */
    for (int li = p->layer_count - 1; li >= 0; --li) {
        tsk_picture_layer* L = &p->layers[li];
        if (L->matte == NULL) L->matte = tsk_alloc(n * sizeof(float), "layer matte");
        if (L->rgba == NULL) L->rgba = tsk_alloc(n * 4 * sizeof(float), "layer colour");
        if (L->matte == NULL || L->rgba == NULL) {
            s = TSK_ERR_MEMORY;
            goto done;
        }
        if (removed) {
            memcpy(current, p->rgba, n * 4 * sizeof(float));
            s = tsk_cvp_inpaint(current, p->width, p->height, region, def->inpaint_radius,
                                (int)def->method, has_alpha ? 4 : 3);
            if (s != TSK_OK) goto done;
        }
        if ((s = tsk_cvp_distances(L->mask, p->width, p->height, din, dout)) != TSK_OK) goto done;
        make_matte(L->mask, din, dout, n, def->feather, L->matte);
        for (size_t i = 0; i < n; ++i) {
            const float a = L->matte[i] * current[4 * i + 3];
            L->rgba[4 * i + 0] = current[4 * i + 0] * a;
            L->rgba[4 * i + 1] = current[4 * i + 1] * a;
            L->rgba[4 * i + 2] = current[4 * i + 2] * a;
            L->rgba[4 * i + 3] = a;
        }
        /* this layer's region: the mask grown by `grow` pixels (and at least the matte) */
        const float reach = def->grow > 0.5f * def->feather ? def->grow : 0.5f * def->feather;
        for (size_t i = 0; i < n; ++i) region[i] |= (L->mask[i] || dout[i] <= reach + 0.5f);
        removed = 1;
    }
    /* the background plate: every layer removed at once */
    memcpy(current, p->rgba, n * 4 * sizeof(float));
    s = tsk_cvp_inpaint(current, p->width, p->height, region, def->inpaint_radius, (int)def->method,
                        has_alpha ? 4 : 3);
    if (s != TSK_OK) goto done;
    if (p->background == NULL) p->background = tsk_alloc(n * 4 * sizeof(float), "background");
    if (p->background == NULL) {
        s = TSK_ERR_MEMORY;
        goto done;
    }
    for (size_t i = 0; i < n; ++i) {
        const float a = current[4 * i + 3];
        p->background[4 * i + 0] = current[4 * i + 0] * a;
        p->background[4 * i + 1] = current[4 * i + 1] * a;
        p->background[4 * i + 2] = current[4 * i + 2] * a;
        p->background[4 * i + 3] = a;
    }
    p->built = 1;
done:
    tsk_free(din);
    tsk_free(dout);
    tsk_free(region);
    tsk_free(current);
    return s;
}
