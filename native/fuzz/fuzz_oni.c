/* Fuzz target: OpenNI2 recordings. The bytes become a .oni file that tsk_depth_open_oni
 * opens through OpenNI2's own player (the OniFile driver, third-party code that runs its
 * own threads); up to three frames are read, the read contract checked, then a seek and
 * another read. Slow by nature (the player thread, a wait for frames that never come in
 * a broken file): see docs/reliability.md for the rate it reaches. */
#include "fuzz.h"
#include "tussock/capture.h"

int LLVMFuzzerInitialize(int* argc, char*** argv) {
    (void)argc;
    (void)argv;
    fz_init();
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size > (1u << 20)) return 0;
    char path[128];
    if (!fz_write_temp(data, size, "oni", path, sizeof path)) return 0;
    tsk_depth_source* src = NULL;
    if (tsk_depth_open_oni(path, &src) == TSK_OK) {
        tsk_depth_info info;
        if (tsk_depth_get_info(src, &info) != TSK_OK) abort();
        if (info.width <= 0 || info.height <= 0) abort();
        const size_t n = (size_t)info.width * (size_t)info.height;
        float* depth = malloc(n * sizeof *depth);
        tsk_depth_frame fr;
        for (int i = 0; i < 3 && depth != NULL; ++i) {
            if (tsk_depth_read(src, depth, n, &fr) != TSK_OK || !fr.is_new) break;
            for (size_t k = 0; k < n; ++k)
                if (!(depth[k] >= 0.0f) || !isfinite(depth[k])) abort();
        }
        if (tsk_depth_seek(src, 0) == TSK_OK && depth != NULL)
            (void)tsk_depth_read(src, depth, n, &fr);
        (void)tsk_depth_seek(src, -1);
        (void)tsk_depth_seek(src, INT_MAX);
        free(depth);
        tsk_depth_close(src);
    }
    unlink(path);
    fz_check_leaks("oni");
    return 0;
}
