/* The warp grid (seed 004, §III-E): corner displacements from the continuum by eq. 5-7 and
 * inverse warping with bilinear sampling by eq. 8 (or Map UV's filter, map_uv.c), delivered
 * as a warped RGBA image and as a UV pass for Blender's compositor Map UV node. */
#include "core/simd.h"
#include "picture_internal.h"
#include "core/tmath.h"

#include <math.h>
#include <stdatomic.h>
#include <stdint.h>

#if TSK_SIMD_SSE2
#include <emmintrin.h> /* one pixel's 4 channels in one register; streaming stores */
#define TSK_WARP_SSE 1
#endif

tsk_warp_def tsk_default_warp_def(void) {
    tsk_warp_def d;
    d.cell_x = 16;
    d.cell_y = 16;
    d.lambda_x = 4.0f;
    d.lambda_y = 4.0f;
    d.dt = 1.0f / 24.0f;
    d.rigidity = 1.0f;
    d.root = TSK_ROOT_BOTTOM;
    d.auto_root = 1;
    d.root_y = 0.0f;
    d.height = 1.0f;
    d.sampling = TSK_SAMPLE_BILINEAR;
    return d;
}

static tsk_status check_cells(int cell_x, int cell_y) {
    if (cell_x < 1 || cell_x > TSK_PICTURE_MAX_CELL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "cell_x", "must be 1..%d pixels, got %d",
                             TSK_PICTURE_MAX_CELL, cell_x);
    if (cell_y < 1 || cell_y > TSK_PICTURE_MAX_CELL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "cell_y", "must be 1..%d pixels, got %d",
                             TSK_PICTURE_MAX_CELL, cell_y);
    return TSK_OK;
}

tsk_status tsk_warp_grid_size(int width, int height, int cell_x, int cell_y, int* corners_x,
                              int* corners_y) {
    tsk_status s = tsk_picture_check_size(width, height, 1, "width, height");
    if (s == TSK_OK) s = check_cells(cell_x, cell_y);
    if (s != TSK_OK) return s;
    if (corners_x == NULL || corners_y == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "corners_x, corners_y", "is NULL");
    *corners_x = (width + cell_x - 1) / cell_x + 1;
    *corners_y = (height + cell_y - 1) / cell_y + 1;
    return TSK_OK;
}

static tsk_status check_def(const tsk_warp_def* d) {
    tsk_status s = check_cells(d->cell_x, d->cell_y);
    if (s != TSK_OK) return s;
    if (!(fabsf(d->lambda_x) <= TSK_WARP_MAX_LAMBDA))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "lambda_x", "must be finite, within +-%g, got %g",
                             (double)TSK_WARP_MAX_LAMBDA, (double)d->lambda_x);
    if (!(fabsf(d->lambda_y) <= TSK_WARP_MAX_LAMBDA))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "lambda_y", "must be finite, within +-%g, got %g",
                             (double)TSK_WARP_MAX_LAMBDA, (double)d->lambda_y);
    if (!(d->dt >= 0.0f && d->dt <= 1e6f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "dt", "must be 0..1e6 s, got %g", (double)d->dt);
    if (!(d->rigidity >= 0.0f && d->rigidity <= 10.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "rigidity", "must be 0..10 (eq. 6), got %g",
                             (double)d->rigidity);
    if (d->root != TSK_ROOT_NONE && d->root != TSK_ROOT_BOTTOM && d->root != TSK_ROOT_TOP)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "root", "must be none, bottom or top, got %d",
                             (int)d->root);
    if (d->root != TSK_ROOT_NONE) {
        if (!isfinite(d->root_y) || fabsf(d->root_y) > 1e7f)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "root_y", "must be finite, got %g",
                                 (double)d->root_y);
        if (!(d->height > 0.0f && d->height <= 1e7f))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "height", "must be > 0 pixels, got %g",
                                 (double)d->height);
    }
    return TSK_OK;
}

