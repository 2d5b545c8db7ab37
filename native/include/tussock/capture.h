/* Tussock capture: depth sources (depth image files and numbered sequences, OpenNI2 .oni
 * recordings, live OpenNI2 devices) behind one interface, and the pipeline that turns one
 * depth frame into grass-blade profiles (seed 000 §4.1–4.3): depth-band mask, blob
 * contours, single-blade partition, symmetric skeleton with widths, each blade continued
 * through the part it shares with its neighbours to the base and out to the last pixel of
 * its tip, knots back-projected to the camera frame (OpenCV convention: x right, y down,
 * z forward, metres). */
#ifndef TUSSOCK_CAPTURE_H
#define TUSSOCK_CAPTURE_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- limits ---------------------------------------------------------------------------- */

/// Largest depth image accepted, per side, in pixels. Larger files are refused with
/// TSK_ERR_LIMIT from their header, before any pixel is decoded.
#define TSK_DEPTH_MAX_SIDE 8192
/// Largest number of frames in a numbered file sequence.
#define TSK_DEPTH_MAX_FRAMES 100000
/// Largest number of blades one frame can yield.
#define TSK_CAPTURE_MAX_BLADES 1024

/* ---- camera intrinsics ------------------------------------------------------------- */

/// Pinhole intrinsics in pixels (OpenCV convention: u = fx*x/z + cx, v = fy*y/z + cy).
typedef struct tsk_intrinsics {
    float fx, fy; ///< focal lengths, pixels
    float cx, cy; ///< principal point, pixels (pixel centres at integer coordinates)
} tsk_intrinsics;

/// Defaults of a 640×480 structured-light sensor (Kinect v1 / Xtion / PrimeSense:
/// fx = fy = 570.3, cx = 319.5, cy = 239.5) scaled to width × height.
tsk_intrinsics tsk_default_intrinsics(int width, int height);

/// Intrinsics from horizontal and vertical field of view (radians), as OpenNI2 reports
/// them: fx = (width/2) / tan(hfov/2), cx = (width-1)/2. Invalid input -> TSK_ERR_ARGUMENT.
tsk_status tsk_intrinsics_from_fov(int width, int height, float hfov, float vfov,
                                   tsk_intrinsics* out);

/* ---- depth sources ---------------------------------------------------------------- */

/// Opaque depth source. Not thread-safe: use one source from one thread at a time.
typedef struct tsk_depth_source tsk_depth_source;

typedef enum tsk_depth_kind {
    TSK_DEPTH_FILES = 0, ///< one depth image or a numbered sequence
    TSK_DEPTH_ONI = 1, ///< an OpenNI2 recording (.oni)
    TSK_DEPTH_DEVICE = 2, ///< a live OpenNI2 device
} tsk_depth_kind;

/// What a source is. Filled by tsk_depth_get_info.
typedef struct tsk_depth_info {
    tsk_depth_kind kind;
    int width, height; ///< pixels of every frame
    int frame_count; ///< frames in a file sequence or recording; -1 for a device
    int first_frame; ///< number of the first file of a sequence (0 otherwise)
    int has_device_intrinsics; ///< 1 if `intrinsics` came from the device/recording
    tsk_intrinsics intrinsics; ///< device intrinsics, else tsk_default_intrinsics
    char description[256]; ///< file pattern, recording path or device URI
} tsk_depth_info;

/// A frame that tsk_depth_read delivered (or did not).
typedef struct tsk_depth_frame {
    int is_new; ///< 1 if the buffer was written; 0: no new frame (device) or past the end
    int end; ///< 1 if a file sequence or recording has no more frames
    int index; ///< frame index (0-based position in a sequence/recording; device counter)
    double timestamp; ///< seconds (device/recording clock; index/30 for files)
    int invalid_pixels; ///< NaN, inf or negative values that were read as "no data" (EXR)
} tsk_depth_frame;

/// Opens a depth image (16-bit single-channel PNG in millimetres, 0 = no data; or a
/// 32-bit float OpenEXR in metres, 0/NaN/inf = no data) or a numbered sequence: a run of
/// '#' in the file name stands for the zero-padded frame number ("depth_####.png"); the
/// sequence starts at the lowest existing number in [0, TSK_DEPTH_MAX_FRAMES) and runs
/// while the numbers are consecutive. The first frame is checked (header and decode)
/// at open time. `*out` is set only on success; close it with tsk_depth_close.
tsk_status tsk_depth_open_files(const char* path, tsk_depth_source** out);

