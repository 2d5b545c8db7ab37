/* Tests of the capture module: the pipeline against synthetic depth maps with analytic
 * blades (count, centreline, width, 3-D points; clean and with sensor-like noise), depth
 * files (PNG16, EXR, sequences) written by the test, the OpenNI2 Dummy device, .oni
 * recordings made by the test, and every bad input with its status and message. */
#define _GNU_SOURCE
#include <errno.h>
#include <signal.h>
#include <stdint.h>
#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#include <tlhelp32.h>
#else
#include <sys/socket.h>
#include <sys/wait.h>
#endif
#include <dirent.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "bridge/opencv_capture_bridge.h"
#include "capture/depth_internal.h"
#include "capture/oni_reader_protocol.h"
#include "capture_scene.h"
#include "oni_writer.h"

#include "test.h"
#define TSK_TEST_TMP_NAME "capture"
#include "test_tmp.h"
#include "tussock/capture.h"

#define W 640
#define H 480

static float g_depth[W * H];

/* OpenNI2's drivers (PS1080, PSLink, Dummy, OniFile) keep allocations that they never free
 * within a process; they are not Tussock's. */
const char* __lsan_default_suppressions(void);
const char* __lsan_default_suppressions(void) {
    return "leak:libOpenNI2\nleak:libPS1080\nleak:libPSLink\nleak:libDummyDevice\n"
           "leak:libOniFile\n";
}

/* ---- comparison with the analytic blades ---------------------------------------------- */

typedef struct eval_stats {
    int blades, matched;
    double centre_mean_px, centre_max_px; /* knot (u,v) to the analytic centreline */
    double width_mean_mm, width_max_mm; /* over s in [root+8 px, 0.9 L] */
    double width_mean_px;
    double xyz_mean_mm, xyz_max_mm; /* knot xyz to the analytic 3-D point */
    double cover_root, cover_tip; /* worst fraction of L reached at root and tip */
    double root_gap_px; /* worst distance of a root knot to the true root */
    double shared_width_px; /* worst mean |width error| over s < 0.3 L */
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
            /* where the blade attaches: hidden under its neighbours' bases, so the root knot
             * is measured by its own figure and left out of the maxima below */
            const double gap = hypot(uv[0] - B->bx, uv[1] - B->by);
            if (gap > e->root_gap_px) e->root_gap_px = gap;
            double sw = 0.0;
            int nsw = 0;
            for (int k = 0; k < n; ++k) {
                const double s = scene_nearest(B, uv[2 * k], uv[2 * k + 1], &dist);
                if (s < 0.3 * B->length) {
                    sw += fabs(wm[k] * f / scene_depth(B, s) - scene_width(B, s));
                    ++nsw;
                }
                e->centre_mean_px += dist;
                if (dist > e->centre_max_px && k > 0) e->centre_max_px = dist;
                if (getenv("TSK_DEBUG") && dist > 1.0)
                    printf("       blade %d k %d/%d s %.1f/%.0f off centre %.2f px\n", best, k, n,
                           s, B->length, dist);
                ++n_c;
                const double z = scene_depth(B, s);
                double px, py;
                scene_point(B, s, &px, &py);
                const double gx = (px - K.cx) * z / K.fx, gy = (py - K.cy) * z / K.fy;
                const double d3 = 1000.0 * sqrt((xyz[3 * k] - gx) * (xyz[3 * k] - gx) +
                                                (xyz[3 * k + 1] - gy) * (xyz[3 * k + 1] - gy) +
                                                (xyz[3 * k + 2] - z) * (xyz[3 * k + 2] - z));
                e->xyz_mean_mm += d3;
                if (d3 > e->xyz_max_mm && k > 0) e->xyz_max_mm = d3;
                if (s >= s_root + 8.0 && s <= 0.9 * B->length) {
                    const double wt = scene_width(B, s) * z / f;
                    const double we = 1000.0 * fabs(wm[k] - wt);
                    e->width_mean_mm += we;
                    e->width_mean_px += fabs(wm[k] - wt) * f / z;
                    if (we > e->width_max_mm) e->width_max_mm = we;
                    if (getenv("TSK_DEBUG") && we > 2.0)
                        printf(
                            "       blade %d k %d/%d s %.1f/%.0f (root %.1f) w %.2f px, truth %.2f "
                            "px\n",
                            best, k, n, s, B->length, s_root, wm[k] * f / z, scene_width(B, s));
                    ++n_w;
                }
            }
            if (nsw > 0 && sw / nsw > e->shared_width_px) e->shared_width_px = sw / nsw;
        }
        free(xyz);
        free(wm);
        free(uv);
    }
    if (n_c) e->centre_mean_px /= (double)n_c, e->xyz_mean_mm /= (double)n_c;
    if (n_w) e->width_mean_mm /= (double)n_w, e->width_mean_px /= (double)n_w;
}

static void print_stats(const char* what, const eval_stats* e) {
    printf(
        "     %s: %d blades (%d matched); centreline mean %.2f max %.2f px; width mean %.2f "
        "px = %.2f mm, max %.2f mm; 3-D mean %.2f max %.2f mm; cover root %.2f tip %.2f; "
        "root gap %.2f px; shared-part width %.2f px\n",
        what, e->blades, e->matched, e->centre_mean_px, e->centre_max_px, e->width_mean_px,
        e->width_mean_mm, e->width_max_mm, e->xyz_mean_mm, e->xyz_max_mm, e->cover_root,
        e->cover_tip, e->root_gap_px, e->shared_width_px);
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
    /* whole blades (issue 31): from the base, through the first 29 % that the five share,
     * to the tip; the root knot within 2 px of where the blade attaches (the end of a
     * blade inside its neighbours' bases is hidden: the walk stops where the union ends),
     * and the width in the shared part the blade's own (the cluster is 2-5x as wide) */
    CHECK(e.cover_tip >= 0.99);
    CHECK(e.cover_root <= 0.02);
    CHECK(e.root_gap_px <= 2.0);
    CHECK(e.shared_width_px <= 1.0);
    /* no blade touches the border or is one-sided */
    uint32_t fl[8] = {0};
    if (e.blades == 5) CHECK(tsk_capture_get_blades(cap, NULL, fl, 5) == TSK_OK);
    for (int b = 0; b < 5; ++b) CHECK(fl[b] == 0);
    float near_m, far_m;
    tsk_capture_band(cap, &near_m, &far_m);
    CHECK(near_m > 0.5f && near_m < 0.72f); /* blades span 0.72 .. 0.82 m */
    CHECK(far_m > 0.82f && far_m < 1.0f); /* the wall at 1.6 m is left out */
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
        CHECK(e.cover_tip >= 0.98);
        CHECK(e.cover_root <= 0.02);
        CHECK(e.root_gap_px <= 2.0);
        CHECK(e.shared_width_px <= 1.2);
        tsk_capture_destroy(cap);
    }
}

/* Fails when a skeleton stops at the partition's cut (seed 000 §4.2's split between
 * neighbours), as it did before issue 31: there the blades cover only 70 % of their length
 * and their widths at the cut are the cluster's. */
TEST(test_capture_crossing_blades_run_from_the_base_through_the_shared_part) {
    scene_blade sb[4];
    const int nb = scene_crossing_fan(sb, 320.0, 450.0);
    for (int noisy = 0; noisy <= 1; ++noisy) {
        scene_render(sb, nb, W, H, 1.6f, g_depth);
        if (noisy) scene_noise(g_depth, W, H, 0.0015, 0.02, 5);
        tsk_capture* cap = NULL;
        CHECK(tsk_capture_create(&cap) == TSK_OK);
        tsk_capture_def def = tsk_default_capture_def();
        CHECK(tsk_capture_process(cap, &def, g_depth, W, H) == TSK_OK);
        eval_stats e;
        evaluate(cap, sb, nb, &e);
        print_stats(noisy ? "crossing, noisy" : "crossing", &e);
        CHECK(e.blades == 4); /* crossing above the base, they stay four blades */
        CHECK(e.matched == 4);
        CHECK(e.cover_root <= 0.02);
        CHECK(e.cover_tip >= 0.98);
        CHECK(e.root_gap_px <= 3.5);
        CHECK(e.centre_mean_px <= 0.3);
        CHECK(e.centre_max_px <= 1.5); /* the shared part walked by the fitted heading */
        CHECK(e.shared_width_px <= 1.2); /* 14 px blades in a 30-40 px wide shared part */
        CHECK(e.width_mean_px <= 0.6);
        CHECK(e.xyz_mean_mm <= 1.0);
        tsk_capture_destroy(cap);
    }
}

