/* Benchmark of the capture pipeline: capture_640x480 = ms per frame from a depth map to
 * blade profiles (mask, morphology, contours, partition, skeletons, widths, 3-D knots),
 * one thread, on the 5-blade test cluster with sensor-like noise; median of 60 runs.
 * With `--images DIR` it also writes the debug images (depth, mask, labels, overlay) of
 * that frame as PNG files into DIR, for the documentation. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <string.h>

#include "../tests/capture_scene.h"
#include "bench.h"
#include "bridge/opencv_capture_bridge.h"
#include "tussock/capture.h"

#define W 640
#define H 480
#define RUNS 60

static float g_depth[W * H];

static int write_images(const char* dir, const tsk_capture* cap) {
    static uint8_t img[W * H];
    static uint8_t rgb[W * H * 3];
    static const char* names[4] = {"capture_depth.png", "capture_mask.png", "capture_labels.png",
                                   "capture_overlay.png"};
    /* distinct colours for labels 1..n (BGR, as OpenCV writes) */
    static const uint8_t pal[8][3] = {{60, 180, 75},  {200, 130, 0},  {75, 25, 230},
                                      {25, 225, 255}, {240, 50, 230}, {180, 30, 145},
                                      {48, 130, 245}, {240, 240, 70}};
    char path[1024];
    for (int k = 0; k < 4; ++k) {
        if (tsk_capture_get_image(cap, (tsk_capture_image)k, img, W * H) != TSK_OK) return 1;
        snprintf(path, sizeof path, "%s/%s", dir, names[k]);
        tsk_status s;
        if (k == TSK_IMAGE_LABELS) {
            for (int i = 0; i < W * H; ++i) {
                const uint8_t l = img[i];
                for (int c = 0; c < 3; ++c)
                    rgb[3 * i + c] = l == 0 ? 0 : l == 255 ? 128 : pal[(l - 1) % 8][c];
            }
            s = tsk_cvb_write_png8(path, rgb, W, H, 3);
        } else {
            s = tsk_cvb_write_png8(path, img, W, H, 1);
        }
        if (s != TSK_OK) {
            fprintf(stderr, "%s\n", tsk_last_error());
            return 1;
        }
        fprintf(stderr, "wrote %s\n", path);
    }
    return 0;
}

int main(int argc, char** argv) {
    const char* images = NULL;
    int nargs = argc;
    for (int i = 1; i < argc; ++i)
        if (strcmp(argv[i], "--images") == 0 && i + 1 < argc) {
            images = argv[i + 1];
            nargs = i; /* names after --images are not filters */
            break;
        }
    if (!bench_wanted(nargs, argv, "capture_640x480")) return 0;
    tsk_set_threads(1);
    scene_blade sb[8];
    const int nb = scene_fan(sb, 320.0, 450.0);
    scene_render(sb, nb, W, H, 1.6f, g_depth);
    scene_noise(g_depth, W, H, 0.0015, 0.02, 11);
    tsk_capture* cap = NULL;
    if (tsk_capture_create(&cap) != TSK_OK) return 1;
    const tsk_capture_def def = tsk_default_capture_def();
    double t[RUNS];
    int blades = 0;
    for (int r = -3; r < RUNS; ++r) { /* three warm-up runs */
        const double t0 = bench_now_s();
        if (tsk_capture_process(cap, &def, g_depth, W, H) != TSK_OK) {
            fprintf(stderr, "capture failed: %s\n", tsk_last_error());
            return 1;
        }
        const double dt = bench_now_s() - t0;
        if (r >= 0) t[r] = dt * 1e3;
        blades = tsk_capture_blade_count(cap);
    }
    const double med = bench_median(t, RUNS);
    char params[256];
    snprintf(params, sizeof params,
             "\"threads\": 1, \"blades\": %d, \"knots\": %d, \"runs\": %d, \"auto_band\": true, "
             "\"noise_mm_at_1m\": 1.5, \"dropout\": 0.02, \"target_ms\": 5",
             blades, tsk_capture_knot_total(cap), RUNS);
    bench_emit("capture_640x480", med, "ms per frame", params, NULL);
    int rc = 0;
    if (images) rc = write_images(images, cap);
    tsk_capture_destroy(cap);
    return rc;
}
