/* Tussock picture: animating vegetation in still pictures (seed 004, §III-B and §III-E).
 * A picture is split into vegetation layers (a caller mask or a GrabCut proposal), the
 * background behind the layers is inpainted, each layer gets a soft matte, and every frame
 * a warp grid displaced by the vegetation continuum (eq. 5-7) inverse-warps each layer
 * (eq. 8). The warp is delivered as a warped RGBA layer and as a UV pass that Blender's
 * compositor Map UV node samples to reproduce it.
 *
 * Conventions used throughout this header:
 *  - Images are float32 RGBA, 4 interleaved values per pixel, rows top-first (row 0 is the
 *    top of the picture) unless a `bottom_up` flag says otherwise. Layers, background and
 *    warped frames are PREMULTIPLIED (rgb already multiplied by alpha), like Blender's
 *    compositor; the loaded picture itself is straight (unpremultiplied).
 *  - Continuous pixel coordinates: x right, y down, pixel (i, j) covers [i, i+1) x [j, j+1)
 *    and its centre is (i + 0.5, j + 0.5). The picture spans [0, W] x [0, H].
 *  - Values are as stored in the file: 8-bit / 16-bit PNG and JPEG become value/255 or
 *    value/65535 (still sRGB encoded), EXR values are kept (linear). The warp is linear
 *    in the values, so this only matters for the preview composite.
 *  - Every buffer is owned by the caller; counts are passed so that sizes are checked.
 */
#ifndef TUSSOCK_PICTURE_H
#define TUSSOCK_PICTURE_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/// Largest picture side in pixels; larger files are refused from their header, before
/// decoding (TSK_ERR_LIMIT).
#define TSK_PICTURE_MAX_SIDE 16384
/// Smallest picture side in pixels (a layer needs background around it).
#define TSK_PICTURE_MIN_SIDE 4
/// Largest picture in pixels (64 Mpx: one float RGBA copy is 1 GiB).
#define TSK_PICTURE_MAX_PIXELS (1ll << 26)
/// Largest picture file in bytes (1 GiB).
#define TSK_PICTURE_MAX_FILE_BYTES (1ll << 30)
/// Most layers a picture may have.
#define TSK_PICTURE_MAX_LAYERS 16
/// Largest warp cell side in pixels.
#define TSK_PICTURE_MAX_CELL 4096

/// A picture with its vegetation layers, their mattes and the inpainted background.
typedef struct tsk_picture tsk_picture;

/* ---- pictures -------------------------------------------------------------------------- */

/// Loads a PNG (8/16-bit; grey, grey+alpha, RGB, RGBA), JPEG or OpenEXR file into a new
/// picture. The size is read from the file header first: a side over TSK_PICTURE_MAX_SIDE
/// or more than TSK_PICTURE_MAX_PIXELS is refused without decoding. Missing files give
/// TSK_ERR_IO, corrupt or unsupported ones TSK_ERR_FORMAT, EXR with NaN/inf TSK_ERR_FORMAT.
/// The caller destroys the picture with tsk_picture_destroy.
tsk_status tsk_picture_load(const char* path, tsk_picture** out);

/// Makes a picture from straight float RGBA pixels (count = 4*width*height, all finite),
/// copied. `bottom_up` = 1 when row 0 of `rgba` is the bottom (Blender's Image.pixels).
tsk_status tsk_picture_create(int width, int height, const float* rgba, size_t count, int bottom_up,
                              tsk_picture** out);

/// Frees a picture and everything it holds. NULL is ignored.
void tsk_picture_destroy(tsk_picture* picture);

/// Width and height in pixels.
tsk_status tsk_picture_size(const tsk_picture* picture, int* width, int* height);

/// Copies the straight RGBA pixels as loaded (count = 4*W*H), rows top-first or bottom-up.
tsk_status tsk_picture_read_rgba(const tsk_picture* picture, float* rgba, size_t count,
                                 int bottom_up);

/* ---- layers ---------------------------------------------------------------------------- */

/// GrabCut proposal (Rother et al. 2004, seed 004 ref. [41]) of one vegetation mask.
typedef struct tsk_grabcut_def {
    int rect_x, rect_y; ///< rectangle around the vegetation, pixels, top-left origin
    int rect_width, rect_height; ///< must lie inside the picture and leave some pixels outside
    int iterations; ///< GrabCut iterations, 1..50 (default 5)
} tsk_grabcut_def;

/// Defaults: empty rectangle (must be set), 5 iterations.
tsk_grabcut_def tsk_default_grabcut_def(void);

