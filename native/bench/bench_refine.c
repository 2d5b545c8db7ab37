/* Benchmarks of skeleton refining (seed 000 §4.4).
 * refine_quality: a 128-knot blade refined to 64/32/16/8 knots by Algorithm 1, by uniform
 *   arc-length resampling and by Douglas-Peucker; every blade is simulated under the same
 *   standard wind with the same bending model (mass and stiffness follow from the refined
 *   knots' widths and segment lengths); the tip-trajectory error (RMS over frames) and the
 *   Hausdorff shape error (worst over frames) against the 128-knot blade are reported.
 *   Headline: tip error of Algorithm 1 at 16 knots / that of uniform resampling.
 * refine_speed: microseconds to refine 10,000 blades of 256 knots (48 frames) to 16. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime under -std=c17 */
#include "bench.h"
#include "tussock/core.h"
#include "tussock/refine.h"

#include <math.h>
#include <stdint.h>

enum { FULL = 128, FRAMES = 48 };
static const double k_length = 0.2; /* m */

/* An idealised grass blade: leaning over along an arc (curvature 3/m, as seed Fig. 6),
 * a little out of plane, widest near the root and pointed at the tip. */
static void make_blade(size_t k, float* knots, float* widths) {
    double p[3] = {0, 0, 0};
    const double ds = k_length / (double)(k - 1);
    for (size_t j = 0; j < k; ++j) {
        const double s = ds * (double)j, u = s / k_length;
        if (j > 0) {
            const double sm = s - 0.5 * ds; /* midpoint direction: exact-length segments */
            const double a = 3.0 * sm, b = 0.8 * sm;
            p[0] += ds * sin(a) * cos(b);
            p[1] += ds * sin(b);
            p[2] += ds * cos(a) * cos(b);
        }
        for (int c = 0; c < 3; ++c) knots[3 * j + c] = (float)p[c];
        widths[j] = (float)(0.006 * (1.0 - u * u) + 0.0003);
    }
}

/* ---- Douglas-Peucker to exactly m knots (top-down: split where the deviation is largest) */

static double point_segment(const float* p, const float* a, const float* b) {
    double ab[3], ap[3], t = 0, l2 = 0;
    for (int c = 0; c < 3; ++c) {
        ab[c] = (double)b[c] - a[c];
        ap[c] = (double)p[c] - a[c];
        l2 += ab[c] * ab[c];
        t += ab[c] * ap[c];
    }
    t = l2 > 0 ? t / l2 : 0;
    if (t < 0) t = 0;
    if (t > 1) t = 1;
    double d2 = 0;
    for (int c = 0; c < 3; ++c) d2 += (ap[c] - t * ab[c]) * (ap[c] - t * ab[c]);
    return sqrt(d2);
}

static void douglas_peucker(const float* knots, const float* widths, size_t k, size_t m,
                            float* out_knots, float* out_widths) {
    char keep[1024] = {0};
    keep[0] = keep[k - 1] = 1;
    for (size_t have = 2; have < m; ++have) {
        double best = -1;
        size_t best_i = 0;
        size_t a = 0;
        for (size_t b = 1; b < k; ++b) {
            if (!keep[b]) continue;
            for (size_t i = a + 1; i < b; ++i) {
                double d = point_segment(knots + 3 * i, knots + 3 * a, knots + 3 * b);
                if (d > best) best = d, best_i = i;
            }
            a = b;
        }
        keep[best_i] = 1;
    }
    size_t o = 0;
    for (size_t i = 0; i < k; ++i)
        if (keep[i]) {
            memcpy(out_knots + 3 * o, knots + 3 * i, 12);
            out_widths[o++] = widths[i];
        }
}