static tsk_status check_field(const tsk_picture_field* f) {
    if (f == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "field", "is NULL");
    if (f->width < 1 || f->width > 4096 || f->height < 1 || f->height > 4096)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "field", "size %dx%d must be 1..4096 per side",
                             f->width, f->height);
    if (f->vx == NULL || f->vy == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "field", "vx or vy is NULL");
    const size_t n = (size_t)f->width * (size_t)f->height;
    for (size_t i = 0; i < n; ++i)
        if (!isfinite(f->vx[i]) || !isfinite(f->vy[i]))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "field", "value %zu is not finite", i);
    return TSK_OK;
}

/* Bilinear sample of a plane of w*h values with samples at (a + 0.5, b + 0.5) in its own
 * cell units, clamped to the outermost samples. (fx, fy) are in cell units. */
static float sample_plane(const float* v, int w, int h, float fx, float fy) {
    fx -= 0.5f;
    fy -= 0.5f;
    if (fx < 0.0f) fx = 0.0f;
    if (fy < 0.0f) fy = 0.0f;
    if (fx > (float)(w - 1)) fx = (float)(w - 1);
    if (fy > (float)(h - 1)) fy = (float)(h - 1);
    int x0 = (int)fx, y0 = (int)fy;
    int x1 = x0 + 1 < w ? x0 + 1 : x0, y1 = y0 + 1 < h ? y0 + 1 : y0;
    const float tx = fx - (float)x0, ty = fy - (float)y0;
    const float a = v[(size_t)y0 * w + x0], b = v[(size_t)y0 * w + x1];
    const float c = v[(size_t)y1 * w + x0], d = v[(size_t)y1 * w + x1];
    const float top = a + tx * (b - a), bottom = c + tx * (d - c);
    return top + ty * (bottom - top);
}

tsk_status tsk_warp_corners(const tsk_warp_def* def, int width, int height,
                            const tsk_picture_field* field, const float* scale_map,
                            size_t scale_count, float* corner_dx, float* corner_dy,
                            size_t corner_count) {
    if (def == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "def", "is NULL");
    tsk_status s = check_def(def);
    if (s != TSK_OK) return s;
    int cx, cy;
    if ((s = tsk_warp_grid_size(width, height, def->cell_x, def->cell_y, &cx, &cy)) != TSK_OK)
        return s;
    if ((s = check_field(field)) != TSK_OK) return s;
    const size_t npix = (size_t)width * (size_t)height;
    if (scale_map != NULL) {
        if (scale_count != npix)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "scale_map",
                                 "size %zu does not match the %dx%d picture (%zu values)",
                                 scale_count, width, height, npix);
        for (size_t i = 0; i < npix; ++i)
            if (!(scale_map[i] >= 0.0f && scale_map[i] <= 1e6f))
                return tsk_error_arg(TSK_ERR_ARGUMENT, "scale_map",
                                     "value %zu is %g; it must be finite and >= 0", i,
                                     (double)scale_map[i]);
    }
    if (corner_dx == NULL || corner_dy == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "corner_dx, corner_dy", "is NULL");
    if (corner_count != (size_t)cx * (size_t)cy)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "corner_count",
                             "must be %d*%d = %zu corners, got %zu", cx, cy,
                             (size_t)cx * (size_t)cy, corner_count);
    const float fsx = (float)field->width / (float)width;
    const float fsy = (float)field->height / (float)height;
    for (int ky = 0; ky < cy; ++ky) {
        const float y = (float)ky * (float)def->cell_y;
        /* seed 004, eq. 6: R from the distance l to the root line over the layer height h */
        float R = 1.0f;
        if (def->root != TSK_ROOT_NONE) {
            float l = def->root == TSK_ROOT_BOTTOM ? def->root_y - y : y - def->root_y;
            float q = l / def->height;
            q = q < 0.0f ? 0.0f : q > 1.0f ? 1.0f : q;
            R = def->rigidity == 0.0f ? 1.0f : tsk_powf(q, def->rigidity);
        }
        for (int kx = 0; kx < cx; ++kx) {
            const float x = (float)kx * (float)def->cell_x;
            float fy = y * fsy;
            float vy_sign = 1.0f;
            if (field->y_up) {
                fy = (float)field->height - fy;
                vy_sign = -1.0f;
            }
            const float vpx = sample_plane(field->vx, field->width, field->height, x * fsx, fy);
            const float vpy =
                vy_sign * sample_plane(field->vy, field->width, field->height, x * fsx, fy);
            float scale = 1.0f;
            if (scale_map != NULL) scale = sample_plane(scale_map, width, height, x, y);
            /* seed 004, eq. 5: n = lambda R Vp dt (lambda scaled by the scale map) */
            const float nx = def->lambda_x * scale * R * vpx * def->dt;
            const float ny = def->lambda_y * scale * R * vpy * def->dt;
            /* seed 004, eq. 7: corners move against the velocity (inverse warping) */
            const size_t k = (size_t)ky * (size_t)cx + (size_t)kx;
            corner_dx[k] = -nx * (float)def->cell_x;
            corner_dy[k] = -ny * (float)def->cell_y;
        }
    }
    return TSK_OK;
}

