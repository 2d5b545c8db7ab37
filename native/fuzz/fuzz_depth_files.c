/* Fuzz target: depth image files. The bytes become a .png (PNG signature) or .exr file that
 * tsk_depth_open_files opens (header check, first decode); a frame is read, its contract
 * checked (never NaN, never negative) and, for images up to 256x256, run through the whole
 * capture pipeline with the default definition and every result getter. */
#include "fuzz.h"
#include "tussock/capture.h"

int LLVMFuzzerInitialize(int* argc, char*** argv) {
    (void)argc;
    (void)argv;
    fz_init();
    return 0;
}

static void run_pipeline(const float* depth, int w, int h) {
    tsk_capture* cap = NULL;
    if (tsk_capture_create(&cap) != TSK_OK) return;
    const tsk_capture_def def = tsk_default_capture_def();
    if (tsk_capture_process(cap, &def, depth, w, h) == TSK_OK) {
        const int nb = tsk_capture_blade_count(cap);
        const int nk = tsk_capture_knot_total(cap);
        if (nb < 0 || nk < 0 || nb > TSK_CAPTURE_MAX_BLADES) abort();
        int32_t* counts = malloc((size_t)(nb + 1) * sizeof *counts);
        uint32_t* flags = malloc((size_t)(nb + 1) * sizeof *flags);
        float* xyz = malloc((size_t)(nk + 1) * 3 * sizeof *xyz);
        float* wid = malloc((size_t)(nk + 1) * sizeof *wid);
        float* uv = malloc((size_t)(nk + 1) * 2 * sizeof *uv);
        if (tsk_capture_get_blades(cap, counts, flags, (size_t)nb) != TSK_OK) abort();
        if (tsk_capture_get_knots(cap, xyz, wid, uv, (size_t)nk) != TSK_OK) abort();
        for (int i = 0; i < nk; ++i)
            if (!isfinite(xyz[3 * i]) || !isfinite(xyz[3 * i + 2]) || !(wid[i] >= 0.0f)) abort();
        if (nb > 0) tsk_capture_get_blade(cap, 0, xyz, wid, uv, (size_t)counts[0]);
        uint8_t* img = malloc((size_t)w * (size_t)h);
        for (int k = 0; k < 4; ++k)
            if (tsk_capture_get_image(cap, (tsk_capture_image)k, img, (size_t)w * h) != TSK_OK)
                abort();
        free(img);
        free(counts);
        free(flags);
        free(xyz);
        free(wid);
        free(uv);
    }
    (void)tsk_capture_status_message(cap);
    tsk_capture_destroy(cap);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size > (1u << 20)) return 0;
    const int png = size >= 1 && data[0] == 0x89;
    char path[128];
    if (!fz_write_temp(data, size, png ? "png" : "exr", path, sizeof path)) return 0;
    tsk_depth_source* src = NULL;
    if (tsk_depth_open_files(path, &src) == TSK_OK) {
        tsk_depth_info info;
        if (tsk_depth_get_info(src, &info) != TSK_OK) abort();
        if (info.width <= 0 || info.height <= 0 || info.width > TSK_DEPTH_MAX_SIDE ||
            info.height > TSK_DEPTH_MAX_SIDE)
            abort();
        const size_t n = (size_t)info.width * (size_t)info.height;
        float* depth = malloc(n * sizeof *depth);
        tsk_depth_frame fr;
        if (depth != NULL && tsk_depth_read(src, depth, n, &fr) == TSK_OK && fr.is_new) {
            for (size_t i = 0; i < n; ++i)
                if (!(depth[i] >= 0.0f) || !isfinite(depth[i])) abort(); /* the contract */
            if (n <= 256 * 256) run_pipeline(depth, info.width, info.height);
        }
        /* past the end: no new frame, no error */
        if (depth != NULL && tsk_depth_read(src, depth, n, &fr) == TSK_OK && fr.is_new) abort();
        free(depth);
        tsk_depth_close(src);
    } else if (src != NULL) {
        abort(); /* *out is set only on success */
    }
    unlink(path);
    fz_check_leaks("depth file");
    return 0;
}