/* Symmetric Hausdorff distance of two polylines, each segment sampled at 8 points. */
static double one_sided(const float* a, size_t na, const float* b, size_t nb) {
    double worst = 0;
    for (size_t i = 0; i + 1 < na; ++i)
        for (int q = 0; q <= 8; ++q) {
            float p[3];
            for (int c = 0; c < 3; ++c)
                p[c] = (float)(a[3 * i + c] + (a[3 * i + 3 + c] - a[3 * i + c]) * (q / 8.0));
            double best = INFINITY;
            for (size_t j = 0; j + 1 < nb; ++j) {
                double d = point_segment(p, b + 3 * j, b + 3 * j + 3);
                if (d < best) best = d;
            }
            if (best > worst) worst = best;
        }
    return worst;
}

static double hausdorff(const float* a, size_t na, const float* b, size_t nb) {
    double x = one_sided(a, na, b, nb), y = one_sided(b, nb, a, na);
    return x > y ? x : y;
}

typedef struct quality {
    double tip_rms, hausdorff, rest_hausdorff, mass_ratio;
} quality;

static double blade_mass(const float* knots, const float* widths, size_t k) {
    double m = 0;
    for (size_t s = 0; s + 1 < k; ++s) {
        double l2 = 0;
        for (int c = 0; c < 3; ++c) l2 += pow(knots[3 * s + 3 + c] - knots[3 * s + c], 2);
        m += sqrt(l2) * 0.5 * (widths[s] + widths[s + 1]);
    }
    return m;
}

static int evaluate(const tsk_refine_bend_def* bend, const float* full_knots,
                    const float* full_widths, const float* full_traj, const float* knots,
                    const float* widths, size_t m, quality* q) {
    float* traj = malloc(FRAMES * m * 3 * sizeof(float));
    if (tsk_refine_simulate(bend, knots, widths, m, FRAMES, traj) != TSK_OK) {
        fprintf(stderr, "simulate: %s\n", tsk_last_error());
        free(traj);
        return 0;
    }
    double se = 0, h = 0;
    for (size_t f = 0; f < FRAMES; ++f) {
        const float* a = full_traj + (f * FULL + FULL - 1) * 3;
        const float* b = traj + (f * m + m - 1) * 3;
        double d2 = 0;
        for (int c = 0; c < 3; ++c) d2 += pow((double)a[c] - b[c], 2);
        se += d2;
        double hf = hausdorff(full_traj + f * FULL * 3, FULL, traj + f * m * 3, m);
        if (hf > h) h = hf;
    }
    q->tip_rms = sqrt(se / FRAMES);
    q->hausdorff = h;
    q->rest_hausdorff = hausdorff(full_knots, FULL, knots, m);
    q->mass_ratio = blade_mass(knots, widths, m) / blade_mass(full_knots, full_widths, FULL);
    free(traj);
    return 1;
}

static void emit_quality(const char* method, int m, const quality* q, float mu) {
    char name[96], params[160];
    int n = snprintf(params, sizeof params,
                     "\"knots\": %d, \"from\": %d, \"frames\": %d, \"mass_ratio\": %.4f", m, FULL,
                     FRAMES, q->mass_ratio);
    if (mu >= 0.0f) snprintf(params + n, sizeof params - (size_t)n, ", \"mu\": %g", (double)mu);
    snprintf(name, sizeof name, "refine_quality_%s_%d_tip", method, m);
    bench_emit(name, q->tip_rms * 1000.0, "mm RMS tip-trajectory error", params, NULL);
    snprintf(name, sizeof name, "refine_quality_%s_%d_hausdorff", method, m);
    bench_emit(name, q->hausdorff * 1000.0, "mm worst Hausdorff shape error over frames", params,
               NULL);
    snprintf(name, sizeof name, "refine_quality_%s_%d_rest_hausdorff", method, m);
    bench_emit(name, q->rest_hausdorff * 1000.0, "mm Hausdorff error of the rest shape", params,
               NULL);
}

