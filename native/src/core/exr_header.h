/* An OpenEXR file's header checked the way OpenEXR itself will read it, before OpenCV hands
 * the file to OpenEXR: the library allocates its line or tile buffers from the header alone,
 * so a header that claims a huge data window, thousands of channels or a huge tile or
 * preview makes it allocate gigabytes before a single pixel is read. */
#ifndef TSK_EXR_HEADER_H
#define TSK_EXR_HEADER_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

/// Largest line block (or tile) buffer an accepted header may make OpenEXR allocate:
/// bytes per line of all channels times the lines its compression packs together.
#define TSK_EXR_MAX_BLOCK_BYTES (256ll << 20)

typedef struct tsk_exr_header {
    long long width, height; /* of the data window */
    int channels;
    int tiled;
} tsk_exr_header;

/// Checks the header in the first `n` bytes of an OpenEXR file (`b` starts with its magic
/// number). Refused, with TSK_ERR_FORMAT and a message naming `name`: a header that does
/// not end within the bytes given; multi-part or deep files; an attribute whose size is not
/// the size of its type (OpenEXR reads the type's size and would go on reading elsewhere than
/// this check); a second dataWindow; a malformed channel list, tile description, preview,
/// float vector or string vector (OpenEXR makes room for each string length it reads); and
/// with TSK_ERR_LIMIT a line block or tile over TSK_EXR_MAX_BLOCK_BYTES. The caller
/// checks width and height against its own limits.
tsk_status tsk_exr_check_header(const uint8_t* b, size_t n, const char* name, tsk_exr_header* out);

#endif
