/* Tests of the picture module: the warp grid of seed 004 (eq. 5-8) against closed forms and
 * an independent bilinear sampler, the UV pass against a Blender-style Map UV sampler,
 * Blender 5.x's Map UV filter against a double-precision reference, layers (GrabCut,
 * inpainting, mattes), file loading and bad input. */
#define _POSIX_C_SOURCE 200809L /* mkstemp */
#include "test.h"
#include "tussock/picture.h"

#include "bridge/opencv_picture_bridge.h"
#include "picture/picture_internal.h"
#include "core/tmath.h"

#include <stdint.h>
#include <unistd.h>
#include <float.h>

#include "test_os.h"

/* ---- helpers ------------------------------------------------------------------------- */

static float* random_image(int w, int h, uint64_t seed) {
    float* v = malloc((size_t)w * h * 4 * sizeof(float));
    for (int i = 0; i < w * h * 4; ++i) v[i] = tsk_rand01(seed, (uint64_t)i, 0, 0);
    return v;
}

/* Smooth image: sums of sines, values in [0, 1]. */
static float* smooth_image(int w, int h) {
    float* v = malloc((size_t)w * h * 4 * sizeof(float));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 4; ++c)
                v[((size_t)y * w + x) * 4 + c] = 0.5f + 0.25f * tsk_sinf(0.21f * x + 0.7f * c) +
                                                 0.2f * tsk_cosf(0.17f * y - 0.3f * c);
    return v;
}

/* Independent bilinear sampler with clamp to edge, in double, pixel centres at k + 0.5. */
static double ref_bilinear(const float* img, int w, int h, int ch, double sx, double sy) {
    double fx = sx - 0.5, fy = sy - 0.5;
    if (fx < 0) fx = 0;
    if (fy < 0) fy = 0;
    if (fx > w - 1) fx = w - 1;
    if (fy > h - 1) fy = h - 1;
    int x0 = (int)floor(fx), y0 = (int)floor(fy);
    int x1 = x0 + 1 < w ? x0 + 1 : w - 1, y1 = y0 + 1 < h ? y0 + 1 : h - 1;
    double tx = fx - x0, ty = fy - y0;
#define PX(x, y) ((double)img[((size_t)(y)*w + (x)) * 4 + ch])
    return (1 - ty) * ((1 - tx) * PX(x0, y0) + tx * PX(x1, y0)) +
           ty * ((1 - tx) * PX(x0, y1) + tx * PX(x1, y1));
#undef PX
}

static tsk_picture_field uniform_field(float* vx, float* vy, float ux, float uy) {
    *vx = ux;
    *vy = uy;
    tsk_picture_field f = {vx, vy, 1, 1, 0};
    return f;
}

static tsk_warp_def free_def(int cell_x, int cell_y) {
    tsk_warp_def d = tsk_default_warp_def();
    d.cell_x = cell_x;
    d.cell_y = cell_y;
    d.lambda_x = d.lambda_y = 1.0f;
    d.dt = 1.0f;
    d.root = TSK_ROOT_NONE;
    d.auto_root = 0;
    return d;
}

/* Warps `src` with the corners eq. 5-7 give for `def` and `field`; dst and/or uv. */
static tsk_status warp(const tsk_warp_def* def, const tsk_picture_field* field, int w, int h,
                       const float* src, float* dst, float* uv, int bottom_up) {
    int cx, cy;
    tsk_status s = tsk_warp_grid_size(w, h, def->cell_x, def->cell_y, &cx, &cy);
    if (s != TSK_OK) return s;
    size_t nc = (size_t)cx * cy, n4 = (size_t)w * h * 4;
    float* dx = malloc(nc * sizeof(float));
    float* dy = malloc(nc * sizeof(float));
    s = tsk_warp_corners(def, w, h, field, NULL, 0, dx, dy, nc);
    if (s == TSK_OK)
        s = tsk_warp_apply(w, h, src, n4, def->cell_x, def->cell_y, dx, dy, nc, def->sampling, dst,
                           dst ? n4 : 0, uv, uv ? n4 : 0, bottom_up);
    free(dx);
    free(dy);
    return s;
}

/* ---- warp ---------------------------------------------------------------------------- */

TEST(test_warp_zero_displacement_is_identity_and_uv_is_pixel_centres) {
    const int W = 67, H = 45;
    float* src = random_image(W, H, 1);
    float* dst = malloc(W * H * 4 * sizeof(float));
    float* uv = malloc(W * H * 4 * sizeof(float));
    float vx, vy;
    tsk_picture_field f = uniform_field(&vx, &vy, 0.0f, 0.0f);
    tsk_warp_def d = free_def(16, 7);
    for (int bottom_up = 0; bottom_up <= 1; ++bottom_up) {
        CHECK(warp(&d, &f, W, H, src, dst, uv, bottom_up) == TSK_OK);
        CHECK(memcmp(src, dst, W * H * 4 * sizeof(float)) == 0);
        int bad = 0;
        for (int j = 0; j < H; ++j)
            for (int i = 0; i < W; ++i) {
                /* Blender: origin bottom-left, centre of pixel (i, jb) at ((i+.5)/W, (jb+.5)/H) */
                const int jb = H - 1 - j;
                const int row = bottom_up ? jb : j;
                const float* p = uv + ((size_t)row * W + i) * 4;
                bad += p[0] != ((float)i + 0.5f) / (float)W;
                bad += p[1] != ((float)jb + 0.5f) / (float)H;
                bad += p[2] != 1.0f || p[3] != 1.0f;
            }
        CHECK_MSG(bad == 0, "%d UV values differ from pixel centres", bad);
    }
    free(src);
    free(dst);
    free(uv);
}

TEST(test_warp_integer_shift_is_exact) {
    const int W = 50, H = 40;
    float* src = random_image(W, H, 2);
    float* dst = malloc(W * H * 4 * sizeof(float));
    float vx, vy;
    /* eq. 5-7 with lambda = dt = 1 and 16x8 cells: content moves by (vx*16, vy*8) pixels */
    tsk_picture_field f = uniform_field(&vx, &vy, 3.0f / 16.0f, -2.0f / 8.0f);
    tsk_warp_def d = free_def(16, 8);
    CHECK(warp(&d, &f, W, H, src, dst, NULL, 0) == TSK_OK);
    const int sx = 3, sy = -2;
    int bad = 0, checked = 0;
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i) {
            int si = i - sx, sj = j - sy;
            if (si < 0 || sj < 0 || si >= W || sj >= H) continue;
            ++checked;
            bad += memcmp(dst + ((size_t)j * W + i) * 4, src + ((size_t)sj * W + si) * 4,
                          4 * sizeof(float)) != 0;
        }
    CHECK(checked > 1000);
    CHECK_MSG(bad == 0, "%d of %d shifted pixels are not exact", bad, checked);
    free(src);
    free(dst);
}

TEST(test_warp_fractional_shift_matches_reference_bilinear) {
    const int W = 48, H = 36;
    float* src = random_image(W, H, 3);
    float* dst = malloc(W * H * 4 * sizeof(float));
    float vx, vy;
    const double ddx = 1.375 * 0.9, ddy = -0.61;
    tsk_picture_field f = uniform_field(&vx, &vy, (float)(ddx / 8.0), (float)(ddy / 8.0));
    tsk_warp_def d = free_def(8, 8);
    CHECK(warp(&d, &f, W, H, src, dst, NULL, 0) == TSK_OK);
    double worst = 0;
    for (int j = 2; j < H - 2; ++j)
        for (int i = 2; i < W - 2; ++i)
            for (int c = 0; c < 4; ++c) {
                double ref = ref_bilinear(src, W, H, c, i + 0.5 - ddx, j + 0.5 - ddy);
                double e = fabs(ref - dst[((size_t)j * W + i) * 4 + c]);
                if (e > worst) worst = e;
            }
    CHECK_MSG(worst <= 1e-5, "max error %g", worst);
    free(src);
    free(dst);
}

/* Rows whose stores would meet their own loads in the page offsets (4K aliasing) are
 * sampled through a row buffer (warp.c): output at the source's page offset, or 16 bytes
 * after it, takes that path, 1024 and 2048 bytes after it take the direct one, 4 bytes
 * after it is not 16-byte aligned and is not streamed. 256-pixel rows are 4 KiB, so every
 * row of the source and of the output sits at its buffer's page offset. Every placement
 * gives the same bytes, and they match the independent bilinear sampler at the UV pass's
 * source points. */
TEST(test_warp_output_at_any_page_offset_gives_the_same_bytes) {
    const int W = 256, H = 48, C = 16;
    const size_t n4 = (size_t)W * H * 4;
    float* src = NULL;
    char* arena = NULL;
    CHECK((src = test_aligned_alloc(4096, n4 * sizeof(float))) != NULL);
    CHECK((arena = test_aligned_alloc(4096, n4 * sizeof(float) + 4096)) != NULL);
    for (size_t i = 0; i < n4; ++i) src[i] = tsk_rand01(41, (uint64_t)i, 0, 0);
    int cx, cy;
    CHECK(tsk_warp_grid_size(W, H, C, C, &cx, &cy) == TSK_OK);
    const size_t nc = (size_t)cx * cy;
    float* dx = malloc(nc * sizeof(float));
    float* dy = malloc(nc * sizeof(float));
    for (size_t k = 0; k < nc; ++k) { /* a few pixels, both signs */
        dx[k] = 2.5f * tsk_sinf(0.9f * (float)k);
        dy[k] = 1.5f * tsk_cosf(0.7f * (float)k);
    }
    float* first = malloc(n4 * sizeof(float));
    float* uv = malloc(n4 * sizeof(float));
    const size_t offsets[] = {0, 16, 1024, 2048, 4};
    for (int o = 0; o < 5; ++o) {
        float* dst = (float*)(arena + offsets[o]);
        memset(dst, 0xff, n4 * sizeof(float));
        CHECK(tsk_warp_apply(W, H, src, n4, C, C, dx, dy, nc, TSK_SAMPLE_BILINEAR, dst, n4,
                             o == 0 ? uv : NULL, o == 0 ? n4 : 0, 0) == TSK_OK);
        if (o == 0) {
            memcpy(first, dst, n4 * sizeof(float));
            continue;
        }
        CHECK_MSG(memcmp(first, dst, n4 * sizeof(float)) == 0,
                  "output %zu bytes past the source's page offset differs", offsets[o]);
    }
    double worst = 0;
    int moved = 0;
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i) {
            const float* q = uv + ((size_t)j * W + i) * 4;
            const double sx = (double)q[0] * W, sy = H - (double)q[1] * H;
            moved += fabs(sx - (i + 0.5)) > 0.5 || fabs(sy - (j + 0.5)) > 0.5;
            for (int c = 0; c < 4; ++c) {
                const double e =
                    fabs(ref_bilinear(src, W, H, c, sx, sy) - first[((size_t)j * W + i) * 4 + c]);
                if (e > worst) worst = e;
            }
        }
    CHECK_MSG(moved > W * H / 4, "only %d of %d pixels moved by half a pixel", moved, W * H);
    CHECK_MSG(worst <= 1e-4, "max error %g against the reference sampler", worst);
    test_aligned_free(src);
    test_aligned_free(arena);
    free(dx);
    free(dy);
    free(first);
    free(uv);
}

