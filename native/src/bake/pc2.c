/* Point Cache 2 (.pc2) files, the format of Blender's Mesh Cache modifier:
 *   char[12] "POINTCACHE2\0" | i32 version 1 | i32 points | f32 start frame
 *   | f32 sample rate | i32 samples | samples*points*3 float32 (little-endian). */
#define _POSIX_C_SOURCE 200809L
#include "tussock/bake.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bake_internal.h"
#include "core/file.h"

static const char PC2_MAGIC[12] = "POINTCACHE2";
enum { PC2_HEADER = 12 + 4 + 4 + 4 + 4 + 4 };

tsk_status tsk_bake_assemble_pc2(const char* path, const char* const* frame_paths,
                                 int32_t frame_count, float start_frame, float sample_rate) {
    if (frame_paths == NULL || frame_count <= 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "frame_count", "must be at least 1, got %d",
                             frame_count);
    if (frame_count > TSK_BAKE_MAX_FRAMES)
        return tsk_error_arg(TSK_ERR_LIMIT, "frame_count", "%d frames exceed the limit %d",
                             frame_count, TSK_BAKE_MAX_FRAMES);
    if (!isfinite(start_frame))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "start_frame", "must be finite, got %g",
                             (double)start_frame);
    if (!(isfinite(sample_rate) && sample_rate > 0.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "sample_rate", "must be positive and finite, got %g",
                             (double)sample_rate);
    uint32_t points = 0;
    int32_t first = 0;
    for (int32_t i = 0; i < frame_count; ++i) { /* verify everything before writing */
        int32_t fr;
        uint32_t n;
        tsk_status s = tsk_bake_frame_info(frame_paths[i], &fr, &n);
        if (s != TSK_OK) return s;
        if (i == 0) {
            points = n;
            first = fr;
        } else if (n != points) {
            return tsk_error_arg(TSK_ERR_FORMAT, "frame_paths",
                                 "'%s' has %u points, the first frame has %u", frame_paths[i], n,
                                 points);
        } else if ((int64_t)fr != (int64_t)first + i) { /* 64 bits: first + i may pass INT32_MAX */
            return tsk_error_arg(TSK_ERR_FORMAT, "frame_paths",
                                 "'%s' holds frame %d, expected frame %lld", frame_paths[i], fr,
                                 (long long)first + i);
        }
    }
    const size_t frame_bytes = (size_t)points * 12u;
    const size_t total = PC2_HEADER + frame_bytes * (size_t)frame_count;
    tsk_status s = tsk_memory_check((double)total, "frame_paths");
    if (s != TSK_OK) return s;
    unsigned char* buf = tsk_alloc(total, "pc2 file");
    if (buf == NULL) return TSK_ERR_MEMORY;
    memcpy(buf, PC2_MAGIC, 12);
    int32_t version = 1, np = (int32_t)points, samples = frame_count;
    memcpy(buf + 12, &version, 4);
    memcpy(buf + 16, &np, 4);
    memcpy(buf + 20, &start_frame, 4);
    memcpy(buf + 24, &sample_rate, 4);
    memcpy(buf + 28, &samples, 4);
    for (int32_t i = 0; i < frame_count && s == TSK_OK; ++i)
        s = tsk_bake_read_frame(
            frame_paths[i], (float*)(void*)(buf + PC2_HEADER + frame_bytes * (size_t)i), points);
    if (s == TSK_OK) {
        const void* parts[1] = {buf};
        const size_t sizes[1] = {total};
        s = tsk_bake_write_parts(path, parts, sizes, 1);
    }
    tsk_free(buf);
    return s;
}

tsk_status tsk_pc2_info(const char* path, uint32_t* points, float* start_frame, float* sample_rate,
                        uint32_t* samples) {
    if (path == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "is NULL");
    FILE* f = tsk_fopen(path, "rb");
    if (f == NULL)
        return tsk_error_arg(TSK_ERR_IO, "path", "cannot open '%s': %s", path, strerror(errno));
    unsigned char h[PC2_HEADER];
    size_t got = fread(h, 1, PC2_HEADER, f);
    uint64_t size = 0;
    int stat_ok = tsk_file_size(f, &size) == 0;
    fclose(f);
    if (got != PC2_HEADER || memcmp(h, PC2_MAGIC, 12) != 0)
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is not a .pc2 point cache", path);
    int32_t version, np, ns;
    float start, rate;
    memcpy(&version, h + 12, 4);
    memcpy(&np, h + 16, 4);
    memcpy(&start, h + 20, 4);
    memcpy(&rate, h + 24, 4);
    memcpy(&ns, h + 28, 4);
    if (version != 1 || np < 0 || ns < 0 || (uint32_t)np > TSK_BAKE_MAX_POINTS)
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' has a bad .pc2 header", path);
    if (!isfinite(start) || !(isfinite(rate) && rate > 0.0f))
        return tsk_error_arg(TSK_ERR_FORMAT, "path",
                             "'%s' has a bad .pc2 header (start frame %g, sample rate %g)", path,
                             (double)start, (double)rate);
    if (!stat_ok || size != PC2_HEADER + (uint64_t)np * 12u * (uint64_t)ns)
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is truncated or too long", path);
    if (points) *points = (uint32_t)np;
    if (start_frame) *start_frame = start;
    if (sample_rate) *sample_rate = rate;
    if (samples) *samples = (uint32_t)ns;
    return TSK_OK;
}

tsk_status tsk_pc2_read_sample(const char* path, uint32_t index, float* xyz, uint32_t points) {
    if (xyz == NULL && points > 0) return tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "is NULL");
    uint32_t np, ns;
    tsk_status s = tsk_pc2_info(path, &np, NULL, NULL, &ns);
    if (s != TSK_OK) return s;
    if (np != points)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "points", "'%s' holds %u points, not %u", path, np,
                             points);
    if (index >= ns)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "index", "'%s' has %u samples, asked for %u", path,
                             ns, index);
    FILE* f = tsk_fopen(path, "rb");
    if (f == NULL)
        return tsk_error_arg(TSK_ERR_IO, "path", "cannot open '%s': %s", path, strerror(errno));
    const uint64_t offset = PC2_HEADER + (uint64_t)np * 12u * index;
    size_t n = (size_t)np * 3;
    int ok = tsk_fseek_set(f, offset) == 0 && fread(xyz, sizeof(float), n, f) == n;
    fclose(f);
    if (!ok) return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is truncated", path);
    for (size_t i = 0; i < n; ++i)
        if (!isfinite(xyz[i]))
            return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' sample %u holds a non-finite point",
                                 path, index);
    return TSK_OK;
}
