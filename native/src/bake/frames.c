/* Frame files of a bake: one file per frame, written atomically and verified by checksum,
 * so that a killed bake leaves only complete frames and a resumed or split bake can trust
 * what it finds. Layout (little-endian):
 *   "TSKFRAME" | u32 format version | i32 frame | u32 count | u32 reserved | u64 checksum
 *   | count*3 float32 */
#define _POSIX_C_SOURCE 200809L
#include "tussock/bake.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bake_internal.h"
#include "core/file.h"

static const char MAGIC[8] = {'T', 'S', 'K', 'F', 'R', 'A', 'M', 'E'};
enum { HEADER_SIZE = 8 + 4 + 4 + 4 + 4 + 8 };

static uint64_t fnv_update(uint64_t h, const void* data, size_t size) {
    const unsigned char* p = data;
    for (size_t i = 0; i < size; ++i) h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

uint64_t tsk_bake_checksum(const void* data, size_t size) {
    return fnv_update(1469598103934665603ull, data, size);
}

tsk_status tsk_bake_write_parts(const char* path, const void* const* parts, const size_t* sizes,
                                int part_count) {
    if (path == NULL || path[0] == '\0') return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "is empty");
    size_t n = strlen(path);
    char* tmp = malloc(n + 32);
    if (tmp == NULL) return tsk_error(TSK_ERR_MEMORY, "out of memory");
    snprintf(tmp, n + 32, "%s.tmp%ld", path, tsk_process_id());
    int fd = tsk_open(tmp, O_WRONLY | O_CREAT | O_TRUNC);
    if (fd < 0) {
        tsk_status s =
            tsk_error_arg(TSK_ERR_IO, "path", "cannot write '%s': %s", path, strerror(errno));
        free(tmp);
        return s;
    }
    for (int k = 0; k < part_count; ++k) {
        const unsigned char* p = parts[k];
        size_t left = sizes[k];
        while (left > 0) {
            /* at most 1 GiB a call: Windows' write takes an unsigned int */
            ssize_t w = write(fd, p, left < ((size_t)1 << 30) ? left : ((size_t)1 << 30));
            if (w < 0 && errno == EINTR) continue;
            if (w <= 0) {
                int err = w < 0 ? errno : ENOSPC;
                close(fd);
                tsk_unlink(tmp);
                free(tmp);
                return tsk_error_arg(TSK_ERR_IO, "path", "cannot write '%s': %s", path,
                                     strerror(err));
            }
            p += w;
            left -= (size_t)w;
        }
    }
    if (tsk_fsync(fd) != 0 || close(fd) != 0) {
        int err = errno;
        tsk_unlink(tmp);
        free(tmp);
        return tsk_error_arg(TSK_ERR_IO, "path", "cannot write '%s': %s", path, strerror(err));
    }
    if (tsk_rename_over(tmp, path) != 0) {
        int err = errno;
        tsk_unlink(tmp);
        free(tmp);
        return tsk_error_arg(TSK_ERR_IO, "path", "cannot write '%s': %s", path, strerror(err));
    }
    free(tmp);
    return TSK_OK;
}

tsk_status tsk_bake_write_frame(const char* path, int32_t frame, const float* xyz, uint32_t count) {
    if (count > TSK_BAKE_MAX_POINTS)
        return tsk_error_arg(TSK_ERR_LIMIT, "count", "%u points exceed the limit %u", count,
                             TSK_BAKE_MAX_POINTS);
    if (count > 0 && xyz == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "is NULL");
    const size_t bytes = (size_t)count * 3 * sizeof(float);
    for (size_t i = 0; i < (size_t)count * 3; ++i)
        if (!isfinite(xyz[i]))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "point %zu of frame %d is not finite",
                                 i / 3, frame);
    unsigned char header[HEADER_SIZE];
    memcpy(header, MAGIC, 8);
    put_u32(header + 8, TSK_BAKE_FORMAT_VERSION);
    put_u32(header + 12, (uint32_t)frame);
    put_u32(header + 16, count);
    put_u32(header + 20, 0);
    put_u64(header + 24, tsk_bake_checksum(xyz, bytes));
    const void* parts[2] = {header, xyz};
    const size_t sizes[2] = {HEADER_SIZE, bytes};
    return tsk_bake_write_parts(path, parts, sizes, count > 0 ? 2 : 1);
}