/// Values of a stroke map given to tsk_picture_propose_mask.
enum { TSK_STROKE_NONE = 0, TSK_STROKE_FOREGROUND = 1, TSK_STROKE_BACKGROUND = 2 };

/// Proposes a vegetation mask with GrabCut: outside the rectangle is background, inside is
/// probably foreground; `strokes` (W*H bytes, TSK_STROKE_*; NULL = none) force pixels to
/// foreground or background. Writes `mask` (W*H bytes, top-first): 255 vegetation, 0 not.
/// Colours are clamped to [0, 1] and quantised to 8 bits for GrabCut. Deterministic (the
/// k-means seed is fixed). Cost at 1920x1080 on the shared 2-core test machine: 3 s for one
/// iteration, 8.5 s for five.
tsk_status tsk_picture_propose_mask(const tsk_picture* picture, const tsk_grabcut_def* def,
                                    const uint8_t* strokes, size_t stroke_count, uint8_t* mask,
                                    size_t mask_count);

/// Adds a vegetation layer from an 8-bit mask (W*H bytes, top-first): value >= 128 is
/// vegetation (a GrabCut proposal, a painted 0/255 mask). Layers are ordered back to front
/// in the order they are added. `index` (may be NULL) receives the new layer's index.
/// An empty mask, one covering every pixel, a size mismatch or too many layers give an
/// error naming the argument.
/// Invalidates a previous tsk_picture_build.
tsk_status tsk_picture_add_layer_u8(tsk_picture* picture, const uint8_t* mask, size_t count,
                                    int* index);
/// As tsk_picture_add_layer_u8 with a float mask: value >= 0.5 is vegetation; NaN/inf refused.
tsk_status tsk_picture_add_layer_f32(tsk_picture* picture, const float* mask, size_t count,
                                     int* index);

/// Number of layers.
int tsk_picture_layer_count(const tsk_picture* picture);

/// Inpainting method (OpenCV cv::inpaint).
typedef enum tsk_inpaint_method {
    TSK_INPAINT_TELEA = 0, ///< fast marching (Telea 2004)
    TSK_INPAINT_NS = 1, ///< Navier-Stokes based (Bertalmio et al. 2001)
} tsk_inpaint_method;

/// How layers are separated from the background.
typedef struct tsk_layers_def {
    tsk_inpaint_method method; ///< default TSK_INPAINT_TELEA
    float inpaint_radius; ///< neighbourhood of each inpainted pixel, pixels, 1..100 (default 5)
    float grow; ///< the inpainted region is the mask grown by this, pixels, 0..64
        ///< (default 3; removes the colour fringe around vegetation)
    float feather; ///< width of the matte's ramp across the mask edge, pixels,
        ///< 0..256 (default 4; 0 = hard edge)
} tsk_layers_def;

/// Defaults: Telea, radius 5, grow 3, feather 4.
tsk_layers_def tsk_default_layers_def(void);

/// Separates the layers (seed 004, §III-B):
///  1. each layer's region is its mask grown by max(grow, feather/2) pixels;
///  2. front to back, layer i's colour is the ORIGINAL picture with the regions of every
///     layer in front of it (index > i) inpainted away, so that when a front layer sways
///     the layer behind it shows plausible colour of its own, not the front layer's, and
///     fills are fed only by pixels of the layers behind and the background;
///  3. the background plate is the original picture with all regions inpainted at once;
///  4. each layer's matte alpha = clamp(0.5 + s / feather, 0, 1) times the picture's alpha,
///     where s is the signed Euclidean distance (pixels) to the mask edge, positive inside,
///     measured from the pixel centre to the edge between mask and non-mask pixels (exact
///     distance transform). So the matte is 1 deeper than feather/2 inside, 0 farther than
///     feather/2 outside, 0.5 on the edge and monotone across it.
/// Needs at least one layer. Costs a few seconds per layer at 1920x1080 (inpainting).
tsk_status tsk_picture_build(tsk_picture* picture, const tsk_layers_def* def);

/// Copies layer `layer`'s premultiplied RGBA at rest (count = 4*W*H). Needs tsk_picture_build.
tsk_status tsk_picture_read_layer(const tsk_picture* picture, int layer, float* rgba, size_t count,
                                  int bottom_up);
/// Copies layer `layer`'s matte (count = W*H, 0..1, before the picture's own alpha).
tsk_status tsk_picture_read_matte(const tsk_picture* picture, int layer, float* alpha, size_t count,
                                  int bottom_up);
/// Copies the inpainted background plate (premultiplied RGBA, count = 4*W*H).
tsk_status tsk_picture_read_background(const tsk_picture* picture, float* rgba, size_t count,
                                       int bottom_up);

/* ---- motion: warp grid (seed 004, eq. 5-8) ---------------------------------------------- */

