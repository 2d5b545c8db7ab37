/* Benchmark of the picture module. Headline picture_1080p: one frame as the add-on makes
 * it - the shared wind's 128^2 fluid + wave continuum stepped one frame (2 steps of 1/48 s,
 * seed 004 eq. 1-4), its continuum sampled over the picture, then one 1920x1080 layer
 * warped by a 16-px grid (eq. 5-8) to RGBA + UV pass. Also the warp alone
 * (picture_1080p_warp), the UV pass alone, the RGBA warp alone, with cv::remap of the same
 * frame as the peer. Medians over repeats. */
#include "bench.h"
#include "tussock/picture.h"
#include "tussock/wind.h"

#include "bridge/opencv_picture_bridge.h"

#include <math.h>
#include <stdint.h>

enum { W = 1920, H = 1080, FW = 64, FH = 64, REPS = 15 };

static void fill_field(float* vx, float* vy, int frame) {
    /* a travelling sine wave standing in for the wind continuum */
    const float t = (float)frame / 24.0f;
    for (int b = 0; b < FH; ++b)
        for (int a = 0; a < FW; ++a) {
            vx[b * FW + a] = 0.8f * sinf(0.4f * a - 0.15f * b - 3.0f * t);
            vy[b * FW + a] = 0.2f * cosf(0.3f * a + 0.2f * b - 2.0f * t);
        }
}

/* The headline frame: wind 128^2 fluid + continuum stepped one frame (as the add-on: 2
 * steps of 1/48 s at 24 fps), the continuum sampled at a 128x72 field over the picture
 * (which spans the wind grid's width), the layer warped to RGBA and the UV pass. */
static void bench_wind_frame(const tsk_picture* pic, float* out, float* uv) {
    enum { NX = 128, FX = 128, FY = 72, STEPS = 2, WARMUP = 48 };
    const float side = 20.0f, cell = side / NX;
    tsk_wind_def wd = tsk_default_wind_def();
    wd.fluid.nx = wd.fluid.ny = NX;
    wd.fluid.cell_size = cell;
    wd.fluid.origin_x = wd.fluid.origin_y = -0.5f * side;
    wd.fluid.dt = 1.0f / 48.0f;
    wd.fluid.speed = 4.0f;
    wd.fluid.decay = 0.2f;
    wd.continuum.enabled = 1;
    wd.continuum.c = 2.0f;
    wd.continuum.gamma = 0.96f;
    tsk_wind_source src = tsk_default_wind_source();
    src.x = -8.0f;
    src.y = 0.0f;
    src.dir_x = 1.0f;
    src.dir_y = 0.0f;
    src.strength = 1.0f;
    src.radius = 6.0f;
    src.interval = 1.0f;
    tsk_wind* wind = NULL;
    float *px = tsk_alloc(FX * FY * sizeof(float), "field x"),
          *py = tsk_alloc(FX * FY * sizeof(float), "field y");
    float *vx = tsk_alloc(FX * FY * sizeof(float), "wind vx"),
          *vy = tsk_alloc(FX * FY * sizeof(float), "wind vy");
    float *sx = tsk_alloc(FX * FY * sizeof(float), "sway x"),
          *sy = tsk_alloc(FX * FY * sizeof(float), "sway y");
    if (!px || !py || !vx || !vy || !sx || !sy || tsk_wind_create(&wd, &wind) != TSK_OK ||
        tsk_wind_set_sources(wind, &src, 1) != TSK_OK ||
        tsk_wind_step(wind, WARMUP * STEPS) != TSK_OK) {
        fprintf(stderr, "bench_picture wind: %s\n", tsk_last_error());
        goto done;
    }
    const float ph = side * (float)H / W; /* the picture spans the grid's width */
    for (int b = 0; b < FY; ++b)
        for (int a = 0; a < FX; ++a) {
            px[b * FX + a] = -0.5f * side + (a + 0.5f) * side / FX;
            py[b * FX + a] = -0.5f * ph + (b + 0.5f) * ph / FY;
        }
    const size_t n = (size_t)W * H;
    tsk_warp_def d = tsk_default_warp_def();
    d.lambda_x = 24.0f;
    d.lambda_y = 8.0f;
    tsk_picture_field f = {sx, sy, FX, FY, 1};
    double t[REPS], tw[REPS];
    for (int r = 0; r < REPS; ++r) {
        double s0 = bench_now_s();
        tsk_wind_step(wind, STEPS);
        tsk_wind_sample(wind, tsk_wind_time(wind), FX * FY, px, py, vx, vy, sx, sy);
        tw[r] = bench_now_s() - s0;
        tsk_picture_layer_frame(pic, 0, &d, &f, NULL, 0, out, n * 4, uv, n * 4, 1);
        t[r] = bench_now_s() - s0;
    }
    char params[320];
    snprintf(params, sizeof params,
             "\"width\": %d, \"height\": %d, \"layers\": 1, \"cell\": 16, \"threads\": %d, "
             "\"wind\": \"fluid %dx%d + continuum, %d steps of 1/48 s\", \"field\": \"%dx%d\", "
             "\"outputs\": \"rgba+uv\", \"sampling\": \"bilinear\"",
             W, H, tsk_get_threads(), NX, NX, STEPS, FX, FY);
    bench_emit("picture_1080p", 1e3 * bench_median(t, REPS), "ms per frame", params, NULL);
    snprintf(params, sizeof params,
             "\"grid\": \"%dx%d\", \"steps\": %d, \"field\": \"%dx%d\", \"threads\": %d", NX, NX,
             STEPS, FX, FY, tsk_get_threads());
    bench_emit("picture_1080p_wind", 1e3 * bench_median(tw, REPS), "ms per frame", params, NULL);
done:
    tsk_wind_destroy(wind);
    tsk_free(px);
    tsk_free(py);
    tsk_free(vx);
    tsk_free(vy);
    tsk_free(sx);
    tsk_free(sy);
}