TEST(test_capture_single_blade_is_one_blade_root_to_tip) {
    scene_blade b = {300.0, 440.0, 0.15, 0.0009, 330.0, 18.0, 0.9, -0.0002};
    scene_render(&b, 1, W, H, 0.0f, g_depth);
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    tsk_capture_def def = tsk_default_capture_def();
    CHECK(tsk_capture_process(cap, &def, g_depth, W, H) == TSK_OK);
    eval_stats e;
    evaluate(cap, &b, 1, &e);
    CHECK(e.blades == 1);
    CHECK(e.matched == 1);
    /* a free-standing blade is covered from its root to its tip */
    CHECK(e.cover_root <= 0.01);
    CHECK(e.cover_tip >= 0.99);
    CHECK(e.root_gap_px <= 1.5);
    CHECK(e.centre_max_px <= 1.0);
    float uv[2 * 1000];
    int32_t kc = 0;
    CHECK(tsk_capture_get_blades(cap, &kc, NULL, 1) == TSK_OK);
    CHECK(kc > 100 && kc < 1000);
    CHECK(tsk_capture_get_blade(cap, 0, NULL, NULL, uv, (size_t)kc) == TSK_OK);
    CHECK(uv[1] > uv[2 * (kc - 1) + 1]); /* root below the tip: ordered root -> tip */
    /* knots are evenly spaced by knot_spacing (2 px) */
    double gap_max = 0.0, gap_min = 1e9;
    for (int k = 1; k < kc; ++k) {
        double g = hypot(uv[2 * k] - uv[2 * k - 2], uv[2 * k + 1] - uv[2 * k - 1]);
        if (g > gap_max) gap_max = g;
        if (g < gap_min) gap_min = g;
    }
    CHECK(gap_min > 1.5 && gap_max < 2.5);
    tsk_capture_destroy(cap);
}

TEST(test_capture_centroid_mode_splits_a_lone_blade_but_root_mode_does_not) {
    /* documents why the default centre is the base: from the centroid of a lone straight
     * blade both ends are far, so the seed's literal centre finds two "tips" */
    scene_blade b = {320.0, 440.0, 0.0, 0.0001, 340.0, 16.0, 0.9, 0.0};
    scene_render(&b, 1, W, H, 0.0f, g_depth);
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    tsk_capture_def def = tsk_default_capture_def();
    def.root = TSK_ROOT_CENTROID;
    CHECK(tsk_capture_process(cap, &def, g_depth, W, H) == TSK_OK);
    CHECK(tsk_capture_blade_count(cap) == 2);
    def.root = TSK_ROOT_BOTTOM;
    CHECK(tsk_capture_process(cap, &def, g_depth, W, H) == TSK_OK);
    CHECK(tsk_capture_blade_count(cap) == 1);
    tsk_capture_destroy(cap);
}

TEST(test_capture_blade_cut_by_border_is_flagged) {
    scene_blade sb[8];
    int nb = scene_fan(sb, 320.0, 450.0);
    sb[4].theta = 1.1; /* the right blade runs out of the picture on the right */
    sb[4].length = 340.0;
    double tx, ty;
    scene_point(&sb[4], sb[4].length, &tx, &ty);
    CHECK(tx > W + 10.0);
    scene_render(sb, nb, W, H, 1.6f, g_depth);
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    tsk_capture_def def = tsk_default_capture_def();
    CHECK(tsk_capture_process(cap, &def, g_depth, W, H) == TSK_OK);
    const int n = tsk_capture_blade_count(cap);
    CHECK(n == 5);
    int32_t kc[16];
    uint32_t fl[16];
    float uv[2 * 2000];
    int flagged = 0, flagged_right = 0;
    if (n == 5) {
        CHECK(tsk_capture_get_blades(cap, kc, fl, 5) == TSK_OK);
        for (int b = 0; b < 5; ++b) {
            if (!(fl[b] & TSK_BLADE_CUT_BY_BORDER)) continue;
            ++flagged;
            CHECK(tsk_capture_get_blade(cap, b, NULL, NULL, uv, (size_t)kc[b]) == TSK_OK);
            /* it is the one whose tip touches the right border */
            if (uv[2 * (kc[b] - 1)] > W - 4 && (fl[b] & TSK_BLADE_TIP_AT_BORDER)) ++flagged_right;
        }
    }
    CHECK(flagged == 1);
    CHECK(flagged_right == 1);
    CHECK(strstr(tsk_capture_status_message(cap), "border") != NULL);
    tsk_capture_destroy(cap);
}

TEST(test_capture_is_deterministic_across_threads_and_runs) {
    scene_blade sb[8];
    int nb = scene_fan(sb, 320.0, 450.0);
    scene_render(sb, nb, W, H, 1.6f, g_depth);
    scene_noise(g_depth, W, H, 0.0015, 0.02, 7);
    uint64_t hashes[2];
    for (int t = 0; t < 2; ++t) {
        tsk_set_threads(t == 0 ? 1 : 2);
        tsk_capture* cap = NULL;
        CHECK(tsk_capture_create(&cap) == TSK_OK);
        tsk_capture_def def = tsk_default_capture_def();
        CHECK(tsk_capture_process(cap, &def, g_depth, W, H) == TSK_OK);
        const int total = tsk_capture_knot_total(cap);
        float* xyz = malloc(sizeof(float) * 3 * (size_t)total);
        CHECK(tsk_capture_get_knots(cap, xyz, NULL, NULL, (size_t)total) == TSK_OK);
        uint64_t h = (uint64_t)total;
        for (int i = 0; i < 3 * total; ++i) {
            uint32_t bits;
            memcpy(&bits, &xyz[i], 4);
            h = tsk_hash4(h, bits, (uint64_t)i, 0);
        }
        hashes[t] = h;
        free(xyz);
        tsk_capture_destroy(cap);
    }
    tsk_set_threads(0);
    CHECK(hashes[0] == hashes[1]);
}

TEST(test_capture_debug_images_show_mask_labels_and_skeletons) {
    scene_blade sb[8];
    int nb = scene_fan(sb, 320.0, 450.0);
    scene_render(sb, nb, W, H, 1.6f, g_depth);
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    tsk_capture_def def = tsk_default_capture_def();
    CHECK(tsk_capture_process(cap, &def, g_depth, W, H) == TSK_OK);
    static uint8_t img[W * H];
    /* mask: equals the analytic blade coverage except at a few edge pixels */
    CHECK(tsk_capture_get_image(cap, TSK_IMAGE_MASK, img, W * H) == TSK_OK);
    long diff = 0, area = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            int in = 0;
            for (int i = 0; i < nb; ++i) in |= scene_cover(&sb[i], x, y) >= 0.0;
            area += in;
            diff += in != (img[y * W + x] == 255);
        }
    CHECK(area > 10000);
    CHECK(diff < area / 50); /* closing adds only the corners of the valleys */
    /* labels: a pixel on blade i's centreline at 60 % of its length carries i's label,
     * and the five labels differ */
    CHECK(tsk_capture_get_image(cap, TSK_IMAGE_LABELS, img, W * H) == TSK_OK);
    int seen[256] = {0}, distinct = 0;
    for (int i = 0; i < nb; ++i) {
        double x, y;
        scene_point(&sb[i], 0.6 * sb[i].length, &x, &y);
        const uint8_t l = img[(int)lround(y) * W + (int)lround(x)];
        CHECK(l >= 1 && l <= 5);
        if (!seen[l]++) ++distinct;
    }
    CHECK(distinct == 5);
    CHECK(tsk_capture_get_image(cap, TSK_IMAGE_OVERLAY, img, W * H) == TSK_OK);
    long skel = 0;
    for (int i = 0; i < W * H; ++i) skel += img[i] == 255;
    CHECK(skel > 600); /* five skeletons of 170..350 px */
    CHECK(tsk_capture_get_image(cap, TSK_IMAGE_DEPTH, img, W * H) == TSK_OK);
    CHECK(tsk_capture_get_image(cap, TSK_IMAGE_DEPTH, img, W * H - 1) == TSK_ERR_ARGUMENT);
    tsk_capture_destroy(cap);
}

/* ---- depth files ---------------------------------------------------------------------- */