/* An allocation failing at any point of a warp (its cell table, a chunk's row scratch, the
 * Map UV pass) gives TSK_ERR_MEMORY with nothing leaked, never a frame with rows missing or
 * a Map UV sampled through an unfinished UV pass; given enough, the same bytes as before. */
TEST(test_warp_allocation_failures_are_reported) {
    const int W = 40, H = 30, C = 8;
    const size_t n4 = (size_t)W * H * 4;
    float* src = random_image(W, H, 43);
    int cx, cy;
    CHECK(tsk_warp_grid_size(W, H, C, C, &cx, &cy) == TSK_OK);
    const size_t nc = (size_t)cx * cy;
    float* dx = malloc(nc * sizeof(float));
    float* dy = malloc(nc * sizeof(float));
    for (size_t k = 0; k < nc; ++k) {
        dx[k] = 1.5f * tsk_sinf(0.9f * (float)k);
        dy[k] = 1.2f * tsk_cosf(0.7f * (float)k);
    }
    float* ref = malloc(n4 * sizeof(float));
    float* dst = malloc(n4 * sizeof(float));
    float* uv = malloc(n4 * sizeof(float));
    CHECK(tsk_set_threads(1) == TSK_OK); /* allocations in a fixed order */
    for (int sampling = TSK_SAMPLE_BILINEAR; sampling <= TSK_SAMPLE_MAP_UV_5; ++sampling) {
        CHECK(tsk_warp_apply(W, H, src, n4, C, C, dx, dy, nc, (tsk_warp_sampling)sampling, ref, n4,
                             uv, n4, 0) == TSK_OK);
        const size_t held = tsk_allocated_bytes();
        int failures = 0;
        for (int n = 0; n < 64; ++n) {
            memset(dst, 0, n4 * sizeof(float));
            int allocs_left = n;
            tsk_set_allocator(tsk_test_failing_alloc, tsk_test_plain_free, &allocs_left);
            const tsk_status s = tsk_warp_apply(W, H, src, n4, C, C, dx, dy, nc,
                                                (tsk_warp_sampling)sampling, dst, n4, uv, n4, 0);
            tsk_set_allocator(NULL, NULL, NULL);
            CHECK(tsk_allocated_bytes() == held);
            if (s == TSK_OK) {
                CHECK(memcmp(ref, dst, n4 * sizeof(float)) == 0);
                break;
            }
            ++failures;
            CHECK_MSG(s == TSK_ERR_MEMORY, "status %d after %d allocations", (int)s, n);
        }
        /* bilinear: the cell table and the first row scratch; Map UV: the UV pass too */
        CHECK_MSG(failures >= (sampling == TSK_SAMPLE_BILINEAR ? 2 : 3) && failures < 64,
                  "%d failing allocations (sampling %d)", failures, sampling);
    }
    tsk_set_threads(0);
    free(src);
    free(dx);
    free(dy);
    free(ref);
    free(dst);
    free(uv);
}

/* Affine field: Vp at sample (a, b) = A + Bx a + By b; bilinear interpolation is exact. */
TEST(test_corners_match_eq5_to_7_closed_form) {
    const int W = 100, H = 80, FW = 8, FH = 6;
    float vxs[FW * FH], vys[FW * FH], vys_up[FW * FH], vxs_up[FW * FH];
    for (int b = 0; b < FH; ++b)
        for (int a = 0; a < FW; ++a) {
            vxs[b * FW + a] = 0.3f + 0.05f * a - 0.02f * b;
            vys[b * FW + a] = -0.1f + 0.01f * a + 0.04f * b;
        }
    /* the same field as the wind module would store it: bottom row first, +y up */
    for (int b = 0; b < FH; ++b)
        for (int a = 0; a < FW; ++a) {
            vxs_up[(FH - 1 - b) * FW + a] = vxs[b * FW + a];
            vys_up[(FH - 1 - b) * FW + a] = -vys[b * FW + a];
        }
    tsk_picture_field f = {vxs, vys, FW, FH, 0}, fu = {vxs_up, vys_up, FW, FH, 1};
    tsk_warp_def d = free_def(10, 8);
    d.lambda_x = 2.0f;
    d.lambda_y = 3.0f;
    d.dt = 0.1f;
    d.rigidity = 1.5f;
    d.root = TSK_ROOT_BOTTOM;
    d.root_y = 70.0f;
    d.height = 60.0f;
    int cx, cy;
    CHECK(tsk_warp_grid_size(W, H, d.cell_x, d.cell_y, &cx, &cy) == TSK_OK);
    CHECK(cx == 11 && cy == 11);
    float dx[121], dy[121], dxu[121], dyu[121];
    CHECK(tsk_warp_corners(&d, W, H, &f, NULL, 0, dx, dy, 121) == TSK_OK);
    CHECK(tsk_warp_corners(&d, W, H, &fu, NULL, 0, dxu, dyu, 121) == TSK_OK);
    int checked = 0;
    for (int ky = 0; ky < cy; ++ky)
        for (int kx = 0; kx < cx; ++kx) {
            double x = kx * 10.0, y = ky * 8.0;
            double a = x * FW / W - 0.5, b = y * FH / H - 0.5; /* field sample coordinates */
            if (a < 0 || b < 0 || a > FW - 1 || b > FH - 1) continue; /* clamped: skip */
            double vpx = 0.3 + 0.05 * a - 0.02 * b, vpy = -0.1 + 0.01 * a + 0.04 * b;
            double l = 70.0 - y, q = l / 60.0;
            q = q < 0 ? 0 : q > 1 ? 1 : q;
            double R = pow(q, 1.5);
            double ex = -(2.0 * R * vpx * 0.1) * 10.0, ey = -(3.0 * R * vpy * 0.1) * 8.0;
            CHECK_NEAR(dx[ky * cx + kx], ex, 1e-5);
            CHECK_NEAR(dy[ky * cx + kx], ey, 1e-5);
            CHECK_NEAR(dxu[ky * cx + kx], ex, 1e-5);
            CHECK_NEAR(dyu[ky * cx + kx], ey, 1e-5);
            ++checked;
        }
    CHECK(checked >= 40);
    /* a scale map of constant 0.5 halves every displacement */
    float* scale = malloc(W * H * sizeof(float));
    for (int i = 0; i < W * H; ++i) scale[i] = 0.5f;
    float dxs[121], dys[121];
    CHECK(tsk_warp_corners(&d, W, H, &f, scale, (size_t)W * H, dxs, dys, 121) == TSK_OK);
    for (int k = 0; k < 121; ++k) {
        CHECK_NEAR(dxs[k], 0.5 * dx[k], 1e-6);
        CHECK_NEAR(dys[k], 0.5 * dy[k], 1e-6);
    }
    free(scale);
}

TEST(test_rigidity_one_keeps_grid_shape) {
    const int W = 64, H = 64;
    float vx, vy;
    tsk_picture_field f = uniform_field(&vx, &vy, 0.7f, -0.4f);
    tsk_warp_def d = free_def(8, 8);
    d.root = TSK_ROOT_BOTTOM;
    d.root_y = 64.0f;
    d.height = 64.0f;
    float dx[81], dy[81];
    for (int r = 0; r <= 2; ++r) {
        d.rigidity = (float)r;
        CHECK(tsk_warp_corners(&d, W, H, &f, NULL, 0, dx, dy, 81) == TSK_OK);
        /* rows keep their shape: one displacement per row */
        double row_spread = 0, second = 0;
        for (int ky = 0; ky < 9; ++ky)
            for (int kx = 1; kx < 9; ++kx)
                row_spread = fmax(row_spread, fabs(dx[ky * 9 + kx] - dx[ky * 9]));
        /* columns stay straight (and all cells congruent) iff displacement is linear in y */
        for (int ky = 1; ky < 8; ++ky) {
            second = fmax(second, fabs(dx[(ky + 1) * 9] - 2 * dx[ky * 9] + dx[(ky - 1) * 9]));
            second = fmax(second, fabs(dy[(ky + 1) * 9] - 2 * dy[ky * 9] + dy[(ky - 1) * 9]));
        }
        CHECK(row_spread == 0);
        if (r <= 1) CHECK_MSG(second < 1e-5, "r=%d: second difference %g", r, second);
        else CHECK_MSG(second > 1e-2, "r=2 should bend the columns, got %g", second);
        if (r == 0) CHECK_NEAR(dx[8 * 9], dx[0], 0); /* r = 0: every part moves alike */
    }
}

