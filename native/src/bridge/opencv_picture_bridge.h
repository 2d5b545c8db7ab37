/* Private C interface to the OpenCV side of the picture module (opencv_picture.cpp):
 * image decoding, GrabCut, inpainting, exact distance transforms and cv::remap for the
 * benchmark's peer. Plain C types only; every function catches every exception. */
#ifndef TSK_OPENCV_PICTURE_BRIDGE_H
#define TSK_OPENCV_PICTURE_BRIDGE_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/// Decodes a PNG, JPEG or EXR file into straight float RGBA, rows top-first, written into
/// `rgba` (4*width*height floats, caller-allocated; width and height were read from the
/// header). 8-bit -> /255, 16-bit -> /65535, float kept. Grey and grey+alpha expanded.
/// The decoded size must equal (width, height).
tsk_status tsk_cvp_decode(const char* path, int width, int height, float* rgba);

/// GrabCut on straight RGBA (top-first). strokes may be NULL. mask receives 255 / 0.
tsk_status tsk_cvp_grabcut(const float* rgba, int width, int height, int rx, int ry, int rw, int rh,
                           int iterations, const uint8_t* strokes, uint8_t* mask);

/// Inpaints, channel by channel, the pixels of `rgba` (4 interleaved float channels) where
/// region != 0. method 0 = Telea, 1 = Navier-Stokes. `channels` = 3 leaves alpha alone.
tsk_status tsk_cvp_inpaint(float* rgba, int width, int height, const uint8_t* region, float radius,
                           int method, int channels);

/// Exact Euclidean distances (pixels, centre to centre) of every pixel to the nearest pixel
/// with mask == 0 (`inside`, 0 where mask == 0) and to the nearest pixel with mask != 0
/// (`outside`, 0 where mask != 0).
tsk_status tsk_cvp_distances(const uint8_t* mask, int width, int height, float* inside,
                             float* outside);

/// cv::remap of 4-channel float images with bilinear sampling and replicated border
/// (the benchmark's peer). map_x, map_y: source pixel coordinates, centres at integers.
tsk_status tsk_cvp_remap(const float* src, int width, int height, const float* map_x,
                         const float* map_y, float* dst, int threads);

/// Writes straight RGBA (top-first) to an image file whose extension picks the format:
/// `channels` 1 (grey from red), 3 or 4 of `bits` 8, 16 or 32 (32: EXR only). Used by the
/// tests to make files and available to tools that export layers.
tsk_status tsk_cvp_encode(const char* path, const float* rgba, int width, int height, int channels,
                          int bits);

/// Writes straight float RGBA (top-first) to `path` as OpenEXR: 32-bit float R, G, B, A
/// channels, lossless ZIP compression. Same pixels, same bytes. OpenCV reports no reason
/// for a failed write: TSK_ERR_IO "OpenCV could not write" (the caller diagnoses).
tsk_status tsk_cvp_write_exr(const char* path, const float* rgba, int width, int height);

#ifdef __cplusplus
}
#endif
#endif