/* ---- seed 004, eq. 8: inverse warping --------------------------------------------------
 * Eq. 8 blends the four displaced corners with the pixel's local (u, v); we blend the four
 * corner displacements and add them to the pixel centre, which is the same point (the
 * undisplaced corners blend to the centre exactly) but stays exact when nothing moves. */

typedef struct warp_ctx {
    int width, height, cell_x, cell_y, cx;
    const float* src;
    const float* dx;
    const float* dy;
    float* dst;
    float* uv;
    int uv_bottom_up;
    const float* ufrac; /* cell_x values: (k + 0.5) / cell_x, the local u of a pixel centre */
    int reach_x, reach_y; /* whole pixels at least as far as any source point is from its pixel */
    atomic_int failed; /* set when a chunk of rows could not get its scratch */
} warp_ctx;

enum { WARP_GRAIN = 8 };

/* Source points of one output row, clamped to the centres of the edge pixels. */
static void row_sources(const warp_ctx* c, int j, float* restrict sxs, float* restrict sys) {
    const int W = c->width, H = c->height;
    const float maxx = (float)W - 0.5f, maxy = (float)H - 0.5f;
    const int ky = j / c->cell_y;
    const float py = (float)j + 0.5f;
    const float v = (py - (float)(ky * c->cell_y)) / (float)c->cell_y;
    const float* dx0 = c->dx + (size_t)ky * c->cx;
    const float* dx1 = dx0 + c->cx;
    const float* dy0 = c->dy + (size_t)ky * c->cx;
    const float* dy1 = dy0 + c->cx;
    for (int kx = 0; kx * c->cell_x < W; ++kx) {
        /* displacement along the cell's left and right edges at this row; the form
         * a + t (b - a) is exact when a == b (a uniform displacement stays exact) */
        const float ax = dx0[kx] + v * (dx1[kx] - dx0[kx]);
        const float bx = dx0[kx + 1] + v * (dx1[kx + 1] - dx0[kx + 1]);
        const float ay = dy0[kx] + v * (dy1[kx] - dy0[kx]);
        const float by = dy0[kx + 1] + v * (dy1[kx + 1] - dy0[kx + 1]);
        const int i0 = kx * c->cell_x;
        const int m = i0 + c->cell_x < W ? c->cell_x : W - i0;
        const float ex = bx - ax, ey = by - ay;
        for (int k = 0; k < m; ++k) {
            const float u = c->ufrac[k];
            float sx = ((float)(i0 + k) + 0.5f) + (ax + u * ex);
            float sy = py + (ay + u * ey);
            sx = sx < 0.5f ? 0.5f : sx;
            sx = sx > maxx ? maxx : sx;
            sy = sy < 0.5f ? 0.5f : sy;
            sy = sy > maxy ? maxy : sy;
            sxs[i0 + k] = sx;
            sys[i0 + k] = sy;
        }
    }
}

/* A row whose source points are sxs[i], sys[i], bilinearly sampled into out, streamed past
 * the cache when `stream` (out 16-byte aligned) */