TEST(test_horizon_root_line_does_not_move) {
    const int W = 40, H = 64;
    float* src = random_image(W, H, 4);
    float* dst = malloc(W * H * 4 * sizeof(float));
    float vx, vy;
    tsk_picture_field f = uniform_field(&vx, &vy, 0.9f, 0.3f);
    tsk_warp_def d = free_def(8, 8);
    d.rigidity = 2.0f;
    float dx[6 * 9], dy[6 * 9];
    /* roots at the bottom, root line at y = 48: rows at and below it stay */
    d.root = TSK_ROOT_BOTTOM;
    d.root_y = 48.0f;
    d.height = 40.0f;
    CHECK(tsk_warp_corners(&d, W, H, &f, NULL, 0, dx, dy, 54) == TSK_OK);
    for (int ky = 0; ky < 9; ++ky) {
        const double y = ky * 8.0;
        const double mag = fabs(dx[ky * 6]);
        if (y >= 48.0) CHECK(dx[ky * 6] == 0.0f && dy[ky * 6] == 0.0f);
        if (ky > 0) CHECK(mag <= fabs(dx[(ky - 1) * 6])); /* grows with height */
        const double q = fmin(1.0, fmax(0.0, (48.0 - y) / 40.0));
        CHECK_NEAR(dx[ky * 6], -0.9 * q * q * 8.0, 1e-5);
    }
    CHECK(fabs(dx[0]) > 5.0);
    CHECK(warp(&d, &f, W, H, src, dst, NULL, 0) == TSK_OK);
    CHECK(memcmp(dst + 48 * W * 4, src + 48 * W * 4, (size_t)(H - 48) * W * 4 * sizeof(float)) ==
          0);
    CHECK(memcmp(dst, src, 8 * W * 4 * sizeof(float)) != 0);
    /* roots at the top, root line at y = 16: rows at and above it stay */
    d.root = TSK_ROOT_TOP;
    d.root_y = 16.0f;
    CHECK(tsk_warp_corners(&d, W, H, &f, NULL, 0, dx, dy, 54) == TSK_OK);
    for (int ky = 0; ky < 9; ++ky) {
        const double y = ky * 8.0;
        if (y <= 16.0) CHECK(dx[ky * 6] == 0.0f && dy[ky * 6] == 0.0f);
        if (ky > 0) CHECK(fabs(dx[ky * 6]) >= fabs(dx[(ky - 1) * 6]));
    }
    CHECK(warp(&d, &f, W, H, src, dst, NULL, 0) == TSK_OK);
    CHECK(memcmp(dst, src, 16 * W * 4 * sizeof(float)) == 0);
    free(src);
    free(dst);
}

/* Map UV as Blender samples it: uv with origin bottom-left, the image stored bottom row
 * first, bilinear with pixel centres at (i + 0.5) / W. */
static double blender_map_uv(const float* img_bottom_up, int w, int h, int ch, double u, double v) {
    double x = u * w - 0.5, y = v * h - 0.5;
    int x0 = (int)floor(x), y0 = (int)floor(y);
    double tx = x - x0, ty = y - y0;
    double acc = 0;
    for (int dyi = 0; dyi <= 1; ++dyi)
        for (int dxi = 0; dxi <= 1; ++dxi) {
            int xi = x0 + dxi, yi = y0 + dyi;
            double wgt = (dxi ? tx : 1 - tx) * (dyi ? ty : 1 - ty);
            if (wgt == 0) continue;
            if (xi < 0 || yi < 0 || xi >= w || yi >= h) return NAN; /* must never happen */
            acc += wgt * img_bottom_up[((size_t)yi * w + xi) * 4 + ch];
        }
    return acc;
}

TEST(test_uv_pass_reproduces_native_warp) {
    const int W = 96, H = 64, FW = 12, FH = 8;
    float* src = smooth_image(W, H);
    float* flipped = malloc(W * H * 4 * sizeof(float));
    for (int j = 0; j < H; ++j)
        memcpy(flipped + (size_t)(H - 1 - j) * W * 4, src + (size_t)j * W * 4,
               W * 4 * sizeof(float));
    /* a travelling sine wave as the continuum's velocity */
    float vx[FW * FH], vy[FW * FH];
    for (int b = 0; b < FH; ++b)
        for (int a = 0; a < FW; ++a) {
            vx[b * FW + a] = 0.8f * tsk_sinf(0.9f * a - 0.5f * b);
            vy[b * FW + a] = 0.5f * tsk_cosf(0.7f * a + 0.3f * b);
        }
    tsk_picture_field f = {vx, vy, FW, FH, 1};
    tsk_warp_def d = free_def(16, 16);
    d.lambda_x = d.lambda_y = 0.4f;
    d.root = TSK_ROOT_BOTTOM;
    d.root_y = 60.0f;
    d.height = 50.0f;
    float* dst = malloc(W * H * 4 * sizeof(float));
    float* uv = malloc(W * H * 4 * sizeof(float));
    CHECK(warp(&d, &f, W, H, src, dst, uv, 1) == TSK_OK);
    double worst = 0, moved = 0;
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i) {
            const float* p = uv + ((size_t)(H - 1 - j) * W + i) * 4;
            moved = fmax(moved, fabs(p[0] * W - (i + 0.5)));
            for (int c = 0; c < 4; ++c) {
                double b = blender_map_uv(flipped, W, H, c, p[0], p[1]);
                double e = fabs(b - dst[((size_t)j * W + i) * 4 + c]);
                if (!(e <= worst)) worst = isnan(e) ? INFINITY : fmax(worst, e);
            }
        }
    printf("    UV pass vs native warp: max error %.3g (values 0..1), max shift %.2f px\n", worst,
           moved);
    CHECK(moved > 2.0);
    CHECK_MSG(worst < 1e-4, "max error %g", worst);
    free(src);
    free(flipped);
    free(dst);
    free(uv);
}

TEST(test_map_uv_sampling_exact_at_rest_and_for_integer_shifts) {
    const int W = 60, H = 44;
    float* src = random_image(W, H, 9);
    float* dst = malloc(W * H * 4 * sizeof(float));
    float vx, vy;
    tsk_picture_field f = uniform_field(&vx, &vy, 0.0f, 0.0f);
    tsk_warp_def d = free_def(8, 8);
    d.sampling = TSK_SAMPLE_MAP_UV;
    CHECK(warp(&d, &f, W, H, src, dst, NULL, 0) == TSK_OK);
    CHECK(memcmp(src, dst, W * H * 4 * sizeof(float)) == 0);
    /* content moves by (+2, -1): the UV pass has unit derivatives, the ellipse covers one
     * pixel, so the filter returns that pixel exactly (away from the clamped border) */
    f = uniform_field(&vx, &vy, 2.0f / 8.0f, -1.0f / 8.0f);
    CHECK(warp(&d, &f, W, H, src, dst, NULL, 0) == TSK_OK);
    int bad = 0, checked = 0;
    for (int j = 2; j < H - 3; ++j)
        for (int i = 4; i < W - 2; ++i) {
            ++checked;
            bad += memcmp(dst + ((size_t)j * W + i) * 4, src + ((size_t)(j + 1) * W + i - 2) * 4,
                          4 * sizeof(float)) != 0;
        }
    CHECK_MSG(bad == 0, "%d of %d pixels differ", bad, checked);
    /* a flat colour stays flat under any warp: the weights are normalised */
    for (int i = 0; i < W * H * 4; ++i) src[i] = (i % 4 == 3) ? 1.0f : 0.25f * (float)(i % 4 + 1);
    float vxs[16], vys[16];
    for (int k = 0; k < 16; ++k) {
        vxs[k] = 0.5f * tsk_sinf(1.3f * k);
        vys[k] = 0.4f * tsk_cosf(0.7f * k);
    }
    tsk_picture_field g = {vxs, vys, 4, 4, 0};
    CHECK(warp(&d, &g, W, H, src, dst, NULL, 0) == TSK_OK);
    /* (Map UV reads zeros outside the picture, so only the interior stays exact) */
    double worst = 0;
    for (int j = 8; j < H - 8; ++j)
        for (int i = 8 * 4; i < (W - 8) * 4; ++i)
            worst = fmax(worst, fabs(dst[(size_t)j * W * 4 + i] - src[(size_t)j * W * 4 + i]));
    CHECK_MSG(worst < 1e-6, "flat colour changed by %g", worst);
    free(src);
    free(dst);
}

/* ---- Blender 5.x's Map UV (TSK_SAMPLE_MAP_UV_5) ----------------------------------------- */

/* Normalised UV of pixel (x, y) of a bottom-up RGBA UV pass, clamped into the picture. */
static void uv_clamped(const float* uv, int w, int h, int x, int y, double out[2]) {
    x = x < w - 1 ? x : w - 1;
    y = y < h - 1 ? y : h - 1;
    out[0] = uv[((size_t)y * w + x) * 4];
    out[1] = uv[((size_t)y * w + x) * 4 + 1];
}

/* The filter of Blender 5.x's Map UV at output pixel (x, y) (bottom-up), from its definition
 * and in double. The pixel's jacobian J (picture pixels per output pixel) is the UV
 * difference across its 2x2 block along each axis (blocks start at even x and y, neighbours
 * clamped into the picture). The footprint is J's image of the unit disc: the ellipse whose
 * semi-axes are J's singular values s1 >= s2, along the eigenvectors of J J^T. Blender's
 * adjustments: the minor semi-axis is at least 0.875 px (the major too, when shorter); and
 * where det(J)^2 <= 1e-5 W^2 (its "degenerate" test, in its own scaling) the major
 * semi-axis squared becomes max(|dU|^2, |dV|^2), the larger squared row of J, and the minor
 * 0.875 px. A texel at r^2 < 1 (its centre in ellipse units) weighs
 * (exp(-2 k / 255) - exp(-2)) / (1 - exp(-2)) with k = floor(256 r^2); texels outside the
 * picture are zero but keep their weight; the weighted mean is multiplied by the UV pass's
 * blue. `ambiguous` is set where float rounding may decide otherwise than double: a texel
 * with 256 r^2 within 0.002 of a table step, or a footprint within 0.1 % of one of the two
 * thresholds. */
