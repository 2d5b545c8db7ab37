/* Synthetic depth scenes with analytic grass blades, for the capture tests and benchmark.
 * A blade is a circular arc of length L from its root point, starting at angle theta from
 * the image's up direction and bending with curvature kappa (1/px); its full width in
 * pixels is w(s) at arc length s, its depth z(s) in metres. The depth map holds, for each
 * pixel centre, the depth of the nearest blade covering it, else the background. Ground
 * truth (centreline, width, 3-D point) comes from the same closed forms, not from the
 * pipeline. */
#ifndef TSK_CAPTURE_SCENE_H
#define TSK_CAPTURE_SCENE_H

#include <math.h>
#include <stdint.h>

#include "tussock/capture.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef struct scene_blade {
    double bx, by; /* root, pixels */
    double theta; /* initial direction, radians from up (-y), positive to the right */
    double kappa; /* curvature, 1/px (nonzero) */
    double length; /* pixels */
    double w0; /* width at the root, pixels */
    double z0, dz; /* depth at the root (m) and its change per pixel of arc (m/px) */
} scene_blade;

static inline double scene_width(const scene_blade* b, double s) {
    const double L = b->length;
    if (s < 0.0 || s > L) return 0.0;
    double taper = (L - s) / (0.12 * L);
    taper = taper >= 1.0 ? 1.0 : sqrt(taper);
    return b->w0 * (1.0 - 0.4 * s / L) * taper;
}

static inline double scene_depth(const scene_blade* b, double s) { return b->z0 + b->dz * s; }

static inline void scene_point(const scene_blade* b, double s, double* x, double* y) {
    const double phi = b->theta + b->kappa * s;
    *x = b->bx + (cos(b->theta) - cos(phi)) / b->kappa;
    *y = b->by - (sin(phi) - sin(b->theta)) / b->kappa;
}

/* Arc length of the point of the centreline nearest to (px, py) (clamped to [0, L]) and
 * its distance. */
static inline double scene_nearest(const scene_blade* b, double px, double py, double* dist) {
    const double R = 1.0 / b->kappa;
    const double cx = b->bx + cos(b->theta) * R, cy = b->by + sin(b->theta) * R;
    const double vx = px - cx, vy = py - cy;
    const double alpha = atan2(vy, vx);
    double phi = b->kappa > 0 ? alpha - M_PI : alpha;
    const double mid = b->theta + b->kappa * 0.5 * b->length;
    double d = phi - mid;
    d = d - 2.0 * M_PI * floor((d + M_PI) / (2.0 * M_PI));
    double s = 0.5 * b->length + d / b->kappa;
    if (s < 0.0) s = 0.0;
    if (s > b->length) s = b->length;
    double x, y;
    scene_point(b, s, &x, &y);
    *dist = hypot(px - x, py - y);
    return s;
}

/* Arc length of the blade at pixel (px, py), or -1 if the pixel is outside the blade. */
static inline double scene_cover(const scene_blade* b, double px, double py) {
    const double R = 1.0 / b->kappa;
    const double cx = b->bx + cos(b->theta) * R, cy = b->by + sin(b->theta) * R;
    const double alpha = atan2(py - cy, px - cx);
    double phi = b->kappa > 0 ? alpha - M_PI : alpha;
    const double mid = b->theta + b->kappa * 0.5 * b->length;
    double d = phi - mid;
    d = d - 2.0 * M_PI * floor((d + M_PI) / (2.0 * M_PI));
    const double s = 0.5 * b->length + d / b->kappa;
    if (s < 0.0 || s > b->length) return -1.0;
    const double off = fabs(hypot(px - cx, py - cy) - fabs(R));
    return off <= 0.5 * scene_width(b, s) ? s : -1.0;
}

/* The standard test cluster: 5 blades fanning out of one base, touching near it. */
static inline int scene_fan(scene_blade* out, double base_x, double base_y) {
    static const double theta[5] = {-0.55, -0.27, 0.02, 0.29, 0.56};
    static const double kappa[5] = {-0.0012, -0.0006, 0.0003, 0.0007, 0.0013};
    static const double len[5] = {250, 310, 350, 300, 240};
    static const double z0[5] = {0.80, 0.79, 0.81, 0.80, 0.82};
    for (int i = 0; i < 5; ++i) {
        scene_blade b = {
            base_x + 3.0 * (i - 2), base_y, theta[i], kappa[i], len[i], 16.0, z0[i], -0.00025};
        out[i] = b;
    }
    return 5;
}

/* A tuft whose 4 blades share their first ~30 % and cross just above the base: each root
 * lies on the other side of the base from its lean, and neighbours alternate 1 cm in depth,
 * so the crossing blades hide each other in turn. */
static inline int scene_crossing_fan(scene_blade* out, double base_x, double base_y) {
    static const double len[4] = {270, 300, 310, 260};
    static const double kappa[4] = {-0.0009, -0.0004, 0.0005, 0.0010};
    for (int i = 0; i < 4; ++i) {
        const double u = i - 1.5;
        scene_blade b = {base_x - 6.0 * u,      base_y, 0.22 * u, kappa[i], len[i], 14.0,
                         0.75 + 0.01 * (i % 2), -0.0002};
        out[i] = b;
    }
    return 4;
}

/* Renders blades over a background depth (metres, 0 = no data). */
static inline void scene_render(const scene_blade* blades, int count, int w, int h,
                                float background, float* depth) {
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double best = background > 0.0f ? background : 1e30;
            int hit = 0;
            for (int i = 0; i < count; ++i) {
                const double s = scene_cover(&blades[i], x, y);
                if (s < 0.0) continue;
                const double z = scene_depth(&blades[i], s);
                if (z < best) {
                    best = z;
                    hit = 1;
                }
            }
            depth[(size_t)y * (size_t)w + (size_t)x] = hit ? (float)best : background;
        }
}

/* Sensor-like noise: Gaussian with sigma = sigma1 * z^2 (sigma1 at 1 m), and dropout
 * (pixel -> 0) with probability `dropout`; counter-based random numbers keyed by seed. */
static inline void scene_noise(float* depth, int w, int h, double sigma1, double dropout,
                               uint64_t seed) {
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float* d = &depth[(size_t)y * (size_t)w + (size_t)x];
            if (*d <= 0.0f) continue;
            if (tsk_rand01(seed, (uint64_t)x, (uint64_t)y, 2) < dropout) {
                *d = 0.0f;
                continue;
            }
            const double u1 = 1.0 - tsk_rand01(seed, (uint64_t)x, (uint64_t)y, 0);
            const double u2 = tsk_rand01(seed, (uint64_t)x, (uint64_t)y, 1);
            const double g = sqrt(-2.0 * log(u1)) * cos(2.0 * M_PI * u2);
            *d = (float)(*d + sigma1 * (double)(*d) * (double)(*d) * g);
        }
}

#endif