static void bench_picture(int argc, char** argv) {
    if (!bench_wanted(argc, argv, "picture_1080p")) return;
    const size_t n = (size_t)W * H;
    float* rgba = tsk_alloc(n * 4 * sizeof(float), "bench picture");
    uint8_t* mask = tsk_alloc(n, "bench mask");
    float* out = tsk_alloc(n * 4 * sizeof(float), "bench frame");
    float* uv = tsk_alloc(n * 4 * sizeof(float), "bench uv");
    float* mx = tsk_alloc(n * sizeof(float), "bench map");
    float* my = tsk_alloc(n * sizeof(float), "bench map");
    float* layer = tsk_alloc(n * 4 * sizeof(float), "bench layer");
    float* vx = tsk_alloc(FW * FH * sizeof(float), "field");
    float* vy = tsk_alloc(FW * FH * sizeof(float), "field");
    if (!rgba || !mask || !out || !uv || !mx || !my || !layer || !vx || !vy) return;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            float* p = rgba + ((size_t)y * W + x) * 4;
            const float grass_top = 620.0f + 40.0f * sinf(0.013f * x);
            const int g = (float)y > grass_top;
            mask[(size_t)y * W + x] = g ? 255 : 0;
            const float n0 = tsk_rand01(5, (uint64_t)x, (uint64_t)y, 0);
            p[0] = g ? 0.2f + 0.2f * n0 : 0.5f + 0.1f * sinf(0.01f * y);
            p[1] = g ? 0.5f + 0.3f * n0 : 0.6f;
            p[2] = g ? 0.1f : 0.9f - 0.2f * (float)y / H;
            p[3] = 1.0f;
        }
    tsk_picture* pic = NULL;
    tsk_layers_def ld = tsk_default_layers_def();
    double t0 = bench_now_s();
    if (tsk_picture_create(W, H, rgba, n * 4, 0, &pic) != TSK_OK ||
        tsk_picture_add_layer_u8(pic, mask, n, NULL) != TSK_OK ||
        tsk_picture_build(pic, &ld) != TSK_OK) {
        fprintf(stderr, "bench_picture: %s\n", tsk_last_error());
        return;
    }
    const double build_s = bench_now_s() - t0;
    tsk_picture_read_layer(pic, 0, layer, n * 4, 0);
    tsk_warp_def d = tsk_default_warp_def(); /* 16-px cells */
    tsk_picture_field f = {vx, vy, FW, FH, 1};
    const int threads = tsk_get_threads();
    char params[256];
    const char* names[3] = {"picture_1080p_warp", "picture_1080p_uv", "picture_1080p_rgba"};
    for (int mode = 0; mode < 3; ++mode) {
        double t[REPS];
        for (int r = 0; r < REPS; ++r) {
            fill_field(vx, vy, r);
            double s0 = bench_now_s();
            tsk_picture_layer_frame(pic, 0, &d, &f, NULL, 0, mode == 1 ? NULL : out,
                                    mode == 1 ? 0 : n * 4, mode == 2 ? NULL : uv,
                                    mode == 2 ? 0 : n * 4, 1);
            t[r] = bench_now_s() - s0;
        }
        snprintf(params, sizeof params,
                 "\"width\": %d, \"height\": %d, \"layers\": 1, \"cell\": 16, \"threads\": %d, "
                 "\"field\": \"%dx%d\", \"outputs\": \"%s\", \"sampling\": \"bilinear\"",
                 W, H, threads, FW, FH,
                 mode == 0   ? "rgba+uv"
                 : mode == 1 ? "uv"
                             : "rgba");
        bench_emit(names[mode], 1e3 * bench_median(t, REPS), "ms per frame", params, NULL);
    }
    /* peer: cv::remap of the same layer with the same source points (maps precomputed) */
    fill_field(vx, vy, 0);
    tsk_picture_layer_frame(pic, 0, &d, &f, NULL, 0, NULL, 0, uv, n * 4, 0);
    for (size_t i = 0; i < n; ++i) {
        mx[i] = uv[4 * i] * W - 0.5f;
        my[i] = (1.0f - uv[4 * i + 1]) * H - 0.5f;
    }
    double t[REPS];
    for (int r = 0; r < REPS; ++r) {
        double s0 = bench_now_s();
        tsk_cvp_remap(layer, W, H, mx, my, out, threads);
        t[r] = bench_now_s() - s0;
    }
    snprintf(params, sizeof params,
             "\"width\": %d, \"height\": %d, \"threads\": %d, \"maps\": \"precomputed\", "
             "\"interpolation\": \"INTER_LINEAR\"",
             W, H, threads);
    const double remap_ms = 1e3 * bench_median(t, REPS);
    bench_emit("picture_1080p_rgba", remap_ms, "ms per frame", params, "opencv_remap");
    bench_emit("picture_1080p_warp", remap_ms, "ms per frame", params, "opencv_remap");
    bench_emit("picture_1080p", remap_ms, "ms per frame", params, "opencv_remap");
    bench_wind_frame(pic, out, uv);
    /* the same frame sampled as Blender's Map UV draws it (for previews equal to renders) */
    d.sampling = TSK_SAMPLE_MAP_UV;
    for (int r = 0; r < REPS; ++r) {
        fill_field(vx, vy, r);
        double s0 = bench_now_s();
        tsk_picture_layer_frame(pic, 0, &d, &f, NULL, 0, out, n * 4, uv, n * 4, 1);
        t[r] = bench_now_s() - s0;
    }
    d.sampling = TSK_SAMPLE_BILINEAR;
    snprintf(params, sizeof params,
             "\"width\": %d, \"height\": %d, \"layers\": 1, \"cell\": 16, \"threads\": %d, "
             "\"outputs\": \"rgba+uv\", \"sampling\": \"map_uv\"",
             W, H, threads);
    bench_emit("picture_1080p_map_uv", 1e3 * bench_median(t, REPS), "ms per frame", params, NULL);
    /* single-thread headline, for the record */
    tsk_set_threads(1);
    for (int r = 0; r < REPS; ++r) {
        fill_field(vx, vy, r);
        double s0 = bench_now_s();
        tsk_picture_layer_frame(pic, 0, &d, &f, NULL, 0, out, n * 4, uv, n * 4, 1);
        t[r] = bench_now_s() - s0;
    }
    tsk_set_threads(0);
    snprintf(params, sizeof params,
             "\"width\": %d, \"height\": %d, \"layers\": 1, \"cell\": 16, \"threads\": 1, "
             "\"outputs\": \"rgba+uv\"",
             W, H);
    bench_emit("picture_1080p_1t", 1e3 * bench_median(t, REPS), "ms per frame", params, NULL);
    snprintf(params, sizeof params, "\"width\": %d, \"height\": %d, \"method\": \"telea\"", W, H);
    bench_emit("picture_1080p_build", build_s * 1e3, "ms per picture", params, NULL);
    tsk_picture_destroy(pic);
    tsk_free(rgba);
    tsk_free(mask);
    tsk_free(out);
    tsk_free(uv);
    tsk_free(mx);
    tsk_free(my);
    tsk_free(layer);
    tsk_free(vx);
    tsk_free(vy);
}

int main(int argc, char** argv) {
    bench_picture(argc, argv);
    return 0;
}
