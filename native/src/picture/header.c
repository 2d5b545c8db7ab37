/* Picture file headers: the width and height of PNG, JPEG and OpenEXR files read from their
 * first bytes, so that huge pictures are refused before anything is decoded. */
#define _POSIX_C_SOURCE 200809L /* strnlen */
#include "picture_internal.h"

#include <string.h>

static uint32_t be32(const uint8_t* p) {
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}
static int32_t le32(const uint8_t* p) {
    return (int32_t)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
                     (uint32_t)p[3] << 24);
}

static tsk_status bad(const char* name, const char* what) {
    return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' %s", name, what);
}

static tsk_status png_size(const uint8_t* b, size_t n, const char* name, long long* w,
                           long long* h) {
    /* signature (8) + IHDR length (4) + "IHDR" (4) + width (4) + height (4) */
    if (n < 24 || memcmp(b + 12, "IHDR", 4) != 0) return bad(name, "is a truncated PNG");
    *w = be32(b + 16);
    *h = be32(b + 20);
    return TSK_OK;
}

static tsk_status jpeg_size(const uint8_t* b, size_t n, const char* name, long long* w,
                            long long* h) {
    size_t i = 2;
    while (i + 4 <= n) {
        if (b[i] != 0xFF) return bad(name, "is a corrupt JPEG (bad marker)");
        uint8_t m = b[i + 1];
        if (m == 0xFF) { /* fill byte */
            ++i;
            continue;
        }
        if (m == 0x01 || (m >= 0xD0 && m <= 0xD7)) { /* markers without length */
            i += 2;
            continue;
        }
        if (m == 0xD9 || m == 0xDA) break; /* end of image or start of scan before SOF */
        size_t len = (size_t)b[i + 2] << 8 | b[i + 3];
        if (len < 2) return bad(name, "is a corrupt JPEG (bad segment length)");
        if (m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC) {
            if (i + 9 > n) break;
            *h = (long long)b[i + 5] << 8 | b[i + 6];
            *w = (long long)b[i + 7] << 8 | b[i + 8];
            return TSK_OK;
        }
        i += 2 + len;
    }
    return bad(name, "is a truncated or corrupt JPEG (no frame header)");
}

static tsk_status exr_size(const uint8_t* b, size_t n, const char* name, long long* w,
                           long long* h) {
    size_t i = 8; /* magic (4) + version and flags (4) */
    while (i < n && b[i] != 0) {
        const char* attr = (const char*)(b + i);
        size_t an = strnlen(attr, n - i);
        if (i + an + 1 >= n) break;
        size_t t = i + an + 1;
        size_t tn = strnlen((const char*)(b + t), n - t);
        size_t s = t + tn + 1;
        if (s + 4 > n) break;
        int32_t size = le32(b + s);
        if (size < 0 || (size_t)size > n - s - 4) break;
        if (strcmp(attr, "dataWindow") == 0 && strcmp((const char*)(b + t), "box2i") == 0 &&
            size == 16) {
            long long x0 = le32(b + s + 4), y0 = le32(b + s + 8);
            long long x1 = le32(b + s + 12), y1 = le32(b + s + 16);
            *w = x1 - x0 + 1;
            *h = y1 - y0 + 1;
            return TSK_OK;
        }
        i = s + 4 + (size_t)size;
    }
    return bad(name, "is a truncated or corrupt OpenEXR file (no dataWindow)");
}

tsk_status tsk_picture_check_size(int width, int height, int min_side, const char* arg) {
    if (width < min_side || height < min_side)
        return tsk_error_arg(TSK_ERR_ARGUMENT, arg, "size %dx%d must be at least %dx%d", width,
                             height, min_side, min_side);
    if (width > TSK_PICTURE_MAX_SIDE || height > TSK_PICTURE_MAX_SIDE ||
        (long long)width * height > TSK_PICTURE_MAX_PIXELS)
        return tsk_error_arg(TSK_ERR_LIMIT, arg,
                             "size %dx%d exceeds the limit of %d pixels per side and %lld "
                             "pixels in all",
                             width, height, TSK_PICTURE_MAX_SIDE, TSK_PICTURE_MAX_PIXELS);
    return TSK_OK;
}

tsk_status tsk_picture_header_size(const uint8_t* b, size_t n, const char* name, int* width,
                                   int* height) {
    static const uint8_t png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    static const uint8_t exr_sig[4] = {0x76, 0x2F, 0x31, 0x01};
    long long w = 0, h = 0;
    tsk_status s;
    if (n >= 8 && memcmp(b, png_sig, 8) == 0) s = png_size(b, n, name, &w, &h);
    else if (n >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) s = jpeg_size(b, n, name, &w, &h);
    else if (n >= 8 && memcmp(b, exr_sig, 4) == 0) s = exr_size(b, n, name, &w, &h);
    else
        return tsk_error_arg(TSK_ERR_FORMAT, "path",
                             "'%s' is not a PNG, JPEG or OpenEXR file (%s)", name,
                             n == 0 ? "it is empty" : "unknown signature");
    if (s != TSK_OK) return s;
    if (w < TSK_PICTURE_MIN_SIDE || h < TSK_PICTURE_MIN_SIDE)
        return tsk_error_arg(TSK_ERR_FORMAT, "path",
                             "'%s' is %lldx%lld pixels; a picture needs at least %dx%d", name, w,
                             h, TSK_PICTURE_MIN_SIDE, TSK_PICTURE_MIN_SIDE);
    if (w > TSK_PICTURE_MAX_SIDE || h > TSK_PICTURE_MAX_SIDE || w * h > TSK_PICTURE_MAX_PIXELS)
        return tsk_error_arg(TSK_ERR_LIMIT, "path",
                             "'%s' is %lldx%lld pixels; the limit is %d per side and %lld in all",
                             name, w, h, TSK_PICTURE_MAX_SIDE, TSK_PICTURE_MAX_PIXELS);
    *width = (int)w;
    *height = (int)h;
    return TSK_OK;
}
