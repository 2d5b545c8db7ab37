/* Tussock meadow: blade models, the grass patch, the tile grid with per-tile patch offsets
 * and blade counts from a Perlin-noise or painted density map, instance data for Blender's
 * geometry nodes, and blade expansion (skeleton knots -> ribbon mesh).
 * Specification: seed 000 (Fan & Sheng) §3, §4.5, Fig. 2e, Fig. 7-8. */
#ifndef TUSSOCK_MEADOW_H
#define TUSSOCK_MEADOW_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- limits ------------------------------------------------------------------------------ */

/// Most knots a blade model may have (seed 000 §4.4 refines skeletons to 64, 32 or 16 knots).
#define TSK_BLADE_MAX_KNOTS 64
/// Most blades in a patch (the seed uses 16,384). More returns TSK_ERR_LIMIT.
#define TSK_PATCH_MAX_BLADES (1 << 20)
/// Most models a patch may draw from.
#define TSK_PATCH_MAX_MODELS 256
/// Most blades a meadow may hold: tiles x blades_per_tile above this returns TSK_ERR_LIMIT.
#define TSK_MEADOW_MAX_BLADES 200000000LL
/// Most tiles in a meadow grid (per-tile arrays are 4-byte each: 64 MB per array at most).
#define TSK_MEADOW_MAX_TILES (1 << 24)
/// Most blades in one tile.
#define TSK_MEADOW_MAX_BLADES_PER_TILE 65536
/// Largest density image side in pixels.
#define TSK_MEADOW_MAX_IMAGE_SIDE 16384

/* ---- blade models ------------------------------------------------------------------------ */

/// A blade at rest: its skeleton knots from root to tip and the full blade width at each.
/// Coordinates in metres, root at the origin, +z up. A plain value type (no allocation).
typedef struct tsk_blade_model {
    int32_t knot_count; ///< 2..TSK_BLADE_MAX_KNOTS
    float xyz[3 * TSK_BLADE_MAX_KNOTS]; ///< knot k at xyz[3k..3k+2], metres
    float width[TSK_BLADE_MAX_KNOTS]; ///< full width at knot k, metres, >= 0
} tsk_blade_model;

/// Sets `model` from `knot_count` knots (xyz, 3 floats each, metres, root first) and widths
/// (metres). The blade is translated so that its root lies at the origin. Errors: NULL
/// pointers, knot_count outside 2..64 (TSK_ERR_LIMIT above 64), non-finite values, negative
/// widths, a blade of zero length.
tsk_status tsk_blade_model_set(tsk_blade_model* model, const float* xyz, const float* width,
                               int32_t knot_count);

/// Default blade height (m) and base width (m) of tsk_blade_model_default.
#define TSK_DEFAULT_BLADE_HEIGHT 0.30f
#define TSK_DEFAULT_BLADE_WIDTH 0.008f

/// The built-in blade used when the artist has none: with t = k/(n-1) for knot k of n,
///   x(t) = 0.25 H t^2,  y(t) = 0,  z(t) = H t,  width(t) = W (1 - t^3),
/// H = TSK_DEFAULT_BLADE_HEIGHT, W = TSK_DEFAULT_BLADE_WIDTH: a blade rising straight from
/// the root, leaning gently towards +x (tip 7.5 cm off the vertical), nearly constant width
/// low down and tapering to a point at the tip. knot_count 2..64.
tsk_status tsk_blade_model_default(tsk_blade_model* model, int32_t knot_count);

/// Sets `model_count` models from flat arrays, as Blender hands them over: knot_counts[m]
/// knots for model m, their xyz (3 floats each) and widths concatenated model after model;
/// `total_knots` is the length of `width` (and a third of that of `xyz`) and must equal the
/// sum of knot_counts. Each model is checked as tsk_blade_model_set does.
tsk_status tsk_blade_models_set(tsk_blade_model* models, int32_t model_count, const float* xyz,
                                const float* width, const int32_t* knot_counts, size_t total_knots);