static void bench_quality(void) {
    float full_knots[FULL * 3], full_widths[FULL];
    make_blade(FULL, full_knots, full_widths);
    tsk_refine_bend_def bend = tsk_default_refine_bend_def();
    bend.warmup = 0.5f;
    float* full_traj = malloc((size_t)FRAMES * FULL * 3 * sizeof(float));
    double t0 = bench_now_s();
    if (tsk_refine_simulate(&bend, full_knots, full_widths, FULL, FRAMES, full_traj) != TSK_OK) {
        fprintf(stderr, "simulate: %s\n", tsk_last_error());
        exit(1);
    }
    double sim_s = bench_now_s() - t0;
    /* how far the full blade's tip moves about its mean, for scale (RMS, m) */
    double mean[3] = {0, 0, 0}, motion = 0;
    for (size_t f = 0; f < FRAMES; ++f)
        for (int c = 0; c < 3; ++c) mean[c] += full_traj[(f * FULL + FULL - 1) * 3 + c] / FRAMES;
    for (size_t f = 0; f < FRAMES; ++f)
        for (int c = 0; c < 3; ++c)
            motion += pow(full_traj[(f * FULL + FULL - 1) * 3 + c] - mean[c], 2) / FRAMES;
    motion = sqrt(motion);
    static const int counts[] = {64, 32, 16, 8};
    static const float mus[] = {0.5f, 1.0f, 0.0f};
    const char* mu_names[] = {"alg1", "alg1_mu1", "alg1_mu0"};
    double ratio16 = NAN, uni_tip[4] = {0}, alg_tip[3][4] = {{0}};
    for (int ci = 0; ci < 4; ++ci) {
        const int m = counts[ci];
        float knots[64 * 3], widths[64];
        int32_t ranges[128];
        quality q;
        for (int mi = 0; mi < 3; ++mi) {
            tsk_refine_def def = {m, mus[mi]};
            tsk_refine_input in = {full_knots, full_widths, full_traj, FULL, FRAMES};
            tsk_refine_output out = {knots, widths, ranges, NULL};
            if (tsk_refine_blade(&def, &in, &out) != TSK_OK) {
                fprintf(stderr, "refine: %s\n", tsk_last_error());
                exit(1);
            }
            if (!evaluate(&bend, full_knots, full_widths, full_traj, knots, widths, (size_t)m, &q))
                exit(1);
            alg_tip[mi][ci] = q.tip_rms;
            emit_quality(mu_names[mi], m, &q, mus[mi]);
        }
        if (tsk_refine_resample(full_knots, full_widths, FULL, (size_t)m, knots, widths) != TSK_OK)
            exit(1);
        if (!evaluate(&bend, full_knots, full_widths, full_traj, knots, widths, (size_t)m, &q))
            exit(1);
        uni_tip[ci] = q.tip_rms;
        emit_quality("uniform", m, &q, -1.0f);
        douglas_peucker(full_knots, full_widths, FULL, (size_t)m, knots, widths);
        if (!evaluate(&bend, full_knots, full_widths, full_traj, knots, widths, (size_t)m, &q))
            exit(1);
        emit_quality("dp", m, &q, -1.0f);
    }
    for (int ci = 0; ci < 4; ++ci) {
        char name[64], params[128];
        snprintf(params, sizeof params, "\"knots\": %d, \"from\": %d, \"frames\": %d, \"mu\": 0.5",
                 counts[ci], FULL, FRAMES);
        const double r = alg_tip[0][ci] / uni_tip[ci];
        if (counts[ci] == 16) ratio16 = r;
        snprintf(name, sizeof name, "refine_quality_%d", counts[ci]);
        bench_emit(name, r, "tip error of Algorithm 1 / that of uniform resampling", params, NULL);
    }
    char params[384];
    snprintf(params, sizeof params,
             "\"knots\": 16, \"from\": %d, \"frames\": %d, \"fps\": %g, \"mu\": 0.5, "
             "\"wind_speed\": %g, \"gust\": %g, \"full_sim_s\": %.2f, \"tip_motion_rms_mm\": %.3f, "
             "\"alg1_tip_mm\": %.4f, \"uniform_tip_mm\": %.4f",
             FULL, FRAMES, (double)bend.fps, (double)bend.wind_speed, (double)bend.gust, sim_s,
             motion * 1000.0, alg_tip[0][2] * 1000.0, uni_tip[2] * 1000.0);
    bench_emit("refine_quality", ratio16,
               "tip error of Algorithm 1 at 16 knots \xc3\xb7 that of uniform resampling", params,
               NULL);
    free(full_traj);
}

