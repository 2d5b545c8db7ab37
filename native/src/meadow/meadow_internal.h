/* Private layout of the meadow module's handles, shared by its files (patch.c, tiles.c,
 * instances.c, expand.c). Not part of the public API. */
#ifndef TSK_MEADOW_INTERNAL_H
#define TSK_MEADOW_INTERNAL_H

#include "tussock/meadow.h"

/* The patch in structure-of-arrays form: one array per per-blade quantity. */
struct tsk_patch {
    int32_t blade_count;
    int32_t knot_count;
    int32_t model_count;
    float* x; /* [blade_count] unit square */
    float* y; /* [blade_count] */
    float* turn; /* [blade_count] radians in [0, 2pi) */
    float* scale; /* [blade_count] */
    int32_t* model; /* [blade_count] */
    tsk_blade_model* models; /* [model_count], all with knot_count knots */
    float* model_side; /* [3 * model_count] rest side vector of each model */
};

/* The meadow grid with every tile's count, offset and density (arrays of tile_count). */
struct tsk_meadow {
    tsk_meadow_def def; /* image pointer cleared: the image is not kept */
    int32_t tiles_x, tiles_y;
    int64_t tile_count;
    int32_t* counts;
    int32_t* offsets;
    float* density;
    int64_t* first_blade; /* [tile_count + 1] prefix sums of counts */
    int64_t nonempty;
};

/* Rotates the model's knots by (cos, sin) about +z, scales them by s and adds the root. */
void tsk_meadow_place_knots(const tsk_blade_model* model, float c, float s, float scale,
                            const float root[3], float* knots);

/* Density in [0, 1] at (cx, cy) metres for the def's density source (density.c). */
double tsk_meadow_density_at(const tsk_meadow_def* def, const tsk_noise* noise, double cx,
                             double cy);

/* Checks the density part of a meadow def (noise parameters or the image). */
tsk_status tsk_meadow_check_density(const tsk_meadow_def* def);

#endif