/// Resamples `in` to `knot_count` knots evenly spaced in arc length (positions and widths
/// linearly interpolated). Root and tip are kept exactly; the same knot count copies `in`.
tsk_status tsk_blade_model_resample(const tsk_blade_model* in, int32_t knot_count,
                                    tsk_blade_model* out);

/// Unit side vector of a model at rest: horizontal, perpendicular to the blade's lean (the
/// root-to-tip direction projected on the ground); +y for a blade that does not lean.
/// Expansion puts a knot's two vertices along this side (see tsk_blade_expand).
void tsk_blade_model_side(const tsk_blade_model* model, float side[3]);

/* ---- the patch --------------------------------------------------------------------------- */

/// How a patch is made (seed 000 §4.5: "a list of grass blades with some random scaling ...
/// randomly located in a square which has the same size of grass tile").
typedef struct tsk_patch_def {
    int32_t blade_count; ///< blades in the patch, 1..TSK_PATCH_MAX_BLADES (default 16384)
    float scale_min; ///< smallest random scale of a blade, > 0 (default 0.8)
    float scale_max; ///< largest random scale, >= scale_min (default 1.2)
    uint64_t seed; ///< same seed -> same patch, bit for bit (default 1)
    int32_t knot_count; ///< knots per blade, 0 = the most of any model, or 16 for the
        ///< default blade (default 0)
    const tsk_blade_model* models; ///< models to draw from; NULL/0 -> the default blade
    int32_t model_count; ///< 0..TSK_PATCH_MAX_MODELS
    const float* model_weights; ///< relative chance of each model (>= 0), NULL = equal
} tsk_patch_def;

/// Defaults: 16384 blades, scale 0.8..1.2, seed 1, default blade model.
tsk_patch_def tsk_default_patch_def(void);

/// A patch: blade_count blades, each a model index, a position in the unit tile square
/// [0,1)^2, a turn about +z in [0, 2pi) radians and a scale; all stored as arrays.
typedef struct tsk_patch tsk_patch;

/// Builds a patch. Every random choice of blade b is tsk_rand01(seed, TSK_PATCH_STREAM, b, k)
/// (k = 0 model, 1 scale, 2 turn, 3 x, 4 y), so it is independent of threads and order.
/// Models with another knot count than def->knot_count are resampled by arc length.
tsk_status tsk_patch_create(const tsk_patch_def* def, tsk_patch** out);
/// Frees a patch (NULL is ignored).
void tsk_patch_destroy(tsk_patch* patch);

/// Stream index keying the patch's random numbers (ASCII "patch").
#define TSK_PATCH_STREAM 0x7061746368ull

int32_t tsk_patch_blade_count(const tsk_patch* patch);
int32_t tsk_patch_knot_count(const tsk_patch* patch);
int32_t tsk_patch_model_count(const tsk_patch* patch);

/// Copies the patch's per-blade data into caller buffers of blade_count elements (xy: 2 per
/// blade, unit square). Any pointer may be NULL to skip that array.
tsk_status tsk_patch_get_blades(const tsk_patch* patch, float* xy, float* turn, float* scale,
                                int32_t* model);

/// The (resampled) rest model `index` the patch uses: knot_count knots and widths.
tsk_status tsk_patch_get_model(const tsk_patch* patch, int32_t index, tsk_blade_model* out);

/* ---- blade expansion (seed 000 Fig. 7-8) -------------------------------------------------- */

/// Vertices and triangles of one expanded blade of n knots: 2n and 2(n-1).
size_t tsk_blade_vertex_count(int32_t knot_count);
size_t tsk_blade_triangle_count(int32_t knot_count);

