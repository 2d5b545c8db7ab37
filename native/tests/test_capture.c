/* Tests of the capture module: the pipeline against synthetic depth maps with analytic
 * blades (count, centreline, width, 3-D points; clean and with sensor-like noise), depth
 * files (PNG16, EXR, sequences) written by the test, the OpenNI2 Dummy device, .oni
 * recordings made by the test, and every bad input with its status and message. */
#include <stdint.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "bridge/opencv_capture_bridge.h"
#include "capture/depth_internal.h"
#include "capture_scene.h"

#include "test.h"
#include "tussock/capture.h"

#define W 640
#define H 480

static float g_depth[W * H];
static char g_dir[256];

__attribute__((unused)) static const char* tmp_path(const char* name) {
    static char buf[4][512];
    static int k;
    k = (k + 1) % 4;
    if (g_dir[0] == '\0') {
        snprintf(g_dir, sizeof g_dir, "/tmp/tsk_test_capture_%d", (int)getpid());
        mkdir(g_dir, 0700);
    }
    snprintf(buf[k], sizeof buf[k], "%s/%s", g_dir, name);
    return buf[k];
}

/* ---- comparison with the analytic blades ---------------------------------------------- */

typedef struct eval_stats {
    int blades, matched;
    double centre_mean_px, centre_max_px; /* knot (u,v) to the analytic centreline */
    double width_mean_mm, width_max_mm;   /* over s in [root+8 px, 0.9 L] */
    double width_mean_px;
    double xyz_mean_mm, xyz_max_mm;       /* knot xyz to the analytic 3-D point */
    double cover_root, cover_tip;         /* worst fraction of L reached at root and tip */
} eval_stats;

static void evaluate(const tsk_capture* cap, const scene_blade* sb, int nb, eval_stats* e) {
    memset(e, 0, sizeof *e);
    e->blades = tsk_capture_blade_count(cap);
    e->cover_root = 0.0;
    e->cover_tip = 1.0;
    const tsk_intrinsics K = tsk_capture_intrinsics(cap);
    const double f = sqrt((double)K.fx * K.fy);
    int used[16] = {0};
    long n_c = 0, n_w = 0;
    for (int b = 0; b < e->blades; ++b) {
        int32_t kc[TSK_CAPTURE_MAX_BLADES];
        uint32_t fl[TSK_CAPTURE_MAX_BLADES];
        tsk_capture_get_blades(cap, kc, fl, (size_t)e->blades);
        const int n = kc[b];
        float* xyz = malloc(sizeof(float) * 3 * (size_t)n);
        float* wm = malloc(sizeof(float) * (size_t)n);
        float* uv = malloc(sizeof(float) * 2 * (size_t)n);
        CHECK(tsk_capture_get_blade(cap, b, xyz, wm, uv, (size_t)n) == TSK_OK);
        /* the analytic blade whose tip is nearest to the captured tip */
        int best = -1;
        double bd = 1e30;
        for (int i = 0; i < nb; ++i) {
            double tx, ty;
            scene_point(&sb[i], sb[i].length, &tx, &ty);
            double d = hypot(tx - uv[2 * (n - 1)], ty - uv[2 * (n - 1) + 1]);
            if (d < bd) {
                bd = d;
                best = i;
            }
        }
        if (best >= 0 && bd < 15.0 && !used[best]) {
            used[best] = 1;
            ++e->matched;
            const scene_blade* B = &sb[best];
            double dist;
            const double s_root = scene_nearest(B, uv[0], uv[1], &dist);
            const double s_tip = scene_nearest(B, uv[2 * (n - 1)], uv[2 * (n - 1) + 1], &dist);
            if (s_root / B->length > e->cover_root) e->cover_root = s_root / B->length;
            if (s_tip / B->length < e->cover_tip) e->cover_tip = s_tip / B->length;
            for (int k = 0; k < n; ++k) {
                const double s = scene_nearest(B, uv[2 * k], uv[2 * k + 1], &dist);
                e->centre_mean_px += dist;
                if (dist > e->centre_max_px) e->centre_max_px = dist;
                ++n_c;
                const double z = scene_depth(B, s);
                double px, py;
                scene_point(B, s, &px, &py);
                const double gx = (px - K.cx) * z / K.fx, gy = (py - K.cy) * z / K.fy;
                const double d3 = 1000.0 * sqrt((xyz[3 * k] - gx) * (xyz[3 * k] - gx) +
                                                (xyz[3 * k + 1] - gy) * (xyz[3 * k + 1] - gy) +
                                                (xyz[3 * k + 2] - z) * (xyz[3 * k + 2] - z));
                e->xyz_mean_mm += d3;
                if (d3 > e->xyz_max_mm) e->xyz_max_mm = d3;
                if (s >= s_root + 8.0 && s <= 0.9 * B->length) {
                    const double wt = scene_width(B, s) * z / f;
                    const double we = 1000.0 * fabs(wm[k] - wt);
                    e->width_mean_mm += we;
                    e->width_mean_px += fabs(wm[k] - wt) * f / z;
                    if (we > e->width_max_mm) e->width_max_mm = we;
                    if (getenv("TSK_DEBUG") && we > 2.0)
                        printf("       blade %d k %d/%d s %.1f/%.0f (root %.1f) w %.2f px, truth %.2f px\n",
                               best, k, n, s, B->length, s_root, wm[k] * f / z, scene_width(B, s));
                    ++n_w;
                }
            }
        }
        free(xyz);
        free(wm);
        free(uv);
    }
    if (n_c) e->centre_mean_px /= (double)n_c, e->xyz_mean_mm /= (double)n_c;
    if (n_w) e->width_mean_mm /= (double)n_w, e->width_mean_px /= (double)n_w;
}

