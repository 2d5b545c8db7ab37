/* Tussock bake caches: frames written one file each, atomically (temporary file, fsync,
 * rename) with a header (format version, frame, point count, checksum) that is verified
 * before use, and their assembly into a Point Cache 2 file (.pc2) that Blender's own Mesh
 * Cache modifier reads without Tussock. Frames from several processes (farm workers
 * baking disjoint frame ranges) assemble into the same bytes as one process's. */
#ifndef TUSSOCK_BAKE_H
#define TUSSOCK_BAKE_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/// Format version of frame files; a file of another version is refused (TSK_ERR_FORMAT).
#define TSK_BAKE_FORMAT_VERSION 1
/// Largest number of points in a frame (TSK_ERR_LIMIT above).
#define TSK_BAKE_MAX_POINTS (1u << 28)
/// Largest number of frames assembled into one .pc2.
#define TSK_BAKE_MAX_FRAMES 1000000

/// 64-bit FNV-1a checksum of `size` bytes.
uint64_t tsk_bake_checksum(const void* data, size_t size);

/// Writes one frame: `count` points (3 floats each, metres) of frame `frame` into `path`,
/// atomically: a reader sees the old file or the complete new one, never a part. A
/// read-only folder or a full disk gives TSK_ERR_IO with the system's reason, and leaves
/// no temporary file behind.
tsk_status tsk_bake_write_frame(const char* path, int32_t frame, const float* xyz, uint32_t count);

/// Reads and checks a frame file: its frame number and point count. A missing file gives
/// TSK_ERR_IO; a file that is not a Tussock frame, of another format version, truncated,
/// whose data does not match its checksum or holds a non-finite value gives TSK_ERR_FORMAT.
/// The data is verified in small chunks: no memory of the frame's size is needed.
tsk_status tsk_bake_frame_info(const char* path, int32_t* frame, uint32_t* count);

/// Reads a verified frame: `count` must equal the file's point count.
tsk_status tsk_bake_read_frame(const char* path, float* xyz, uint32_t count);

/// Assembles `frame_count` frame files (paths in frame order) into a .pc2 file at `path`
/// (atomically), with `start_frame` and `sample_rate` (frames per sample, 1 = every
/// frame) in its header. start_frame must be finite, sample_rate positive and finite
/// (TSK_ERR_ARGUMENT). Every frame file is verified first: a missing, corrupt or
/// mismatched frame (other point count, frame numbers not consecutive) is reported with
/// its path and nothing is written. The file is assembled in memory: more than the memory
/// budget (tsk_memory_check) gives TSK_ERR_LIMIT.
tsk_status tsk_bake_assemble_pc2(const char* path, const char* const* frame_paths,
                                 int32_t frame_count, float start_frame, float sample_rate);

/// Reads a .pc2 header: point count, start frame, sample rate and sample count, checking
/// that the file is as long as the header says and that the start frame is finite and the
/// sample rate positive and finite (else TSK_ERR_FORMAT).
tsk_status tsk_pc2_info(const char* path, uint32_t* points, float* start_frame, float* sample_rate,
                        uint32_t* samples);

/// Reads sample `index` (0-based) of a .pc2 file into xyz (3*points floats). A sample
/// holding a non-finite value gives TSK_ERR_FORMAT.
tsk_status tsk_pc2_read_sample(const char* path, uint32_t index, float* xyz, uint32_t points);

#ifdef __cplusplus
}
#endif
#endif
