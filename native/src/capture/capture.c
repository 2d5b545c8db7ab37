/* The capture pipeline's driver and result object: validates a frame and its parameters,
 * builds the depth-band mask (seed 000 §4.1), cleans it with OpenCV morphology, takes the
 * blobs' outer contours (cv::findContours) and runs partition and skeleton on each; then
 * hands out blades, knots and debug images into caller-owned buffers. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bridge/opencv_capture_bridge.h"
#include "capture_internal.h"

tsk_capture_def tsk_default_capture_def(void) {
    tsk_capture_def d;
    memset(&d, 0, sizeof d);
    d.near_m = 0.0f;
    d.far_m = 0.0f;
    d.min_area = 150;
    d.hole_radius = 2;
    d.open_radius = 0;
    d.contour_smooth = 1.5f;
    d.split_smooth = 3.0f;
    d.split_prominence = 12.0f;
    d.root = TSK_ROOT_BOTTOM;
    d.knot_spacing = 2.0f;
    d.width_smooth = 2.0f;
    d.depth_window = 2;
    d.min_knots = 4;
    d.root_trim = 1.0f;
    return d;
}

static tsk_status check_def(const tsk_capture_def* d) {
    if (!isfinite(d->near_m) || !isfinite(d->far_m) || d->near_m < 0.0f || d->far_m < 0.0f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "near_m",
                             "depth band must be finite and >= 0, got [%g, %g]", d->near_m,
                             d->far_m);
    if (d->far_m > 1e4f)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "far_m", "must be at most 10000 m, got %g",
                             d->far_m);
    if (!(d->near_m == 0.0f && d->far_m == 0.0f) && !(d->far_m > d->near_m))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "far_m",
                             "must be greater than near_m (%g), got %g (both 0 = automatic)",
                             d->near_m, d->far_m);
    const tsk_intrinsics* K = &d->intrinsics;
    const int k_zero = K->fx == 0.0f && K->fy == 0.0f && K->cx == 0.0f && K->cy == 0.0f;
    if (!k_zero && !(isfinite(K->fx) && isfinite(K->fy) && isfinite(K->cx) && isfinite(K->cy) &&
                     K->fx >= 1e-2f && K->fy >= 1e-2f && K->fx < 1e6f && K->fy < 1e6f &&
                     fabsf(K->cx) <= 1e6f && fabsf(K->cy) <= 1e6f))
        /* bounds keep back-projected knots finite: |u - cx| z / fx <= ~1e12 m */
        return tsk_error_arg(TSK_ERR_ARGUMENT, "intrinsics",
                             "fx, fy must be in [0.01, 1e6) and |cx|, |cy| <= 1e6 (all 0 = "
                             "defaults), got "
                             "fx=%g fy=%g cx=%g cy=%g",
                             K->fx, K->fy, K->cx, K->cy);
    if (d->min_area < 1 || d->min_area > 1 << 26)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "min_area", "must be in 1..2^26, got %d",
                             d->min_area);
    if (d->hole_radius < 0 || d->hole_radius > 32)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "hole_radius", "must be in 0..32, got %d",
                             d->hole_radius);
    if (d->open_radius < 0 || d->open_radius > 32)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "open_radius", "must be in 0..32, got %d",
                             d->open_radius);
    if (!(d->contour_smooth >= 0.0f && d->contour_smooth <= 20.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "contour_smooth", "must be in 0..20, got %g",
                             d->contour_smooth);
    if (!(d->split_smooth >= 0.0f && d->split_smooth <= 20.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "split_smooth", "must be in 0..20, got %g",
                             d->split_smooth);
    if (!(d->split_prominence >= 0.0f && d->split_prominence <= 1e5f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "split_prominence", "must be in 0..1e5, got %g",
                             d->split_prominence);
    if (d->root != TSK_ROOT_BOTTOM && d->root != TSK_ROOT_CENTROID)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "root", "unknown value %d", (int)d->root);
    if (!(d->knot_spacing >= 0.25f && d->knot_spacing <= 100.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "knot_spacing", "must be in 0.25..100, got %g",
                             d->knot_spacing);
    if (!(d->width_smooth >= 0.0f && d->width_smooth <= 20.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "width_smooth", "must be in 0..20, got %g",
                             d->width_smooth);
    if (d->depth_window < 0 || d->depth_window > 5)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "depth_window", "must be in 0..5, got %d",
                             d->depth_window);
    if (!(d->root_trim >= 0.0f && d->root_trim <= 10.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "root_trim", "must be in 0..10, got %g",
                             d->root_trim);
    if (d->min_knots < 2 || d->min_knots > 100000)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "min_knots", "must be in 2..100000, got %d",
                             d->min_knots);
    return TSK_OK;
}

tsk_status tsk_capture_create(tsk_capture** out) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    tsk_capture* cap = tsk_calloc(1, sizeof *cap, "capture");
    if (cap == NULL) return TSK_ERR_MEMORY;
    snprintf(cap->message, sizeof cap->message, "no frame processed yet");
    *out = cap;
    return TSK_OK;
}

void tsk_capture_destroy(tsk_capture* cap) {
    if (cap == NULL) return;
    void* arrays[] = {cap->depth,      cap->mask,       cap->contour_start, cap->contour_xy,
                      cap->knot_start, cap->flags,      cap->xyz,           cap->width_m,
                      cap->uv,         cap->poly_start, cap->poly_xy,       cap->ring.x,
                      cap->ring.y,     cap->ring.d,     cap->ring.edge,     cap->tmp,
                      cap->skel,       cap->knots,      cap->spans,         cap->peaks,
                      cap->pair_j};
    for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; ++i) tsk_free(arrays[i]);
    tsk_free(cap);
}