static void sample_row(const warp_ctx* c, const float* sxs, const float* sys, float* restrict out,
                       int stream) {
    const int W = c->width, H = c->height;
    const float* restrict src = c->src;
    int i = 0;
#if TSK_WARP_SSE
    /* four pixels at a time: the same operations, in the same order, as the scalar loop
     * below, so both give the same bytes */
    const __m128 half = _mm_set1_ps(0.5f), one = _mm_set1_ps(1.0f);
    const __m128 xmax = _mm_set1_ps((float)(W > 1 ? W - 2 : 0));
    const __m128 ymax = _mm_set1_ps((float)(H > 1 ? H - 2 : 0));
    const int ox4 = W > 1 ? 4 : 0;
    const size_t oy4 = H > 1 ? (size_t)W * 4 : 0;
    for (; i + 4 <= W; i += 4) {
        const __m128 fx = _mm_sub_ps(_mm_loadu_ps(sxs + i), half);
        const __m128 fy = _mm_sub_ps(_mm_loadu_ps(sys + i), half);
        const __m128 x0f = _mm_min_ps(_mm_cvtepi32_ps(_mm_cvttps_epi32(fx)), xmax);
        const __m128 y0f = _mm_min_ps(_mm_cvtepi32_ps(_mm_cvttps_epi32(fy)), ymax);
        const __m128 tx = _mm_sub_ps(fx, x0f), ty = _mm_sub_ps(fy, y0f);
        const __m128 mtx = _mm_sub_ps(one, tx), mty = _mm_sub_ps(one, ty);
        const __m128 w00 = _mm_mul_ps(mtx, mty), w10 = _mm_mul_ps(tx, mty);
        const __m128 w01 = _mm_mul_ps(mtx, ty), w11 = _mm_mul_ps(tx, ty);
        int xi[4], yi[4];
        _mm_storeu_si128((__m128i*)xi, _mm_cvttps_epi32(x0f));
        _mm_storeu_si128((__m128i*)yi, _mm_cvttps_epi32(y0f));
        float* o = out + (size_t)4 * i;
#define TSK_WARP_PIXEL(k)                                                                          \
    do {                                                                                           \
        const float* a = src + ((size_t)yi[k] * W + xi[k]) * 4;                                    \
        const __m128 top = _mm_add_ps(                                                             \
            _mm_mul_ps(_mm_shuffle_ps(w00, w00, _MM_SHUFFLE(k, k, k, k)), _mm_loadu_ps(a)),        \
            _mm_mul_ps(_mm_shuffle_ps(w10, w10, _MM_SHUFFLE(k, k, k, k)), _mm_loadu_ps(a + ox4))); \
        const __m128 bot = _mm_add_ps(                                                             \
            _mm_mul_ps(_mm_shuffle_ps(w01, w01, _MM_SHUFFLE(k, k, k, k)), _mm_loadu_ps(a + oy4)),  \
            _mm_mul_ps(_mm_shuffle_ps(w11, w11, _MM_SHUFFLE(k, k, k, k)),                          \
                       _mm_loadu_ps(a + oy4 + ox4)));                                              \
        if (stream) _mm_stream_ps(o + 4 * (k), _mm_add_ps(top, bot));                              \
        else _mm_storeu_ps(o + 4 * (k), _mm_add_ps(top, bot));                                     \
    } while (0)
        TSK_WARP_PIXEL(0);
        TSK_WARP_PIXEL(1);
        TSK_WARP_PIXEL(2);
        TSK_WARP_PIXEL(3);
#undef TSK_WARP_PIXEL
    }
#else
    (void)stream;
#endif
    for (; i < W; ++i) {
        const float fx = sxs[i] - 0.5f, fy = sys[i] - 0.5f;
        int x0 = (int)fx, y0 = (int)fy;
        if (x0 > W - 2) x0 = W > 1 ? W - 2 : 0;
        if (y0 > H - 2) y0 = H > 1 ? H - 2 : 0;
        const int ox = x0 + 1 < W ? 4 : 0;
        const size_t oy = y0 + 1 < H ? (size_t)W * 4 : 0;
        const float tx = fx - (float)x0, ty = fy - (float)y0;
        const float* a = src + ((size_t)y0 * W + x0) * 4;
        const float w00 = (1.0f - tx) * (1.0f - ty), w10 = tx * (1.0f - ty);
        const float w01 = (1.0f - tx) * ty, w11 = tx * ty;
        float* o = out + (size_t)4 * i;
        for (int ch = 0; ch < 4; ++ch)
            o[ch] = (w00 * a[ch] + w10 * a[ox + ch]) + (w01 * a[oy + ch] + w11 * a[oy + ox + ch]);
    }
}