/// Expands one blade skeleton into a ribbon (seed 000 Fig. 7: each knot becomes two
/// vertices). Knot k (xyz at knots[3k]) gives vertex 2k at knot - side_k*w_k/2 and vertex
/// 2k+1 at knot + side_k*w_k/2, where side_k is `side` made perpendicular to the blade's
/// tangent at k and normalised, so the two vertices are exactly w_k apart. Normals are
/// normalize(side_k x tangent_k). UV: u = 0 (left) / 1 (right), v = arc length from the
/// root / total length (0 at the root, 1 at the tip). Outputs: positions and normals
/// 3 floats per vertex, uvs 2 per vertex; any may be NULL. `widths` are full widths (m).
tsk_status tsk_blade_expand(const float* knots, const float* widths, int32_t knot_count,
                            const float side[3], float* positions, float* normals, float* uvs);

/// tsk_blade_expand for `blade_count` blades of `knot_count` knots each, blade after blade:
/// knots 3K floats, widths K floats, sides 3 floats per blade; outputs 2K vertices per blade
/// (positions, normals 3 floats, uvs 2 floats; any may be NULL). Deterministic in parallel.
tsk_status tsk_blades_expand(const float* knots, const float* widths, const float* sides,
                             size_t blade_count, int32_t knot_count, float* positions,
                             float* normals, float* uvs);

/// Triangle indices of one expanded blade: for each segment k, (2k, 2k+1, 2k+3) and
/// (2k, 2k+3, 2k+2), plus `vertex_base`; counter-clockwise seen from the normal side.
/// `tris` holds 3 * tsk_blade_triangle_count(knot_count) int32.
tsk_status tsk_blade_indices(int32_t knot_count, int32_t vertex_base, int32_t* tris);

/// tsk_blade_indices for `blade_count` blades laid out one after another (blade b's vertices
/// start at 2*K*b), into 6(K-1) int32 per blade. blade_count * 2K must fit in int32.
tsk_status tsk_blades_indices(int32_t knot_count, size_t blade_count, int32_t* tris);

/// Vertex and triangle counts of tsk_patch_expand.
tsk_status tsk_patch_mesh_counts(const tsk_patch* patch, size_t* vertex_count,
                                 size_t* triangle_count);

/// Expands every blade of the patch into one mesh in tile-local coordinates: blade b is
/// scaled by its scale, turned by its turn about +z and stood at (x*tile_size,
/// y*tile_size, 0). Blade b owns vertices [b*2K, (b+1)*2K) and triangles
/// [b*2(K-1), (b+1)*2(K-1)) (K = knot count), so a run of blades is a run of the mesh.
/// Buffers (caller-owned, sized from tsk_patch_mesh_counts): positions, normals 3 floats per
/// vertex; uvs 2 floats per vertex; tris 3 int32 per triangle; blade_index 1 int32 per
/// vertex. Any may be NULL. Deterministic for any thread count.
tsk_status tsk_patch_expand(const tsk_patch* patch, float tile_size, float* positions,
                            float* normals, float* uvs, int32_t* tris, int32_t* blade_index);

/* ---- Perlin noise ------------------------------------------------------------------------ */

/// Improved Perlin noise in 2D (Perlin 2002, "Improving noise": quintic fade
/// 6t^5 - 15t^4 + 10t^3, a 256-entry permutation, gradients from a hash of the lattice
/// point) with the permutation derived from a seed. Values lie in [-1, 1] and are 0 at
/// integer lattice points.
typedef struct tsk_noise {
    uint8_t perm[512]; ///< permutation of 0..255, repeated once
} tsk_noise;

/// Permutation by Fisher-Yates: start from 0..255; for i = 255 down to 1, swap entry i with
/// entry j = tsk_hash4(seed, TSK_NOISE_STREAM, i, 0) % (i + 1).
void tsk_noise_init(tsk_noise* noise, uint64_t seed);
#define TSK_NOISE_STREAM 0x6e6f697365ull /* ASCII "noise" */

/// The 8 gradients: g_h = sqrt(2) (cos(h pi/4), sin(h pi/4)) for h = perm[perm[X]+Y] & 7
/// (X, Y the lattice point mod 256). Length sqrt(2) makes the value range [-1, 1].
double tsk_noise_perlin2(const tsk_noise* noise, double x, double y);