/// Opens an OpenNI2 recording (.oni) with a depth stream, for reading frame by frame
/// (frame count, seek). Playback does not run on a clock: each read gives the next frame.
tsk_status tsk_depth_open_oni(const char* path, tsk_depth_source** out);

/// Opens a live OpenNI2 device by URI (NULL or "" = the first device; "Dummy" is
/// OpenNI2's built-in test device). The depth stream is created but not started.
/// No device -> TSK_ERR_DEVICE.
tsk_status tsk_depth_open_device(const char* uri, tsk_depth_source** out);

/// Starts the stream of a device (files and recordings: no-op). Idempotent.
tsk_status tsk_depth_start(tsk_depth_source* src);
/// Stops the stream of a device (files and recordings: no-op). Idempotent.
tsk_status tsk_depth_stop(tsk_depth_source* src);

/// Closes a source and frees everything it holds. NULL is ignored.
void tsk_depth_close(tsk_depth_source* src);

/// Describes a source.
tsk_status tsk_depth_get_info(const tsk_depth_source* src, tsk_depth_info* out);

/// Moves a file sequence or recording so that the next read gives frame `index`
/// (0-based). Devices: TSK_ERR_ARGUMENT. Out of range: TSK_ERR_ARGUMENT.
tsk_status tsk_depth_seek(tsk_depth_source* src, int index);

/// Reads a frame into `depth_m` (width*height floats, row-major, metres, 0 = no data;
/// never NaN). Files and recordings: the frame at the read position, which then advances;
/// past the last frame returns TSK_OK with is_new = 0, end = 1. Devices: never blocks —
/// the newest frame if one arrived since the last read, else TSK_OK with is_new = 0 and
/// the buffer untouched; a device lost mid-capture gives TSK_ERR_DEVICE. A stream not
/// started gives TSK_ERR_ARGUMENT. `frame` may be NULL.
tsk_status tsk_depth_read(tsk_depth_source* src, float* depth_m, size_t count,
                          tsk_depth_frame* frame);

/// Writes a depth map (metres, 0 = no data) as a 16-bit PNG in millimetres (rounded,
/// clamped to 65535 mm). Values that are not finite or negative: TSK_ERR_ARGUMENT.
tsk_status tsk_depth_write_png16(const char* path, const float* depth_m, int width, int height);
/// Writes a depth map (metres) as a single-channel 32-bit float OpenEXR.
tsk_status tsk_depth_write_exr(const char* path, const float* depth_m, int width, int height);

/* ---- the pipeline ----------------------------------------------------------------- */

/// Where the blades of a cluster grow from: the "centre" of seed 000 §4.2 from which
/// contour distances are measured.
typedef enum tsk_capture_root {
    TSK_ROOT_BOTTOM = 0, ///< centre at the blob's base (bottom of the image): default
    TSK_ROOT_CENTROID = 1, ///< the blob's centroid, literally as in the seed
} tsk_capture_root;

/// Parameters of the capture pipeline. Get defaults with tsk_default_capture_def().
typedef struct tsk_capture_def {
    float near_m, far_m; ///< depth band in metres, far_m <= 10000; both 0 = automatic
        ///< (nearest depth mode)
    tsk_intrinsics intrinsics; ///< all 0 = tsk_default_intrinsics(width, height); else
        ///< fx, fy in [0.01, 1e6) px and |cx|, |cy| <= 1e6 px
    int min_area; ///< smallest blob kept, pixels (also the speckle size). Default 150
    int hole_radius; ///< closing radius that fills dropout holes, pixels. Default 2
    int open_radius; ///< opening radius that removes thin speckles, pixels. Default 0
    float contour_smooth; ///< Gaussian sigma along the contour, pixels. Default 1.5
    float split_smooth; ///< Gaussian sigma of the distance function, pixels. Default 3
    float split_prominence; ///< a tip must stand this far (pixels) above the splits
        ///< beside it, or it is noise. Default 12
    tsk_capture_root root; ///< TSK_ROOT_BOTTOM (default) or TSK_ROOT_CENTROID
    float knot_spacing; ///< distance between skeleton knots, pixels. Default 2
    float width_smooth; ///< Gaussian sigma of widths and depths along the skeleton, knots.
        ///< Default 2
    int depth_window; ///< half size of the window whose median depth a knot takes. Default 2
    int min_knots; ///< blades with fewer knots are dropped. Default 4
    float root_trim; ///< skeleton pairs this many median blade widths from the end of
        ///< either side (a split or the base) are dropped, because a side
        ///< that ends at a split turns onto the neighbour there; the blade
        ///< is then continued from where its pairs end, through the part it
        ///< shares with its neighbours, down to the base. Default 1
} tsk_capture_def;