TEST(test_depth_png16_round_trip_and_capture) {
    scene_blade sb[8];
    int nb = scene_fan(sb, 320.0, 450.0);
    scene_render(sb, nb, W, H, 1.6f, g_depth);
    const char* path = tmp_path("fan.png");
    CHECK(tsk_depth_write_png16(path, g_depth, W, H) == TSK_OK);
    tsk_depth_source* src = NULL;
    CHECK_STATUS(tsk_depth_open_files(path, &src), TSK_OK, "");
    if (src == NULL) return;
    tsk_depth_info info;
    CHECK(tsk_depth_get_info(src, &info) == TSK_OK);
    CHECK(info.width == W && info.height == H && info.frame_count == 1);
    CHECK(info.kind == TSK_DEPTH_FILES && !info.has_device_intrinsics);
    CHECK_NEAR(info.intrinsics.fx, 570.3, 1e-3);
    CHECK_NEAR(info.intrinsics.cx, 319.5, 1e-3);
    static float back[W * H];
    tsk_depth_frame fr;
    CHECK(tsk_depth_read(src, back, W * H, &fr) == TSK_OK);
    CHECK(fr.is_new == 1 && fr.end == 1 && fr.index == 0);
    double err = 0.0;
    for (int i = 0; i < W * H; ++i) err = fmax(err, fabs(back[i] - g_depth[i]));
    CHECK(err <= 0.0005 + 1e-6); /* millimetre rounding */
    CHECK(tsk_depth_read(src, back, W * H, &fr) == TSK_OK);
    CHECK(fr.is_new == 0 && fr.end == 1);
    CHECK(tsk_depth_seek(src, 0) == TSK_OK);
    CHECK(tsk_depth_read(src, back, W * H, &fr) == TSK_OK && fr.is_new == 1);
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    tsk_capture_def def = tsk_default_capture_def();
    def.intrinsics = info.intrinsics;
    CHECK(tsk_capture_process(cap, &def, back, W, H) == TSK_OK);
    eval_stats e;
    evaluate(cap, sb, nb, &e);
    CHECK(e.blades == 5 && e.matched == 5);
    CHECK(e.width_mean_px <= 0.4);
    CHECK(e.xyz_mean_mm <= 0.6);
    tsk_capture_destroy(cap);
    tsk_depth_close(src);
}

TEST(test_depth_exr_round_trip_is_exact_and_nan_inf_read_as_no_data) {
    scene_blade sb[8];
    int nb = scene_fan(sb, 320.0, 450.0);
    scene_render(sb, nb, W, H, 1.6f, g_depth);
    const char* path = tmp_path("fan.exr");
    CHECK_STATUS(tsk_depth_write_exr(path, g_depth, W, H), TSK_OK, "");
    tsk_depth_source* src = NULL;
    CHECK_STATUS(tsk_depth_open_files(path, &src), TSK_OK, "");
    if (src == NULL) return;
    static float back[W * H];
    tsk_depth_frame fr;
    CHECK(tsk_depth_read(src, back, W * H, &fr) == TSK_OK);
    CHECK(memcmp(back, g_depth, sizeof back) == 0);
    CHECK(fr.invalid_pixels == 0);
    tsk_depth_close(src);
    /* NaN and inf (as a renderer writes for empty background) become "no data" */
    static float odd[W * H];
    memcpy(odd, g_depth, sizeof odd);
    odd[5] = NAN;
    odd[6] = INFINITY;
    odd[7] = -1.0f;
    const char* p2 = tmp_path("nan.exr");
    CHECK(tsk_depth_write_exr(p2, odd, W, H) == TSK_ERR_ARGUMENT); /* the writer refuses */
    CHECK(tsk_cvb_write_exr(p2, odd, W, H) == TSK_OK);
    CHECK(tsk_depth_open_files(p2, &src) == TSK_OK);
    CHECK(tsk_depth_read(src, back, W * H, &fr) == TSK_OK);
    CHECK(fr.invalid_pixels == 3);
    CHECK(back[5] == 0.0f && back[6] == 0.0f && back[7] == 0.0f && back[8] == g_depth[8]);
    tsk_depth_close(src);
}

TEST(test_depth_numbered_sequence_counts_seeks_and_ends) {
    scene_blade sb[8];
    int nb = scene_fan(sb, 320.0, 450.0);
    char name[64];
    for (int f = 3; f <= 5; ++f) {
        for (int i = 0; i < nb; ++i) sb[i].z0 = 0.5 + 0.1 * f; /* frame f at (0.5+0.1f) m */
        scene_render(sb, nb, W, H, 0.0f, g_depth);
        snprintf(name, sizeof name, "seq_%04d.png", f);
        CHECK(tsk_depth_write_png16(tmp_path(name), g_depth, W, H) == TSK_OK);
    }
    tsk_depth_source* src = NULL;
    CHECK_STATUS(tsk_depth_open_files(tmp_path("seq_####.png"), &src), TSK_OK, "");
    if (src == NULL) return;
    tsk_depth_info info;
    tsk_depth_get_info(src, &info);
    CHECK(info.frame_count == 3 && info.first_frame == 3);
    static float back[W * H];
    tsk_depth_frame fr;
    /* the root pixel of the middle blade tells the frame by its depth */
    const int root = 449 * W + 320;
    for (int f = 0; f < 3; ++f) {
        CHECK(tsk_depth_read(src, back, W * H, &fr) == TSK_OK);
        CHECK(fr.is_new && fr.index == f && fr.end == (f == 2));
        CHECK_NEAR(back[root], 0.5 + 0.1 * (f + 3), 0.002);
    }
    CHECK(tsk_depth_read(src, back, W * H, &fr) == TSK_OK && !fr.is_new && fr.end);
    CHECK(tsk_depth_seek(src, 1) == TSK_OK);
    CHECK(tsk_depth_read(src, back, W * H, &fr) == TSK_OK && fr.index == 1);
    CHECK_NEAR(back[root], 0.9, 0.002);
    CHECK_STATUS(tsk_depth_seek(src, 3), TSK_ERR_ARGUMENT, "index");
    CHECK_STATUS(tsk_depth_seek(src, -1), TSK_ERR_ARGUMENT, "index");
    tsk_depth_close(src);
}

/* ---- bad input ------------------------------------------------------------------------ */

static void write_bytes(const char* path, const void* data, size_t n) {
    FILE* f = fopen(path, "wb");
    if (f) {
        fwrite(data, 1, n, f);
        fclose(f);
    }
}

static void truncate_file(const char* path, long keep) {
    FILE* f = fopen(path, "rb");
    if (!f) return;
    static unsigned char buf[1 << 22];
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    write_bytes(path, buf, (size_t)keep < n ? (size_t)keep : n);
}

TEST(test_depth_bad_files_give_clear_errors) {
    tsk_depth_source* src = NULL;
    CHECK_STATUS(tsk_depth_open_files(tmp_path("missing.png"), &src), TSK_ERR_IO, "cannot open");
    CHECK(src == NULL);
    CHECK_STATUS(tsk_depth_open_files(tmp_path("none_####.png"), &src), TSK_ERR_IO,
                 "no file of the sequence");
    CHECK_STATUS(tsk_depth_open_files(NULL, &src), TSK_ERR_ARGUMENT, "path");
    CHECK_STATUS(tsk_depth_open_files("", &src), TSK_ERR_ARGUMENT, "path");
    /* unreadable: a directory */
    CHECK_STATUS(tsk_depth_open_files(g_dir, &src), TSK_ERR_IO, "is a folder");
    /* not an image */
    write_bytes(tmp_path("text.png"), "hello, not a png", 16);
    CHECK_STATUS(tsk_depth_open_files(tmp_path("text.png"), &src), TSK_ERR_FORMAT,
                 "neither a PNG nor an OpenEXR");
    write_bytes(tmp_path("empty.png"), "", 0);
    CHECK_STATUS(tsk_depth_open_files(tmp_path("empty.png"), &src), TSK_ERR_FORMAT, "empty");
    /* truncated PNG and EXR: header intact, pixel data cut */
    scene_blade sb[8];
    int nb = scene_fan(sb, 320.0, 450.0);
    scene_render(sb, nb, W, H, 1.6f, g_depth);
    CHECK(tsk_depth_write_png16(tmp_path("cut.png"), g_depth, W, H) == TSK_OK);
    truncate_file(tmp_path("cut.png"), 2000);
    CHECK_STATUS(tsk_depth_open_files(tmp_path("cut.png"), &src), TSK_ERR_FORMAT,
                 "could not be decoded");
    CHECK(tsk_depth_write_png16(tmp_path("cut2.png"), g_depth, W, H) == TSK_OK);
    truncate_file(tmp_path("cut2.png"), 20);
    CHECK_STATUS(tsk_depth_open_files(tmp_path("cut2.png"), &src), TSK_ERR_FORMAT, "truncated");
    CHECK(tsk_depth_write_exr(tmp_path("cut.exr"), g_depth, W, H) == TSK_OK);
    truncate_file(tmp_path("cut.exr"), 3000);
    CHECK_STATUS(tsk_depth_open_files(tmp_path("cut.exr"), &src), TSK_ERR_FORMAT, "decoded");
    CHECK(tsk_depth_write_exr(tmp_path("cut2.exr"), g_depth, W, H) == TSK_OK);
    truncate_file(tmp_path("cut2.exr"), 40);
    CHECK_STATUS(tsk_depth_open_files(tmp_path("cut2.exr"), &src), TSK_ERR_FORMAT, "OpenEXR");
    /* 8-bit and colour PNGs are not depth */
    static uint8_t rgb[W * H * 3];
    for (int i = 0; i < W * H * 3; ++i) rgb[i] = (uint8_t)(i * 7);
    CHECK(tsk_cvb_write_png8(tmp_path("grey8.png"), rgb, W, H, 1) == TSK_OK);
    CHECK_STATUS(tsk_depth_open_files(tmp_path("grey8.png"), &src), TSK_ERR_FORMAT, "8-bit");
    CHECK(tsk_cvb_write_png8(tmp_path("rgb.png"), rgb, W, H, 3) == TSK_OK);
    CHECK_STATUS(tsk_depth_open_files(tmp_path("rgb.png"), &src), TSK_ERR_FORMAT, "colour");
    CHECK(src == NULL);
}