/// Fractal sum: sum_o p^o perlin(2^o x, 2^o y) / sum_o p^o over o = 0..octaves-1; in [-1, 1].
double tsk_noise_fbm2(const tsk_noise* noise, double x, double y, int32_t octaves,
                      double persistence);

/* ---- the meadow: tiles, offsets, density ---------------------------------------------- */

/// Where a tile's blade count comes from.
typedef enum tsk_density_kind {
    TSK_DENSITY_UNIFORM = 0, ///< every tile has blades_per_tile blades
    TSK_DENSITY_NOISE = 1, ///< Perlin density map (seed 000 §4.5, Fig. 8)
    TSK_DENSITY_IMAGE = 2, ///< a caller's float32 image in [0, 1] over the meadow area
} tsk_density_kind;

/// How a meadow is laid out. The rectangle [origin.x, origin.x + size.x] x [origin.y,
/// origin.y + size.y] at height origin.z is covered by tiles_x = floor(size.x / tile_size)
/// by tiles_y = floor(size.y / tile_size) square tiles; a strip narrower than one tile at the
/// +x and +y edges stays empty. Tile (i, j) has index j*tiles_x + i and its corner at
/// origin + (i, j, 0) * tile_size.
typedef struct tsk_meadow_def {
    float origin[3]; ///< metres (default 0, 0, 0)
    float size[2]; ///< metres, > 0 (default 10 x 10)
    float tile_size; ///< metres, > 0 and <= both sizes (default 0.5)
    int32_t blades_per_tile; ///< blades where density is 1, 1..65536 (default 64)
    int32_t patch_blades; ///< blade count of the patch tiles draw from (default 16384)
    int32_t chunk_blades; ///< offsets and counts are multiples of this (default 1);
        ///< must divide patch_blades; see tsk_meadow_chunk_instances
    uint64_t seed; ///< keys tile offsets and the noise permutation (default 1)
    tsk_density_kind density; ///< default TSK_DENSITY_NOISE
    float noise_scale; ///< metres per noise lattice cell of octave 0, > 0 (default 8)
    int32_t noise_octaves; ///< 1..12 (default 3)
    float noise_persistence; ///< amplitude ratio of octave o+1 to o, [0, 1] (default 0.5)
    float noise_contrast; ///< gain on the noise before the threshold, 0..100 (default 2.5:
        ///< fractal Perlin noise mostly stays within +-0.4)
    float noise_threshold; ///< [0, 1): noise values below it leave bare ground (default 0.15)
    const float* image; ///< density image, row-major, row 0 at origin.y (Blender's
        ///< pixel order), read only during tsk_meadow_create
    int32_t image_width; ///< pixels, 1..TSK_MEADOW_MAX_IMAGE_SIDE
    int32_t image_height; ///< pixels, 1..TSK_MEADOW_MAX_IMAGE_SIDE
} tsk_meadow_def;

tsk_meadow_def tsk_default_meadow_def(void);

/// Stream index keying the tile offsets (ASCII "tile").
#define TSK_TILE_STREAM 0x74696c65ull

/// Density d of the tile with centre (cx, cy) in metres:
///  - UNIFORM: d = 1;
///  - NOISE: n = tsk_noise_fbm2(noise, (cx - origin.x) / noise_scale, (cy - origin.y) /
///    noise_scale, octaves, persistence), v = clamp((1 + contrast * n) / 2, 0, 1),
///    d = clamp((v - threshold) / (1 - threshold), 0, 1);
///  - IMAGE: bilinear sample of the image at pixel coordinates
///    ((cx - origin.x) / size.x * width - 1/2, (cy - origin.y) / size.y * height - 1/2),
///    edges clamped, then clamped to [0, 1].
/// Count = C * floor(blades_per_tile * d / C + 1/2) with C = chunk_blades (round to nearest
/// multiple of C, capped at blades_per_tile rounded down to a multiple of C).
/// Offset = C * (tsk_hash4(seed, TSK_TILE_STREAM, i, j) % (patch_blades / C)): tile (i, j)
/// uses patch blades offset, offset+1, ..., offset+count-1, wrapping at the patch end
/// (seed 000 §4.5: "a subset of continuous blades ... offset calculated by tile's position").
typedef struct tsk_meadow tsk_meadow;