static void ref_map_uv_5(const float* img_top_first, const float* uv, int w, int h, int x, int y,
                         double out[4], int* ambiguous) {
    const int x0 = x - x % 2, y0 = y - y % 2;
    double a[2], b[2], jx[2], jy[2];
    uv_clamped(uv, w, h, x0, y, a);
    uv_clamped(uv, w, h, x0 + 1, y, b);
    jx[0] = (b[0] - a[0]) * w; /* dU/dx, dV/dx in pixels */
    jx[1] = (b[1] - a[1]) * h;
    uv_clamped(uv, w, h, x, y0, a);
    uv_clamped(uv, w, h, x, y0 + 1, b);
    jy[0] = (b[0] - a[0]) * w; /* dU/dy, dV/dy */
    jy[1] = (b[1] - a[1]) * h;
    /* J J^T = [[p, q], [q, s]]: its eigenvalues are the squared singular values */
    const double p = jx[0] * jx[0] + jy[0] * jy[0], q = jx[0] * jx[1] + jy[0] * jy[1],
                 s = jx[1] * jx[1] + jy[1] * jy[1];
    const double det = jx[0] * jy[1] - jy[0] * jx[1];
    const double mid = 0.5 * (p + s), half = sqrt(0.25 * (p - s) * (p - s) + q * q);
    double major2 = mid + half, minor2 = fmax(mid - half, 0.0);
    /* direction of the major axis: eigenvector of the larger eigenvalue */
    double e1[2] = {q, major2 - p};
    if (fabs(q) < 1e-300) {
        e1[0] = p >= s ? 1.0 : 0.0;
        e1[1] = p >= s ? 0.0 : 1.0;
    }
    const double n = hypot(e1[0], e1[1]);
    e1[0] /= n;
    e1[1] /= n;
    const double limit = 1e-5 * (double)w * w, rmin2 = 0.765625;
    *ambiguous = fabs(det * det - limit) < 1e-3 * limit;
    if (det * det <= limit) {
        major2 = fmax(p, s);
        minor2 = 0.0;
    }
    *ambiguous |= fabs(minor2 - rmin2) < 1e-3 || fabs(major2 - rmin2) < 1e-3;
    if (minor2 < rmin2) {
        minor2 = rmin2;
        if (major2 < rmin2) major2 = rmin2;
    }
    const double u0 = uv[((size_t)y * w + x) * 4] * (double)w;
    const double v0 = uv[((size_t)y * w + x) * 4 + 1] * (double)h;
    const double alpha = uv[((size_t)y * w + x) * 4 + 2];
    const int reach = (int)ceil(sqrt(major2)) + 2;
    double acc[4] = {0, 0, 0, 0}, wsum = 0;
    const double ea = exp(-2.0);
    for (int j = (int)floor(v0) - reach; j <= (int)floor(v0) + reach; ++j)
        for (int i = (int)floor(u0) - reach; i <= (int)floor(u0) + reach; ++i) {
            const double du = i + 0.5 - u0, dv = j + 0.5 - v0;
            const double along = du * e1[0] + dv * e1[1], across = -du * e1[1] + dv * e1[0];
            const double t = 256.0 * (along * along / major2 + across * across / minor2);
            if (t >= 256.0 + 0.002) continue;
            if (fabs(t - floor(t + 0.5)) < 0.002) *ambiguous = 1;
            if (t >= 256.0) continue;
            const double wt = (exp(-2.0 * floor(t) / 255.0) - ea) / (1.0 - ea);
            wsum += wt;
            if (i < 0 || j < 0 || i >= w || j >= h) continue;
            const float* px = img_top_first + ((size_t)(h - 1 - j) * w + i) * 4;
            for (int c = 0; c < 4; ++c) acc[c] += wt * px[c];
        }
    for (int c = 0; c < 4; ++c) out[c] = acc[c] / wsum * alpha;
}

/* A bottom-up UV pass: the identity, then `shape` 0 keeps it, 1 shears, scales (from 1.3x
 * smaller to 1.6x larger), bends and partly leaves the picture, 2 flattens v to a constant
 * (a degenerate jacobian), 3 magnifies both axes about 2.3x (the smallest, round
 * footprint); blue = alpha in [0.25, 1] when `with_alpha`, else 1. Offsets keep texel
 * centres off the exact table steps that a grid-aligned footprint would hit. */
static float* test_uv_pass(int w, int h, int shape, int with_alpha) {
    float* uv = malloc((size_t)w * h * 4 * sizeof(float));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float* p = uv + ((size_t)y * w + x) * 4;
            const float u = (x + 0.5f) / (float)w, v = (y + 0.5f) / (float)h;
            p[0] = u;
            p[1] = v;
            if (shape == 1) {
                p[0] = 0.5f + 1.3f * (u - 0.5f) + 0.25f * (v - 0.5f) +
                       0.05f * tsk_sinf(9.0f * v + 4.0f * u);
                p[1] = 0.5f - 0.2f * (u - 0.5f) + 0.62f * (v - 0.5f) +
                       0.04f * tsk_cosf(7.0f * u - 5.0f * v);
            } else if (shape == 2) {
                p[0] = 0.97f * u + 0.0123f;
                p[1] = 0.4871f;
            } else if (shape == 3) {
                p[0] = 0.5f + 0.4f * (u - 0.5f) - 0.15f * (v - 0.5f);
                p[1] = 0.5f + 0.1f * (u - 0.5f) + 0.45f * (v - 0.5f);
            }
            p[2] = with_alpha ? 0.25f + 0.75f * tsk_rand01(77, (uint64_t)(y * w + x), 0, 0) : 1.0f;
            p[3] = 1.0f;
        }
    return uv;
}

TEST(test_map_uv_5_matches_reference_ewa) {
    const int W = 45, H = 31; /* odd: the last block column and row are half blocks */
    float* src = random_image(W, H, 21);
    float* dst = malloc((size_t)W * H * 4 * sizeof(float));
    for (int shape = 1; shape <= 3; ++shape) {
        float* uv = test_uv_pass(W, H, shape, 1);
        tsk_picture_map_uv_5(W, H, src, uv, dst);
        double worst = 0;
        int skipped = 0, outside = 0;
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                double ref[4];
                int ambiguous = 0;
                ref_map_uv_5(src, uv, W, H, x, y, ref, &ambiguous);
                if (ambiguous) {
                    ++skipped;
                    continue;
                }
                const float* got = dst + ((size_t)(H - 1 - y) * W + x) * 4;
                outside += ref[3] == 0.0;
                for (int c = 0; c < 4; ++c) worst = fmax(worst, fabs(got[c] - ref[c]));
            }
        printf(
            "    shape %d: max |native - reference| = %.3g, %d of %d pixels too close to a "
            "float/double decision to compare, %d sampled wholly outside\n",
            shape, worst, skipped, W * H, outside);
        CHECK_MSG(worst < 1e-5, "shape %d: max error %g", shape, worst);
        CHECK_MSG(skipped < W * H / 10, "shape %d: %d pixels skipped", shape, skipped);
        free(uv);
    }
    free(src);
    free(dst);
}

TEST(test_map_uv_5_identity_keeps_a_constant_and_the_picture) {
    const int W = 37, H = 23;
    float* src = malloc((size_t)W * H * 4 * sizeof(float));
    float* dst = malloc((size_t)W * H * 4 * sizeof(float));
    for (int i = 0; i < W * H * 4; ++i) src[i] = 0.2f + 0.15f * (float)(i % 4);
    float* uv = test_uv_pass(W, H, 0, 0);
    tsk_picture_map_uv_5(W, H, src, uv, dst);
    double worst = 0;
    for (int i = 0; i < W * H * 4; ++i) worst = fmax(worst, fabs(dst[i] - src[i]));
    CHECK_MSG(worst < 1e-6, "a constant picture changed by %g", worst);
    /* the identity's jacobian is one pixel: the ellipse holds the pixel itself alone */
    free(src);
    src = random_image(W, H, 5);
    tsk_picture_map_uv_5(W, H, src, uv, dst);
    CHECK(memcmp(src, dst, (size_t)W * H * 4 * sizeof(float)) == 0);
    /* the same through the warp at rest */
    float vx, vy;
    tsk_picture_field f = uniform_field(&vx, &vy, 0.0f, 0.0f);
    tsk_warp_def d = free_def(8, 8);
    d.sampling = TSK_SAMPLE_MAP_UV_5;
    memset(dst, 0, (size_t)W * H * 4 * sizeof(float));
    CHECK(warp(&d, &f, W, H, src, dst, NULL, 0) == TSK_OK);
    CHECK(memcmp(src, dst, (size_t)W * H * 4 * sizeof(float)) == 0);
    free(uv);
    free(src);
    free(dst);
}

TEST(test_map_uv_5_multiplies_by_the_uv_alpha) {
    const int W = 30, H = 21;
    float* src = random_image(W, H, 8);
    float* opaque = malloc((size_t)W * H * 4 * sizeof(float));
    float* scaled = malloc((size_t)W * H * 4 * sizeof(float));
    float* uv1 = test_uv_pass(W, H, 1, 0);
    float* uva = test_uv_pass(W, H, 1, 1);
    tsk_picture_map_uv_5(W, H, src, uv1, opaque);
    tsk_picture_map_uv_5(W, H, src, uva, scaled);
    int bad = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const float a = uva[((size_t)y * W + x) * 4 + 2];
            const size_t o = ((size_t)(H - 1 - y) * W + x) * 4;
            for (int c = 0; c < 4; ++c) bad += scaled[o + c] != opaque[o + c] * a;
        }
    CHECK_MSG(bad == 0, "%d values are not the opaque sample times the UV pass's blue", bad);
    free(src);
    free(opaque);
    free(scaled);
    free(uv1);
    free(uva);
}

TEST(test_warp_map_uv_5_samples_its_own_uv_pass) {
    const int W = 53, H = 35;
    float* src = random_image(W, H, 31);
    float* dst = malloc((size_t)W * H * 4 * sizeof(float));
    float* uv = malloc((size_t)W * H * 4 * sizeof(float));
    float* again = malloc((size_t)W * H * 4 * sizeof(float));
    float* old = malloc((size_t)W * H * 4 * sizeof(float));
    float vxs[16], vys[16];
    for (int k = 0; k < 16; ++k) {
        vxs[k] = 0.6f * tsk_sinf(1.1f * k);
        vys[k] = 0.5f * tsk_cosf(0.8f * k);
    }
    tsk_picture_field g = {vxs, vys, 4, 4, 0};
    tsk_warp_def d = free_def(8, 8);
    d.sampling = TSK_SAMPLE_MAP_UV_5;
    CHECK(warp(&d, &g, W, H, src, dst, uv, 1) == TSK_OK);
    tsk_picture_map_uv_5(W, H, src, uv, again);
    CHECK(memcmp(dst, again, (size_t)W * H * 4 * sizeof(float)) == 0);
    /* 3.x's central differences give other ellipses on a bent warp */
    d.sampling = TSK_SAMPLE_MAP_UV;
    CHECK(warp(&d, &g, W, H, src, old, NULL, 1) == TSK_OK);
    double apart = 0;
    for (int i = 0; i < W * H * 4; ++i) apart = fmax(apart, fabs(old[i] - dst[i]));
    CHECK_MSG(apart > 1e-3, "3.x and 5.x sampling agree within %g", apart);
    /* a sampling that does not exist is refused, naming the argument */
    int cx, cy;
    CHECK(tsk_warp_grid_size(W, H, 8, 8, &cx, &cy) == TSK_OK);
    float* zeros = calloc((size_t)cx * cy, sizeof(float));
    CHECK_STATUS(tsk_warp_apply(W, H, src, (size_t)W * H * 4, 8, 8, zeros, zeros, (size_t)cx * cy,
                                (tsk_warp_sampling)3, dst, (size_t)W * H * 4, NULL, 0, 1),
                 TSK_ERR_ARGUMENT, "sampling");
    free(zeros);
    free(src);
    free(dst);
    free(uv);
    free(again);
    free(old);
}