TEST(test_depth_huge_images_are_refused_from_the_header) {
    /* a PNG header claiming 20000x20000 16-bit grey: refused before decoding */
    unsigned char png[64] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a,
                             0,    0,   0,   13,  'I',  'H',  'D',  'R'};
    const uint32_t side = 20000;
    for (int k = 0; k < 2; ++k) {
        png[16 + 4 * k] = (unsigned char)(side >> 24);
        png[17 + 4 * k] = (unsigned char)(side >> 16);
        png[18 + 4 * k] = (unsigned char)(side >> 8);
        png[19 + 4 * k] = (unsigned char)side;
    }
    png[24] = 16;
    png[25] = 0;
    write_bytes(tmp_path("huge.png"), png, sizeof png);
    tsk_depth_source* src = NULL;
    const size_t before = tsk_allocated_bytes();
    CHECK_STATUS(tsk_depth_open_files(tmp_path("huge.png"), &src), TSK_ERR_LIMIT, "20000x20000");
    CHECK(tsk_allocated_bytes() == before);
    /* an OpenEXR header whose dataWindow is 20000x20000 */
    unsigned char exr[256];
    size_t n = 0;
    const unsigned char magic[8] = {0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0};
    memcpy(exr, magic, 8);
    n = 8;
    const char* name = "dataWindow";
    memcpy(exr + n, name, strlen(name) + 1);
    n += strlen(name) + 1;
    memcpy(exr + n, "box2i", 6);
    n += 6;
    const int32_t sz = 16, box[4] = {0, 0, 19999, 19999};
    memcpy(exr + n, &sz, 4); /* little-endian host, as OpenEXR */
    n += 4;
    memcpy(exr + n, box, 16);
    n += 16;
    exr[n++] = 0;
    write_bytes(tmp_path("huge.exr"), exr, n);
    CHECK_STATUS(tsk_depth_open_files(tmp_path("huge.exr"), &src), TSK_ERR_LIMIT, "limited");
    /* the pipeline refuses oversized frames too */
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    tsk_capture_def def = tsk_default_capture_def();
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, 20000, 20000), TSK_ERR_LIMIT, "limit");
    tsk_capture_destroy(cap);
}

TEST(test_capture_bad_frames_and_parameters_give_clear_errors) {
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    tsk_capture_def def = tsk_default_capture_def();
    memset(g_depth, 0, sizeof g_depth);
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, W, H), TSK_ERR_FORMAT, "all-zero");
    CHECK(tsk_capture_blade_count(cap) == 0);
    /* an empty mask: only specks smaller than min_area in the band */
    for (int i = 0; i < 40; ++i) g_depth[(100 + 7 * i) * W + 50 + 11 * i] = 0.8f;
    def.near_m = 0.5f;
    def.far_m = 1.0f;
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, W, H), TSK_OK, "");
    CHECK(tsk_capture_blade_count(cap) == 0);
    CHECK(strstr(tsk_capture_status_message(cap), "mask empty") != NULL);
    /* the automatic band finds nothing significant in the same frame */
    def = tsk_default_capture_def();
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, W, H), TSK_ERR_FORMAT,
                 "no significant depth");
    /* a band that selects nothing */
    scene_blade sb[8];
    int nb = scene_fan(sb, 320.0, 450.0);
    scene_render(sb, nb, W, H, 1.6f, g_depth);
    def.near_m = 0.1f;
    def.far_m = 0.2f;
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, W, H), TSK_ERR_FORMAT, "selects no pixel");
    /* a band that takes in the wall: one blob filling the picture; every blade it yields
     * is flagged as cut by the border */
    def.near_m = 0.1f;
    def.far_m = 5.0f;
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, W, H), TSK_OK, "");
    {
        const int n = tsk_capture_blade_count(cap);
        uint32_t fl[TSK_CAPTURE_MAX_BLADES];
        CHECK(tsk_capture_get_blades(cap, NULL, fl, (size_t)n) == TSK_OK);
        for (int b = 0; b < n; ++b) CHECK(fl[b] & TSK_BLADE_CUT_BY_BORDER);
        CHECK(n == 0 || strstr(tsk_capture_status_message(cap), "border") != NULL);
    }
    def = tsk_default_capture_def();
    def.near_m = 0.9f;
    def.far_m = 0.5f;
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, W, H), TSK_ERR_ARGUMENT, "far_m");
    def = tsk_default_capture_def();
    def.near_m = NAN;
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, W, H), TSK_ERR_ARGUMENT, "near_m");
    def = tsk_default_capture_def();
    def.min_area = 0;
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, W, H), TSK_ERR_ARGUMENT, "min_area");
    def = tsk_default_capture_def();
    def.intrinsics.fx = -5.0f;
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, W, H), TSK_ERR_ARGUMENT, "intrinsics");
    def = tsk_default_capture_def();
    def.knot_spacing = 0.0f;
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, W, H), TSK_ERR_ARGUMENT, "knot_spacing");
    def = tsk_default_capture_def();
    g_depth[1234] = NAN;
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, W, H), TSK_ERR_ARGUMENT, "depth_m");
    g_depth[1234] = -0.5f;
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, W, H), TSK_ERR_ARGUMENT, "depth_m");
    g_depth[1234] = 1.6f;
    CHECK_STATUS(tsk_capture_process(cap, &def, NULL, W, H), TSK_ERR_ARGUMENT, "depth_m");
    CHECK_STATUS(tsk_capture_process(cap, &def, g_depth, 0, H), TSK_ERR_ARGUMENT, "width");
    CHECK_STATUS(tsk_capture_process(cap, NULL, g_depth, W, H), TSK_ERR_ARGUMENT, "def");
    CHECK_STATUS(tsk_capture_process(NULL, &def, g_depth, W, H), TSK_ERR_ARGUMENT, "capture");
    /* after the errors a good frame works again, and buffers are checked */
    CHECK(tsk_capture_process(cap, &def, g_depth, W, H) == TSK_OK);
    CHECK(tsk_capture_blade_count(cap) == 5);
    int32_t kc[5];
    CHECK_STATUS(tsk_capture_get_blades(cap, kc, NULL, 4), TSK_ERR_ARGUMENT, "count");
    CHECK_STATUS(tsk_capture_get_knots(cap, NULL, NULL, NULL, 3), TSK_ERR_ARGUMENT, "total");
    CHECK_STATUS(tsk_capture_get_blade(cap, 9, NULL, NULL, NULL, 3), TSK_ERR_ARGUMENT, "blade");
    tsk_capture_destroy(cap);
    tsk_capture_destroy(NULL);
}

TEST(test_band_proposal_finds_the_nearest_mode) {
    /* three planes: 300 px of flying pixels at 0.3 m (too few), blades at 1.0..1.05 m,
     * a wall at 2 m */
    for (int i = 0; i < W * H; ++i) g_depth[i] = 2.0f;
    for (int y = 100; y < 300; ++y)
        for (int x = 200; x < 260; ++x)
            g_depth[y * W + x] = 1.0f + 0.05f * (float)(y - 100) / 200.0f;
    for (int i = 0; i < 100; ++i) g_depth[i * 37] = 0.3f;
    float near_m = 0, far_m = 0;
    CHECK(tsk_capture_propose_band(g_depth, W, H, 150, &near_m, &far_m) == TSK_OK);
    CHECK(near_m >= 0.97f && near_m <= 1.0f);
    CHECK(far_m >= 1.05f && far_m <= 1.08f);
    memset(g_depth, 0, sizeof g_depth);
    CHECK_STATUS(tsk_capture_propose_band(g_depth, W, H, 150, &near_m, &far_m), TSK_ERR_FORMAT,
                 "all-zero");
}

