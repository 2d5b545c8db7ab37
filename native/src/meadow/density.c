/* The density map (seed 000 §4.5, Fig. 8): the fraction of blades_per_tile a tile gets,
 * from fractal Perlin noise with a threshold, or from an image the artist paints. */
#include "meadow_internal.h"

#include <math.h>

static double clamp01(double v) { return v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v); }

tsk_status tsk_meadow_check_density(const tsk_meadow_def* def) {
    switch (def->density) {
        case TSK_DENSITY_UNIFORM:
            return TSK_OK;
        case TSK_DENSITY_NOISE:
            if (!isfinite(def->noise_scale) || !(def->noise_scale > 0.0f))
                return tsk_error_arg(TSK_ERR_ARGUMENT, "noise_scale",
                                     "must be finite and > 0 m, got %g", (double)def->noise_scale);
            if (def->noise_octaves < 1 || def->noise_octaves > 12)
                return tsk_error_arg(TSK_ERR_ARGUMENT, "noise_octaves", "must be 1..12, got %d",
                                     (int)def->noise_octaves);
            if (!isfinite(def->noise_persistence) || def->noise_persistence < 0.0f ||
                def->noise_persistence > 1.0f)
                return tsk_error_arg(TSK_ERR_ARGUMENT, "noise_persistence",
                                     "must be in [0, 1], got %g", (double)def->noise_persistence);
            if (!isfinite(def->noise_contrast) || def->noise_contrast < 0.0f ||
                def->noise_contrast > 100.0f)
                return tsk_error_arg(TSK_ERR_ARGUMENT, "noise_contrast",
                                     "must be in [0, 100], got %g", (double)def->noise_contrast);
            if (!isfinite(def->noise_threshold) || def->noise_threshold < 0.0f ||
                def->noise_threshold >= 1.0f)
                return tsk_error_arg(TSK_ERR_ARGUMENT, "noise_threshold",
                                     "must be in [0, 1), got %g", (double)def->noise_threshold);
            return TSK_OK;
        case TSK_DENSITY_IMAGE: {
            if (def->image_width < 1 || def->image_height < 1)
                return tsk_error_arg(TSK_ERR_ARGUMENT, "image",
                                     "size must be at least 1 x 1, got %d x %d",
                                     (int)def->image_width, (int)def->image_height);
            if (def->image_width > TSK_MEADOW_MAX_IMAGE_SIDE ||
                def->image_height > TSK_MEADOW_MAX_IMAGE_SIDE)
                return tsk_error_arg(
                    TSK_ERR_LIMIT, "image", "%d x %d exceeds the limit of %d pixels a side",
                    (int)def->image_width, (int)def->image_height, TSK_MEADOW_MAX_IMAGE_SIDE);
            if (def->image == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "image", "is NULL");
            const size_t n = (size_t)def->image_width * (size_t)def->image_height;
            for (size_t i = 0; i < n; ++i)
                if (!isfinite(def->image[i]))
                    return tsk_error_arg(
                        TSK_ERR_ARGUMENT, "image", "pixel %zu (x %zu, y %zu) is not finite", i,
                        i % (size_t)def->image_width, i / (size_t)def->image_width);
            return TSK_OK;
        }
    }
    return tsk_error_arg(TSK_ERR_ARGUMENT, "density", "unknown density kind %d", (int)def->density);
}

/* Bilinear sample with clamp-to-edge at pixel coordinates (px, py); pixel centres at
 * integer + 0 after the half-pixel shift done by the caller. */
static double sample_bilinear(const float* img, int32_t w, int32_t h, double px, double py) {
    if (px < 0.0) px = 0.0;
    if (py < 0.0) py = 0.0;
    if (px > (double)(w - 1)) px = (double)(w - 1);
    if (py > (double)(h - 1)) py = (double)(h - 1);
    int32_t x0 = (int32_t)floor(px), y0 = (int32_t)floor(py);
    int32_t x1 = x0 + 1 < w ? x0 + 1 : x0, y1 = y0 + 1 < h ? y0 + 1 : y0;
    const double fx = px - x0, fy = py - y0;
    const double a = img[(size_t)y0 * w + x0], b = img[(size_t)y0 * w + x1];
    const double c = img[(size_t)y1 * w + x0], d = img[(size_t)y1 * w + x1];
    const double top = a + (b - a) * fx, bottom = c + (d - c) * fx;
    return top + (bottom - top) * fy;
}

double tsk_meadow_density_at(const tsk_meadow_def* def, const tsk_noise* noise, double cx,
                             double cy) {
    switch (def->density) {
        case TSK_DENSITY_NOISE: {
            const double n = tsk_noise_fbm2(noise, (cx - def->origin[0]) / def->noise_scale,
                                            (cy - def->origin[1]) / def->noise_scale,
                                            def->noise_octaves, def->noise_persistence);
            const double v = clamp01(0.5 * (1.0 + (double)def->noise_contrast * n));
            const double t = def->noise_threshold;
            return clamp01((v - t) / (1.0 - t));
        }
        case TSK_DENSITY_IMAGE: {
            const double px = (cx - def->origin[0]) / def->size[0] * def->image_width - 0.5;
            const double py = (cy - def->origin[1]) / def->size[1] * def->image_height - 0.5;
            return clamp01(
                sample_bilinear(def->image, def->image_width, def->image_height, px, py));
        }
        case TSK_DENSITY_UNIFORM:
        default:
            return 1.0;
    }
}
