/* Depth image files and numbered sequences: opening one, frame discovery for '#' patterns,
 * a header check of PNG and OpenEXR files before any decoding (size limit, 16-bit grey PNG
 * only), decoding through the OpenCV bridge and conversion to metres (PNG: millimetres,
 * 0 = no data; EXR: metres, NaN/inf/negative = no data, counted); and the depth map writers.
 * Everything of the capture that calls OpenCV's codecs is here. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bridge/opencv_capture_bridge.h"
#include "core/exr_header.h"
#include "core/file.h"
#include "depth_internal.h"

static uint32_t be32(const unsigned char* p) {
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

#define HEADER_BYTES 65536

tsk_status tsk_depth_check_header(const char* path, int* w, int* h) {
    FILE* f = NULL; /* never OpenCV on a FIFO or a device */
    const tsk_status opened = tsk_fopen_regular(path, "path", &f);
    if (opened != TSK_OK) return opened;
    static _Thread_local unsigned char buf[HEADER_BYTES];
    const size_t n = fread(buf, 1, sizeof buf, f);
    const int read_error = ferror(f);
    fclose(f);
    if (read_error) return tsk_error_arg(TSK_ERR_IO, "path", "cannot read '%s'", path);
    static const unsigned char png_sig[8] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
    long long width = -1, height = -1;
    if (n >= 8 && memcmp(buf, png_sig, 8) == 0) {
        if (n < 33 || memcmp(buf + 12, "IHDR", 4) != 0)
            return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is a truncated PNG", path);
        width = be32(buf + 16);
        height = be32(buf + 20);
        const int bit_depth = buf[24], colour = buf[25];
        if (width > TSK_DEPTH_MAX_SIDE || height > TSK_DEPTH_MAX_SIDE)
            return tsk_error_arg(TSK_ERR_LIMIT, "path",
                                 "'%s' is %lldx%lld; depth images are limited to %dx%d", path,
                                 width, height, TSK_DEPTH_MAX_SIDE, TSK_DEPTH_MAX_SIDE);
        if (colour != 0)
            return tsk_error_arg(TSK_ERR_FORMAT, "path",
                                 "'%s' is a colour PNG; depth must be a 16-bit grey PNG in "
                                 "millimetres",
                                 path);
        if (bit_depth != 16)
            return tsk_error_arg(TSK_ERR_FORMAT, "path",
                                 "'%s' is a %d-bit PNG; depth must be a 16-bit grey PNG in "
                                 "millimetres",
                                 path, bit_depth);
    } else if (n >= 8 && buf[0] == 0x76 && buf[1] == 0x2f && buf[2] == 0x31 && buf[3] == 0x01) {
        /* the whole header, as OpenEXR will read it: its buffers are sized from it */
        tsk_exr_header eh;
        const tsk_status st = tsk_exr_check_header(buf, n, path, &eh);
        if (st != TSK_OK) return st;
        width = eh.width;
        height = eh.height;
        if (width > TSK_DEPTH_MAX_SIDE || height > TSK_DEPTH_MAX_SIDE)
            return tsk_error_arg(TSK_ERR_LIMIT, "path",
                                 "'%s' is %lldx%lld; depth images are limited to %dx%d", path,
                                 width, height, TSK_DEPTH_MAX_SIDE, TSK_DEPTH_MAX_SIDE);
        if (eh.channels > 4)
            return tsk_error_arg(TSK_ERR_FORMAT, "path",
                                 "'%s' has %d channels; depth must be one channel of metres", path,
                                 eh.channels);
    } else {
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is neither a PNG nor an OpenEXR file%s",
                             path, n == 0 ? " (it is empty)" : "");
    }
    if (width <= 0 || height <= 0)
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' has size %lldx%lld", path, width,
                             height);
    *w = (int)width;
    *h = (int)height;
    return TSK_OK;
}

static void frame_path(const tsk_depth_source* src, int number, char* out, size_t cap) {
    if (src->hash_len == 0) {
        snprintf(out, cap, "%s", src->pattern);
        return;
    }
    snprintf(out, cap, "%.*s%0*d%s", src->hash_pos, src->pattern, src->hash_len, number,
             src->pattern + src->hash_pos + src->hash_len);
}

/* Anything at the path counts (opening it says what is wrong with a pipe or a folder);
 * stat never waits on a FIFO, as opening one for reading would. */
static int file_exists(const char* path) { return tsk_path_exists(path); }