/* Opens a frame file and checks everything but the data checksum. */
static tsk_status read_header(const char* path, FILE** out, int32_t* frame, uint32_t* count,
                              uint64_t* checksum) {
    if (path == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "is NULL");
    FILE* f = tsk_fopen(path, "rb");
    if (f == NULL)
        return tsk_error_arg(TSK_ERR_IO, "path", "cannot open '%s': %s", path, strerror(errno));
    unsigned char h[HEADER_SIZE];
    if (fread(h, 1, HEADER_SIZE, f) != HEADER_SIZE || memcmp(h, MAGIC, 8) != 0) {
        fclose(f);
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is not a Tussock bake frame", path);
    }
    uint32_t version = get_u32(h + 8);
    if (version != TSK_BAKE_FORMAT_VERSION) {
        fclose(f);
        return tsk_error_arg(TSK_ERR_FORMAT, "path",
                             "'%s' was baked by another Tussock (cache format %u, this one reads "
                             "%u): free the bake and bake again",
                             path, version, TSK_BAKE_FORMAT_VERSION);
    }
    *frame = (int32_t)get_u32(h + 12);
    *count = get_u32(h + 16);
    *checksum = get_u64(h + 24);
    if (*count > TSK_BAKE_MAX_POINTS) {
        fclose(f);
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' claims %u points", path, *count);
    }
    uint64_t size = 0;
    if (tsk_file_size(f, &size) != 0 || size != HEADER_SIZE + (uint64_t)*count * 12u) {
        fclose(f);
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is truncated or too long", path);
    }
    *out = f;
    return TSK_OK;
}

/* Reads `count` points in chunks into `xyz` (or, with xyz NULL, into a small buffer: the
 * check needs no memory of the frame's size), verifying the checksum and that every value is
 * finite (the writer refuses others, so one means a forged or damaged file). */
static tsk_status read_data(FILE* f, const char* path, float* xyz, uint32_t count,
                            uint64_t checksum) {
    enum { CHUNK = 4096 }; /* floats */
    float local[CHUNK];
    const size_t n = (size_t)count * 3;
    uint64_t h = 1469598103934665603ull;
    int finite = 1;
    for (size_t done = 0; done < n;) {
        const size_t m = n - done < CHUNK ? n - done : CHUNK;
        float* dst = xyz ? xyz + done : local;
        if (fread(dst, sizeof(float), m, f) != m)
            return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is truncated", path);
        h = fnv_update(h, dst, m * sizeof(float));
        for (size_t i = 0; i < m; ++i) finite &= isfinite(dst[i]) != 0;
        done += m;
    }
    if (h != checksum)
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is corrupt (checksum mismatch)", path);
    if (!finite)
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' holds a non-finite point", path);
    return TSK_OK;
}

tsk_status tsk_bake_frame_info(const char* path, int32_t* frame, uint32_t* count) {
    FILE* f = NULL;
    int32_t fr = 0;
    uint32_t n = 0;
    uint64_t sum = 0;
    tsk_status s = read_header(path, &f, &fr, &n, &sum);
    if (s != TSK_OK) return s;
    s = read_data(f, path, NULL, n, sum);
    fclose(f);
    if (s != TSK_OK) return s;
    if (frame) *frame = fr;
    if (count) *count = n;
    return TSK_OK;
}

tsk_status tsk_bake_read_frame(const char* path, float* xyz, uint32_t count) {
    if (xyz == NULL && count > 0) return tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "is NULL");
    FILE* f = NULL;
    int32_t fr = 0;
    uint32_t n = 0;
    uint64_t sum = 0;
    tsk_status s = read_header(path, &f, &fr, &n, &sum);
    if (s != TSK_OK) return s;
    if (n != count) {
        fclose(f);
        return tsk_error_arg(TSK_ERR_FORMAT, "count", "'%s' holds %u points, expected %u", path, n,
                             count);
    }
    s = read_data(f, path, xyz, n, sum);
    fclose(f);
    return s;
}