static void print_stats(const char* what, const eval_stats* e) {
    printf("     %s: %d blades (%d matched); centreline mean %.2f max %.2f px; width mean %.2f "
           "px = %.2f mm, max %.2f mm; 3-D mean %.2f max %.2f mm; cover root %.2f tip %.2f\n",
           what, e->blades, e->matched, e->centre_mean_px, e->centre_max_px, e->width_mean_px,
           e->width_mean_mm, e->width_max_mm, e->xyz_mean_mm, e->xyz_max_mm, e->cover_root,
           e->cover_tip);
}

static tsk_capture* run_fan(int noisy, uint64_t seed, scene_blade* sb, int* nb, eval_stats* e) {
    *nb = scene_fan(sb, 320.0, 450.0);
    scene_render(sb, *nb, W, H, 1.6f, g_depth);
    if (noisy) scene_noise(g_depth, W, H, 0.0015, 0.02, seed);
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    tsk_capture_def def = tsk_default_capture_def();
    tsk_status s = tsk_capture_process(cap, &def, g_depth, W, H);
    CHECK_MSG(s == TSK_OK, "%s", tsk_last_error());
    evaluate(cap, sb, *nb, e);
    return cap;
}

/* ---- the pipeline on analytic blades -------------------------------------------------- */

TEST(test_capture_clean_fan_gives_exact_blades_and_profiles) {
    scene_blade sb[8];
    int nb;
    eval_stats e;
    tsk_capture* cap = run_fan(0, 0, sb, &nb, &e);
    print_stats("clean", &e);
    /* Tolerances: the depth map is a binary raster sampled at pixel centres, so each edge
     * is known to +-0.5 px; the centreline (mean of two edges) to +-0.5 px and the width
     * to +-1 px in the worst case, less on average after smoothing along the contour.
     * At 0.8 m with f = 570 px, 1 px is 1.4 mm. */
    CHECK(e.blades == 5);
    CHECK(e.matched == 5);
    CHECK(e.centre_mean_px <= 0.25);
    CHECK(e.centre_max_px <= 1.0);
    CHECK(e.width_mean_px <= 0.4);
    CHECK(e.width_max_mm <= 1.5);
    CHECK(e.xyz_mean_mm <= 0.5);
    CHECK(e.xyz_max_mm <= 2.0);
    CHECK(e.cover_tip >= 0.97);
    CHECK(e.cover_root <= 0.35);
    float near_m, far_m;
    tsk_capture_band(cap, &near_m, &far_m);
    CHECK(near_m > 0.5f && near_m < 0.72f); /* blades span 0.72 .. 0.82 m */
    CHECK(far_m > 0.82f && far_m < 1.0f);   /* the wall at 1.6 m is left out */
    tsk_capture_destroy(cap);
}

TEST(test_capture_noisy_fan_keeps_count_and_tolerances) {
    scene_blade sb[8];
    int nb;
    for (uint64_t seed = 1; seed <= 3; ++seed) {
        eval_stats e;
        tsk_capture* cap = run_fan(1, seed, sb, &nb, &e);
        print_stats("noisy", &e);
        CHECK(e.blades == 5);
        CHECK(e.matched == 5);
        /* as above, plus depth noise (sigma 1 mm at 0.8 m, reduced by the 5x5 median) and
         * dropout holes that the closing fills, each adding up to half a pixel of edge */
        CHECK(e.centre_mean_px <= 0.3);
        CHECK(e.centre_max_px <= 1.5);
        CHECK(e.width_mean_px <= 0.5);
        CHECK(e.width_max_mm <= 2.0);
        CHECK(e.xyz_mean_mm <= 0.75);
        CHECK(e.xyz_max_mm <= 2.5);
        CHECK(e.cover_tip >= 0.95);
        CHECK(e.cover_root <= 0.35);
        tsk_capture_destroy(cap);
    }
}

TEST_MAIN(TEST_ENTRY(test_capture_clean_fan_gives_exact_blades_and_profiles),
          TEST_ENTRY(test_capture_noisy_fan_keeps_count_and_tolerances))
