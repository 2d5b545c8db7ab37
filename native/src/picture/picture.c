/* Picture handles: creation from pixels or a file, the layers' masks, and copies out. */
#include "picture_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bridge/opencv_picture_bridge.h"
#include "core/file.h"

void tsk_picture_copy_rows(float* dst, const float* src, int width, int height, int channels,
                           int flip) {
    const size_t row = (size_t)width * (size_t)channels;
    for (int y = 0; y < height; ++y) {
        const int sy = flip ? height - 1 - y : y;
        memcpy(dst + (size_t)y * row, src + (size_t)sy * row, row * sizeof(float));
    }
}

static tsk_status check_finite(const float* v, size_t count, const char* arg) {
    for (size_t i = 0; i < count; ++i)
        if (!isfinite(v[i]))
            return tsk_error_arg(TSK_ERR_ARGUMENT, arg, "value %zu is not finite", i);
    return TSK_OK;
}

static tsk_status new_picture(int width, int height, tsk_picture** out) {
    /* memory budget: the float RGBA pixels, the decoder's copy and the background plate */
    tsk_status s = tsk_memory_check((double)width * (double)height * 48.0, "picture");
    if (s != TSK_OK) return s;
    tsk_picture* p = tsk_calloc(1, sizeof *p, "picture");
    if (p == NULL) return TSK_ERR_MEMORY;
    p->width = width;
    p->height = height;
    p->rgba = tsk_alloc((size_t)width * (size_t)height * 4 * sizeof(float), "picture pixels");
    if (p->rgba == NULL) {
        tsk_free(p);
        return TSK_ERR_MEMORY;
    }
    *out = p;
    return TSK_OK;
}

tsk_status tsk_picture_create(int width, int height, const float* rgba, size_t count, int bottom_up,
                              tsk_picture** out) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    tsk_status s = tsk_picture_check_size(width, height, TSK_PICTURE_MIN_SIDE, "width, height");
    if (s != TSK_OK) return s;
    if (rgba == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "rgba", "is NULL");
    const size_t need = (size_t)width * (size_t)height * 4;
    if (count != need)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "rgba", "must have 4*%d*%d = %zu values, got %zu",
                             width, height, need, count);
    if ((s = check_finite(rgba, count, "rgba")) != TSK_OK) return s;
    tsk_picture* p;
    if ((s = new_picture(width, height, &p)) != TSK_OK) return s;
    tsk_picture_copy_rows(p->rgba, rgba, width, height, 4, bottom_up != 0);
    *out = p;
    return TSK_OK;
}

tsk_status tsk_picture_load(const char* path, tsk_picture** out) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    if (path == NULL || path[0] == '\0') return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "is empty");
    FILE* f = NULL;
    const tsk_status opened = tsk_fopen_regular(path, "path", &f);
    if (opened != TSK_OK) return opened;
    long long size = -1;
    if (fseek(f, 0, SEEK_END) == 0) size = (long long)ftell(f);
    if (size < 0 || fseek(f, 0, SEEK_SET) != 0) {
        fclose(f);
        return tsk_error_arg(TSK_ERR_IO, "path", "cannot read '%s' (not a regular file?)", path);
    }
    if (size > TSK_PICTURE_MAX_FILE_BYTES) {
        fclose(f);
        return tsk_error_arg(TSK_ERR_LIMIT, "path", "'%s' has %lld bytes; the limit is %lld", path,
                             size, TSK_PICTURE_MAX_FILE_BYTES);
    }
    /* Read the header first so that a huge picture is refused before it is decoded. */
    uint8_t head[65536];
    size_t head_n = fread(head, 1, sizeof head, f);
    fclose(f);
    int width = 0, height = 0;
    tsk_status s = tsk_picture_header_size(head, head_n, path, &width, &height);
    if (s != TSK_OK) return s;
    tsk_picture* p;
    if ((s = new_picture(width, height, &p)) != TSK_OK) return s;
    s = tsk_cvp_decode(path, width, height, p->rgba);
    if (s == TSK_OK) {
        const size_t n = (size_t)width * (size_t)height * 4;
        for (size_t i = 0; i < n; ++i)
            if (!isfinite(p->rgba[i])) {
                s = tsk_error_arg(TSK_ERR_FORMAT, "path",
                                  "'%s' contains NaN or infinite values (pixel %zu)", path, i / 4);
                break;
            }
    }
    if (s != TSK_OK) {
        tsk_picture_destroy(p);
        return s;
    }
    *out = p;
    return TSK_OK;
}

