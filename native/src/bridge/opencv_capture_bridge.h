/* Private bridge between the capture module and OpenCV: depth image decoding and
 * encoding, mask morphology, outer contours and polygon drawing on caller-owned
 * buffers. No OpenCV type crosses this header; every function catches all exceptions
 * and returns a tsk_status with a message. */
#ifndef TSK_OPENCV_CAPTURE_BRIDGE_H
#define TSK_OPENCV_CAPTURE_BRIDGE_H

#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/// Pixel type of a decoded depth image.
typedef enum tsk_cvb_depth_type { TSK_CVB_U16 = 1, TSK_CVB_F32 = 2 } tsk_cvb_depth_type;

/// Decodes a single-channel 16-bit (PNG) or 32-bit float (EXR) image. `*data` is
/// allocated with tsk_alloc (caller frees). Enables OpenCV's OpenEXR codec (env var
/// OPENCV_IO_ENABLE_OPENEXR=1) before the first decode when the caller has not set it.
/// Colour or 8-bit images give TSK_ERR_FORMAT; undecodable files TSK_ERR_FORMAT.
tsk_status tsk_cvb_read_depth(const char* path, int* width, int* height, tsk_cvb_depth_type* type,
                              void** data);

/// Encodes `data` (width*height, row-major) as 16-bit PNG.
tsk_status tsk_cvb_write_png16(const char* path, const uint16_t* data, int width, int height);
/// Encodes `data` (width*height, row-major) as a single-channel 32-bit float OpenEXR.
tsk_status tsk_cvb_write_exr(const char* path, const float* data, int width, int height);
/// Encodes an 8-bit image with 1 or 3 channels (interleaved) as PNG (test and debug use).
tsk_status tsk_cvb_write_png8(const char* path, const uint8_t* data, int width, int height,
                              int channels);

/// Morphological closing of a 0/255 mask with an elliptic element of `close_radius`
/// pixels (0 = none), then opening with `open_radius` (0 = none), in place.
tsk_status tsk_cvb_morphology(uint8_t* mask, int width, int height, int close_radius,
                              int open_radius);

/// Outer contours (cv::findContours, RETR_EXTERNAL, CHAIN_APPROX_NONE) of a 0/255 mask
/// whose enclosed area is at least `min_area` pixels. Points of contour k are
/// xy[2*start[k] .. 2*start[k+1]), integers in pixel coordinates. Arrays are tsk_alloc'd.
typedef struct tsk_cvb_contours {
    int count;
    int* start; ///< count + 1 offsets into the point list
    int32_t* xy; ///< 2 * start[count] coordinates
    double* area; ///< count areas in pixels
} tsk_cvb_contours;

tsk_status tsk_cvb_find_contours(const uint8_t* mask, int width, int height, double min_area,
                                 tsk_cvb_contours* out);
void tsk_cvb_contours_free(tsk_cvb_contours* c);

/// Fills the polygon xy[0..2n) (float pixel coordinates) into img with `value`.
tsk_status tsk_cvb_fill_poly(uint8_t* img, int width, int height, const float* xy, int n,
                             uint8_t value);
/// Draws the open polyline xy[0..2n) into img with `value`, 1 pixel thick.
tsk_status tsk_cvb_polyline(uint8_t* img, int width, int height, const float* xy, int n,
                            uint8_t value);

/// Sets OpenCV's worker thread count (cached: only calls OpenCV when it changes).
void tsk_cvb_set_threads(int threads);

#ifdef __cplusplus
}
#endif
#endif
