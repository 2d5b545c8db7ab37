/* Fuzz target: the capture definition and pipeline on a synthetic depth frame. The bytes
 * give a tsk_capture_def (defaults with fields replaced by edge values), intrinsics, a
 * frame size (1..96 per side) and the depth pixels (mostly millimetre values from the bytes,
 * sometimes NaN/inf/negative), then tsk_capture_propose_band, tsk_capture_process twice on
 * the same handle (buffer reuse) and every getter. */
#include "fuzz.h"
#include "tussock/capture.h"

int LLVMFuzzerInitialize(int* argc, char*** argv) {
    (void)argc;
    (void)argv;
    fz_init();
    return 0;
}

static void fuzz_def(fz* r, tsk_capture_def* d) {
    *d = tsk_default_capture_def();
    if (fz_u8(r) & 1) return;
    d->near_m = fz_float(r, d->near_m);
    d->far_m = fz_float(r, d->far_m);
    d->intrinsics.fx = fz_float(r, 57.0f);
    d->intrinsics.fy = fz_float(r, 57.0f);
    d->intrinsics.cx = fz_float(r, 32.0f);
    d->intrinsics.cy = fz_float(r, 24.0f);
    if (fz_u8(r) & 1) d->intrinsics = (tsk_intrinsics){0, 0, 0, 0};
    d->min_area = fz_int(r, 20);
    d->hole_radius = fz_int(r, d->hole_radius);
    d->open_radius = fz_int(r, d->open_radius);
    d->contour_smooth = fz_float(r, d->contour_smooth);
    d->split_smooth = fz_float(r, d->split_smooth);
    d->split_prominence = fz_float(r, d->split_prominence);
    d->root = (tsk_capture_root)(fz_u8(r) % 3);
    d->knot_spacing = fz_float(r, d->knot_spacing);
    d->width_smooth = fz_float(r, d->width_smooth);
    d->depth_window = fz_int(r, d->depth_window);
    d->min_knots = fz_int(r, d->min_knots);
    d->root_trim = fz_float(r, d->root_trim);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fz r = {data, size};
    tsk_capture_def def;
    fuzz_def(&r, &def);
    int w = 1 + fz_u8(&r) % 96, h = 1 + fz_u8(&r) % 96;
    const size_t n = (size_t)w * h;
    float* depth = malloc(n * sizeof *depth);
    const int mode = fz_u8(&r) % 4;
    for (size_t i = 0; i < n; ++i) {
        if (mode == 0) { /* a vertical blade shape from the bytes: one byte per column run */
            depth[i] = (fz_u8(&r) > 100) ? 0.5f : 0.0f;
        } else if (mode == 1) {
            depth[i] = (float)(fz_u8(&r) | fz_u8(&r) << 8) * 0.001f;
        } else if (mode == 2) {
            depth[i] = (fz_u8(&r) % 64 == 0) ? fz_float(&r, 0.6f) : 0.6f * (i % 7 < 3);
        } else {
            depth[i] = fz_float(&r, 0.4f);
        }
    }
    float nearv = 0, farv = 0;
    (void)tsk_capture_propose_band(depth, w, h, fz_int(&r, 10), &nearv, &farv);
    tsk_capture* cap = NULL;
    if (tsk_capture_create(&cap) != TSK_OK) abort();
    for (int pass = 0; pass < 2; ++pass) {
        if (tsk_capture_process(cap, &def, depth, w, h) == TSK_OK) {
            const int nb = tsk_capture_blade_count(cap), nk = tsk_capture_knot_total(cap);
            if (nb < 0 || nk < 0) abort();
            int32_t* counts = malloc((size_t)(nb + 1) * sizeof *counts);
            float* xyz = malloc((size_t)(nk + 1) * 3 * sizeof *xyz);
            float* wid = malloc((size_t)(nk + 1) * sizeof *wid);
            float* uv = malloc((size_t)(nk + 1) * 2 * sizeof *uv);
            if (tsk_capture_get_blades(cap, counts, NULL, (size_t)nb) != TSK_OK) abort();
            if (tsk_capture_get_knots(cap, xyz, wid, uv, (size_t)nk) != TSK_OK) abort();
            int sum = 0;
            for (int b = 0; b < nb; ++b) sum += counts[b];
            if (sum != nk) abort();
            for (int i = 0; i < nk; ++i)
                if (!isfinite(xyz[3 * i]) || !isfinite(xyz[3 * i + 1]) ||
                    !isfinite(xyz[3 * i + 2]) || !(wid[i] >= 0.0f) || !isfinite(wid[i])) {
                    const tsk_intrinsics in = tsk_capture_intrinsics(cap);
                    fprintf(stderr, "knot %d: %g %g %g width %g (fx %g fy %g cx %g cy %g)\n", i,
                            xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], wid[i], in.fx, in.fy, in.cx,
                            in.cy);
                    fprintf(stderr,
                            "def: band %g %g area %d hole %d open %d cs %g ss %g sp %g "
                            "root %d ks %g ws %g dw %d mk %d rt %g; %dx%d\n",
                            def.near_m, def.far_m, def.min_area, def.hole_radius, def.open_radius,
                            def.contour_smooth, def.split_smooth, def.split_prominence, def.root,
                            def.knot_spacing, def.width_smooth, def.depth_window, def.min_knots,
                            def.root_trim, w, h);
                    abort();
                }
            (void)tsk_capture_get_knots(cap, xyz, wid, uv, (size_t)nk + 1); /* wrong size */
            if (nb > 0) {
                const int b = fz_u8(&r) % nb;
                if (tsk_capture_get_blade(cap, b, xyz, wid, uv, (size_t)counts[b]) != TSK_OK)
                    abort();
            }
            (void)tsk_capture_get_blade(cap, nb, xyz, wid, uv, 1);
            const size_t npix = (size_t)w * (size_t)h; /* this pass's frame */
            uint8_t* img = malloc(npix);
            for (int k = 0; k < 4; ++k)
                if (tsk_capture_get_image(cap, (tsk_capture_image)k, img, npix) != TSK_OK) abort();
            (void)tsk_capture_get_image(cap, (tsk_capture_image)4, img, npix);
            free(img);
            free(counts);
            free(xyz);
            free(wid);
            free(uv);
        }
        (void)tsk_capture_status_message(cap);
        /* second pass: a smaller frame on the same handle */
        w = 1 + w / 2;
        h = 1 + h / 2;
    }
    tsk_capture_destroy(cap);
    tsk_intrinsics in;
    (void)tsk_intrinsics_from_fov(fz_int(&r, 640), fz_int(&r, 480), fz_float(&r, 1.0f),
                                  fz_float(&r, 0.8f), &in);
    free(depth);
    fz_check_leaks("capture def");
    return 0;
}
