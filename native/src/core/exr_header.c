/* OpenEXR headers checked as OpenEXR reads them (exr_header.h). The layout: magic (4 bytes),
 * version 2 and flags (4), then attributes — name\0 type\0 size (int32 LE) value — until an
 * empty name. OpenEXR reads a value of a known type by that type's own length (or, for a
 * channel list and a preview, by their contents) whatever size the file gives, so this
 * check refuses any attribute whose size disagrees: from there on OpenEXR would be reading
 * other bytes as the header than this check did. */
#define _POSIX_C_SOURCE 200809L /* strnlen */
#include "core/exr_header.h"

#include <string.h>

static int32_t le32(const uint8_t* p) {
    return (int32_t)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
                     (uint32_t)p[3] << 24);
}

/* Length of the value of OpenEXR's fixed-size attribute types; -1 for the others. */
static int fixed_size(const char* type) {
    static const struct {
        const char* type;
        int size;
    } sizes[] = {{"box2i", 16},      {"box2f", 16},   {"chromaticities", 32},
                 {"compression", 1}, {"double", 8},   {"envmap", 1},
                 {"float", 4},       {"int", 4},      {"keycode", 28},
                 {"lineOrder", 1},   {"m33f", 36},    {"m33d", 72},
                 {"m44f", 64},       {"m44d", 128},   {"rational", 8},
                 {"tiledesc", 9},    {"timecode", 8}, {"v2i", 8},
                 {"v2f", 8},         {"v2d", 16},     {"v3i", 12},
                 {"v3f", 12},        {"v3d", 24},     {"deepImageState", 1}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; ++i)
        if (strcmp(type, sizes[i].type) == 0) return sizes[i].size;
    return -1;
}

/* Scan lines OpenEXR packs into one block for a compression (NO, RLE, ZIPS, ZIP, PIZ, PXR24,
 * B44, B44A, DWAA, DWAB); 0 for an unknown one. */
static int block_lines(int compression) {
    static const int lines[10] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};
    return compression >= 0 && compression < 10 ? lines[compression] : 0;
}

static tsk_status bad(const char* name, const char* what) {
    return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is a malformed OpenEXR file (%s)", name,
                         what);
}

/* Parses a channel list of `size` bytes: entries name\0 pixel_type(int32) pLinear(u8)
 * reserved(3) xSampling(int32) ySampling(int32), then \0, which must be its last byte.
 * Adds up the bytes of one line of `width` pixels. */
static tsk_status parse_channels(const uint8_t* v, size_t size, size_t max_name, long long width,
                                 const char* name, int* count, long long* line_bytes,
                                 long long* pixel_bytes) {
    size_t p = 0;
    *count = 0;
    *line_bytes = 0;
    *pixel_bytes = 0;
    while (p < size && v[p] != 0) {
        const size_t ln = strnlen((const char*)(v + p), size - p);
        if (ln > max_name || p + ln + 1 + 16 > size) return bad(name, "bad channel list");
        const uint8_t* e = v + p + ln + 1;
        const int32_t type = le32(e), xs = le32(e + 8), ys = le32(e + 12);
        if (type < 0 || type > 2) return bad(name, "unknown channel pixel type");
        if (xs < 1 || ys < 1) return bad(name, "channel sampling below 1");
        const int bytes = type == 1 ? 2 : 4; /* HALF, else UINT or FLOAT */
        *line_bytes += (width + xs - 1) / xs * bytes;
        *pixel_bytes += bytes;
        if (++*count > 4096) return bad(name, "more than 4096 channels");
        p += ln + 1 + 16;
    }
    if (p + 1 != size) return bad(name, "channel list of the wrong size");
    return TSK_OK;
}

