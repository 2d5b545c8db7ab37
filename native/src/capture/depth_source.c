/* The one interface over all depth sources (files, .oni recordings, live devices):
 * opening, info, seek, read and close dispatch to the back ends; camera intrinsics
 * defaults; depth map writers. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bridge/opencv_capture_bridge.h"
#include "core/file.h"
#include "depth_internal.h"
#include "core/tmath.h"

/* Kinect v1 / PrimeSense 640x480 depth: fx = fy = 570.3 (58.5° horizontal FOV) */
#define DEFAULT_F_640 570.3f

tsk_intrinsics tsk_default_intrinsics(int width, int height) {
    tsk_intrinsics k;
    const float sx = width > 0 ? (float)width / 640.0f : 1.0f;
    const float sy = height > 0 ? (float)height / 480.0f : 1.0f;
    k.fx = DEFAULT_F_640 * sx;
    k.fy = DEFAULT_F_640 * sy;
    k.cx = 0.5f * (float)((width > 0 ? width : 640) - 1);
    k.cy = 0.5f * (float)((height > 0 ? height : 480) - 1);
    return k;
}

tsk_status tsk_intrinsics_from_fov(int width, int height, float hfov, float vfov,
                                   tsk_intrinsics* out) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    if (width <= 0 || height <= 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "width", "size %dx%d must be positive", width,
                             height);
    const float pi = 3.14159265358979f;
    if (!(hfov > 0.0f && hfov < pi && vfov > 0.0f && vfov < pi))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "hfov",
                             "fields of view must be in (0, pi) radians, got %g, %g", hfov, vfov);
    out->fx = 0.5f * (float)width / tsk_tanf(0.5f * hfov);
    out->fy = 0.5f * (float)height / tsk_tanf(0.5f * vfov);
    out->cx = 0.5f * (float)(width - 1);
    out->cy = 0.5f * (float)(height - 1);
    return TSK_OK;
}

static tsk_depth_source* new_source(tsk_depth_kind kind) {
    tsk_depth_source* s = tsk_calloc(1, sizeof *s, "depth source");
    if (s) s->kind = kind;
    return s;
}

tsk_status tsk_depth_open_files(const char* path, tsk_depth_source** out) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    if (path == NULL || path[0] == '\0') return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "is empty");
    const size_t len = strlen(path);
    if (len > 4000) return tsk_error_arg(TSK_ERR_LIMIT, "path", "longer than 4000 characters");
    tsk_depth_source* src = new_source(TSK_DEPTH_FILES);
    if (src == NULL) return TSK_ERR_MEMORY;
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

static tsk_status open_recording(const char* path, tsk_depth_source** out, int in_process) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    if (path == NULL || path[0] == '\0') return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "is empty");
    FILE* f = NULL; /* a FIFO would block OpenNI2's player */
    const tsk_status opened = tsk_fopen_regular(path, "path", &f);
    if (opened != TSK_OK) return opened;
    fclose(f);
    tsk_depth_source* src = new_source(TSK_DEPTH_ONI);
    if (src == NULL) return TSK_ERR_MEMORY;
    if (strlen(path) >= sizeof src->description) {
        tsk_depth_close(src);
        return tsk_error_arg(TSK_ERR_LIMIT, "path", "longer than %zu characters",
                             sizeof src->description - 1);
    }
    snprintf(src->description, sizeof src->description, "%s", path);
    tsk_status s = in_process ? tsk_oni_open(src, path, 1) : tsk_oni_proxy_open(src, path);
    if (s != TSK_OK) {
        tsk_depth_close(src);
        return s;
    }
    *out = src;
    return TSK_OK;
}

/* Recordings are read by the recording reader process: OpenNI2's player can crash on a
 * damaged file (oni_reader_protocol.h). */
tsk_status tsk_depth_open_oni(const char* path, tsk_depth_source** out) {
    return open_recording(path, out, 0);
}

tsk_status tsk_depth_open_oni_local(const char* path, tsk_depth_source** out) {
    return open_recording(path, out, 1);
}

