/* Private declarations shared by the capture module's files: the result object, growable
 * arrays, 1-D smoothing, and the stages of the pipeline (band, partition, skeleton). */
#ifndef TSK_CAPTURE_INTERNAL_H
#define TSK_CAPTURE_INTERNAL_H

#include <stdint.h>

#include "tussock/capture.h"

/* A contour resampled at (about) 1 pixel arc spacing; closed. */
typedef struct tsk_ring {
    float* x;
    float* y;
    float* d; /* smoothed distance to the cluster centre */
    uint8_t* edge; /* 1 if the sample lies on the image border */
    int n;
    float cx, cy; /* the cluster centre the distances are measured from */
} tsk_ring;

/* One blade's part of a ring: the tip sample and the split samples before and after it
 * (ring indices, circular; left side walks backwards from tip to lo, right forwards to hi). */
typedef struct tsk_blade_span {
    int tip, lo, hi;
} tsk_blade_span;

struct tsk_capture {
    int width, height;
    float near_m, far_m;
    tsk_intrinsics K;
    char message[256];

    float* depth; /* copy of the frame (for knots' depth and the debug image) */
    uint8_t* mask;
    size_t pixels_cap;

    /* contours of the kept blobs (for the overlay) */
    int* contour_start; /* contour_count + 1 */
    float* contour_xy;
    int contour_count;
    size_t contour_start_cap, contour_xy_cap;

    /* blades: knots, blade after blade */
    int blade_count;
    int* knot_start; /* blade_count + 1 */
    uint32_t* flags;
    size_t knot_start_cap, flags_cap, poly_start_cap;
    float* xyz;
    float* width_m;
    float* uv;
    size_t xyz_cap, width_cap, uv_cap;
    /* region polygon of each blade (for the label image) */
    int* poly_start; /* blade_count + 1 */
    float* poly_xy;
    size_t poly_cap;

    /* scratch */
    tsk_ring ring;
    size_t ring_cap;
    float* tmp;
    size_t tmp_cap;
    float* skel; /* matching output: x, y, w per pair, 3 floats */
    size_t skel_cap;
    float* knots; /* resampled: u, v, w, z per knot, 4 floats */
    size_t knots_cap;
    tsk_blade_span* spans;
    size_t spans_cap;
    int* peaks;
    size_t peaks_cap;
    int* pair_j; /* matching: index on the right side of each pair */
    size_t pair_j_cap;
};

/* Grows *p (element size elem) to hold at least need elements; keeps contents. */
int tsk_cap_grow(void** p, size_t* cap, size_t need, size_t elem, const char* what);

/* Gaussian smoothing of n values with sigma (in samples), circular or with the kernel
 * renormalised at the ends. out may not alias in. sigma <= 0 copies. */
void tsk_smooth_circular(const float* in, float* out, int n, float sigma);
void tsk_smooth_open(const float* in, float* out, int n, float sigma);

/* Builds cap->ring from integer contour points: smoothing, 1-pixel resampling, border
 * marks, and the distance to the centre (root mode), smoothed. */
tsk_status tsk_capture_make_ring(tsk_capture* cap, const tsk_capture_def* def, const int32_t* xy,
                                 int n);

/* Finds the blades of cap->ring: significant peaks of the distance and the splits between
 * them (seed 000 §4.2). Writes spans into cap->spans, returns their count (>= 1) or -1. */
int tsk_capture_partition(tsk_capture* cap, const tsk_capture_def* def);

/* Skeleton and widths of one span (seed 000 §4.3), appended to the blade arrays. Returns
 * TSK_OK also when the blade is dropped (too few knots). */
tsk_status tsk_capture_skeleton(tsk_capture* cap, const tsk_capture_def* def,
                                const tsk_blade_span* span);

/* Continues a matched skeleton (x, y, w: count samples ordered tip -> root, smoothed,
 * about 1 px apart) beyond its root end through the part shared with neighbouring blades to
 * where the mask ends (the base), by the blade's own heading, heading change and width
 * trend, at most twice as far as the matched part is long and, with the centroid as
 * centre, not past the centre.
 * Writes up to max_out samples (1 px apart, root end first) and returns their count. */
int tsk_capture_extend_root(const tsk_capture* cap, const tsk_capture_def* def, const float* x,
                            const float* y, const float* w, int count, int max_out, float* ox,
                            float* oy, float* ow);
/* The same beyond the tip: along the last direction to the edge of the last mask pixel,
 * in 0.5 px steps (nearest the tip first), widths tapering to 0. */
int tsk_capture_extend_tip(const tsk_capture* cap, const float* x, const float* y, const float* w,
                           int count, int max_out, float* ox, float* oy, float* ow);

#endif