#if TSK_WARP_SSE
/* ---- 4K aliasing. A load whose address agrees in its low 12 bits with a store still in
 * flight waits for that store, and streamed stores stay in flight long. A row's sampling
 * loads run a few pixels around the pixels whose stores have just gone out, so when a
 * source row and the output row sit at nearly the same offset in their 4 KiB pages, most
 * loads wait. Two large buffers from mmap do sit so (the picture's layer and a frame
 * allocated the same way), and the rows of a 1920-pixel picture alternate between two
 * offsets: there the RGBA warp was markedly slower (docs/performance.md, "Picture warp"). Such a
 * row is sampled into a row buffer with ordinary stores, which leave for the cache at once
 * wherever the buffer sits, then streamed out. Speed only: a pixel's bytes are the same
 * wherever it is sampled. */

/* Pixels of stores taken to be in flight behind the current one, and bytes of margin. */
enum { ALIAS_PIXELS = 32, ALIAS_MARGIN = 64 };

/* How far the page offset of d lies outside [lo, hi] (bytes, lo <= 0 <= hi) on the circle of
 * 4096 page offsets; 0 inside. */
static unsigned clear_of(uintptr_t d, int lo, int hi) {
    const int x = (int)(d & 4095u);
    if (hi - lo >= 4096 || x <= hi || x >= 4096 + lo) return 0;
    const int a = x - hi, b = 4096 + lo - x;
    return (unsigned)(a < b ? a : b);
}

/* How clear stores that run along a row starting at page offset `start` are of the loads
 * from the source rows that row j samples (0: they meet): a source point is within reach_x
 * pixels of its pixel (its right neighbour one more), the stores in flight up to
 * ALIAS_PIXELS behind. */
static unsigned clear_of_sources(const warp_ctx* c, int j, uintptr_t start) {
    const int y_lo = j - c->reach_y - 1, y_hi = j + c->reach_y + 1;
    if (y_hi - y_lo > 16) return 0; /* too many rows to keep clear of */
    const int lo = -16 * c->reach_x - ALIAS_MARGIN;
    const int hi = 16 * (c->reach_x + 1 + ALIAS_PIXELS) + ALIAS_MARGIN;
    unsigned best = 4096;
    for (int y = y_lo < 0 ? 0 : y_lo; y <= y_hi && y < c->height; ++y) {
        const unsigned d = clear_of(start - (uintptr_t)(c->src + (size_t)y * c->width * 4), lo, hi);
        if (d < best) best = d;
    }
    return best;
}

/* n floats (a multiple of 4) from the 64-byte-aligned row buffer to the 16-byte-aligned dst,
 * streamed past the cache */
static void copy_row(float* restrict dst, const float* restrict src, size_t n) {
    for (size_t i = 0; i < n; i += 4) _mm_stream_ps(dst + i, _mm_load_ps(src + i));
}
#endif