TEST(test_intrinsics_defaults_scale_and_fov) {
    tsk_intrinsics k = tsk_default_intrinsics(320, 240);
    CHECK_NEAR(k.fx, 285.15, 1e-3);
    CHECK_NEAR(k.cx, 159.5, 1e-6);
    CHECK_NEAR(k.cy, 119.5, 1e-6);
    /* 58.5 deg horizontal FOV at 640 px is the classic 570-ish focal length */
    const double hf = 2.0 * atan(320.0 / 570.3), vf = 2.0 * atan(240.0 / 570.3);
    CHECK(tsk_intrinsics_from_fov(640, 480, (float)hf, (float)vf, &k) == TSK_OK);
    CHECK_NEAR(k.fx, 570.3, 0.01);
    CHECK_NEAR(k.fy, 570.3, 0.01);
    CHECK_STATUS(tsk_intrinsics_from_fov(640, 480, 0.0f, 1.0f, &k), TSK_ERR_ARGUMENT, "hfov");
    CHECK_STATUS(tsk_intrinsics_from_fov(640, 480, NAN, 1.0f, &k), TSK_ERR_ARGUMENT, "hfov");
}

/* ---- OpenNI2 -------------------------------------------------------------------------- */

static double mono_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

TEST(test_device_dummy_reads_latest_frame_without_blocking) {
    tsk_depth_source* src = NULL;
    CHECK_STATUS(tsk_depth_open_device("Dummy", &src), TSK_OK, "");
    if (src == NULL) return;
    tsk_depth_info info;
    CHECK(tsk_depth_get_info(src, &info) == TSK_OK);
    CHECK(info.kind == TSK_DEPTH_DEVICE && info.width == 320 && info.height == 240);
    CHECK(info.frame_count == -1);
    CHECK_NEAR(info.intrinsics.fx, 570.3 / 2, 1e-3); /* Dummy reports no FOV: defaults */
    static float d[320 * 240];
    tsk_depth_frame fr;
    CHECK_STATUS(tsk_depth_read(src, d, 320 * 240, &fr), TSK_ERR_ARGUMENT, "not started");
    CHECK_STATUS(tsk_depth_seek(src, 0), TSK_ERR_ARGUMENT, "cannot seek");
    CHECK(tsk_depth_start(src) == TSK_OK);
    CHECK(tsk_depth_start(src) == TSK_OK); /* idempotent */
    int got = 0;
    double slowest = 0.0;
    const double t0 = mono_s();
    while (mono_s() - t0 < 3.0 && got < 3) {
        const double a = mono_s();
        CHECK(tsk_depth_read(src, d, 320 * 240, &fr) == TSK_OK);
        const double dt = mono_s() - a;
        if (dt > slowest) slowest = dt;
        if (fr.is_new) {
            ++got;
            /* the Dummy device draws its top row at 2000 mm */
            CHECK_NEAR(d[0], 2.0, 1e-6);
            CHECK_NEAR(d[319], 2.0, 1e-6);
        }
        nanosleep(&(struct timespec){0, 2000000}, NULL);
    }
    CHECK(got == 3);
    CHECK_MSG(slowest < 0.02, "a read took %.1f ms", 1e3 * slowest); /* never waits a frame */
    CHECK(tsk_depth_stop(src) == TSK_OK);
    CHECK_STATUS(tsk_depth_read(src, d, 320 * 240, &fr), TSK_ERR_ARGUMENT, "not started");
    CHECK(tsk_depth_start(src) == TSK_OK);
    /* a device lost mid-capture (simulated: OpenNI2's Dummy cannot be unplugged) */
    tsk_oni_simulate_loss(src);
    CHECK_STATUS(tsk_depth_read(src, d, 320 * 240, &fr), TSK_ERR_DEVICE, "lost");
    tsk_depth_close(src);
}

TEST(test_device_missing_gives_device_error) {
    tsk_depth_source* src = NULL;
    CHECK_STATUS(tsk_depth_open_device("tussock://no-such-device", &src), TSK_ERR_DEVICE,
                 "no depth device");
    CHECK(src == NULL);
    /* the first device: none is connected on test machines; if one is, it must open */
    tsk_status s = tsk_depth_open_device(NULL, &src);
    CHECK(s == TSK_OK || s == TSK_ERR_DEVICE);
    if (s == TSK_ERR_DEVICE) CHECK(strstr(tsk_last_error(), "no depth device") != NULL);
    tsk_depth_close(src);
    CHECK_STATUS(tsk_depth_open_oni(tmp_path("missing.oni"), &src), TSK_ERR_IO, "cannot open");
    write_bytes(tmp_path("junk.oni"), "definitely not an oni file", 26);
    CHECK_STATUS(tsk_depth_open_oni(tmp_path("junk.oni"), &src), TSK_ERR_FORMAT, "recording");
    CHECK(src == NULL);
}

TEST(test_oni_recording_made_by_the_test_plays_frame_by_frame) {
    /* four frames of the fan at 0.6, 0.7, 0.8, 0.9 m, written as an OpenNI2 recording */
    const char* path = tmp_path("fan.oni");
    const double hfov = 1.0, vfov = 0.8;
    oni_writer ow;
    CHECK(oniw_open(&ow, path, W, H, hfov, vfov) == 0);
    static uint16_t mm[W * H];
    scene_blade sb[8];
    int nb = scene_fan(sb, 320.0, 450.0);
    for (int f = 0; f < 4; ++f) {
        for (int i = 0; i < nb; ++i) sb[i].z0 = 0.6 + 0.1 * f;
        scene_render(sb, nb, W, H, 0.0f, g_depth);
        for (int i = 0; i < W * H; ++i) mm[i] = (uint16_t)lroundf(g_depth[i] * 1000.0f);
        CHECK(oniw_frame(&ow, mm) == 0);
    }
    CHECK(oniw_close(&ow) == 0);
    tsk_depth_source* src = NULL;
    CHECK_STATUS(tsk_depth_open_oni(path, &src), TSK_OK, "");
    if (src == NULL) return;
    tsk_depth_info info;
    CHECK(tsk_depth_get_info(src, &info) == TSK_OK);
    CHECK(info.kind == TSK_DEPTH_ONI && info.width == W && info.height == H);
    CHECK(info.frame_count == 4);
    /* intrinsics from the recorded field of view: fx = (W/2) / tan(hfov/2) */
    CHECK(info.has_device_intrinsics == 1);
    CHECK_NEAR(info.intrinsics.fx, 0.5 * W / tan(0.5 * hfov), 0.01);
    CHECK_NEAR(info.intrinsics.fy, 0.5 * H / tan(0.5 * vfov), 0.01);
    static float d[W * H];
    tsk_depth_frame fr;
    const int root = 449 * W + 320;
    for (int f = 0; f < 4; ++f) {
        CHECK_STATUS(tsk_depth_read(src, d, W * H, &fr), TSK_OK, "");
        CHECK(fr.is_new == 1 && fr.index == f && fr.end == (f == 3));
        CHECK_NEAR(d[root], 0.6 + 0.1 * f, 0.0015);
    }
    CHECK(tsk_depth_read(src, d, W * H, &fr) == TSK_OK && fr.is_new == 0 && fr.end == 1);
    CHECK_STATUS(tsk_depth_seek(src, 1), TSK_OK, "");
    CHECK_STATUS(tsk_depth_read(src, d, W * H, &fr), TSK_OK, "");
    CHECK(fr.index == 1);
    CHECK_NEAR(d[root], 0.7, 0.0015);
    /* the frame is exactly what was written */
    long diff = 0;
    for (int i = 0; i < nb; ++i) sb[i].z0 = 0.7;
    scene_render(sb, nb, W, H, 0.0f, g_depth);
    for (int i = 0; i < W * H; ++i)
        diff += fabsf(d[i] - 0.001f * lroundf(g_depth[i] * 1000.0f)) > 1e-6f;
    CHECK(diff == 0);
    /* and captures like the image */
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    tsk_capture_def def = tsk_default_capture_def();
    def.intrinsics = info.intrinsics;
    CHECK(tsk_capture_process(cap, &def, d, W, H) == TSK_OK);
    CHECK(tsk_capture_blade_count(cap) == 5);
    tsk_capture_destroy(cap);
    CHECK_STATUS(tsk_depth_seek(src, 4), TSK_ERR_ARGUMENT, "index");
    tsk_depth_close(src);
    /* a truncated recording: fails cleanly at open or at read, never hangs */
    truncate_file(path, 6000);
    tsk_status s = tsk_depth_open_oni(path, &src);
    if (s == TSK_OK) {
        s = tsk_depth_read(src, d, W * H, &fr);
        CHECK(s != TSK_OK || fr.is_new == 0);
        tsk_depth_close(src);
    } else {
        CHECK(s == TSK_ERR_FORMAT);
    }
}

static double oni_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The reader's crash as reported: a signal (Windows: an access violation), or in sanitizer
 * builds (whose handler catches the signal and exits) an exit code. */
