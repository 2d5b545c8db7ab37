/* Tussock bake caches of pictures: one OpenEXR file per frame (32-bit float RGBA, lossless
 * ZIP compression) that stock Blender reads as an image sequence, written atomically
 * (temporary file, fsync, rename), and beside it a small sidecar file `<path>.tski` holding
 * the format version, the frame, the caller's inputs key, the picture size and a checksum
 * of the EXR's bytes, so that Tussock can verify a frame before it uses it. OpenEXR has no
 * place for Tussock's data that OpenCV can write, hence the sidecar.
 *
 * Sidecar layout (48 bytes, little-endian):
 *   "TSKIMAGE" | u32 format version | i32 frame | u32 width | u32 height | u64 inputs key
 *   | u64 EXR size in bytes | u64 FNV-1a checksum of the EXR bytes */
#ifndef TUSSOCK_BAKE_IMAGE_H
#define TUSSOCK_BAKE_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/// Format version of image frames; a sidecar of another version is refused (TSK_ERR_FORMAT).
#define TSK_BAKE_IMAGE_FORMAT_VERSION 1
/// Suffix of the sidecar file appended to the EXR path.
#define TSK_BAKE_IMAGE_SIDECAR ".tski"

/// Writes `rgba` (count = 4*width*height float32, rows top-first, every value finite) as an
/// OpenEXR file at `path` (must end in ".exr"), then its sidecar `<path>.tski` with
/// `frame` and `key` (any 64-bit value the caller derives from the inputs of the frame).
/// Both atomically: a reader sees a complete file or none. A frame is valid only when the
/// sidecar matches the EXR, so a bake killed between the two writes leaves a frame that
/// tsk_bake_image_info refuses and a resumed bake writes again. Same input, same bytes.
/// A read-only folder or a full disk gives TSK_ERR_IO with the system's reason.
/// Width and height: TSK_PICTURE_MIN_SIDE..TSK_PICTURE_MAX_SIDE as for pictures.
tsk_status tsk_bake_write_image(const char* path, int32_t frame, uint64_t key, const float* rgba,
                                size_t count, int width, int height);

/// Verifies an image frame: its sidecar exists, is of this format version, and the EXR
/// has the size and checksum the sidecar records. Returns the frame, key, width and
/// height recorded (any pointer may be NULL). A missing EXR or sidecar gives TSK_ERR_IO
/// naming the file; another format version, a corrupt or mismatched file TSK_ERR_FORMAT.
tsk_status tsk_bake_image_info(const char* path, int32_t* frame, uint64_t* key, int* width,
                               int* height);

#ifdef __cplusplus
}
#endif
#endif