static void warp_rows(size_t row_begin, size_t row_end, size_t chunk, void* vctx) {
    (void)chunk;
    const warp_ctx* c = vctx;
    const int W = c->width, H = c->height;
    const float fw = (float)W, fh = (float)H;
    /* per chunk of rows: the row's source points, and the row buffer (below) */
    const size_t row4 = (size_t)W * 4, buf4 = c->dst ? row4 : 0;
    float* const heap = tsk_alloc((buf4 + 2 * (size_t)W) * sizeof(float), "warp row");
    if (heap == NULL) { /* tsk_warp_apply reports it; this chunk's rows are left as they were */
        atomic_store(&((warp_ctx*)vctx)->failed, 1);
        return;
    }
    float* const row_buf = heap; /* 64-byte aligned */
    float* const sxs = heap + buf4;
    float* const sys = sxs + W;
    for (size_t jr = row_begin; jr < row_end; ++jr) {
        const int j = (int)jr;
        row_sources(c, j, sxs, sys);
        if (c->uv) {
            float* restrict uvo = c->uv + (size_t)(c->uv_bottom_up ? H - 1 - j : j) * W * 4;
#if TSK_WARP_SSE
            if (((uintptr_t)uvo & 15u) == 0) {
                /* the UV pass is written once and not read back: bypass the cache */
                const __m128 vfw = _mm_set1_ps(fw), vfh = _mm_set1_ps(fh);
                const __m128 ones = _mm_set1_ps(1.0f);
                int i = 0;
                for (; i + 4 <= W; i += 4) {
                    const __m128 u = _mm_div_ps(_mm_loadu_ps(sxs + i), vfw);
                    const __m128 v = _mm_div_ps(_mm_sub_ps(vfh, _mm_loadu_ps(sys + i)), vfh);
                    const __m128 uv01 = _mm_unpacklo_ps(u, v), uv23 = _mm_unpackhi_ps(u, v);
                    _mm_stream_ps(uvo + 4 * i, _mm_movelh_ps(uv01, ones));
                    _mm_stream_ps(uvo + 4 * i + 4, _mm_movehl_ps(ones, uv01));
                    _mm_stream_ps(uvo + 4 * i + 8, _mm_movelh_ps(uv23, ones));
                    _mm_stream_ps(uvo + 4 * i + 12, _mm_movehl_ps(ones, uv23));
                }
                for (; i < W; ++i)
                    _mm_stream_ps(uvo + 4 * i,
                                  _mm_set_ps(1.0f, 1.0f, (fh - sys[i]) / fh, sxs[i] / fw));
            } else
#endif
                for (int i = 0; i < W; ++i) {
                    uvo[4 * i + 0] = sxs[i] / fw;
                    uvo[4 * i + 1] = (fh - sys[i]) / fh;
                    uvo[4 * i + 2] = 1.0f;
                    uvo[4 * i + 3] = 1.0f;
                }
        }
        if (c->dst) {
            float* const dst_row = c->dst + (size_t)j * row4;
#if TSK_WARP_SSE
            /* stream the frame past the cache: it is written once and not read back */
            const int stream = ((uintptr_t)dst_row & 15u) == 0;
            if (stream && clear_of_sources(c, j, (uintptr_t)dst_row) == 0) {
                sample_row(c, sxs, sys, row_buf, 0);
                copy_row(dst_row, row_buf, row4);
                continue;
            }
#else
            const int stream = 0;
            (void)row_buf; /* only the streaming path samples into it */
#endif
            sample_row(c, sxs, sys, dst_row, stream);
        }
    }
#if TSK_WARP_SSE
    _mm_sfence(); /* make the streamed stores visible before the chunk ends */
#endif
    tsk_free(heap);
}

