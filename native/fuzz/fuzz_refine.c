/* Fuzz target: refine inputs. The bytes give a tsk_refine_def, a blade (2..80 knots,
 * widths, 1..6 frames of trajectories; edge values included), then tsk_refine_blade (and
 * tsk_refine_blades on two copies), tsk_refine_track with fuzzed frame offsets,
 * tsk_refine_resample, tsk_refine_difference and, for short blades and a short simulated
 * span (cost only), tsk_refine_simulate with a fuzzed tsk_refine_bend_def. Outputs must be
 * finite and the knot ranges must partition the input. */
#include "fuzz.h"
#include "tussock/refine.h"

int LLVMFuzzerInitialize(int* argc, char*** argv) {
    (void)argc;
    (void)argv;
    fz_init();
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fz r = {data, size};
    tsk_refine_def def = tsk_default_refine_def();
    def.target_knots = fz_int(&r, 4);
    def.mu = fz_float(&r, def.mu);
    const size_t K = 2 + fz_u8(&r) % 79, F = 1 + fz_u8(&r) % 6;
    float* knots = malloc(K * 3 * sizeof *knots);
    float* widths = malloc(K * sizeof *widths);
    float* traj = malloc(F * K * 3 * sizeof *traj);
    for (size_t i = 0; i < K; ++i) {
        knots[3 * i] = fz_float(&r, 0.001f * i);
        knots[3 * i + 1] = fz_float(&r, 0.0f);
        knots[3 * i + 2] = fz_float(&r, 0.01f * i);
        widths[i] = fz_float(&r, 0.005f);
    }
    for (size_t f = 0; f < F; ++f)
        for (size_t i = 0; i < K * 3; ++i)
            traj[f * K * 3 + i] = knots[i] + ((fz_u8(&r) % 8) ? 0.001f * f : fz_float(&r, 0.0f));
    tsk_refine_input in = {knots, widths, traj, K, F};
    if (fz_u8(&r) % 16 == 0) in.knot_count = (size_t)fz_u32(&r);
    if (fz_u8(&r) % 16 == 0) in.frame_count = (size_t)fz_u32(&r) % 1000;
    if (in.knot_count > K || in.frame_count > F) { /* never hand over a buffer too short */
        in.knot_count = K;
        in.frame_count = F;
    }
    float ok[64 * 3], ow[64], otraj[6 * 64 * 3], ok2[64 * 3], ow2[64];
    int32_t rg[64 * 2], rg2[64 * 2];
    tsk_refine_output out = {ok, ow, rg, otraj};
    if (tsk_refine_blade(&def, &in, &out) == TSK_OK) {
        const int m = def.target_knots;
        int32_t next = 0;
        for (int k = 0; k < m; ++k) {
            if (rg[2 * k] != next || rg[2 * k + 1] < 1) abort();
            next += rg[2 * k + 1];
            if (!isfinite(ok[3 * k]) || !isfinite(ow[k])) abort();
        }
        if ((size_t)next != in.knot_count) abort();
    }
    tsk_refine_input two[2] = {in, in};
    tsk_refine_output outs[2] = {{ok, ow, rg, NULL}, {ok2, ow2, rg2, NULL}};
    (void)tsk_refine_blades(&def, two, outs, 2);
    (void)tsk_refine_difference(def.mu, traj, traj + 3 * (K > 1), F, (double)fz_float(&r, 1.0f));
    /* tracking: frames of fuzzed knot counts */
    {
        const size_t nf = 1 + fz_u8(&r) % 4;
        int32_t offs[5] = {0};
        for (size_t f = 0; f < nf; ++f) {
            int32_t c = (int32_t)(fz_u8(&r) % 8);
            if (fz_u8(&r) % 16 == 0) c = -c;
            offs[f + 1] = offs[f] + c;
        }
        if (offs[nf] < 0 || (size_t)offs[nf] > K) offs[nf] = (int32_t)K; /* buffer bound */
        for (size_t f = 0; f < nf; ++f)
            if (offs[f + 1] > offs[nf]) offs[f + 1] = offs[nf];
        float* tt = malloc(nf * K * 3 * sizeof *tt);
        (void)tsk_refine_track(knots, K, knots, offs, nf, tt);
        free(tt);
    }
    {
        const size_t oc = fz_u8(&r) % 70;
        float* rk = malloc((oc + 1) * 3 * sizeof *rk);
        float* rw = malloc((oc + 1) * sizeof *rw);
        if (tsk_refine_resample(knots, widths, K, oc, rk, rw) == TSK_OK)
            for (size_t i = 0; i < oc * 3; ++i)
                if (!isfinite(rk[i])) abort();
        free(rk);
        free(rw);
    }
    if (K <= 12) {
        tsk_refine_bend_def bd = tsk_default_refine_bend_def();
        bd.youngs_modulus = fz_float(&r, bd.youngs_modulus);
        bd.thickness = fz_float(&r, bd.thickness);
        bd.density = fz_float(&r, bd.density);
        bd.min_width_ratio = fz_float(&r, bd.min_width_ratio);
        bd.gravity[2] = fz_float(&r, bd.gravity[2]);
        bd.gravity_prestress = fz_u8(&r) % 3;
        bd.air_density = fz_float(&r, bd.air_density);
        bd.drag_coefficient = fz_float(&r, bd.drag_coefficient);
        bd.damping = fz_float(&r, bd.damping);
        bd.wind_speed = fz_float(&r, bd.wind_speed);
        bd.wind_direction[0] = fz_float(&r, 1.0f);
        bd.gust = fz_float(&r, bd.gust);
        bd.fps = fz_float(&r, bd.fps);
        bd.warmup = fz_float(&r, 0.02f);
        bd.time_step = fz_float(&r, 0.0f);
        /* cost only: a short span of simulated time, an automatic or not-tiny step */
        const size_t frames = 1 + fz_u8(&r) % 3;
        const double span = (double)bd.warmup + (double)frames / (double)bd.fps;
        if (span == span && span <= 0.1 && (bd.time_step == 0.0f || bd.time_step >= 1e-5f)) {
            float* st = malloc(frames * K * 3 * sizeof *st);
            (void)tsk_refine_simulate(&bd, knots, widths, K, frames, st);
            free(st);
        }
        float wv[3];
        tsk_refine_wind_at(&bd, (double)fz_float(&r, 1.0f), wv);
    }
    free(knots);
    free(widths);
    free(traj);
    fz_check_leaks("refine");
    return 0;
}
