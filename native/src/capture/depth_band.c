/* Depth band of the capture pipeline (seed 000 §4.1, "distance masking"): the automatic
 * band proposal from the histogram of depths, and the mask of pixels inside the band. */
#include <math.h>
#include <string.h>

#include "capture_internal.h"

#define BAND_BIN_M 0.01f /* histogram bin: 1 cm */
#define BAND_BINS 2000 /* 0 .. 20 m; farther depths are never proposed */
#define BAND_WINDOW 10 /* a mode's mass is counted over 10 cm */
#define BAND_GAP 2 /* a band may bridge up to 2 empty bins */

tsk_status tsk_capture_propose_band(const float* depth_m, int width, int height, int min_pixels,
                                    float* near_m, float* far_m) {
    if (depth_m == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "depth_m", "is NULL");
    if (near_m == NULL || far_m == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "near_m", "output pointers are NULL");
    if (width <= 0 || height <= 0 || width > TSK_DEPTH_MAX_SIDE || height > TSK_DEPTH_MAX_SIDE)
        return tsk_error_arg(TSK_ERR_LIMIT, "width", "size %dx%d outside 1..%d", width, height,
                             TSK_DEPTH_MAX_SIDE);
    if (min_pixels < 1) min_pixels = 1;
    int hist[BAND_BINS + 2];
    memset(hist, 0, sizeof hist);
    size_t valid = 0;
    const size_t n = (size_t)width * (size_t)height;
    for (size_t i = 0; i < n; ++i) {
        float d = depth_m[i];
        if (!(d > 0.0f) || !isfinite(d)) continue;
        ++valid;
        /* farther than the histogram: not binned (and a huge d would overflow the int) */
        if (d >= (float)BAND_BINS * BAND_BIN_M) continue;
        int b = (int)(d / BAND_BIN_M);
        if (b < BAND_BINS) ++hist[b];
    }
    if (valid == 0)
        return tsk_error_arg(TSK_ERR_FORMAT, "depth_m", "all-zero depth: no pixel has data");
    /* nearest window of BAND_WINDOW bins holding min_pixels */
    int run = 0, start = -1;
    for (int b = 0; b < BAND_BINS; ++b) {
        run += hist[b];
        if (b >= BAND_WINDOW) run -= hist[b - BAND_WINDOW];
        if (run >= min_pixels) {
            start = b - BAND_WINDOW + 1 < 0 ? 0 : b - BAND_WINDOW + 1;
            break;
        }
    }
    if (start < 0)
        return tsk_error_arg(TSK_ERR_FORMAT, "depth_m",
                             "no significant depth: no 10 cm slice nearer than 20 m holds %d "
                             "pixels",
                             min_pixels);
    /* its peak within 20 cm, then widen to 5 % of the peak, bridging small gaps */
    int peak = start;
    for (int b = start; b < start + 2 * BAND_WINDOW && b < BAND_BINS; ++b)
        if (hist[b] > hist[peak]) peak = b;
    const int floor_count = hist[peak] / 20 > 0 ? hist[peak] / 20 : 1;
    int lo = peak, hi = peak;
    for (int gap = 0, b = peak - 1; b >= 0 && gap <= BAND_GAP; --b) {
        if (hist[b] >= floor_count) {
            lo = b;
            gap = 0;
        } else {
            ++gap;
        }
    }
    for (int gap = 0, b = peak + 1; b < BAND_BINS && gap <= BAND_GAP; ++b) {
        if (hist[b] >= floor_count) {
            hi = b;
            gap = 0;
        } else {
            ++gap;
        }
    }
    float nm = (float)lo * BAND_BIN_M - BAND_BIN_M;
    *near_m = nm > 0.001f ? nm : 0.001f;
    *far_m = (float)(hi + 1) * BAND_BIN_M + BAND_BIN_M;
    return TSK_OK;
}