/* ---- layers --------------------------------------------------------------------------- */

/* A flat background with a disc of another colour; the disc's exact mask is returned. */
static tsk_picture* disc_picture(int w, int h, float cxp, float cyp, float r, uint8_t* mask,
                                 const float bg[3], const float fg[3]) {
    float* rgba = malloc((size_t)w * h * 4 * sizeof(float));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float dxp = x + 0.5f - cxp, dyp = y + 0.5f - cyp;
            const int in = dxp * dxp + dyp * dyp <= r * r;
            mask[(size_t)y * w + x] = in ? 255 : 0;
            for (int c = 0; c < 3; ++c) rgba[((size_t)y * w + x) * 4 + c] = in ? fg[c] : bg[c];
            rgba[((size_t)y * w + x) * 4 + 3] = 1.0f;
        }
    tsk_picture* p = NULL;
    CHECK(tsk_picture_create(w, h, rgba, (size_t)w * h * 4, 0, &p) == TSK_OK);
    free(rgba);
    return p;
}

TEST(test_inpainting_removes_the_layer) {
    const int W = 80, H = 64;
    const float bg[3] = {0.3f, 0.5f, 0.2f}, fg[3] = {0.9f, 0.1f, 0.1f};
    uint8_t* mask = malloc(W * H);
    for (int method = 0; method <= 1; ++method) {
        tsk_picture* p = disc_picture(W, H, 40, 30, 14, mask, bg, fg);
        CHECK(tsk_picture_add_layer_u8(p, mask, W * H, NULL) == TSK_OK);
        tsk_layers_def ld = tsk_default_layers_def();
        ld.method = method;
        CHECK(tsk_picture_build(p, &ld) == TSK_OK);
        float* b = malloc(W * H * 4 * sizeof(float));
        CHECK(tsk_picture_read_background(p, b, W * H * 4, 0) == TSK_OK);
        double worst = 0;
        for (int i = 0; i < W * H; ++i)
            for (int c = 0; c < 3; ++c) worst = fmax(worst, fabs(b[4 * i + c] - bg[c]));
        CHECK_MSG(worst < 1e-3, "method %d: background differs from flat by %g", method, worst);
        tsk_picture_destroy(p);
        free(b);
    }
    free(mask);
}

TEST(test_matte_is_one_inside_zero_outside_monotone) {
    const int W = 72, H = 60;
    const float bg[3] = {0.2f, 0.2f, 0.2f}, fg[3] = {0.1f, 0.8f, 0.1f};
    const float R = 18.0f;
    uint8_t* mask = malloc(W * H);
    tsk_picture* p = disc_picture(W, H, 36, 30, R, mask, bg, fg);
    CHECK(tsk_picture_add_layer_u8(p, mask, W * H, NULL) == TSK_OK);
    tsk_layers_def ld = tsk_default_layers_def();
    ld.feather = 6.0f;
    CHECK(tsk_picture_build(p, &ld) == TSK_OK);
    float* m = malloc(W * H * sizeof(float));
    CHECK(tsk_picture_read_matte(p, 0, m, W * H, 0) == TSK_OK);
    int partial = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            double r = hypot(x + 0.5 - 36, y + 0.5 - 30), a = m[y * W + x];
            if (r < R - 4.5) CHECK_MSG(a == 1.0f, "inside (%d,%d) alpha %g", x, y, a);
            if (r > R + 4.5) CHECK_MSG(a == 0.0f, "outside (%d,%d) alpha %g", x, y, a);
            partial += a > 0.05 && a < 0.95;
        }
    CHECK(partial > 50);
    /* along the row through the centre, alpha falls monotonically from centre to border */
    for (int x = 37; x < W; ++x) CHECK(m[30 * W + x] <= m[30 * W + x - 1]);
    for (int x = 35; x > 0; --x) CHECK(m[30 * W + x - 1] <= m[30 * W + x]);
    /* the layer carries the picture's colour premultiplied by the matte */
    float* L = malloc(W * H * 4 * sizeof(float));
    CHECK(tsk_picture_read_layer(p, 0, L, W * H * 4, 0) == TSK_OK);
    CHECK_NEAR(L[(30 * W + 36) * 4 + 1], 0.8, 1e-6);
    CHECK_NEAR(L[(30 * W + 36) * 4 + 3], 1.0, 0);
    /* a hard matte (feather 0) is the mask itself */
    ld.feather = 0.0f;
    CHECK(tsk_picture_build(p, &ld) == TSK_OK);
    CHECK(tsk_picture_read_matte(p, 0, m, W * H, 0) == TSK_OK);
    int diff = 0;
    for (int i = 0; i < W * H; ++i) diff += m[i] != (mask[i] ? 1.0f : 0.0f);
    CHECK(diff == 0);
    tsk_picture_destroy(p);
    free(mask);
    free(m);
    free(L);
}

TEST(test_grabcut_separates_green_blob) {
    const int W = 96, H = 80;
    float* rgba = malloc(W * H * 4 * sizeof(float));
    uint8_t* truth = malloc(W * H);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const double ex = (x + 0.5 - 48) / 22.0, ey = (y + 0.5 - 42) / 16.0;
            const int in = ex * ex + ey * ey <= 1.0;
            truth[y * W + x] = in;
            const float n = 0.12f * (tsk_rand01(7, x, y, 0) - 0.5f);
            float* px = rgba + ((size_t)y * W + x) * 4;
            if (in) { /* green, textured */
                px[0] = 0.15f + n;
                px[1] = 0.6f + 1.5f * n;
                px[2] = 0.12f + n;
            } else { /* brown soil */
                px[0] = 0.45f + n;
                px[1] = 0.3f + n;
                px[2] = 0.15f + n;
            }
            px[3] = 1.0f;
        }
    tsk_picture* p = NULL;
    CHECK(tsk_picture_create(W, H, rgba, (size_t)W * H * 4, 0, &p) == TSK_OK);
    tsk_grabcut_def g = tsk_default_grabcut_def();
    g.rect_x = 16;
    g.rect_y = 16;
    g.rect_width = 64;
    g.rect_height = 54;
    uint8_t* mask = malloc(W * H);
    CHECK(tsk_picture_propose_mask(p, &g, NULL, 0, mask, W * H) == TSK_OK);
    int inter = 0, uni = 0;
    for (int i = 0; i < W * H; ++i) {
        const int a = mask[i] == 255, b = truth[i];
        CHECK(mask[i] == 0 || mask[i] == 255);
        inter += a && b;
        uni += a || b;
    }
    const double iou = (double)inter / uni;
    printf("    GrabCut IoU %.3f\n", iou);
    CHECK(iou > 0.9);
    /* strokes: force a patch of the blob to background and a soil patch to foreground */
    uint8_t* strokes = calloc(W * H, 1);
    for (int y = 40; y < 44; ++y)
        for (int x = 44; x < 52; ++x) strokes[y * W + x] = TSK_STROKE_BACKGROUND;
    for (int y = 2; y < 5; ++y)
        for (int x = 2; x < 6; ++x) strokes[y * W + x] = TSK_STROKE_FOREGROUND;
    CHECK(tsk_picture_propose_mask(p, &g, strokes, W * H, mask, W * H) == TSK_OK);
    CHECK(mask[42 * W + 48] == 0);
    CHECK(mask[3 * W + 3] == 255);
    CHECK(mask[42 * W + 30] == 255);
    /* the proposal is deterministic */
    uint8_t* again = malloc(W * H);
    CHECK(tsk_picture_propose_mask(p, &g, strokes, W * H, again, W * H) == TSK_OK);
    CHECK(memcmp(mask, again, W * H) == 0);
    tsk_picture_destroy(p);
    free(rgba);
    free(truth);
    free(mask);
    free(strokes);
    free(again);
}

TEST(test_composite_at_rest_and_far_pixels_never_move) {
    const int W = 80, H = 64;
    float* rgba = smooth_image(W, H);
    for (int i = 0; i < W * H; ++i) rgba[4 * i + 3] = 1.0f;
    uint8_t* mask = calloc(W * H, 1);
    for (int y = 24; y < 56; ++y)
        for (int x = 20; x < 60; ++x) mask[y * W + x] = 255;
    tsk_picture* p = NULL;
    CHECK(tsk_picture_create(W, H, rgba, (size_t)W * H * 4, 0, &p) == TSK_OK);
    CHECK(tsk_picture_add_layer_u8(p, mask, W * H, NULL) == TSK_OK);
    tsk_layers_def ld = tsk_default_layers_def();
    CHECK(tsk_picture_build(p, &ld) == TSK_OK);
    float* out = malloc(W * H * 4 * sizeof(float));
    float* frame = malloc(W * H * 4 * sizeof(float));
    float* uv = malloc(W * H * 4 * sizeof(float));
    CHECK(tsk_picture_composite(p, NULL, 1, out, W * H * 4) == TSK_OK);
    /* at rest: deep inside the mask and outside the grown region, the picture itself */
    double worst = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const int deep = x >= 23 && x < 57 && y >= 27 && y < 53;
            const int far = x < 14 || x >= 66 || y < 18;
            if (!deep && !far) continue;
            for (int c = 0; c < 4; ++c)
                worst = fmax(worst, fabs(out[(y * W + x) * 4 + c] - rgba[(y * W + x) * 4 + c]));
        }
    CHECK_MSG(worst < 1e-6, "at rest the composite differs by %g", worst);
    /* a frame: uniform wind to the right; roots found from the mask (bottom row 56) */
    float vx, vy;
    tsk_picture_field f = uniform_field(&vx, &vy, 1.0f, 0.0f);
    tsk_warp_def d = tsk_default_warp_def(); /* lambda 4, dt 1/24: up to 2.67 px */
    d.cell_y = 8; /* a corner row on the root line */
    CHECK(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, frame, W * H * 4, uv, W * H * 4, 0) ==
          TSK_OK);
    /* below the root line (rows >= 56) the UV pass is the identity */
    int moved_below = 0;
    for (int y = 56; y < H; ++y)
        for (int x = 0; x < W; ++x) moved_below += uv[(y * W + x) * 4] != (x + 0.5f) / W;
    CHECK(moved_below == 0);
    /* pixel centre y = 24.5 lies 1/16 of the way from the corner row y = 24 (R = 1) to
     * y = 32 (R = (56 - 32) / 32): R = 1 - 0.25 / 16 */
    CHECK_NEAR(uv[(24 * W + 40) * 4] * W, 40.5 - 4.0 / 24.0 * 16.0 * (1.0 - 0.25 / 16.0), 1e-4);
    const float* layers[1] = {frame};
    CHECK(tsk_picture_composite(p, layers, 1, out, W * H * 4) == TSK_OK);
    worst = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const int far = x < 12 || x >= 68 || y < 16;
            if (!far) continue;
            for (int c = 0; c < 4; ++c)
                worst = fmax(worst, fabs(out[(y * W + x) * 4 + c] - rgba[(y * W + x) * 4 + c]));
        }
    CHECK_MSG(worst < 1e-6, "far pixels moved by %g", worst);
    tsk_picture_destroy(p);
    free(rgba);
    free(mask);
    free(out);
    free(frame);
    free(uv);
}