void tsk_picture_destroy(tsk_picture* p) {
    if (p == NULL) return;
    for (int i = 0; i < p->layer_count; ++i) {
        tsk_free(p->layers[i].mask);
        tsk_free(p->layers[i].matte);
        tsk_free(p->layers[i].rgba);
    }
    tsk_free(p->background);
    tsk_free(p->rgba);
    tsk_free(p);
}

tsk_status tsk_picture_size(const tsk_picture* p, int* width, int* height) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "picture", "is NULL");
    if (width == NULL || height == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "width, height", "is NULL");
    *width = p->width;
    *height = p->height;
    return TSK_OK;
}

int tsk_picture_layer_count(const tsk_picture* p) { return p ? p->layer_count : 0; }

static tsk_status check_out(const tsk_picture* p, const void* buf, size_t count, int channels,
                            const char* arg) {
    if (p == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "picture", "is NULL");
    if (buf == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, arg, "is NULL");
    const size_t need = (size_t)p->width * (size_t)p->height * (size_t)channels;
    if (count != need)
        return tsk_error_arg(TSK_ERR_ARGUMENT, arg, "must have %d*%d*%d = %zu values, got %zu",
                             channels, p->width, p->height, need, count);
    return TSK_OK;
}

tsk_status tsk_picture_read_rgba(const tsk_picture* p, float* rgba, size_t count, int bottom_up) {
    tsk_status s = check_out(p, rgba, count, 4, "rgba");
    if (s != TSK_OK) return s;
    tsk_picture_copy_rows(rgba, p->rgba, p->width, p->height, 4, bottom_up != 0);
    return TSK_OK;
}

static tsk_status check_built_layer(const tsk_picture* p, int layer) {
    if (!p->built)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "picture",
                             "layers are not built yet (call tsk_picture_build after adding "
                             "layers)");
    if (layer < 0 || layer >= p->layer_count)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "layer", "%d is not in 0..%d", layer,
                             p->layer_count - 1);
    return TSK_OK;
}

tsk_status tsk_picture_read_layer(const tsk_picture* p, int layer, float* rgba, size_t count,
                                  int bottom_up) {
    tsk_status s = check_out(p, rgba, count, 4, "rgba");
    if (s == TSK_OK) s = check_built_layer(p, layer);
    if (s != TSK_OK) return s;
    tsk_picture_copy_rows(rgba, p->layers[layer].rgba, p->width, p->height, 4, bottom_up != 0);
    return TSK_OK;
}

tsk_status tsk_picture_read_matte(const tsk_picture* p, int layer, float* alpha, size_t count,
                                  int bottom_up) {
    tsk_status s = check_out(p, alpha, count, 1, "alpha");
    if (s == TSK_OK) s = check_built_layer(p, layer);
    if (s != TSK_OK) return s;
    tsk_picture_copy_rows(alpha, p->layers[layer].matte, p->width, p->height, 1, bottom_up != 0);
    return TSK_OK;
}

tsk_status tsk_picture_read_background(const tsk_picture* p, float* rgba, size_t count,
                                       int bottom_up) {
    tsk_status s = check_out(p, rgba, count, 4, "rgba");
    if (s == TSK_OK && !p->built)
        s = tsk_error_arg(TSK_ERR_ARGUMENT, "picture",
                          "layers are not built yet (call tsk_picture_build first)");
    if (s != TSK_OK) return s;
    tsk_picture_copy_rows(rgba, p->background, p->width, p->height, 4, bottom_up != 0);
    return TSK_OK;
}