tsk_status tsk_depth_attach_oni_reader(tsk_oni_channel ch, const char* name,
                                       tsk_depth_source** out) {
    *out = NULL;
    tsk_depth_source* src = new_source(TSK_DEPTH_ONI);
    if (src == NULL) return TSK_ERR_MEMORY;
    snprintf(src->description, sizeof src->description, "%s", name);
    tsk_status s = tsk_oni_proxy_attach(src, ch, -1, src->description);
    if (s != TSK_OK) {
        tsk_depth_close(src);
        return s;
    }
    *out = src;
    return TSK_OK;
}

tsk_status tsk_depth_open_device(const char* uri, tsk_depth_source** out) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    tsk_depth_source* src = new_source(TSK_DEPTH_DEVICE);
    if (src == NULL) return TSK_ERR_MEMORY;
    tsk_status s = tsk_oni_open(src, uri, 0);
    if (s != TSK_OK) {
        tsk_depth_close(src);
        return s;
    }
    *out = src;
    return TSK_OK;
}

tsk_status tsk_depth_start(tsk_depth_source* src) {
    if (src == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "source", "is NULL");
    return src->kind == TSK_DEPTH_DEVICE ? tsk_oni_start(src) : TSK_OK;
}

tsk_status tsk_depth_stop(tsk_depth_source* src) {
    if (src == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "source", "is NULL");
    return src->kind == TSK_DEPTH_DEVICE ? tsk_oni_stop(src) : TSK_OK;
}

void tsk_depth_close(tsk_depth_source* src) {
    if (src == NULL) return;
    if (src->oni) tsk_oni_close(src);
    if (src->proxy) tsk_oni_proxy_close(src);
    tsk_free(src->pattern);
    tsk_free(src);
}

tsk_status tsk_depth_get_info(const tsk_depth_source* src, tsk_depth_info* out) {
    if (src == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "source", "is NULL");
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    memset(out, 0, sizeof *out);
    out->kind = src->kind;
    out->width = src->width;
    out->height = src->height;
    out->frame_count = src->frame_count;
    out->first_frame = src->first_frame;
    out->has_device_intrinsics = src->has_K;
    out->intrinsics = src->K;
    memcpy(out->description, src->description, sizeof out->description);
    return TSK_OK;
}

tsk_status tsk_depth_seek(tsk_depth_source* src, int index) {
    if (src == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "source", "is NULL");
    if (src->kind == TSK_DEPTH_DEVICE)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "source", "a live device cannot seek");
    if (index < 0 || index >= src->frame_count)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "index", "%d is not in 0..%d", index,
                             src->frame_count - 1);
    if (src->kind == TSK_DEPTH_ONI)
        return src->proxy ? tsk_oni_proxy_seek(src, index) : tsk_oni_seek(src, index);
    src->cursor = index;
    return TSK_OK;
}

tsk_status tsk_depth_read(tsk_depth_source* src, float* depth_m, size_t count,
                          tsk_depth_frame* frame) {
    tsk_depth_frame local;
    if (frame == NULL) frame = &local;
    memset(frame, 0, sizeof *frame);
    if (src == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "source", "is NULL");
    if (depth_m == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "depth_m", "is NULL");
    const size_t npix = (size_t)src->width * (size_t)src->height;
    if (count != npix)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "count", "must be width*height = %zu, got %zu", npix,
                             count);
    if (src->proxy) return tsk_oni_proxy_read(src, depth_m, count, frame);
    if (src->kind != TSK_DEPTH_FILES) return tsk_oni_read(src, depth_m, count, frame);
    frame->index = src->cursor;
    frame->timestamp = src->cursor / 30.0;
    if (src->cursor >= src->frame_count) {
        frame->end = 1;
        return TSK_OK;
    }
    int invalid = 0;
    tsk_status s = tsk_files_read(src, src->cursor, depth_m, count, &invalid);
    if (s != TSK_OK) return s;
    ++src->cursor;
    frame->invalid_pixels = invalid;
    frame->is_new = 1;
    frame->end = src->cursor >= src->frame_count;
    return TSK_OK;
}

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
