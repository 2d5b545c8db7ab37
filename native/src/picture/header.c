/* Picture file headers: the width and height of PNG, JPEG and OpenEXR files read from their
 * first bytes, so that huge pictures are refused before anything is decoded. */
#include "picture_internal.h"

#include "core/exr_header.h"

#include <string.h>

static uint32_t be32(const uint8_t* p) {
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
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
    /* the whole header, as OpenEXR will read it: its buffers are sized from it */
    tsk_exr_header eh;
    const tsk_status s = tsk_exr_check_header(b, n, name, &eh);
    if (s != TSK_OK) return s;
    *w = eh.width;
    *h = eh.height;
    return TSK_OK;
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
    else if (n >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF)
        s = jpeg_size(b, n, name, &w, &h);
    else if (n >= 8 && memcmp(b, exr_sig, 4) == 0) s = exr_size(b, n, name, &w, &h);
    else
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' is not a PNG, JPEG or OpenEXR file (%s)",
                             name, n == 0 ? "it is empty" : "unknown signature");
    if (s != TSK_OK) return s;
    if (w < TSK_PICTURE_MIN_SIDE || h < TSK_PICTURE_MIN_SIDE)
        return tsk_error_arg(TSK_ERR_FORMAT, "path",
                             "'%s' is %lldx%lld pixels; a picture needs at least %dx%d", name, w, h,
                             TSK_PICTURE_MIN_SIDE, TSK_PICTURE_MIN_SIDE);
    if (w > TSK_PICTURE_MAX_SIDE || h > TSK_PICTURE_MAX_SIDE || w * h > TSK_PICTURE_MAX_PIXELS)
        return tsk_error_arg(TSK_ERR_LIMIT, "path",
                             "'%s' is %lldx%lld pixels; the limit is %d per side and %lld in all",
                             name, w, h, TSK_PICTURE_MAX_SIDE, TSK_PICTURE_MAX_PIXELS);
    *width = (int)w;
    *height = (int)h;
    return TSK_OK;
}