static int reader_crashed(const char* msg) {
    return strstr(msg, "crashed (signal 11") != NULL ||
           strstr(msg, "crashed (exception 0xC0000005") != NULL ||
           strstr(msg, "stopped with exit code") != NULL;
}

/* The reader's process and its channel as the tests drive them: children_left() says if a
 * reader process is left behind (not reaped, or on Windows still running), crash_reader()
 * makes one crash as OpenNI2 would, not_a_reader() is a program that ends at once without a
 * word to Tussock, and a fake channel's reader side is written by the test itself. */
#ifndef _WIN32
static int children_left(void) { return waitpid(-1, NULL, WNOHANG) != -1 || errno != ECHILD; }
static void crash_reader(int pid) { kill(pid, SIGSEGV); }
static const char* not_a_reader(void) { return "/bin/true"; }

typedef int fake_end; /* a socket pair's other end */
static int fake_channel(tsk_oni_channel* ours, fake_end* theirs) {
    int sv[2];
    if (socketpair(AF_UNIX, SOCK_STREAM, 0, sv) != 0) return -1;
    *ours = sv[0];
    *theirs = sv[1];
    return 0;
}
static int fake_send(fake_end* e, const void* bytes, size_t n) {
    return write(*e, bytes, n) == (ssize_t)n ? 0 : -1;
}
/* the reader's answers end here; its end still takes requests */
static void fake_end_answers(fake_end* e) { shutdown(*e, SHUT_WR); }
static void fake_close(fake_end* e) { close(*e); }
#else
static int children_left(void) {
    HANDLE snap = CreateToolhelp32Snapshot(TH32CS_SNAPPROCESS, 0);
    if (snap == INVALID_HANDLE_VALUE) return 0;
    PROCESSENTRY32 e;
    e.dwSize = sizeof e;
    int left = 0;
    for (BOOL more = Process32First(snap, &e); more; more = Process32Next(snap, &e))
        left += e.th32ParentProcessID == GetCurrentProcessId();
    CloseHandle(snap);
    return left > 0;
}
static void crash_reader(int pid) {
    HANDLE h = OpenProcess(PROCESS_TERMINATE, FALSE, (DWORD)pid);
    if (h != NULL) TerminateProcess(h, (UINT)EXCEPTION_ACCESS_VIOLATION);
    if (h != NULL) CloseHandle(h);
}
static const char* not_a_reader(void) {
    static char path[MAX_PATH + 32];
    const UINT n = GetSystemDirectoryA(path, MAX_PATH);
    snprintf(path + (n < MAX_PATH ? n : 0), 32, "\\hostname.exe");
    return path;
}

typedef tsk_oni_channel fake_end; /* the reader's sides of the two pipes */
static int fake_channel(tsk_oni_channel* ours, fake_end* theirs) {
    return tsk_oni_channel_pair(ours, theirs, 0);
}
static int fake_send(fake_end* e, const void* bytes, size_t n) {
    DWORD w = 0;
    return WriteFile(e->answers, bytes, (DWORD)n, &w, NULL) && w == n ? 0 : -1;
}
static void fake_end_answers(fake_end* e) {
    CloseHandle(e->answers);
    e->answers = NULL;
}
static void fake_close(fake_end* e) {
    if (e->answers != NULL) CloseHandle(e->answers);
    CloseHandle(e->requests);
}
#endif

TEST(test_oni_damaged_recordings_cannot_crash_the_caller) {
    /* a recording that crashes OpenNI2's player (found by fuzz_oni): the reader process
     * crashes, this process gets a status that says so */
    tsk_depth_source* src = NULL;
    double t0 = oni_now();
    CHECK_STATUS(tsk_depth_open_oni(TSK_SOURCE_DIR "/fuzz/crashes/oni-segv-libOniFile.oni", &src),
                 TSK_ERR_FORMAT, "recording reader");
    CHECK(reader_crashed(tsk_last_error()));
    CHECK(src == NULL);
    CHECK(oni_now() - t0 < 10.0);
    CHECK(!children_left());
    /* 40 damaged copies of a good recording (bytes overwritten at spread positions, or cut
     * short): each opens and plays, or fails with a message; never longer than the limits */
    const char* good = tmp_path("good.oni");
    oni_writer ow;
    CHECK(oniw_open(&ow, good, 160, 120, 1.0, 0.8) == 0);
    static uint16_t mm[160 * 120];
    for (int f = 0; f < 3; ++f) {
        for (int i = 0; i < 160 * 120; ++i) mm[i] = (uint16_t)(600 + 100 * f + (i % 160));
        CHECK(oniw_frame(&ow, mm) == 0);
    }
    CHECK(oniw_close(&ow) == 0);
    FILE* fp = fopen(good, "rb");
    CHECK(fp != NULL);
    if (fp == NULL) return;
    static unsigned char bytes[1 << 20], bad[1 << 20];
    const size_t n = fread(bytes, 1, sizeof bytes, fp);
    fclose(fp);
    CHECK(n > 1000 && n < sizeof bytes);
    int opened = 0, refused = 0, played = 0;
    static float d[160 * 120];
    for (int v = 0; v < 40; ++v) {
        memcpy(bad, bytes, n);
        size_t len = n;
        if (v % 4 == 3) {
            len = (size_t)(tsk_rand01(7, (uint64_t)v, 0, 0) * (double)n);
        } else {
            for (int k = 0; k < 1 + v % 8; ++k) {
                /* most of the file is frame data: aim at the first 4 KiB (headers, stream
                 * and property records) half of the time */
                const double u = tsk_rand01(7, (uint64_t)v, (uint64_t)k, 1);
                const size_t at = (size_t)(u * (double)(k % 2 ? n : 4096));
                bad[at] = (unsigned char)(tsk_hash4(7, (uint32_t)v, (uint32_t)k, 2) & 0xff);
            }
        }
        const char* path = tmp_path("bad.oni");
        write_bytes(path, bad, len);
        t0 = oni_now();
        tsk_status s = tsk_depth_open_oni(path, &src);
        if (s != TSK_OK) {
            ++refused;
            CHECK_MSG(tsk_last_error()[0] != '\0', "variant %d: no message", v);
            CHECK(src == NULL);
            continue;
        }
        ++opened;
        tsk_depth_info info;
        CHECK(tsk_depth_get_info(src, &info) == TSK_OK);
        CHECK(info.width == 160 && info.height == 120);
        tsk_depth_frame fr;
        int frames = 0;
        for (int i = 0; i < info.frame_count + 1; ++i) {
            if (tsk_depth_read(src, d, 160 * 120, &fr) != TSK_OK) {
                CHECK(tsk_last_error()[0] != '\0');
                break;
            }
            if (!fr.is_new) break;
            ++frames;
            int finite = 1;
            for (int k = 0; k < 160 * 120; ++k) finite &= d[k] >= 0.0f && isfinite(d[k]);
            CHECK(finite);
        }
        played += frames == 3;
        tsk_depth_close(src);
        CHECK_MSG(oni_now() - t0 < 30.0, "variant %d took %.1f s", v, oni_now() - t0);
    }
    printf("    damaged recordings: %d opened (%d played all 3 frames), %d refused\n", opened,
           played, refused);
    CHECK(opened + refused == 40);
    CHECK(refused > 0); /* truncations at least */
    CHECK(!children_left());
}

TEST(test_oni_reader_that_dies_mid_read_or_is_missing_gives_clear_errors) {
    const char* path = tmp_path("three.oni");
    oni_writer ow;
    CHECK(oniw_open(&ow, path, 64, 48, 1.0, 0.8) == 0);
    static uint16_t mm[64 * 48];
    for (int f = 0; f < 3; ++f) {
        for (int i = 0; i < 64 * 48; ++i) mm[i] = (uint16_t)(1000 + f);
        CHECK(oniw_frame(&ow, mm) == 0);
    }
    CHECK(oniw_close(&ow) == 0);
    tsk_depth_source* src = NULL;
    CHECK_STATUS(tsk_depth_open_oni(path, &src), TSK_OK, "");
    if (src == NULL) return;
    static float d[64 * 48];
    tsk_depth_frame fr;
    CHECK_STATUS(tsk_depth_read(src, d, 64 * 48, &fr), TSK_OK, "");
    CHECK(fr.is_new && fr.index == 0);
    CHECK_NEAR(d[100], 1.000, 1e-6);
    const int pid = tsk_oni_proxy_pid(src);
    CHECK(pid > 0);
    crash_reader(pid); /* as if OpenNI2 crashed on the next frame */
    CHECK_STATUS(tsk_depth_read(src, d, 64 * 48, &fr), TSK_ERR_FORMAT, "while reading");
    CHECK(reader_crashed(tsk_last_error()));
    /* the source stays broken, with the same message */
    CHECK_STATUS(tsk_depth_seek(src, 0), TSK_ERR_FORMAT, "while reading");
    tsk_depth_close(src);
    CHECK(!children_left());
    /* no reader installed */
    setenv("TSK_ONI_READER", "/nonexistent/tussock_oni_reader", 1);
    CHECK_STATUS(tsk_depth_open_oni(path, &src), TSK_ERR_INTERNAL, "missing or not executable");
    unsetenv("TSK_ONI_READER");
    CHECK(src == NULL);
    /* a reader that is not one: /bin/true ends at once without a word */
    setenv("TSK_ONI_READER", not_a_reader(), 1);
    CHECK_STATUS(tsk_depth_open_oni(path, &src), TSK_ERR_FORMAT, "while opening");
    unsetenv("TSK_ONI_READER");
    CHECK(!children_left());
}

