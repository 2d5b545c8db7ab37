/* Image frames of a bake (pictures): an OpenEXR file per frame that Blender reads as an
 * image sequence, and a sidecar that lets Tussock verify it (see tussock/bake_image.h). */
#define _POSIX_C_SOURCE 200809L
#include "tussock/bake_image.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bake_internal.h"
#include "bridge/opencv_picture_bridge.h"
#include "core/file.h"
#include "tussock/bake.h"
#include "tussock/picture.h"

static const char MAGIC[8] = {'T', 'S', 'K', 'I', 'M', 'A', 'G', 'E'};
enum { SIDECAR_SIZE = 8 + 4 + 4 + 4 + 4 + 8 + 8 + 8 };

/* `path` + ".tski" in a new tsk_alloc'd string, or NULL (error set). */
static char* sidecar_path(const char* path) {
    size_t n = strlen(path);
    char* s = tsk_alloc(n + sizeof TSK_BAKE_IMAGE_SIDECAR, "sidecar path");
    if (s == NULL) return NULL;
    memcpy(s, path, n);
    memcpy(s + n, TSK_BAKE_IMAGE_SIDECAR, sizeof TSK_BAKE_IMAGE_SIDECAR);
    return s;
}

/* Continues tsk_bake_checksum (FNV-1a) over more bytes. */
static uint64_t checksum_more(uint64_t h, const unsigned char* p, size_t size) {
    for (size_t i = 0; i < size; ++i) h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

static int ends_with_exr(const char* path) {
    size_t n = strlen(path);
    return n > 4 && (strcmp(path + n - 4, ".exr") == 0 || strcmp(path + n - 4, ".EXR") == 0);
}

/* Size and checksum of a whole file, read in blocks. */
static tsk_status file_checksum(const char* path, uint64_t* size, uint64_t* sum) {
    int fd = tsk_open(path, O_RDONLY);
    if (fd < 0)
        return tsk_error_arg(TSK_ERR_IO, "path", "cannot open '%s': %s", path, strerror(errno));
    unsigned char buf[65536];
    uint64_t h = tsk_bake_checksum(NULL, 0), n = 0;
    for (;;) {
        ssize_t r = read(fd, buf, sizeof buf);
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) {
            int err = errno;
            close(fd);
            return tsk_error_arg(TSK_ERR_IO, "path", "cannot read '%s': %s", path, strerror(err));
        }
        if (r == 0) break;
        h = checksum_more(h, buf, (size_t)r);
        n += (uint64_t)r;
    }
    close(fd);
    *size = n;
    *sum = h;
    return TSK_OK;
}

/* Writes the EXR to `tmp` with OpenCV, then reads it back for its size and checksum and
 * syncs it to disk. OpenCV gives no reason for a failed write, so the folder is tried
 * first (a read-only folder gets the system's message) and a failed write is diagnosed
 * from the free space left. */
static tsk_status write_exr_synced(const char* path, const char* tmp, const float* rgba, int width,
                                   int height, uint64_t* size, uint64_t* sum) {
    int fd = tsk_open(tmp, O_WRONLY | O_CREAT | O_TRUNC);
    if (fd < 0)
        return tsk_error_arg(TSK_ERR_IO, "path", "cannot write '%s': %s", path, strerror(errno));
    close(fd);
    tsk_status s = tsk_cvp_write_exr(tmp, rgba, width, height);
    if (s != TSK_OK) {
        /* the folder, not the file: OpenCV removes a file it failed to write */
        char dir[4096] = ".";
        const char* slash = tsk_last_separator(tmp);
        if (slash == tmp) {
            dir[0] = '/';
        } else if (slash != NULL) {
            size_t len = (size_t)(slash - tmp);
            if (len >= sizeof dir) len = sizeof dir - 1;
            memcpy(dir, tmp, len);
            dir[len] = '\0';
        }
        uint64_t free_bytes = 0;
        const uint64_t need = (uint64_t)width * (uint64_t)height * 16u + 65536u;
        if (tsk_free_bytes(dir, &free_bytes) == 0 && free_bytes < need)
            return tsk_error_arg(TSK_ERR_IO, "path", "cannot write '%s': %s", path,
                                 strerror(ENOSPC));
        return tsk_error_arg(TSK_ERR_IO, "path",
                             "cannot write '%s': OpenCV failed to write the OpenEXR file (a "
                             "disk quota or file size limit?)",
                             path);
    }
    s = file_checksum(tmp, size, sum);
    if (s != TSK_OK) return s;
    /* opened for writing: Windows flushes only a handle with write access */
    fd = tsk_open(tmp, O_WRONLY);
    if (fd < 0 || tsk_fsync(fd) != 0) {
        int err = errno;
        if (fd >= 0) close(fd);
        return tsk_error_arg(TSK_ERR_IO, "path", "cannot write '%s': %s", path, strerror(err));
    }
    close(fd);
    return TSK_OK;
}

