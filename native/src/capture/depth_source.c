/* The one interface over all depth sources (files, .oni recordings, live devices):
 * opening, info, seek, read and close dispatch to the back ends; camera intrinsics
 * defaults. Nothing here calls OpenCV: opening files and writing depth maps are in
 * depth_files.c, so that the recording reader, which never does either, links no image
 * codec. */
#include <math.h>
#include <stdio.h>
#include <string.h>

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

tsk_depth_source* tsk_depth_new_source(tsk_depth_kind kind) {
    tsk_depth_source* s = tsk_calloc(1, sizeof *s, "depth source");
    if (s) s->kind = kind;
    return s;
}

static tsk_status open_recording(const char* path, tsk_depth_source** out, int in_process) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    if (path == NULL || path[0] == '\0') return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "is empty");
    FILE* f = NULL; /* a FIFO would block OpenNI2's player */
    const tsk_status opened = tsk_fopen_regular(path, "path", &f);
    if (opened != TSK_OK) return opened;
    fclose(f);
    tsk_depth_source* src = tsk_depth_new_source(TSK_DEPTH_ONI);
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
    tsk_depth_source* src = tsk_depth_new_source(TSK_DEPTH_ONI);
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
    tsk_depth_source* src = tsk_depth_new_source(TSK_DEPTH_DEVICE);
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
    tsk_status s = src->read_file(src, src->cursor, depth_m, count, &invalid);
    if (s != TSK_OK) return s;
    ++src->cursor;
    frame->invalid_pixels = invalid;
    frame->is_new = 1;
    frame->end = src->cursor >= src->frame_count;
    return TSK_OK;
}