/* ---- speed ----------------------------------------------------------------------------- */

enum { SPEED_BLADES = 10000, SPEED_KNOTS = 256, SPEED_FRAMES = 48, SPEED_DISTINCT = 64 };

static void bench_speed(void) {
    /* 64 distinct blades with smooth synthetic sways plus jitter (the cost does not depend on
     * how the trajectories were made), shared round-robin by the 10,000 blades */
    const size_t k = SPEED_KNOTS, f = SPEED_FRAMES;
    float* knots = malloc(SPEED_DISTINCT * k * 3 * sizeof(float));
    float* widths = malloc(SPEED_DISTINCT * k * sizeof(float));
    float* traj = malloc(SPEED_DISTINCT * f * k * 3 * sizeof(float));
    for (size_t b = 0; b < SPEED_DISTINCT; ++b) {
        make_blade(k, knots + b * k * 3, widths + b * k);
        for (size_t fr = 0; fr < f; ++fr)
            for (size_t j = 0; j < k; ++j)
                for (int c = 0; c < 3; ++c) {
                    double s = (double)j / (double)k;
                    traj[((b * f + fr) * k + j) * 3 + c] =
                        (float)(knots[(b * k + j) * 3 + c] +
                                0.02 * s * s * sin(0.4 * (double)fr + c + b) +
                                1e-4 * (tsk_rand01(7, b, fr * k + j, (uint64_t)c) - 0.5));
                }
    }
    tsk_refine_input* in = malloc(SPEED_BLADES * sizeof *in);
    tsk_refine_output* out = malloc(SPEED_BLADES * sizeof *out);
    float* ok = malloc(SPEED_BLADES * 16 * 3 * sizeof(float));
    float* ow = malloc(SPEED_BLADES * 16 * sizeof(float));
    int32_t* orng = malloc(SPEED_BLADES * 32 * sizeof(int32_t));
    for (size_t i = 0; i < SPEED_BLADES; ++i) {
        size_t b = i % SPEED_DISTINCT;
        in[i] = (tsk_refine_input){knots + b * k * 3, widths + b * k, traj + b * f * k * 3, k, f};
        out[i] = (tsk_refine_output){ok + i * 48, ow + i * 16, orng + i * 32, NULL};
    }
    tsk_refine_def def = tsk_default_refine_def();
    def.target_knots = 16;
    const int threads_list[2] = {0, 1};
    for (int ti = 0; ti < 2; ++ti) {
        tsk_set_threads(threads_list[ti]);
        double v[3];
        for (int r = 0; r < 3; ++r) {
            double t0 = bench_now_s();
            if (tsk_refine_blades(&def, in, out, SPEED_BLADES) != TSK_OK) {
                fprintf(stderr, "refine: %s\n", tsk_last_error());
                exit(1);
            }
            v[r] = (bench_now_s() - t0) * 1e6;
        }
        char params[160];
        snprintf(params, sizeof params,
                 "\"blades\": %d, \"knots\": %d, \"to\": 16, \"frames\": %d, \"threads\": %d",
                 SPEED_BLADES, SPEED_KNOTS, SPEED_FRAMES, tsk_get_threads());
        bench_emit(ti == 0 ? "refine_speed" : "refine_speed_1thread", bench_median(v, 3), "us",
                   params, NULL);
    }
    tsk_set_threads(0);
    free(knots), free(widths), free(traj), free(in), free(out), free(ok), free(ow), free(orng);
}

int main(int argc, char** argv) {
    if (bench_wanted(argc, argv, "refine_speed")) bench_speed();
    if (bench_wanted(argc, argv, "refine_quality")) bench_quality();
    return 0;
}