tsk_status tsk_warp_apply(int width, int height, const float* src, size_t src_count, int cell_x,
                          int cell_y, const float* corner_dx, const float* corner_dy,
                          size_t corner_count, tsk_warp_sampling sampling, float* dst,
                          size_t dst_count, float* uv, size_t uv_count, int uv_bottom_up) {
    int cx, cy;
    tsk_status s = tsk_warp_grid_size(width, height, cell_x, cell_y, &cx, &cy);
    if (s != TSK_OK) return s;
    const size_t n4 = (size_t)width * (size_t)height * 4;
    if (dst == NULL && uv == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "dst, uv", "both are NULL: nothing to compute");
    if (dst != NULL) {
        if (src == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "src", "is NULL");
        if (src_count != n4)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "src", "must have 4*%d*%d = %zu values, got %zu",
                                 width, height, n4, src_count);
        if (dst_count != n4)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "dst", "must have 4*%d*%d = %zu values, got %zu",
                                 width, height, n4, dst_count);
        if (dst == src) return tsk_error_arg(TSK_ERR_ARGUMENT, "dst", "must not be src");
    }
    if (uv != NULL && uv_count != n4)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "uv", "must have 4*%d*%d = %zu values, got %zu",
                             width, height, n4, uv_count);
    if (sampling != TSK_SAMPLE_BILINEAR && sampling != TSK_SAMPLE_MAP_UV &&
        sampling != TSK_SAMPLE_MAP_UV_5)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "sampling",
                             "must be bilinear (0), map_uv (1) or map_uv_5 (2), got %d",
                             (int)sampling);
    if (corner_dx == NULL || corner_dy == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "corner_dx, corner_dy", "is NULL");
    const size_t nc = (size_t)cx * (size_t)cy;
    if (corner_count != nc)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "corner_count",
                             "must be %d*%d = %zu corners, got %zu", cx, cy, nc, corner_count);
    float reach_x = 0.0f, reach_y = 0.0f;
    for (size_t k = 0; k < nc; ++k) {
        if (!(fabsf(corner_dx[k]) <= 1e7f && fabsf(corner_dy[k]) <= 1e7f))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "corner_dx, corner_dy",
                                 "corner %zu is not finite or beyond 1e7 pixels", k);
        reach_x = fmaxf(reach_x, fabsf(corner_dx[k]));
        reach_y = fmaxf(reach_y, fabsf(corner_dy[k]));
    }
    float* ufrac = tsk_alloc((size_t)cell_x * sizeof(float), "warp cell");
    if (ufrac == NULL) return TSK_ERR_MEMORY;
    for (int k = 0; k < cell_x; ++k) ufrac[k] = ((float)k + 0.5f) / (float)cell_x;
    /* a pixel's displacement blends its cell's corners, so it is no larger than theirs */
    warp_ctx c = {width,
                  height,
                  cell_x,
                  cell_y,
                  cx,
                  src,
                  corner_dx,
                  corner_dy,
                  dst,
                  uv,
                  uv_bottom_up != 0,
                  ufrac,
                  (int)fminf(ceilf(reach_x) + 1.0f, (float)width),
                  (int)fminf(ceilf(reach_y) + 1.0f, (float)height),
                  0};
    if (dst != NULL && sampling != TSK_SAMPLE_BILINEAR) {
        /* Map UV needs the whole UV pass (bottom-up) before it samples */
        float* uvb = uv != NULL && uv_bottom_up ? uv : tsk_alloc(n4 * sizeof(float), "uv pass");
        if (uvb == NULL) {
            s = TSK_ERR_MEMORY;
        } else {
            c.dst = NULL;
            c.uv = uvb;
            c.uv_bottom_up = 1;
            tsk_parallel_for((size_t)height, WARP_GRAIN, warp_rows, &c);
            /* never sample through a UV pass with rows missing (reported below) */
            if (!atomic_load(&c.failed)) {
                if (sampling == TSK_SAMPLE_MAP_UV_5)
                    tsk_picture_map_uv_5(width, height, src, uvb, dst);
                else tsk_picture_map_uv(width, height, src, uvb, dst);
            }
            if (uvb != uv) {
                tsk_free(uvb);
                if (uv != NULL) { /* the caller wants it top-first */
                    c.uv = uv;
                    c.uv_bottom_up = 0;
                    tsk_parallel_for((size_t)height, WARP_GRAIN, warp_rows, &c);
                }
            }
        }
    } else {
        /* fixed grain of rows: each output pixel depends on nothing but its inputs */
        tsk_parallel_for((size_t)height, WARP_GRAIN, warp_rows, &c);
    }
    tsk_free(ufrac);
    if (s == TSK_OK && atomic_load(&c.failed))
        return tsk_error(TSK_ERR_MEMORY, "out of memory for the warp's row scratch");
    return s;
}