static void reset_result(tsk_capture* cap) {
    cap->blade_count = 0;
    cap->contour_count = 0;
    if (cap->knot_start) cap->knot_start[0] = 0;
    if (cap->poly_start) cap->poly_start[0] = 0;
    if (cap->contour_start) cap->contour_start[0] = 0;
}

tsk_status tsk_capture_process(tsk_capture* cap, const tsk_capture_def* def, const float* depth_m,
                               int width, int height) {
    if (cap == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "capture", "is NULL");
    reset_result(cap);
    cap->width = cap->height = 0;
    snprintf(cap->message, sizeof cap->message, "failed");
    if (def == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "def", "is NULL");
    if (depth_m == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "depth_m", "is NULL");
    if (width <= 0 || height <= 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "width", "size %dx%d must be positive", width,
                             height);
    if (width > TSK_DEPTH_MAX_SIDE || height > TSK_DEPTH_MAX_SIDE)
        return tsk_error_arg(TSK_ERR_LIMIT, "width", "size %dx%d exceeds the limit %dx%d", width,
                             height, TSK_DEPTH_MAX_SIDE, TSK_DEPTH_MAX_SIDE);
    tsk_status s = check_def(def);
    if (s != TSK_OK) return s;
    /* memory budget: the depth copy, masks, labels and distance images of one frame */
    s = tsk_memory_check((double)width * (double)height * 48.0, "width");
    if (s != TSK_OK) return s;
    const size_t npix = (size_t)width * (size_t)height;
    size_t c1 = cap->pixels_cap, c2 = cap->pixels_cap;
    if (!tsk_cap_grow((void**)&cap->depth, &c1, npix, sizeof(float), "depth copy") ||
        !tsk_cap_grow((void**)&cap->mask, &c2, npix, 1, "mask"))
        return TSK_ERR_MEMORY;
    cap->pixels_cap = c1;
    if (!tsk_cap_grow((void**)&cap->knot_start, &cap->knot_start_cap, 1, sizeof(int), "blades") ||
        !tsk_cap_grow((void**)&cap->poly_start, &cap->poly_start_cap, 1, sizeof(int), "blades") ||
        !tsk_cap_grow((void**)&cap->contour_start, &cap->contour_start_cap, 1, sizeof(int),
                      "contours"))
        return TSK_ERR_MEMORY;
    reset_result(cap);
    size_t valid = 0;
    for (size_t i = 0; i < npix; ++i) {
        const float d = depth_m[i];
        if (!isfinite(d) || d < 0.0f)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "depth_m",
                                 "value %g at pixel (%d, %d): depth must be finite metres >= 0 "
                                 "(0 = no data)",
                                 d, (int)(i % (size_t)width), (int)(i / (size_t)width));
        valid += d > 0.0f;
    }
    if (valid == 0)
        return tsk_error_arg(TSK_ERR_FORMAT, "depth_m", "all-zero depth: no pixel has data");
    memcpy(cap->depth, depth_m, npix * sizeof(float));
    cap->width = width;
    cap->height = height;
    const tsk_intrinsics* K = &def->intrinsics;
    cap->K = (K->fx == 0.0f && K->fy == 0.0f && K->cx == 0.0f && K->cy == 0.0f)
                 ? tsk_default_intrinsics(width, height)
                 : *K;
    float near_m = def->near_m, far_m = def->far_m;
    if (near_m == 0.0f && far_m == 0.0f) {
        s = tsk_capture_propose_band(depth_m, width, height, def->min_area, &near_m, &far_m);
        if (s != TSK_OK) return s;
    }
    cap->near_m = near_m;
    cap->far_m = far_m;
    size_t inside = 0;
    for (size_t i = 0; i < npix; ++i) {
        const float d = depth_m[i];
        const int in = d > 0.0f && d >= near_m && d <= far_m;
        cap->mask[i] = in ? 255 : 0;
        inside += (size_t)in;
    }
    if (inside == 0)
        return tsk_error_arg(TSK_ERR_FORMAT, "band",
                             "[%.3f, %.3f] m selects no pixel (valid depths exist elsewhere)",
                             near_m, far_m);
    /* hole filling (closing) and speckle removal (opening; small blobs go by min_area) */
    tsk_cvb_set_threads(tsk_get_threads());
    s = tsk_cvb_morphology(cap->mask, width, height, def->hole_radius, def->open_radius);
    if (s != TSK_OK) return s;
    tsk_cvb_contours cont;
    s = tsk_cvb_find_contours(cap->mask, width, height, (double)def->min_area, &cont);
    if (s != TSK_OK) return s;
    if (cont.count == 0) {
        tsk_cvb_contours_free(&cont);
        snprintf(cap->message, sizeof cap->message,
                 "mask empty: no blob of at least min_area %d px in the band [%.3f, %.3f] m",
                 def->min_area, near_m, far_m);
        return TSK_OK;
    }
    const size_t total_pts = (size_t)cont.start[cont.count];
    if (!tsk_cap_grow((void**)&cap->contour_start, &cap->contour_start_cap, (size_t)cont.count + 1,
                      sizeof(int), "contours") ||
        !tsk_cap_grow((void**)&cap->contour_xy, &cap->contour_xy_cap, 2 * total_pts, sizeof(float),
                      "contours")) {
        tsk_cvb_contours_free(&cont);
        return TSK_ERR_MEMORY;
    }
    for (int c = 0; c <= cont.count; ++c) cap->contour_start[c] = cont.start[c];
    for (size_t i = 0; i < 2 * total_pts; ++i) cap->contour_xy[i] = (float)cont.xy[i];
    cap->contour_count = cont.count;
    int truncated = 0;
    for (int c = 0; c < cont.count && s == TSK_OK; ++c) {
        const int n = cont.start[c + 1] - cont.start[c];
        s = tsk_capture_make_ring(cap, def, cont.xy + 2 * (size_t)cont.start[c], n);
        if (s != TSK_OK) break;
        const int spans = tsk_capture_partition(cap, def);
        if (spans < 0) {
            s = TSK_ERR_MEMORY;
            break;
        }
        for (int k = 0; k < spans && s == TSK_OK; ++k) {
            if (cap->blade_count >= TSK_CAPTURE_MAX_BLADES) {
                truncated = 1;
                break;
            }
            s = tsk_capture_skeleton(cap, def, &cap->spans[k]);
        }
    }
    tsk_cvb_contours_free(&cont);
    if (s != TSK_OK) {
        reset_result(cap);
        return s;
    }
    int cut = 0;
    for (int b = 0; b < cap->blade_count; ++b)
        cut += (cap->flags[b] & TSK_BLADE_CUT_BY_BORDER) != 0;
    snprintf(cap->message, sizeof cap->message, "%d blade%s in %d blob%s, band [%.3f, %.3f] m%s%s",
             cap->blade_count, cap->blade_count == 1 ? "" : "s", cap->contour_count,
             cap->contour_count == 1 ? "" : "s", near_m, far_m,
             cut ? ", some cut by the image border" : "",
             truncated ? ", stopped at the blade limit" : "");
    return TSK_OK;
}