/// Defaults documented in tsk_capture_def.
tsk_capture_def tsk_default_capture_def(void);

/// Flags per blade.
enum {
    TSK_BLADE_CUT_BY_BORDER = 1u << 0, ///< its contour touches the image border: the blade
    ///< continues outside the picture
    TSK_BLADE_TIP_AT_BORDER = 1u << 1, ///< the tip itself lies on the border (blade is cut)
    TSK_BLADE_ASYMMETRIC = 1u << 2, ///< one side is much longer than the other (merged
    ///< with a neighbour over a long stretch)
};

/// Proposes a depth band: the nearest significant mode of the histogram of valid depths
/// (1 cm bins; a mode is significant if it holds at least `min_pixels` pixels), widened
/// to where the histogram falls to 5 % of the mode's height. No mode -> TSK_ERR_FORMAT
/// ("all-zero depth" or "no significant depth").
tsk_status tsk_capture_propose_band(const float* depth_m, int width, int height, int min_pixels,
                                    float* near_m, float* far_m);

/// Result of processing one frame. Reuse it from frame to frame: its buffers are kept and
/// only grow, so a live preview does not reallocate them.
typedef struct tsk_capture tsk_capture;

tsk_status tsk_capture_create(tsk_capture** out);
void tsk_capture_destroy(tsk_capture* cap);

/// Runs the pipeline on one depth frame (metres, 0 = no data, width*height floats).
/// Errors: invalid def (TSK_ERR_ARGUMENT naming the field), non-finite or negative depth
/// (TSK_ERR_ARGUMENT), no valid depth at all (TSK_ERR_FORMAT "all-zero"), a band that
/// selects no pixel (TSK_ERR_FORMAT "band"). An empty mask after cleaning (nothing above
/// min_area) is not an error: blade count 0 (tsk_capture_status_message says why).
tsk_status tsk_capture_process(tsk_capture* cap, const tsk_capture_def* def, const float* depth_m,
                               int width, int height);

/// Number of blades found by the last tsk_capture_process.
int tsk_capture_blade_count(const tsk_capture* cap);
/// Total number of knots over all blades.
int tsk_capture_knot_total(const tsk_capture* cap);
/// Band used by the last frame (given or proposed), metres.
void tsk_capture_band(const tsk_capture* cap, float* near_m, float* far_m);
/// Intrinsics used by the last frame.
tsk_intrinsics tsk_capture_intrinsics(const tsk_capture* cap);
/// Human-readable summary of the last frame ("5 blades", "mask empty: nothing above
/// min_area 150 px", ...). Never NULL.
const char* tsk_capture_status_message(const tsk_capture* cap);

/// Knot counts (int32, blade_count entries) and flags (uint32, blade_count entries).
/// Either pointer may be NULL. `count` must equal the blade count.
tsk_status tsk_capture_get_blades(const tsk_capture* cap, int32_t* knot_counts, uint32_t* flags,
                                  size_t count);

/// Knots of all blades, blade after blade, each root -> tip. `total` must equal
/// tsk_capture_knot_total. Any pointer may be NULL:
///   camera_xyz: 3*total floats, metres, camera frame (x right, y down, z forward)
///   width_m:    total floats, full blade width at the knot, metres
///   pixel_uv:   2*total floats, image position (u right, v down), pixels
tsk_status tsk_capture_get_knots(const tsk_capture* cap, float* camera_xyz, float* width_m,
                                 float* pixel_uv, size_t total);

/// The same for one blade: `knot_count` must equal that blade's knot count.
tsk_status tsk_capture_get_blade(const tsk_capture* cap, int blade, float* camera_xyz,
                                 float* width_m, float* pixel_uv, size_t knot_count);

/// Debug images of the last frame, width*height bytes each, for a live preview.
typedef enum tsk_capture_image {
    TSK_IMAGE_DEPTH = 0, ///< depth: 255 near .. 1 far over the band ±50 %, 0 = no data
    TSK_IMAGE_MASK = 1, ///< 255 where the cleaned mask is set
    TSK_IMAGE_LABELS = 2, ///< blade b (0-based) as b+1 in its region; 255 = mask pixel of no
    ///< blade; 0 = background. Wraps above 254 blades.
    TSK_IMAGE_OVERLAY = 3, ///< 0 background, 64 mask, 128 contour, 255 skeletons
} tsk_capture_image;

tsk_status tsk_capture_get_image(const tsk_capture* cap, tsk_capture_image which, uint8_t* out,
                                 size_t count);

#ifdef __cplusplus
}
#endif
#endif