/// Lays out the meadow and computes every tile's density, count and offset. Errors name the
/// argument: TSK_ERR_ARGUMENT for zero/negative/non-finite sizes, a tile larger than the
/// area, 0 blades per tile, a bad image; TSK_ERR_LIMIT when tiles exceed
/// TSK_MEADOW_MAX_TILES or tiles x blades_per_tile exceeds TSK_MEADOW_MAX_BLADES.
tsk_status tsk_meadow_create(const tsk_meadow_def* def, tsk_meadow** out);
void tsk_meadow_destroy(tsk_meadow* meadow);

/// Grid summary.
typedef struct tsk_meadow_info {
    int32_t tiles_x, tiles_y;
    int64_t tile_count;
    int64_t blade_count; ///< sum of all tile counts
    int64_t nonempty_tiles; ///< tiles with count > 0
    int64_t chunk_instances; ///< blade_count / chunk_blades
    int32_t patch_blades, chunk_blades;
    float tile_size;
    float origin[3];
} tsk_meadow_info;

tsk_status tsk_meadow_get_info(const tsk_meadow* meadow, tsk_meadow_info* info);

/// Per-tile data into caller arrays of tile_count elements; any may be NULL.
tsk_status tsk_meadow_get_tiles(const tsk_meadow* meadow, int32_t* counts, int32_t* offsets,
                                float* density);

/// Instance data of every tile for geometry nodes: origins (3 floats per tile, the tile's
/// corner in metres), offsets and counts (int32 per tile). Any may be NULL.
tsk_status tsk_meadow_instances(const tsk_meadow* meadow, float* origins, int32_t* offsets,
                                int32_t* counts);

/// One instance per chunk of chunk_blades patch blades that some tile uses, tile by tile in
/// index order: origins (3 floats, the tile's corner), chunk (int32: which chunk of the
/// patch, (offset / C + k) mod (patch_blades / C)) and tile (int32: the tile's index, so that
/// the instances of simulated tiles can be hidden). There are info.chunk_instances of them;
/// any pointer may be NULL. With the patch mesh split into patch_blades / C chunks (chunk c
/// is blades [c*C, (c+1)*C), i.e. a run of vertices), instancing chunk `chunk[n]` at
/// `origins[n]` reproduces the meadow exactly.
tsk_status tsk_meadow_chunk_instances(const tsk_meadow* meadow, float* origins, int32_t* chunk,
                                      int32_t* tile);

/// Number of blades in tiles [tile_begin, tile_end).
tsk_status tsk_meadow_blade_count(const tsk_meadow* meadow, int64_t tile_begin, int64_t tile_end,
                                  int64_t* count);

/// Writes every blade of tiles [tile_begin, tile_end) explicitly, tile by tile, blade by
/// blade in patch-run order: xyz (3 floats, root position in metres), turn (radians about
/// +z), scale, patch_index (int32, the patch blade it is). Buffers hold
/// tsk_meadow_blade_count elements; any may be NULL. `patch` must have patch_blades blades.
tsk_status tsk_meadow_realise(const tsk_meadow* meadow, const tsk_patch* patch, int64_t tile_begin,
                              int64_t tile_end, float* xyz, float* turn, float* scale,
                              int32_t* patch_index);

/// Rest skeletons of every blade of tiles [tile_begin, tile_end) in world space (for the
/// simulation): knots (3K floats per blade, metres), widths (K floats per blade, scaled) and
/// sides (3 floats per blade, the turned unit side vector). Any may be NULL.
tsk_status tsk_meadow_realise_knots(const tsk_meadow* meadow, const tsk_patch* patch,
                                    int64_t tile_begin, int64_t tile_end, float* knots,
                                    float* widths, float* sides);

#ifdef __cplusplus
}
#endif
#endif