int tsk_capture_blade_count(const tsk_capture* cap) { return cap ? cap->blade_count : 0; }

int tsk_capture_knot_total(const tsk_capture* cap) {
    return cap && cap->blade_count > 0 ? cap->knot_start[cap->blade_count] : 0;
}

void tsk_capture_band(const tsk_capture* cap, float* near_m, float* far_m) {
    if (near_m) *near_m = cap ? cap->near_m : 0.0f;
    if (far_m) *far_m = cap ? cap->far_m : 0.0f;
}

tsk_intrinsics tsk_capture_intrinsics(const tsk_capture* cap) {
    tsk_intrinsics z = {0, 0, 0, 0};
    return cap ? cap->K : z;
}

const char* tsk_capture_status_message(const tsk_capture* cap) {
    return cap ? cap->message : "no capture";
}

tsk_status tsk_capture_get_blades(const tsk_capture* cap, int32_t* knot_counts, uint32_t* flags,
                                  size_t count) {
    if (cap == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "capture", "is NULL");
    if (count != (size_t)cap->blade_count)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "count", "must equal the blade count %d, got %zu",
                             cap->blade_count, count);
    for (int b = 0; b < cap->blade_count; ++b) {
        if (knot_counts) knot_counts[b] = cap->knot_start[b + 1] - cap->knot_start[b];
        if (flags) flags[b] = cap->flags[b];
    }
    return TSK_OK;
}