/* A reader's side of the conversation written by the test: its answers, then the end of
 * its stream; its end stays open to take requests until the next call. */
static int fake_reader(const void* bytes, size_t n, tsk_depth_source** out) {
    static fake_end peer;
    static int has_peer = 0;
    if (has_peer) fake_close(&peer);
    has_peer = 0;
    tsk_oni_channel ours;
    if (fake_channel(&ours, &peer) != 0) return -1;
    has_peer = 1;
    if (fake_send(&peer, bytes, n) != 0) return -1;
    fake_end_answers(&peer);
    return (int)tsk_depth_attach_oni_reader(ours, "fake.oni", out);
}

typedef struct fake_talk {
    tsk_oni_hello h;
    tsk_oni_reply r;
    float px[4];
} fake_talk;

TEST(test_oni_reader_answers_are_checked) {
    fake_talk m;
    memset(&m, 0, sizeof m);
    memcpy(m.h.magic, TSK_ONI_MAGIC, 8);
    m.h.width = 2;
    m.h.height = 2;
    m.h.frame_count = 1;
    m.h.fx = m.h.fy = 2.0;
    m.h.cx = m.h.cy = 0.5;
    m.r.is_new = 1;
    m.r.end = 1;
    m.px[0] = 0.5f;
    m.px[3] = 2.0f;
    tsk_depth_source* src = NULL;
    /* a well-formed conversation plays */
    tsk_oni_channel ours;
    fake_end theirs;
    memset(&ours, 0xff, sizeof ours); /* -1: no descriptor, no handle */
    memset(&theirs, 0xff, sizeof theirs);
    CHECK(fake_channel(&ours, &theirs) == 0);
    CHECK(fake_send(&theirs, &m, sizeof m) == 0);
    CHECK_STATUS(tsk_depth_attach_oni_reader(ours, "fake.oni", &src), TSK_OK, "");
    float d[4];
    tsk_depth_frame fr;
    CHECK_STATUS(tsk_depth_read(src, d, 4, &fr), TSK_OK, "");
    CHECK(fr.is_new == 1 && fr.end == 1 && d[0] == 0.5f && d[3] == 2.0f);
    tsk_depth_close(src);
    fake_close(&theirs);
    /* each damaged answer is refused with a message */
    fake_talk b = m;
    memcpy(b.h.magic, "NOTONI!!", 8);
    CHECK_STATUS(fake_reader(&b, sizeof b, &src), TSK_ERR_FORMAT, "another format");
    b = m;
    b.h.width = 0;
    CHECK_STATUS(fake_reader(&b, sizeof b, &src), TSK_ERR_FORMAT, "inconsistent");
    b = m;
    b.h.height = 1 << 20;
    CHECK_STATUS(fake_reader(&b, sizeof b, &src), TSK_ERR_FORMAT, "inconsistent");
    b = m;
    b.h.fx = NAN;
    CHECK_STATUS(fake_reader(&b, sizeof b, &src), TSK_ERR_FORMAT, "inconsistent");
    b = m;
    b.h.status = 99;
    CHECK_STATUS(fake_reader(&b, sizeof b, &src), TSK_ERR_FORMAT, "another format");
    b = m;
    b.h.status = TSK_ERR_LIMIT;
    snprintf(b.h.message, sizeof b.h.message, "too big, says the reader");
    CHECK_STATUS(fake_reader(&b, sizeof b, &src), TSK_ERR_LIMIT, "too big, says the reader");
    CHECK_STATUS(fake_reader(&m, sizeof m.h - 1, &src), TSK_ERR_FORMAT, "while opening");
    /* bad frames: NaN depth, a frame index past the end, a short frame */
    struct {
        const char* want;
        int field;
    } cases[] = {{"invalid depth", 0},
                 {"past the end", 1},
                 {"sending a frame", 2},
                 {"inconsistent reply", 3}};
    for (int c = 0; c < 4; ++c) {
        b = m;
        size_t n = sizeof b;
        if (cases[c].field == 0) b.px[1] = NAN;
        if (cases[c].field == 1) b.r.index = 1;
        if (cases[c].field == 2) n -= 3;
        if (cases[c].field == 3) b.r.is_new = 7;
        CHECK_STATUS(fake_reader(&b, n, &src), TSK_OK, "");
        if (src == NULL) continue;
        CHECK_STATUS(tsk_depth_read(src, d, 4, &fr), TSK_ERR_FORMAT, cases[c].want);
        tsk_depth_close(src);
    }
}

TEST(test_capture_random_depth_is_handled_without_harm) {
    /* random depths (half of them in one band, some holes): many odd blobs; the pipeline
     * must return a status, keep its limits, and give only finite knots */
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    for (uint64_t seed = 1; seed <= 3; ++seed) {
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                const float u =
                    tsk_rand01(seed, (uint64_t)x / (seed + 1), (uint64_t)y / (seed + 1), 9);
                g_depth[y * W + x] = u < 0.1f ? 0.0f : (u < 0.6f ? 0.8f + 0.05f * u : 3.0f * u);
            }
        tsk_capture_def def = tsk_default_capture_def();
        def.min_area = 20;
        const double t0 = mono_s();
        tsk_status s = tsk_capture_process(cap, &def, g_depth, W, H);
        CHECK(mono_s() - t0 < 5.0);
        CHECK_MSG(s == TSK_OK || s == TSK_ERR_FORMAT, "%s", tsk_last_error());
        const int n = tsk_capture_blade_count(cap);
        CHECK(n >= 0 && n <= TSK_CAPTURE_MAX_BLADES);
        const int total = tsk_capture_knot_total(cap);
        float* xyz = malloc(sizeof(float) * 3 * (size_t)(total + 1));
        CHECK(tsk_capture_get_knots(cap, xyz, NULL, NULL, (size_t)total) == TSK_OK);
        int finite = 1;
        for (int k = 0; k < 3 * total; ++k) finite &= isfinite(xyz[k]) != 0;
        CHECK(finite);
        free(xyz);
    }
    tsk_capture_destroy(cap);
}

/* A frame whose pipeline images (48 bytes per pixel) exceed the budget is refused with
 * TSK_ERR_LIMIT before any buffer grows. */
TEST(test_capture_frame_over_memory_budget_is_refused) {
    const int w = 256, h = 256;
    float* depth = calloc((size_t)w * h, sizeof *depth);
    for (int i = 0; i < w * h; ++i) depth[i] = (i % w > 100 && i % w < 110) ? 0.5f : 0.0f;
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    const tsk_capture_def def = tsk_default_capture_def();
    tsk_set_memory_budget((uint64_t)w * h * 48 - 1);
    CHECK_STATUS(tsk_capture_process(cap, &def, depth, w, h), TSK_ERR_LIMIT, "width: needs");
    tsk_set_memory_budget((uint64_t)w * h * 48);
    CHECK(tsk_capture_process(cap, &def, depth, w, h) == TSK_OK);
    tsk_set_memory_budget(0);
    tsk_capture_destroy(cap);
    free(depth);
}

/* Fuzz finding (fuzz_capture_def): a first frame with no blade left the knot buffers
 * unallocated, and the getters then did memcpy from NULL + 0 (undefined behaviour that
 * UBSan reports). With zero knots they must return TSK_OK and leave the buffers alone. */
TEST(test_capture_no_blades_getters_copy_nothing) {
    enum { w = 64, h = 48 };
    static float depth[w * h];
    memset(depth, 0, sizeof depth);
    depth[10 * w + 10] = 0.8f; /* one speck, far below min_area */
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    tsk_capture_def def = tsk_default_capture_def();
    def.near_m = 0.5f;
    def.far_m = 1.0f;
    CHECK(tsk_capture_process(cap, &def, depth, w, h) == TSK_OK);
    CHECK(tsk_capture_blade_count(cap) == 0);
    CHECK(tsk_capture_knot_total(cap) == 0);
    float xyz[3] = {7, 7, 7}, wid[1] = {7}, uv[2] = {7, 7};
    int32_t counts[1] = {7};
    CHECK(tsk_capture_get_knots(cap, xyz, wid, uv, 0) == TSK_OK);
    CHECK(tsk_capture_get_blades(cap, counts, NULL, 0) == TSK_OK);
    CHECK(xyz[0] == 7 && wid[0] == 7 && uv[1] == 7 && counts[0] == 7);
    tsk_capture_destroy(cap);
}