TEST(test_several_layers_are_removed_front_to_back) {
    const int W = 64, H = 48;
    float* rgba = malloc(W * H * 4 * sizeof(float));
    uint8_t* back = calloc(W * H, 1);
    uint8_t* front = calloc(W * H, 1);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const int inb = x >= 10 && x < 40 && y >= 10 && y < 40;
            const int inf = x >= 30 && x < 54 && y >= 16 && y < 34;
            back[y * W + x] = inb ? 255 : 0;
            front[y * W + x] = inf ? 255 : 0;
            float* px = rgba + ((size_t)y * W + x) * 4;
            px[0] = inf ? 0.9f : inb ? 0.1f : 0.4f;
            px[1] = inf ? 0.1f : inb ? 0.8f : 0.4f;
            px[2] = inf ? 0.1f : inb ? 0.1f : 0.4f;
            px[3] = 1.0f;
        }
    tsk_picture* p = NULL;
    CHECK(tsk_picture_create(W, H, rgba, (size_t)W * H * 4, 0, &p) == TSK_OK);
    int i0 = -1, i1 = -1;
    CHECK(tsk_picture_add_layer_u8(p, back, W * H, &i0) == TSK_OK);
    CHECK(tsk_picture_add_layer_u8(p, front, W * H, &i1) == TSK_OK);
    CHECK(i0 == 0 && i1 == 1 && tsk_picture_layer_count(p) == 2);
    tsk_layers_def ld = tsk_default_layers_def();
    ld.feather = 2.0f;
    CHECK(tsk_picture_build(p, &ld) == TSK_OK);
    float* L0 = malloc(W * H * 4 * sizeof(float));
    float* B = malloc(W * H * 4 * sizeof(float));
    CHECK(tsk_picture_read_layer(p, 0, L0, W * H * 4, 0) == TSK_OK);
    CHECK(tsk_picture_read_background(p, B, W * H * 4, 0) == TSK_OK);
    /* the back layer, where the front layer covered it, carries no front-layer red */
    const float* q = L0 + (25 * W + 34) * 4;
    CHECK_MSG(q[0] < 0.3f && q[1] > 0.5f, "back layer under the front layer: %g %g", q[0], q[1]);
    /* the background under both is the grey around them */
    for (int c = 0; c < 3; ++c) CHECK_NEAR(B[(25 * W + 34) * 4 + c], 0.4, 0.02);
    for (int c = 0; c < 3; ++c) CHECK_NEAR(B[(20 * W + 20) * 4 + c], 0.4, 0.02);
    tsk_picture_destroy(p);
    free(rgba);
    free(back);
    free(front);
    free(L0);
    free(B);
}

/* ---- files ---------------------------------------------------------------------------- */

static void temp_path(char* buf, size_t n, const char* ext) {
    snprintf(buf, n, "%s/tsk_picture_test_%d_%s", test_tmp_root(), (int)getpid(), ext);
}

TEST(test_load_png_jpeg_exr_variants) {
    const int W = 37, H = 23;
    float* src = smooth_image(W, H);
    for (int i = 0; i < W * H; ++i) src[4 * i + 3] = 0.25f + 0.5f * (float)(i % 7) / 6.0f;
    float* got = malloc(W * H * 4 * sizeof(float));
    struct {
        const char* ext;
        int channels, bits;
        double tol;
    } cases[] = {{"rgba8.png", 4, 8, 0.5 / 255 + 1e-6},
                 {"rgb16.png", 3, 16, 0.5 / 65535 + 1e-6},
                 {"grey8.png", 1, 8, 0.5 / 255 + 1e-6},
                 {"grey16.png", 1, 16, 0.5 / 65535 + 1e-6},
                 {"rgb.jpg", 3, 8, 0.06},
                 {"rgba32.exr", 4, 32, 0.0},
                 {"grey32.exr", 1, 32, 0.0}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
        char path[256];
        temp_path(path, sizeof path, cases[k].ext);
        CHECK(tsk_cvp_encode(path, src, W, H, cases[k].channels, cases[k].bits) == TSK_OK);
        tsk_picture* p = NULL;
        tsk_status s = tsk_picture_load(path, &p);
        CHECK_MSG(s == TSK_OK, "%s: %s", cases[k].ext, tsk_last_error());
        if (s != TSK_OK) continue;
        int w = 0, h = 0;
        CHECK(tsk_picture_size(p, &w, &h) == TSK_OK && w == W && h == H);
        CHECK(tsk_picture_read_rgba(p, got, W * H * 4, 0) == TSK_OK);
        double worst = 0;
        for (int i = 0; i < W * H; ++i)
            for (int c = 0; c < 4; ++c) {
                double want = cases[k].channels == 1             ? (c == 3 ? 1.0 : src[4 * i])
                              : cases[k].channels == 3 && c == 3 ? 1.0
                                                                 : src[4 * i + c];
                worst = fmax(worst, fabs(got[4 * i + c] - want));
            }
        CHECK_MSG(worst <= cases[k].tol, "%s: error %g > %g", cases[k].ext, worst, cases[k].tol);
        /* bottom_up reads flip the rows */
        CHECK(tsk_picture_read_rgba(p, got, W * H * 4, 1) == TSK_OK);
        float top[4];
        CHECK(tsk_picture_read_rgba(p, got, W * H * 4, 0) == TSK_OK);
        memcpy(top, got, sizeof top);
        CHECK(tsk_picture_read_rgba(p, got, W * H * 4, 1) == TSK_OK);
        CHECK(memcmp(top, got + (size_t)(H - 1) * W * 4, sizeof top) == 0);
        tsk_picture_destroy(p);
        remove(path);
    }
    free(src);
    free(got);
}

static void write_bytes(const char* path, const uint8_t* b, size_t n) {
    FILE* f = fopen(path, "wb");
    if (f) {
        fwrite(b, 1, n, f);
        fclose(f);
    }
}

/* A PNG written by hand (stored deflate blocks, our own CRC and Adler sums), independent of
 * OpenCV's encoder: grey + alpha, 8 bit, the variant OpenCV cannot write. */