/// The continuum's velocity Vp over the whole picture, as the wind module delivers it:
/// two planes vx, vy of width*height values at cell centres (structure of arrays),
/// row-major. Cell (a, b) covers pixels [a*W/width, (a+1)*W/width) x ... and its sample
/// sits at the cell centre. Sampled bilinearly, clamped to the outermost centres.
/// A 1x1 field is a uniform velocity.
typedef struct tsk_picture_field {
    const float* vx; ///< width*height values (units of Vp; multiplied by dt in eq. 5)
    const float* vy; ///< width*height values
    int width; ///< columns, 1..4096
    int height; ///< rows, 1..4096
    int y_up; ///< 1: row 0 is the bottom and +vy points up (wind module, Blender);
        ///< 0: row 0 is the top and +vy points down (image rows)
} tsk_picture_field;

/// Where the vegetation is rooted (seed 004, eq. 6 and Fig. 3-4).
typedef enum tsk_picture_root {
    TSK_ROOT_NONE = 0, ///< every part can move: R = 1
    TSK_ROOT_BOTTOM = 1, ///< roots at the bottom: displacement grows upwards from the root line
    TSK_ROOT_TOP = 2, ///< root line at the top (field seen from above): grows downwards
} tsk_picture_root;

/// How a warped frame samples its source (the UV pass is the same for both).
typedef enum tsk_warp_sampling {
    /// Bilinear, pixel centres at half-integers: the reference warp (eq. 8), exact for
    /// integer shifts, fast. Blender's Map UV does NOT sample this way.
    TSK_SAMPLE_BILINEAR = 0,
    /// As Blender's compositor Map UV node draws the UV pass (Blender 3.x; presumably 4.x
    /// with filter "Anisotropic", not verified): an elliptical weighted average whose
    /// ellipse comes from the UV pass's differences between neighbouring pixels, reading
    /// zeros outside the picture. Use it when the native frame must equal the render
    /// (previews, bakes, tests): it matches Blender 3.4.1 bit for bit on the tests' frames.
    /// About 15x slower than bilinear (still several times faster than Blender's own node).
    TSK_SAMPLE_MAP_UV = 1,
    /// As Blender 5.x's rewritten Map UV node draws the UV pass with Interpolation
    /// "Anisotropic" on the CPU compositor: the same elliptical weighted average, but the
    /// pixels go in 2x2 blocks that share the UV pass's differences (each pixel takes its
    /// block row's horizontal and its block column's vertical difference), and the sample
    /// is multiplied by the UV pass's third channel (1 in Tussock's passes). It matches
    /// Blender 5.2.2 bit for bit on the tests' frames. Blender's GPU compositor (5.x's
    /// default device) samples through the graphics driver's anisotropic filter and
    /// mipmaps instead, which no native mode reproduces: set the scene's compositor device
    /// to CPU where frames must match.
    TSK_SAMPLE_MAP_UV_5 = 2,
} tsk_warp_sampling;

/// Largest |lambda| of a warp (cells per unit of Vp*dt). Beyond, any wind moves the grid by
/// more than the 1e7 pixels the frames accept, so the value is refused where it is set, not
/// on every frame (a lambda of 3e38, Blender's "inf", passed the old finite-only check).
#define TSK_WARP_MAX_LAMBDA 1.0e6f

/// Warp grid and eq. 5-7 parameters of one layer.
typedef struct tsk_warp_def {
    int cell_x, cell_y; ///< grid cell size sx, sy, pixels, 1..4096 (default 16)
    float lambda_x, lambda_y; ///< scale factor lambda of eq. 5, in cells per unit of Vp*dt,
        ///< |lambda| <= TSK_WARP_MAX_LAMBDA (default 4)
    float dt; ///< simulation step dt of eq. 5, seconds, >= 0 (default 1/24)
    float rigidity; ///< r of eq. 6, 0..10 (default 1)
    tsk_picture_root root; ///< default TSK_ROOT_BOTTOM
    int auto_root; ///< 1: root line and height h from the layer mask's bounding
        ///< box (bottom or top edge, box height); 0: use the two
        ///< fields below (default 1; the low-level tsk_warp_corners
        ///< always uses them)
    float root_y; ///< root line, pixels from the top (y of the line)
    float height; ///< h of eq. 6, pixels, > 0
    tsk_warp_sampling sampling; ///< how warped RGBA frames sample (default bilinear)
} tsk_warp_def;

/// Defaults: 16 px cells, lambda 4, dt 1/24 s, r = 1, roots at the bottom found from the
/// mask, bilinear sampling.
tsk_warp_def tsk_default_warp_def(void);