/* index -1: discover the frames and check the first one */
tsk_status tsk_files_read(tsk_depth_source* src, int index, float* depth_m, size_t count,
                          int* invalid) {
    char path[4200];
    if (index < 0) {
        if (src->hash_len == 0) {
            src->first_frame = 0;
            src->frame_count = 1;
        } else {
            int first = -1;
            for (int i = 0; i < TSK_DEPTH_MAX_FRAMES; ++i) {
                frame_path(src, i, path, sizeof path);
                if (file_exists(path)) {
                    first = i;
                    break;
                }
            }
            if (first < 0) {
                frame_path(src, 0, path, sizeof path);
                return tsk_error_arg(TSK_ERR_IO, "path",
                                     "no file of the sequence '%s' exists (tried '%s' and "
                                     "higher numbers)",
                                     src->pattern, path);
            }
            int n = 1;
            while (first + n < TSK_DEPTH_MAX_FRAMES) {
                frame_path(src, first + n, path, sizeof path);
                if (!file_exists(path)) break;
                ++n;
            }
            src->first_frame = first;
            src->frame_count = n;
        }
        frame_path(src, src->first_frame, path, sizeof path);
        int w = 0, h = 0;
        tsk_status s = tsk_depth_check_header(path, &w, &h);
        if (s != TSK_OK) return s;
        src->width = w;
        src->height = h;
        /* memory budget: the decoded file, a float frame and the pipeline's images */
        s = tsk_memory_check((double)w * (double)h * 56.0, "path");
        if (s != TSK_OK) return s;
        /* decode the first frame once so that a broken file fails at open time */
        const size_t npix = (size_t)w * (size_t)h;
        float* tmp = tsk_alloc(npix * sizeof(float), "depth frame");
        if (tmp == NULL) return TSK_ERR_MEMORY;
        int bad = 0;
        s = tsk_files_read(src, 0, tmp, npix, &bad);
        tsk_free(tmp);
        return s;
    }
    frame_path(src, src->first_frame + index, path, sizeof path);
    int w = 0, h = 0;
    tsk_status s = tsk_depth_check_header(path, &w, &h);
    if (s != TSK_OK) return s;
    if (w != src->width || h != src->height)
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is %dx%d but the sequence is %dx%d",
                             path, w, h, src->width, src->height);
    int dw = 0, dh = 0;
    tsk_cvb_depth_type type;
    void* data = NULL;
    s = tsk_cvb_read_depth(path, &dw, &dh, &type, &data);
    if (s != TSK_OK) return s;
    if (dw != w || dh != h || (size_t)dw * (size_t)dh != count) {
        tsk_free(data);
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' decoded to %dx%d, header says %dx%d",
                             path, dw, dh, w, h);
    }
    int bad = 0;
    if (type == TSK_CVB_U16) {
        const uint16_t* mm = data;
        for (size_t i = 0; i < count; ++i) depth_m[i] = (float)mm[i] * 0.001f;
    } else {
        const float* m = data;
        for (size_t i = 0; i < count; ++i) {
            const float v = m[i];
            if (isfinite(v) && v >= 0.0f) {
                depth_m[i] = v;
            } else {
                depth_m[i] = 0.0f;
                ++bad;
            }
        }
    }
    tsk_free(data);
    if (invalid) *invalid = bad;
    return TSK_OK;
}

/* ---- a source of depth files (depth_source.c dispatches to it) ---------------------- */

tsk_status tsk_depth_open_files(const char* path, tsk_depth_source** out) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    if (path == NULL || path[0] == '\0') return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "is empty");
    const size_t len = strlen(path);
    if (len > 4000) return tsk_error_arg(TSK_ERR_LIMIT, "path", "longer than 4000 characters");
    tsk_depth_source* src = tsk_depth_new_source(TSK_DEPTH_FILES);
    if (src == NULL) return TSK_ERR_MEMORY;
    src->read_file = tsk_files_read;
    src->pattern = tsk_alloc(len + 16, "path");
    if (src->pattern == NULL) {
        tsk_free(src);
        return TSK_ERR_MEMORY;
    }
    memcpy(src->pattern, path, len + 1);
    /* the last run of '#' in the file name is the frame number */
    const char* base = strrchr(path, '/');
    base = base ? base + 1 : path;
    const char* last = strrchr(base, '#');
    if (last != NULL) {
        const char* first = last;
        while (first > base && first[-1] == '#') --first;
        src->hash_pos = (int)(first - path);
        src->hash_len = (int)(last - first + 1);
        if (src->hash_len > 9) {
            tsk_depth_close(src);
            return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "more than 9 '#' in '%s'", path);
        }
    }
    tsk_status s = tsk_files_read(src, -1, NULL, 0, NULL); /* finds frames, checks the first */
    if (s != TSK_OK) {
        tsk_depth_close(src);
        return s;
    }
    snprintf(src->description, sizeof src->description, "%s", path);
    src->K = tsk_default_intrinsics(src->width, src->height);
    *out = src;
    return TSK_OK;
}

/* ---- depth map writers ---------------------------------------------------------------- */

static tsk_status check_depth(const float* depth_m, int width, int height) {
    if (depth_m == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "depth_m", "is NULL");
    if (width <= 0 || height <= 0 || width > TSK_DEPTH_MAX_SIDE || height > TSK_DEPTH_MAX_SIDE)
        return tsk_error_arg(TSK_ERR_LIMIT, "width", "size %dx%d outside 1..%d", width, height,
                             TSK_DEPTH_MAX_SIDE);
    const size_t n = (size_t)width * (size_t)height;
    for (size_t i = 0; i < n; ++i)
        if (!isfinite(depth_m[i]) || depth_m[i] < 0.0f)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "depth_m",
                                 "value %g at index %zu is not finite metres >= 0", depth_m[i], i);
    return TSK_OK;
}

tsk_status tsk_depth_write_png16(const char* path, const float* depth_m, int width, int height) {
    if (path == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "is NULL");
    tsk_status s = check_depth(depth_m, width, height);
    if (s != TSK_OK) return s;
    const size_t n = (size_t)width * (size_t)height;
    uint16_t* mm = tsk_alloc(n * sizeof(uint16_t), "png16 buffer");
    if (mm == NULL) return TSK_ERR_MEMORY;
    for (size_t i = 0; i < n; ++i) {
        const float v = depth_m[i] * 1000.0f + 0.5f;
        mm[i] = v >= 65535.0f ? 65535 : (uint16_t)v;
    }
    s = tsk_cvb_write_png16(path, mm, width, height);
    tsk_free(mm);
    return s;
}

tsk_status tsk_depth_write_exr(const char* path, const float* depth_m, int width, int height) {
    if (path == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "is NULL");
    tsk_status s = check_depth(depth_m, width, height);
    if (s != TSK_OK) return s;
    return tsk_cvb_write_exr(path, depth_m, width, height);
}