tsk_status tsk_bake_write_image(const char* path, int32_t frame, uint64_t key, const float* rgba,
                                size_t count, int width, int height) {
    if (path == NULL || !ends_with_exr(path))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "must end in .exr, got '%s'",
                             path ? path : "(null)");
    if (width < TSK_PICTURE_MIN_SIDE || height < TSK_PICTURE_MIN_SIDE ||
        width > TSK_PICTURE_MAX_SIDE || height > TSK_PICTURE_MAX_SIDE ||
        (long long)width * height > TSK_PICTURE_MAX_PIXELS)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "width, height",
                             "%dx%d is outside %dx%d..%dx%d (or over %lld pixels)", width, height,
                             TSK_PICTURE_MIN_SIDE, TSK_PICTURE_MIN_SIDE, TSK_PICTURE_MAX_SIDE,
                             TSK_PICTURE_MAX_SIDE, TSK_PICTURE_MAX_PIXELS);
    const size_t n = (size_t)width * (size_t)height * 4;
    if (rgba == NULL || count != n)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "rgba", "must hold 4*%d*%d = %zu floats, got %zu",
                             width, height, n, rgba ? count : 0);
    for (size_t i = 0; i < n; ++i)
        if (!isfinite(rgba[i]))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "rgba",
                                 "value %zu (pixel %zu) of frame %d is not finite", i, i / 4,
                                 frame);
    char* spath = sidecar_path(path);
    char* tmp = tsk_alloc(strlen(path) + 40, "temporary path");
    if (spath == NULL || tmp == NULL) {
        tsk_free(spath);
        tsk_free(tmp);
        return TSK_ERR_MEMORY;
    }
    /* OpenCV picks the format by the extension, so the temporary name ends in .exr too */
    snprintf(tmp, strlen(path) + 40, "%s.tmp%ld.exr", path, tsk_process_id());
    uint64_t size = 0, sum = 0;
    tsk_status s = write_exr_synced(path, tmp, rgba, width, height, &size, &sum);
    if (s == TSK_OK && tsk_rename_over(tmp, path) != 0)
        s = tsk_error_arg(TSK_ERR_IO, "path", "cannot write '%s': %s", path, strerror(errno));
    if (s != TSK_OK) tsk_unlink(tmp);
    tsk_free(tmp);
    if (s == TSK_OK) { /* the EXR first, then the sidecar that vouches for it */
        unsigned char side[SIDECAR_SIZE];
        memcpy(side, MAGIC, 8);
        put_u32(side + 8, TSK_BAKE_IMAGE_FORMAT_VERSION);
        put_u32(side + 12, (uint32_t)frame);
        put_u32(side + 16, (uint32_t)width);
        put_u32(side + 20, (uint32_t)height);
        put_u64(side + 24, key);
        put_u64(side + 32, size);
        put_u64(side + 40, sum);
        const void* parts[1] = {side};
        const size_t sizes[1] = {SIDECAR_SIZE};
        s = tsk_bake_write_parts(spath, parts, sizes, 1);
    }
    tsk_free(spath);
    return s;
}

tsk_status tsk_bake_image_info(const char* path, int32_t* frame, uint64_t* key, int* width,
                               int* height) {
    if (path == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "is NULL");
    char* spath = sidecar_path(path);
    if (spath == NULL) return TSK_ERR_MEMORY;
    unsigned char h[SIDECAR_SIZE];
    FILE* f = tsk_fopen(spath, "rb");
    if (f == NULL) {
        tsk_status s =
            tsk_error_arg(TSK_ERR_IO, "path", "cannot open '%s': %s", spath, strerror(errno));
        tsk_free(spath);
        return s;
    }
    size_t got = fread(h, 1, SIDECAR_SIZE, f);
    int extra = fgetc(f) != EOF;
    fclose(f);
    if (got != SIDECAR_SIZE || extra || memcmp(h, MAGIC, 8) != 0) {
        tsk_status s =
            tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is not a Tussock image sidecar", spath);
        tsk_free(spath);
        return s;
    }
    tsk_free(spath);
    const uint32_t version = get_u32(h + 8);
    if (version != TSK_BAKE_IMAGE_FORMAT_VERSION)
        return tsk_error_arg(TSK_ERR_FORMAT, "path",
                             "'%s' was baked by another Tussock (cache format %u, this one "
                             "reads %u): free the bake and bake again",
                             path, version, TSK_BAKE_IMAGE_FORMAT_VERSION);
    const uint32_t w = get_u32(h + 16), hh = get_u32(h + 20);
    const uint64_t size = get_u64(h + 32), sum = get_u64(h + 40);
    uint64_t got_size = 0, got_sum = 0;
    tsk_status s = file_checksum(path, &got_size, &got_sum);
    if (s != TSK_OK) return s;
    if (got_size != size || got_sum != sum)
        return tsk_error_arg(TSK_ERR_FORMAT, "path",
                             "'%s' does not match its sidecar (corrupt, truncated, or written "
                             "again by a bake that did not finish)",
                             path);
    if (w < TSK_PICTURE_MIN_SIDE || hh < TSK_PICTURE_MIN_SIDE || w > TSK_PICTURE_MAX_SIDE ||
        hh > TSK_PICTURE_MAX_SIDE)
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' claims %ux%u pixels", path, w, hh);
    if (frame) *frame = (int32_t)get_u32(h + 12);
    if (key) *key = get_u64(h + 24);
    if (width) *width = (int)w;
    if (height) *height = (int)hh;
    return TSK_OK;
}