tsk_status tsk_exr_check_header(const uint8_t* b, size_t n, const char* name, tsk_exr_header* out) {
    memset(out, 0, sizeof *out);
    if (n < 8 || b[0] != 0x76 || b[1] != 0x2f || b[2] != 0x31 || b[3] != 0x01)
        return bad(name, "no OpenEXR magic number");
    if (b[4] != 2) return bad(name, "not format version 2");
    const uint32_t flags = (uint32_t)b[5] | (uint32_t)b[6] << 8 | (uint32_t)b[7] << 16;
    if (flags & 0x1800u)
        return tsk_error_arg(TSK_ERR_FORMAT, "path",
                             "'%s' is a multi-part or deep OpenEXR file; only single-part "
                             "images are read",
                             name);
    const size_t max_name = (flags & 0x400u) ? 255 : 31; /* long names flag */
    out->tiled = (flags & 0x200u) != 0;
    int have_window = 0, have_channels = 0, have_tiles = 0, have_compression = 0;
    int compression = 0, channels = 0;
    long long pixel_bytes = 0;
    const uint8_t* chan_value = NULL;
    size_t chan_size = 0;
    uint32_t tile_x = 0, tile_y = 0;
    size_t at = 8;
    for (;;) {
        if (at >= n) return bad(name, "header longer than the bytes read, or truncated");
        if (b[at] == 0) break; /* the empty name that ends the header */
        const char* attr = (const char*)(b + at);
        const size_t an = strnlen(attr, n - at);
        if (an > max_name || at + an + 1 >= n) return bad(name, "attribute name too long");
        const char* type = (const char*)(b + at + an + 1);
        const size_t tn = strnlen(type, n - (at + an + 1));
        if (tn == 0 || tn > max_name) return bad(name, "bad attribute type name");
        const size_t s = at + an + 1 + tn + 1;
        if (s + 4 > n) return bad(name, "header longer than the bytes read, or truncated");
        const int32_t size = le32(b + s);
        if (size < 0 || (size_t)size > n - s - 4)
            return bad(name, "header longer than the bytes read, or truncated");
        const uint8_t* v = b + s + 4;
        const int fixed = fixed_size(type);
        if (fixed >= 0 && size != fixed) return bad(name, "an attribute of the wrong size");
        if (strcmp(type, "preview") == 0) { /* width, height, then 4 bytes a pixel */
            if (size < 8) return bad(name, "bad preview");
            const uint64_t pw = (uint32_t)le32(v), ph = (uint32_t)le32(v + 4);
            if (pw > n || ph > n || 8 + 4 * pw * ph != (uint64_t)size)
                return bad(name, "bad preview");
        } else if (strcmp(type, "floatvector") == 0) { /* OpenEXR reads size / 4 floats */
            if (size % 4 != 0) return bad(name, "a float vector of the wrong size");
        } else if (strcmp(type, "stringvector") == 0) {
            /* (length, bytes) pairs: OpenEXR makes room for each length it reads */
            size_t q = 0;
            while (q < (size_t)size) {
                if ((size_t)size - q < 4) return bad(name, "bad string vector");
                const int32_t len = le32(v + q);
                q += 4;
                if (len < 0 || (size_t)len > (size_t)size - q)
                    return bad(name, "bad string vector");
                q += (size_t)len;
            }
        }
        if (strcmp(attr, "dataWindow") == 0) {
            if (have_window || strcmp(type, "box2i") != 0)
                return bad(name, "a second dataWindow, or one not a box2i");
            out->width = (long long)le32(v + 8) - le32(v) + 1;
            out->height = (long long)le32(v + 12) - le32(v + 4) + 1;
            have_window = 1;
        } else if (strcmp(attr, "channels") == 0) {
            if (have_channels || strcmp(type, "chlist") != 0)
                return bad(name, "a second channel list, or one not a chlist");
            chan_value = v, chan_size = (size_t)size; /* parsed once the width is known */
            have_channels = 1;
        } else if (strcmp(attr, "tiles") == 0) {
            if (have_tiles || strcmp(type, "tiledesc") != 0)
                return bad(name, "a second tile description, or one not a tiledesc");
            tile_x = (uint32_t)le32(v), tile_y = (uint32_t)le32(v + 4);
            have_tiles = 1;
        } else if (strcmp(attr, "compression") == 0) {
            if (have_compression || strcmp(type, "compression") != 0)
                return bad(name, "a second compression, or one not a compression");
            compression = v[0];
            have_compression = 1;
        } else if (strcmp(type, "chlist") == 0) {
            return bad(name, "a channel list other than 'channels'");
        }
        at = s + 4 + (size_t)size;
    }
    if (!have_window) return bad(name, "no dataWindow");
    if (out->width <= 0 || out->height <= 0)
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' has an empty data window", name);
    if (block_lines(compression) == 0) return bad(name, "unknown compression");
    long long line_bytes = 0;
    if (have_channels) {
        tsk_status st = parse_channels(chan_value, chan_size, max_name, out->width, name, &channels,
                                       &line_bytes, &pixel_bytes);
        if (st != TSK_OK) return st;
    }
    out->channels = channels;
    const long long block = line_bytes * block_lines(compression);
    if (block > TSK_EXR_MAX_BLOCK_BYTES)
        return tsk_error_arg(TSK_ERR_LIMIT, "path",
                             "'%s': a block of its scan lines would take %lld bytes (%d "
                             "channels, %lld pixels wide); the limit is %lld",
                             name, block, channels, out->width, TSK_EXR_MAX_BLOCK_BYTES);
    if (out->tiled || have_tiles) {
        if (!have_tiles || tile_x == 0 || tile_y == 0 || tile_x > 65536 || tile_y > 65536)
            return bad(name, "a tiled file without a valid tile description");
        const long long tile = (long long)tile_x * (long long)tile_y * pixel_bytes;
        if (tile > TSK_EXR_MAX_BLOCK_BYTES)
            return tsk_error_arg(TSK_ERR_LIMIT, "path",
                                 "'%s': one %ux%u tile would take %lld bytes; the limit is %lld",
                                 name, tile_x, tile_y, tile, TSK_EXR_MAX_BLOCK_BYTES);
    }
    return TSK_OK;
}