/* Fuzz finding (fuzz_capture_def): a finite but huge depth (FLT_MAX) overflowed the
 * histogram bin index (float -> int conversion out of range: undefined behaviour). Depths
 * beyond 20 m are now skipped; the band is the one of the real 0.5 m blade. */
TEST(test_capture_band_ignores_huge_finite_depths) {
    enum { w = 32, h = 32 };
    static float depth[w * h];
    for (int i = 0; i < w * h; ++i) depth[i] = (i % 3 == 0) ? 3.4e38f : 0.505f;
    float nearv = 0, farv = 0;
    CHECK(tsk_capture_propose_band(depth, w, h, 10, &nearv, &farv) == TSK_OK);
    CHECK(nearv <= 0.505f && farv >= 0.505f);
    CHECK(farv < 1.0f);
    for (int i = 0; i < w * h; ++i) depth[i] = 3.4e38f;
    CHECK_STATUS(tsk_capture_propose_band(depth, w, h, 10, &nearv, &farv), TSK_ERR_FORMAT,
                 "no significant depth");
}

/* Fuzz finding (fuzz_capture_def): a positive but tiny focal length (FLT_MIN) or a huge
 * principal point passed validation and back-projected knots to +-inf. Intrinsics and the
 * band are now bounded so that every knot is finite; a 0.5 px focal length still works
 * and gives finite knots. */
TEST(test_capture_tiny_focal_length_or_far_band_is_refused) {
    enum { w = 64, h = 64 };
    static float depth[w * h];
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) depth[y * w + x] = (x >= 28 && x < 36 && y > 8) ? 0.5f : 0.0f;
    tsk_capture* cap = NULL;
    CHECK(tsk_capture_create(&cap) == TSK_OK);
    tsk_capture_def def = tsk_default_capture_def();
    def.min_area = 20;
    def.intrinsics = (tsk_intrinsics){1.17549435e-38f, 1.17549435e-38f, 1.17549435e-38f, 24.0f};
    CHECK_STATUS(tsk_capture_process(cap, &def, depth, w, h), TSK_ERR_ARGUMENT, "intrinsics");
    def.intrinsics = (tsk_intrinsics){50.0f, 50.0f, 3e30f, 24.0f};
    CHECK_STATUS(tsk_capture_process(cap, &def, depth, w, h), TSK_ERR_ARGUMENT, "intrinsics");
    def.intrinsics = (tsk_intrinsics){0.0f, 0.0f, 0.0f, 0.0f};
    def.near_m = 0.1f;
    def.far_m = 1e30f;
    CHECK_STATUS(tsk_capture_process(cap, &def, depth, w, h), TSK_ERR_ARGUMENT, "far_m");
    def.near_m = def.far_m = 0.0f;
    def.intrinsics = (tsk_intrinsics){0.5f, 0.5f, 32.0f, 32.0f};
    CHECK(tsk_capture_process(cap, &def, depth, w, h) == TSK_OK);
    const int nk = tsk_capture_knot_total(cap);
    CHECK(nk > 0);
    float* xyz = malloc((size_t)(nk + 1) * 3 * sizeof *xyz);
    float* wid = malloc((size_t)(nk + 1) * sizeof *wid);
    CHECK(tsk_capture_get_knots(cap, xyz, wid, NULL, (size_t)nk) == TSK_OK);
    int finite = 1;
    for (int i = 0; i < 3 * nk; ++i) finite &= isfinite(xyz[i]) != 0;
    for (int i = 0; i < nk; ++i) finite &= isfinite(wid[i]) && wid[i] >= 0.0f;
    CHECK(finite);
    free(xyz);
    free(wid);
    tsk_capture_destroy(cap);
}

/* Fuzz finding (fuzz_capture_def): a positive sigma so small that sigma^2 underflows
 * (width_smooth = FLT_MIN) made the Gaussian kernel 0/0 = NaN and every knot NaN. Such a
 * sigma is the identity: the blades equal those with smoothing 0, bit for bit. */
TEST(test_capture_tiny_smoothing_sigma_is_identity_not_nan) {
    enum { w = 64, h = 64 };
    static float depth[w * h];
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) depth[y * w + x] = (x >= 28 && x < 36 && y > 8) ? 0.5f : 0.0f;
    tsk_capture_def def = tsk_default_capture_def();
    def.min_area = 20;
    float* out[2] = {NULL, NULL};
    int nk[2] = {0, 0};
    for (int pass = 0; pass < 2; ++pass) {
        def.width_smooth = pass ? 1.17549435e-38f : 0.0f;
        def.contour_smooth = pass ? 1e-30f : 0.0f;
        tsk_capture* cap = NULL;
        CHECK(tsk_capture_create(&cap) == TSK_OK);
        CHECK(tsk_capture_process(cap, &def, depth, w, h) == TSK_OK);
        nk[pass] = tsk_capture_knot_total(cap);
        out[pass] = malloc((size_t)(nk[pass] + 1) * 4 * sizeof(float));
        CHECK(tsk_capture_get_knots(cap, out[pass], out[pass] + 3 * nk[pass], NULL,
                                    (size_t)nk[pass]) == TSK_OK);
        tsk_capture_destroy(cap);
    }
    CHECK(nk[0] > 0 && nk[0] == nk[1]);
    if (nk[0] == nk[1]) CHECK(memcmp(out[0], out[1], (size_t)nk[0] * 4 * sizeof(float)) == 0);
    for (int i = 0; i < 4 * nk[1]; ++i)
        if (!isfinite(out[1][i])) {
            CHECK(isfinite(out[1][i]));
            break;
        }
    free(out[0]);
    free(out[1]);
}

TEST_MAIN(TEST_NEEDS(test_capture_tiny_smoothing_sigma_is_identity_not_nan, OpenCV),
          TEST_NEEDS(test_capture_tiny_focal_length_or_far_band_is_refused, OpenCV),
          TEST_ENTRY(test_capture_band_ignores_huge_finite_depths),
          TEST_NEEDS(test_capture_no_blades_getters_copy_nothing, OpenCV),
          TEST_NEEDS(test_capture_frame_over_memory_budget_is_refused, OpenCV),
          TEST_NEEDS(test_capture_clean_fan_gives_exact_blades_and_profiles, OpenCV),
          TEST_NEEDS(test_capture_noisy_fan_keeps_count_and_tolerances, OpenCV),
          TEST_NEEDS(test_capture_crossing_blades_run_from_the_base_through_the_shared_part,
                     OpenCV),
          TEST_NEEDS(test_capture_single_blade_is_one_blade_root_to_tip, OpenCV),
          TEST_NEEDS(test_capture_centroid_mode_splits_a_lone_blade_but_root_mode_does_not, OpenCV),
          TEST_NEEDS(test_capture_blade_cut_by_border_is_flagged, OpenCV),
          TEST_NEEDS(test_capture_is_deterministic_across_threads_and_runs, OpenCV),
          TEST_NEEDS(test_capture_debug_images_show_mask_labels_and_skeletons, OpenCV),
          TEST_NEEDS(test_depth_png16_round_trip_and_capture, OpenCV),
          TEST_NEEDS(test_depth_exr_round_trip_is_exact_and_nan_inf_read_as_no_data, OpenCV),
          TEST_NEEDS(test_depth_numbered_sequence_counts_seeks_and_ends, OpenCV),
          TEST_NEEDS(test_depth_bad_files_give_clear_errors, OpenCV),
          TEST_ENTRY(test_depth_huge_images_are_refused_from_the_header),
          TEST_NEEDS(test_capture_bad_frames_and_parameters_give_clear_errors, OpenCV),
          TEST_ENTRY(test_band_proposal_finds_the_nearest_mode),
          TEST_ENTRY(test_intrinsics_defaults_scale_and_fov),
          TEST_NEEDS(test_device_dummy_reads_latest_frame_without_blocking, OpenNI2),
          TEST_NEEDS(test_device_missing_gives_device_error, OpenNI2),
          TEST_NEEDS(test_oni_recording_made_by_the_test_plays_frame_by_frame, OpenNI2),
          TEST_NEEDS(test_oni_damaged_recordings_cannot_crash_the_caller, OpenNI2),
          TEST_NEEDS(test_oni_reader_that_dies_mid_read_or_is_missing_gives_clear_errors, OpenNI2),
          TEST_ENTRY(test_oni_reader_answers_are_checked),
          TEST_NEEDS(test_capture_random_depth_is_handled_without_harm, OpenCV))