static uint32_t crc32_of(const uint8_t* b, size_t n, uint32_t crc) {
    crc = ~crc;
    for (size_t i = 0; i < n; ++i) {
        crc ^= b[i];
        for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

static void put32(uint8_t* p, uint32_t v) {
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
}

static size_t png_chunk(uint8_t* out, const char* type, const uint8_t* data, uint32_t n) {
    put32(out, n);
    memcpy(out + 4, type, 4);
    if (n) memcpy(out + 8, data, n);
    put32(out + 8 + n, crc32_of(out + 4, n + 4, 0));
    return 12 + n;
}

TEST(test_load_grey_alpha_png_written_by_hand) {
    enum { W = 9, H = 6, ROW = 1 + 2 * W, RAW = ROW * H };
    uint8_t raw[RAW];
    for (int j = 0; j < H; ++j) {
        raw[j * ROW] = 0; /* filter: none */
        for (int i = 0; i < W; ++i) {
            raw[j * ROW + 1 + 2 * i] = (uint8_t)(17 * i + 29 * j); /* grey */
            raw[j * ROW + 2 + 2 * i] = (uint8_t)(255 - 11 * i - 7 * j); /* alpha */
        }
    }
    uint8_t z[2 + 5 + RAW + 4];
    z[0] = 0x78;
    z[1] = 0x01;
    z[2] = 1; /* final block, stored */
    z[3] = RAW & 0xFF;
    z[4] = RAW >> 8;
    z[5] = (uint8_t) ~(RAW & 0xFF);
    z[6] = (uint8_t) ~(RAW >> 8);
    memcpy(z + 7, raw, RAW);
    uint32_t s1 = 1, s2 = 0;
    for (int i = 0; i < RAW; ++i) {
        s1 = (s1 + raw[i]) % 65521u;
        s2 = (s2 + s1) % 65521u;
    }
    put32(z + 7 + RAW, s2 << 16 | s1);
    uint8_t ihdr[13];
    put32(ihdr, W);
    put32(ihdr + 4, H);
    ihdr[8] = 8; /* bit depth */
    ihdr[9] = 4; /* colour type: grey + alpha */
    ihdr[10] = ihdr[11] = ihdr[12] = 0;
    uint8_t file[8 + 25 + 12 + sizeof z + 12];
    const uint8_t sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    memcpy(file, sig, 8);
    size_t n = 8;
    n += png_chunk(file + n, "IHDR", ihdr, 13);
    n += png_chunk(file + n, "IDAT", z, sizeof z);
    n += png_chunk(file + n, "IEND", NULL, 0);
    char path[256];
    temp_path(path, sizeof path, "grey_alpha.png");
    write_bytes(path, file, n);
    tsk_picture* p = NULL;
    CHECK_MSG(tsk_picture_load(path, &p) == TSK_OK, "%s", tsk_last_error());
    if (p != NULL) {
        float got[W * H * 4];
        CHECK(tsk_picture_read_rgba(p, got, W * H * 4, 0) == TSK_OK);
        double worst = 0;
        for (int j = 0; j < H; ++j)
            for (int i = 0; i < W; ++i) {
                const float* q = got + (j * W + i) * 4;
                const double g = raw[j * ROW + 1 + 2 * i] / 255.0,
                             a = raw[j * ROW + 2 + 2 * i] / 255.0;
                worst = fmax(worst, fmax(fabs(q[0] - g), fmax(fabs(q[1] - g), fabs(q[2] - g))));
                worst = fmax(worst, fabs(q[3] - a));
            }
        CHECK_MSG(worst < 1e-6, "grey+alpha differs by %g", worst);
        tsk_picture_destroy(p);
    }
    remove(path);
}

TEST(test_bad_files_give_messages) {
    const size_t before = tsk_allocated_bytes();
    tsk_picture* p = (tsk_picture*)1;
    CHECK_STATUS(tsk_picture_load("/nonexistent/grass.png", &p), TSK_ERR_IO, "path");
    CHECK(p == NULL);
    char path[256];
    /* a PNG header declaring 30000 x 30000: refused from the header, nothing decoded */
    const uint8_t huge_png[33] = {0x89, 'P',  'N', 'G', '\r', '\n', 0x1A, '\n', 0,    0, 0,
                                  13,   'I',  'H', 'D', 'R',  0,    0,    0x75, 0x30, 0, 0,
                                  0x75, 0x30, 8,   6,   0,    0,    0,    0,    0,    0, 0};
    temp_path(path, sizeof path, "huge.png");
    write_bytes(path, huge_png, sizeof huge_png);
    CHECK_STATUS(tsk_picture_load(path, &p), TSK_ERR_LIMIT, "30000x30000");
    /* a JPEG frame header declaring 20000 x 100 */
    const uint8_t huge_jpg[] = {0xFF, 0xD8, 0xFF, 0xE0, 0,    4,    0, 0, 0xFF, 0xC0, 0,
                                11,   8,    0,    100,  0x4E, 0x20, 3, 0, 0,    0};
    temp_path(path, sizeof path, "huge.jpg");
    write_bytes(path, huge_jpg, sizeof huge_jpg);
    CHECK_STATUS(tsk_picture_load(path, &p), TSK_ERR_LIMIT, "20000x100");
    /* an OpenEXR header whose dataWindow is 0..29999 x 0..9 */
    uint8_t huge_exr[8 + 11 + 6 + 4 + 16 + 1] = {0x76, 0x2F, 0x31, 0x01, 2, 0, 0, 0};
    size_t e = 8;
    memcpy(huge_exr + e, "dataWindow", 11);
    e += 11;
    memcpy(huge_exr + e, "box2i", 6);
    e += 6;
    const int32_t box[5] = {16, 0, 0, 29999, 9}; /* size, xMin, yMin, xMax, yMax */
    for (int k = 0; k < 5; ++k)
        for (int b = 0; b < 4; ++b) huge_exr[e++] = (uint8_t)((uint32_t)box[k] >> (8 * b));
    huge_exr[e++] = 0;
    temp_path(path, sizeof path, "huge.exr");
    write_bytes(path, huge_exr, e);
    CHECK_STATUS(tsk_picture_load(path, &p), TSK_ERR_LIMIT, "30000x10");
    remove(path);
    /* not an image */
    temp_path(path, sizeof path, "text.png");
    write_bytes(path, (const uint8_t*)"hello, grass", 12);
    CHECK_STATUS(tsk_picture_load(path, &p), TSK_ERR_FORMAT, "not a PNG, JPEG or OpenEXR");
    temp_path(path, sizeof path, "empty.png");
    write_bytes(path, (const uint8_t*)"", 0);
    CHECK_STATUS(tsk_picture_load(path, &p), TSK_ERR_FORMAT, "empty");
    /* a truncated PNG and a truncated EXR: header fine, data missing */
    const int W = 40, H = 30;
    float* src = smooth_image(W, H);
    const char* exts[] = {"trunc.png", "trunc.exr", "trunc.jpg"};
    const int bits[] = {8, 32, 8};
    for (int k = 0; k < 3; ++k) {
        temp_path(path, sizeof path, exts[k]);
        CHECK(tsk_cvp_encode(path, src, W, H, k == 2 ? 3 : 4, bits[k]) == TSK_OK);
        FILE* f = fopen(path, "rb");
        uint8_t buf[20000];
        size_t n = f ? fread(buf, 1, sizeof buf, f) : 0;
        if (f) fclose(f);
        write_bytes(path, buf, n / 2);
        p = NULL;
        tsk_status s = tsk_picture_load(path, &p);
        /* JPEG decoders may return a partly grey image for a truncated stream; PNG and EXR
         * must fail */
        if (k < 2) CHECK_MSG(s == TSK_ERR_FORMAT, "%s: %s", exts[k], tsk_last_error());
        if (s == TSK_OK) tsk_picture_destroy(p);
        else CHECK(strstr(tsk_last_error(), "path") != NULL);
        remove(path);
    }
    /* a 2x2 picture is below the minimum */
    temp_path(path, sizeof path, "tiny.png");
    CHECK(tsk_cvp_encode(path, src, 2, 2, 4, 8) == TSK_OK);
    CHECK_STATUS(tsk_picture_load(path, &p), TSK_ERR_FORMAT, "at least");
    remove(path);
    temp_path(path, sizeof path, "huge.png");
    remove(path);
    temp_path(path, sizeof path, "huge.jpg");
    remove(path);
    temp_path(path, sizeof path, "text.png");
    remove(path);
    temp_path(path, sizeof path, "empty.png");
    remove(path);
    free(src);
    CHECK(tsk_allocated_bytes() == before);
}

TEST(test_bad_arguments_name_the_argument) {
    const int W = 32, H = 24;
    float* rgba = smooth_image(W, H);
    tsk_picture* p = NULL;
    CHECK_STATUS(tsk_picture_create(30000, 30000, rgba, 4, 0, &p), TSK_ERR_LIMIT, "width, height");
    CHECK_STATUS(tsk_picture_create(1, 1, rgba, 4, 0, &p), TSK_ERR_ARGUMENT, "at least");
    CHECK_STATUS(tsk_picture_create(W, H, rgba, 100, 0, &p), TSK_ERR_ARGUMENT, "rgba");
    rgba[17] = NAN;
    CHECK_STATUS(tsk_picture_create(W, H, rgba, W * H * 4, 0, &p), TSK_ERR_ARGUMENT, "rgba");
    rgba[17] = 0.5f;
    CHECK(tsk_picture_create(W, H, rgba, W * H * 4, 0, &p) == TSK_OK);
    uint8_t* mask = calloc(W * H, 1);
    float* fmask = calloc(W * H, sizeof(float));
    CHECK_STATUS(tsk_picture_add_layer_u8(p, mask, W * H - 1, NULL), TSK_ERR_ARGUMENT, "mask");
    CHECK_STATUS(tsk_picture_add_layer_u8(p, mask, W * H, NULL), TSK_ERR_ARGUMENT, "empty");
    mask[40] = 1; /* 1 is not vegetation in an 8-bit mask: the message says so */
    CHECK_STATUS(tsk_picture_add_layer_u8(p, mask, W * H, NULL), TSK_ERR_ARGUMENT, "255");
    fmask[3] = NAN;
    CHECK_STATUS(tsk_picture_add_layer_f32(p, fmask, W * H, NULL), TSK_ERR_ARGUMENT, "mask");
    for (int i = 0; i < W * H; ++i) fmask[i] = 1.0f;
    CHECK_STATUS(tsk_picture_add_layer_f32(p, fmask, W * H, NULL), TSK_ERR_ARGUMENT, "whole");
    tsk_layers_def ld = tsk_default_layers_def();
    CHECK_STATUS(tsk_picture_build(p, &ld), TSK_ERR_ARGUMENT, "no layer");
    for (int i = 0; i < W * H; ++i) fmask[i] = (i % W) > 10 && (i / W) > 8 ? 0.8f : 0.1f;
    CHECK(tsk_picture_add_layer_f32(p, fmask, W * H, NULL) == TSK_OK);
    float* out = malloc(W * H * 4 * sizeof(float));
    float vx = 0, vy = 0;
    tsk_picture_field f = {&vx, &vy, 1, 1, 0};
    tsk_warp_def d = tsk_default_warp_def();
    CHECK_STATUS(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, out, W * H * 4, NULL, 0, 0),
                 TSK_ERR_ARGUMENT, "not built");
    ld.feather = -1.0f;
    CHECK_STATUS(tsk_picture_build(p, &ld), TSK_ERR_ARGUMENT, "feather");
    ld = tsk_default_layers_def();
    ld.inpaint_radius = NAN;
    CHECK_STATUS(tsk_picture_build(p, &ld), TSK_ERR_ARGUMENT, "inpaint_radius");
    ld = tsk_default_layers_def();
    CHECK(tsk_picture_build(p, &ld) == TSK_OK);
    CHECK_STATUS(tsk_picture_layer_frame(p, 3, &d, &f, NULL, 0, out, W * H * 4, NULL, 0, 0),
                 TSK_ERR_ARGUMENT, "layer");
    d.lambda_x = NAN;
    CHECK_STATUS(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, out, W * H * 4, NULL, 0, 0),
                 TSK_ERR_ARGUMENT, "lambda_x");
    /* a finite but huge lambda (Blender's inf is FLT_MAX) is refused even on a still field,
       where it would pass and then fail every frame with wind (bad-input suite) */
    d.lambda_x = FLT_MAX;
    CHECK_STATUS(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, out, W * H * 4, NULL, 0, 0),
                 TSK_ERR_ARGUMENT, "lambda_x");
    d.lambda_x = 4.0f;
    d.lambda_y = -2e6f;
    CHECK_STATUS(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, out, W * H * 4, NULL, 0, 0),
                 TSK_ERR_ARGUMENT, "lambda_y");
    d.lambda_y = -TSK_WARP_MAX_LAMBDA;
    CHECK(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, out, W * H * 4, NULL, 0, 0) == TSK_OK);
    d = tsk_default_warp_def();
    d.cell_x = -4;
    CHECK_STATUS(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, out, W * H * 4, NULL, 0, 0),
                 TSK_ERR_ARGUMENT, "cell_x");
    d = tsk_default_warp_def();
    d.rigidity = 11.0f;
    CHECK_STATUS(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, out, W * H * 4, NULL, 0, 0),
                 TSK_ERR_ARGUMENT, "rigidity");
    d = tsk_default_warp_def();
    vx = INFINITY;
    CHECK_STATUS(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, out, W * H * 4, NULL, 0, 0),
                 TSK_ERR_ARGUMENT, "field");
    vx = 0;
    float* scale = calloc(W * H, sizeof(float));
    scale[5] = -1.0f;
    CHECK_STATUS(tsk_picture_layer_frame(p, 0, &d, &f, scale, W * H, out, W * H * 4, NULL, 0, 0),
                 TSK_ERR_ARGUMENT, "scale_map");
    CHECK_STATUS(tsk_picture_layer_frame(p, 0, &d, &f, scale, 7, out, W * H * 4, NULL, 0, 0),
                 TSK_ERR_ARGUMENT, "scale_map");
    CHECK_STATUS(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, out, 12, NULL, 0, 0),
                 TSK_ERR_ARGUMENT, "dst");
    CHECK_STATUS(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, NULL, 0, NULL, 0, 0),
                 TSK_ERR_ARGUMENT, "nothing");
    CHECK_STATUS(tsk_picture_composite(p, NULL, 2, out, W * H * 4), TSK_ERR_ARGUMENT, "layers");
    tsk_grabcut_def g = tsk_default_grabcut_def();
    CHECK_STATUS(tsk_picture_propose_mask(p, &g, NULL, 0, mask, W * H), TSK_ERR_ARGUMENT, "rect");
    g.rect_x = 0;
    g.rect_y = 0;
    g.rect_width = W;
    g.rect_height = H;
    CHECK_STATUS(tsk_picture_propose_mask(p, &g, NULL, 0, mask, W * H), TSK_ERR_ARGUMENT, "rect");
    g.rect_width = 10;
    g.rect_height = 10;
    mask[0] = 3;
    CHECK_STATUS(tsk_picture_propose_mask(p, &g, mask, W * H, mask, W * H), TSK_ERR_ARGUMENT,
                 "strokes");
    CHECK_STATUS(tsk_picture_propose_mask(p, &g, NULL, 0, mask, 5), TSK_ERR_ARGUMENT, "mask");
    int cx, cy;
    CHECK_STATUS(tsk_warp_grid_size(W, H, 0, 16, &cx, &cy), TSK_ERR_ARGUMENT, "cell_x");
    CHECK_STATUS(tsk_warp_grid_size(W, H, 16, 5000, &cx, &cy), TSK_ERR_ARGUMENT, "cell_y");
    tsk_picture_destroy(p);
    free(rgba);
    free(mask);
    free(fmask);
    free(out);
    free(scale);
}