static void copy_knots(const tsk_capture* cap, int k0, int n, float* xyz, float* w, float* uv) {
    if (n <= 0) return; /* no knots: the buffers may never have been allocated (NULL) */
    if (xyz) memcpy(xyz, cap->xyz + 3 * (size_t)k0, 3 * (size_t)n * sizeof(float));
    if (w) memcpy(w, cap->width_m + (size_t)k0, (size_t)n * sizeof(float));
    if (uv) memcpy(uv, cap->uv + 2 * (size_t)k0, 2 * (size_t)n * sizeof(float));
}

tsk_status tsk_capture_get_knots(const tsk_capture* cap, float* camera_xyz, float* width_m,
                                 float* pixel_uv, size_t total) {
    if (cap == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "capture", "is NULL");
    const int t = tsk_capture_knot_total(cap);
    if (total != (size_t)t)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "total", "must equal the knot total %d, got %zu", t,
                             total);
    copy_knots(cap, 0, t, camera_xyz, width_m, pixel_uv);
    return TSK_OK;
}

tsk_status tsk_capture_get_blade(const tsk_capture* cap, int blade, float* camera_xyz,
                                 float* width_m, float* pixel_uv, size_t knot_count) {
    if (cap == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "capture", "is NULL");
    if (blade < 0 || blade >= cap->blade_count)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "blade", "%d is not in 0..%d", blade,
                             cap->blade_count - 1);
    const int k0 = cap->knot_start[blade], n = cap->knot_start[blade + 1] - k0;
    if (knot_count != (size_t)n)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "knot_count",
                             "must equal blade %d's knot count %d, got %zu", blade, n, knot_count);
    copy_knots(cap, k0, n, camera_xyz, width_m, pixel_uv);
    return TSK_OK;
}

tsk_status tsk_capture_get_image(const tsk_capture* cap, tsk_capture_image which, uint8_t* out,
                                 size_t count) {
    if (cap == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "capture", "is NULL");
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    if (cap->width == 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "capture", "no frame was processed successfully");
    const size_t npix = (size_t)cap->width * (size_t)cap->height;
    if (count != npix)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "count", "must be width*height = %zu, got %zu", npix,
                             count);
    const int w = cap->width, h = cap->height;
    tsk_status s = TSK_OK;
    switch (which) {
        case TSK_IMAGE_DEPTH: {
            const float span = cap->far_m - cap->near_m;
            const float lo = cap->near_m - 0.5f * span, hi = cap->far_m + 0.5f * span;
            for (size_t i = 0; i < npix; ++i) {
                const float d = cap->depth[i];
                if (!(d > 0.0f)) {
                    out[i] = 0;
                    continue;
                }
                float t = (d - lo) / (hi - lo);
                t = t < 0.0f ? 0.0f : (t > 1.0f ? 1.0f : t);
                out[i] = (uint8_t)(255.0f - 254.0f * t + 0.5f);
            }
            return TSK_OK;
        }
        case TSK_IMAGE_MASK:
            memcpy(out, cap->mask, npix);
            return TSK_OK;
        case TSK_IMAGE_LABELS:
            memset(out, 0, npix);
            for (int b = 0; b < cap->blade_count && s == TSK_OK; ++b) {
                const int p0 = cap->poly_start[b], n = cap->poly_start[b + 1] - p0;
                s = tsk_cvb_fill_poly(out, w, h, cap->poly_xy + 2 * (size_t)p0, n,
                                      (uint8_t)(b % 254 + 1));
            }
            for (size_t i = 0; i < npix; ++i) {
                if (!cap->mask[i]) out[i] = 0;
                else if (out[i] == 0) out[i] = 255;
            }
            return s;
        case TSK_IMAGE_OVERLAY:
            for (size_t i = 0; i < npix; ++i) out[i] = cap->mask[i] ? 64 : 0;
            for (int c = 0; c < cap->contour_count; ++c) {
                const int c0 = cap->contour_start[c], n = cap->contour_start[c + 1] - c0;
                for (int k = 0; k < n; ++k) {
                    const int x = (int)cap->contour_xy[2 * (size_t)(c0 + k)];
                    const int y = (int)cap->contour_xy[2 * (size_t)(c0 + k) + 1];
                    out[(size_t)y * (size_t)w + (size_t)x] = 128;
                }
            }
            for (int b = 0; b < cap->blade_count && s == TSK_OK; ++b) {
                const int k0 = cap->knot_start[b], n = cap->knot_start[b + 1] - k0;
                s = tsk_cvb_polyline(out, w, h, cap->uv + 2 * (size_t)k0, n, 255);
            }
            return s;
    }
    return tsk_error_arg(TSK_ERR_ARGUMENT, "which", "unknown image %d", (int)which);
}
