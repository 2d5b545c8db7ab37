/* Benchmark of the picture module: one 1920x1080 layer warped by a 16-px grid (seed 004,
 * eq. 5-8) per frame - warp + UV pass (headline picture_1080p), the UV pass alone and the
 * RGBA warp alone - with cv::remap of the same frame as the peer. Medians over repeats. */
#include "bench.h"
#include "tussock/picture.h"

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
    const char* names[3] = {"picture_1080p", "picture_1080p_uv", "picture_1080p_rgba"};
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
                 W, H, threads, FW, FH, mode == 0 ? "rgba+uv" : mode == 1 ? "uv" : "rgba");
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
    bench_emit("picture_1080p", remap_ms, "ms per frame", params, "opencv_remap");
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