/* ---- determinism ------------------------------------------------------------------------ */

/* The composite holds the background that OpenCV's cv::inpaint fills in, and Debian 12's
 * libopencv-photo binary inpaints with other bytes than the same source (4.6.0+dfsg-12)
 * built by native/portable/build_deps.sh, with Debian's flags or without (docs/platforms.md):
 * the portable build has its own golden composite. */
#ifdef TSK_PORTABLE_BUILD
#define PICTURE_COMPOSITE_GOLDEN 0x4b554f8f96b06913ull
#else
#define PICTURE_COMPOSITE_GOLDEN 0x8903afdc44991c12ull
#endif

/* Golden hashes (see tsk_test_fnv) of the warp (layer, UV), the composite, and the two Map UV
 * samplings of test_identical_bytes_with_1_and_2_threads. */
static const uint64_t PICTURE_GOLDEN[5] = {0x22f413763cc4bc6cull, 0x4753eab07922eb7eull,
                                           PICTURE_COMPOSITE_GOLDEN, 0x216d9e01bc4bdfa0ull,
                                           0x05283e72c01fc101ull};

TEST(test_identical_bytes_with_1_and_2_threads) {
    const int W = 200, H = 150, FW = 16, FH = 12;
    float* rgba = smooth_image(W, H);
    uint8_t* mask = calloc(W * H, 1);
    for (int y = 40; y < 140; ++y)
        for (int x = 30; x < 170; ++x) mask[y * W + x] = ((x * 7 + y * 3) % 23 < 20) ? 255 : 0;
    float vx[FW * FH], vy[FW * FH];
    for (int i = 0; i < FW * FH; ++i) {
        vx[i] = tsk_sinf(0.37f * i);
        vy[i] = tsk_cosf(0.21f * i);
    }
    tsk_picture_field f = {vx, vy, FW, FH, 1};
    float* out[2][5];
    for (int t = 0; t < 2; ++t) {
        CHECK(tsk_set_threads(t + 1) == TSK_OK);
        tsk_picture* p = NULL;
        CHECK(tsk_picture_create(W, H, rgba, (size_t)W * H * 4, 0, &p) == TSK_OK);
        CHECK(tsk_picture_add_layer_u8(p, mask, W * H, NULL) == TSK_OK);
        tsk_layers_def ld = tsk_default_layers_def();
        CHECK(tsk_picture_build(p, &ld) == TSK_OK);
        for (int k = 0; k < 5; ++k) out[t][k] = malloc(W * H * 4 * sizeof(float));
        tsk_warp_def d = tsk_default_warp_def();
        d.cell_x = 12;
        d.cell_y = 10;
        CHECK(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, out[t][0], W * H * 4, out[t][1],
                                      W * H * 4, 1) == TSK_OK);
        const float* layers[1] = {out[t][0]};
        CHECK(tsk_picture_composite(p, layers, 1, out[t][2], W * H * 4) == TSK_OK);
        d.sampling = TSK_SAMPLE_MAP_UV;
        CHECK(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, out[t][3], W * H * 4, NULL, 0, 1) ==
              TSK_OK);
        d.sampling = TSK_SAMPLE_MAP_UV_5;
        CHECK(tsk_picture_layer_frame(p, 0, &d, &f, NULL, 0, out[t][4], W * H * 4, NULL, 0, 1) ==
              TSK_OK);
        tsk_picture_destroy(p);
    }
    for (int k = 0; k < 5; ++k) {
        CHECK(memcmp(out[0][k], out[1][k], W * H * 4 * sizeof(float)) == 0);
        const uint64_t h = tsk_test_fnv(out[0][k], W * H * 4 * sizeof(float), TSK_TEST_FNV_START);
        CHECK_MSG(h == PICTURE_GOLDEN[k], "output %d's bytes changed: hash %#018llx", k,
                  (unsigned long long)h);
        free(out[0][k]);
        free(out[1][k]);
    }
    tsk_set_threads(0);
    free(rgba);
    free(mask);
}

/* A picture whose pixels and plates (48 bytes per pixel) exceed the budget is refused; so
 * is a layer that would take the built picture over it. */
TEST(test_picture_and_layers_over_memory_budget_are_refused) {
    const int w = 64, h = 32;
    const size_t n = (size_t)w * h;
    float* rgba = calloc(n * 4, sizeof *rgba);
    uint8_t* mask = calloc(n, 1);
    mask[5 * w + 5] = 255;
    tsk_picture* p = NULL;
    tsk_set_memory_budget((uint64_t)n * 48 - 1);
    CHECK_STATUS(tsk_picture_create(w, h, rgba, n * 4, 0, &p), TSK_ERR_LIMIT,
                 "picture: needs about");
    CHECK(p == NULL);
    tsk_set_memory_budget((uint64_t)n * 48);
    CHECK(tsk_picture_create(w, h, rgba, n * 4, 0, &p) == TSK_OK);
    /* one layer needs n * (21 + 48 + 25) + n * 21 bytes */
    CHECK_STATUS(tsk_picture_add_layer_u8(p, mask, n, NULL), TSK_ERR_LIMIT, "mask: needs");
    tsk_set_memory_budget((uint64_t)n * (21 * 2 + 48 + 25));
    CHECK(tsk_picture_add_layer_u8(p, mask, n, NULL) == TSK_OK);
    tsk_set_memory_budget(0);
    tsk_picture_destroy(p);
    free(rgba);
    free(mask);
}

TEST_MAIN(TEST_ENTRY(test_picture_and_layers_over_memory_budget_are_refused),
          TEST_ENTRY(test_warp_zero_displacement_is_identity_and_uv_is_pixel_centres),
          TEST_ENTRY(test_warp_integer_shift_is_exact),
          TEST_ENTRY(test_warp_fractional_shift_matches_reference_bilinear),
          TEST_ENTRY(test_warp_output_at_any_page_offset_gives_the_same_bytes),
          TEST_ENTRY(test_warp_allocation_failures_are_reported),
          TEST_ENTRY(test_corners_match_eq5_to_7_closed_form),
          TEST_ENTRY(test_rigidity_one_keeps_grid_shape),
          TEST_ENTRY(test_horizon_root_line_does_not_move),
          TEST_ENTRY(test_uv_pass_reproduces_native_warp),
          TEST_ENTRY(test_map_uv_sampling_exact_at_rest_and_for_integer_shifts),
          TEST_ENTRY(test_map_uv_5_matches_reference_ewa),
          TEST_ENTRY(test_map_uv_5_identity_keeps_a_constant_and_the_picture),
          TEST_ENTRY(test_map_uv_5_multiplies_by_the_uv_alpha),
          TEST_ENTRY(test_warp_map_uv_5_samples_its_own_uv_pass),
          TEST_NEEDS(test_inpainting_removes_the_layer, OpenCV),
          TEST_NEEDS(test_matte_is_one_inside_zero_outside_monotone, OpenCV),
          TEST_NEEDS(test_grabcut_separates_green_blob, OpenCV),
          TEST_NEEDS(test_composite_at_rest_and_far_pixels_never_move, OpenCV),
          TEST_NEEDS(test_several_layers_are_removed_front_to_back, OpenCV),
          TEST_NEEDS(test_load_png_jpeg_exr_variants, OpenCV),
          TEST_NEEDS(test_load_grey_alpha_png_written_by_hand, OpenCV),
          TEST_NEEDS(test_bad_files_give_messages, OpenCV),
          TEST_NEEDS(test_bad_arguments_name_the_argument, OpenCV),
          TEST_NEEDS(test_identical_bytes_with_1_and_2_threads, OpenCV))