/// Number of grid corners for a W x H picture: corners_x = ceil(W / cell_x) + 1 columns at
/// x = k*cell_x, corners_y = ceil(H / cell_y) + 1 rows at y = k*cell_y.
tsk_status tsk_warp_grid_size(int width, int height, int cell_x, int cell_y, int* corners_x,
                              int* corners_y);

/// Corner displacements of the inverse warp, pixels (seed 004, eq. 5-7): for the corner at
/// (x, y), with Vp sampled bilinearly from `field` at (x, y) and lambda multiplied by
/// `scale_map` (W*H values >= 0 at pixel centres, sampled bilinearly at (x, y); NULL = 1),
///   n = lambda * R * Vp * dt                          (eq. 5)
///   R = 1 for TSK_ROOT_NONE, else clamp(l / h, 0, 1)^r  (eq. 6; 0^0 = 1)
///   l = root_y - y (roots at the bottom) or y - root_y (roots at the top)
///   (dx, dy) = (-n_x * cell_x, -n_y * cell_y)         (eq. 7)
/// So the content moves by +n*s: along Vp. Writes corners_x*corners_y values to each of
/// corner_dx, corner_dy (row-major, top row first). Deterministic, thread-count independent.
tsk_status tsk_warp_corners(const tsk_warp_def* def, int width, int height,
                            const tsk_picture_field* field, const float* scale_map,
                            size_t scale_count, float* corner_dx, float* corner_dy,
                            size_t corner_count);

/// Inverse warp (seed 004, eq. 8) of a premultiplied RGBA image with displaced corners.
/// For the output pixel centre p = (i + 0.5, j + 0.5) in cell (kx, ky) at local (u, v),
/// the source point is s = p + d with d the bilinear blend of the cell's four corner
/// displacements (the same point as eq. 8's blend of displaced corners, but exact when
/// d = 0). s is clamped to [0.5, W - 0.5] x [0.5, H - 0.5] (clamp to edge).
/// Outputs (either may be NULL, not both; count 4*W*H each):
///  - dst: the warped image (rows top-first like src): src sampled at s bilinearly with
///    pixel centres at half-integers (TSK_SAMPLE_BILINEAR), or as Blender's Map UV samples
///    the UV pass below (TSK_SAMPLE_MAP_UV for Blender 3.x/4.x, TSK_SAMPLE_MAP_UV_5 for 5.x);
///  - uv: the UV pass for Blender's compositor Map UV node: (u, v, 1, 1) per pixel with
///    u = s_x / W and v = (H - s_y) / H, i.e. Blender's bottom-left origin with pixel
///    centres at ((i + 0.5) / W, (j_from_bottom + 0.5) / H); blue = 1 is the alpha Map UV
///    reads. Rows bottom-first when uv_bottom_up = 1 (ready for Image.pixels), else
///    top-first. Because s is clamped to the edge pixels' centres, no sample point falls
///    outside the picture (Map UV's filter footprint still may, see TSK_SAMPLE_MAP_UV).
/// src is read only when dst is given.
tsk_status tsk_warp_apply(int width, int height, const float* src, size_t src_count, int cell_x,
                          int cell_y, const float* corner_dx, const float* corner_dy,
                          size_t corner_count, tsk_warp_sampling sampling, float* dst,
                          size_t dst_count, float* uv, size_t uv_count, int uv_bottom_up);

/* ---- frames of a built picture ---------------------------------------------------------- */

/// One frame of one layer: the warp corners from `def`, `field` and `scale_map` (root line
/// and h from the mask when def->auto_root), then tsk_warp_apply on the layer with
/// def->sampling. `rgba` (premultiplied, top-first) and `uv` as in tsk_warp_apply; either
/// may be NULL.
tsk_status tsk_picture_layer_frame(const tsk_picture* picture, int layer, const tsk_warp_def* def,
                                   const tsk_picture_field* field, const float* scale_map,
                                   size_t scale_count, float* rgba, size_t rgba_count, float* uv,
                                   size_t uv_count, int uv_bottom_up);

/// Composites layers back to front over the background plate with premultiplied "over"
/// (out = layer + (1 - layer.a) * out, Blender's Alpha Over with Convert Premultiplied off).
/// `layers[i]` is layer i's warped frame (4*W*H, premultiplied, top-first), or NULL for the
/// layer at rest; `layer_count` must equal tsk_picture_layer_count. Writes out (4*W*H,
/// premultiplied, top-first).
tsk_status tsk_picture_composite(const tsk_picture* picture, const float* const* layers,
                                 size_t layer_count, float* out, size_t count);

#ifdef __cplusplus
}
#endif
#endif
