/* Tests of picture bake frames: an EXR frame decodes (by the picture loader, an independent
 * reader path through OpenEXR) to exactly the floats written, the same pixels give the same
 * bytes, and a corrupt EXR, a foreign or missing sidecar, another format version, a
 * read-only folder and a full disk are reported with the file's name. */
#define _DEFAULT_SOURCE
#include "test.h"
#define TSK_TEST_TMP_NAME "bake_image"
#include "test_tmp.h"
#include "tussock/bake_image.h"
#include "tussock/picture.h"

#include <dirent.h>
#include <signal.h>
#include <stdint.h>
#ifndef _WIN32
#include <sys/resource.h>
#endif
#include <sys/stat.h>
#include <unistd.h>

/* A UV-pass-like image: u, v at pixel centres plus a frame-dependent wobble, B = A = 1. */
static float* uv_image(int w, int h, int frame) {
    float* v = malloc((size_t)w * h * 4 * sizeof(float));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float* p = v + ((size_t)y * w + x) * 4;
            p[0] = (x + 0.5f) / w + 0.01f * sinf(0.3f * x + frame);
            p[1] = (h - y - 0.5f) / h + 0.007f * cosf(0.2f * y - frame);
            p[2] = p[3] = 1.0f;
        }
    return v;
}

/* A missing file (a write that failed before) leaves the checks after it to fail. */
static void flip_byte(const char* path, long offset) {
    FILE* f = fopen(path, "r+b");
    if (f == NULL || offset < 0) {
        if (f) fclose(f);
        return;
    }
    fseek(f, offset, SEEK_SET);
    int c = fgetc(f);
    fseek(f, offset, SEEK_SET);
    fputc(c ^ 0x40, f);
    fclose(f);
}

static long file_size(const char* path) {
    struct stat st;
    return stat(path, &st) == 0 ? (long)st.st_size : -1;
}

static int same_bytes(const char* a, const char* b) {
    FILE *fa = fopen(a, "rb"), *fb = fopen(b, "rb");
    int same = fa && fb;
    while (same) {
        int ca = fgetc(fa), cb = fgetc(fb);
        if (ca != cb) same = 0;
        if (ca == EOF || cb == EOF) break;
    }
    if (fa) fclose(fa);
    if (fb) fclose(fb);
    return same;
}

TEST(test_image_frame_round_trip_is_exact_and_deterministic) {
    enum { W = 37, H = 23 };
    float* a = uv_image(W, H, 5);
    const char* p = strdup(tmp_path("uv_0005.exr"));
    CHECK(tsk_bake_write_image(p, 5, 0x1234567890abcdefull, a, 4 * W * H, W, H) == TSK_OK);
    int32_t frame = 0;
    uint64_t key = 0;
    int w = 0, h = 0;
    CHECK(tsk_bake_image_info(p, &frame, &key, &w, &h) == TSK_OK);
    CHECK(frame == 5 && key == 0x1234567890abcdefull && w == W && h == H);
    tsk_picture* pic = NULL;
    CHECK(tsk_picture_load(p, &pic) == TSK_OK);
    float* b = malloc(sizeof(float) * 4 * W * H);
    CHECK(pic && tsk_picture_read_rgba(pic, b, 4 * W * H, 0) == TSK_OK);
    CHECK(memcmp(a, b, sizeof(float) * 4 * W * H) == 0); /* 32-bit float, lossless */
    tsk_picture_destroy(pic);
    /* the same pixels written again (another process of a split bake): the same bytes */
    const char* q = strdup(tmp_path("again.exr"));
    CHECK(tsk_bake_write_image(q, 5, 0x1234567890abcdefull, a, 4 * W * H, W, H) == TSK_OK);
    CHECK(same_bytes(p, q));
    char ps[620], qs[620];
    snprintf(ps, sizeof ps, "%s.tski", p);
    snprintf(qs, sizeof qs, "%s.tski", q);
    CHECK(same_bytes(ps, qs) && file_size(ps) == 48);
    free(a);
    free(b);
    free((void*)p);
    free((void*)q);
}

TEST(test_corrupt_foreign_and_missing_image_frames_are_refused) {
    enum { W = 16, H = 12 };
    float* a = uv_image(W, H, 2);
    char p[600], side[620];
    snprintf(p, sizeof p, "%s", tmp_path("c_0002.exr"));
    snprintf(side, sizeof side, "%s.tski", p);
    CHECK(tsk_bake_write_image(p, 2, 7, a, 4 * W * H, W, H) == TSK_OK);
    flip_byte(p, file_size(p) - 10);
    CHECK_STATUS(tsk_bake_image_info(p, NULL, NULL, NULL, NULL), TSK_ERR_FORMAT,
                 "does not match its sidecar");
    CHECK(tsk_bake_write_image(p, 2, 7, a, 4 * W * H, W, H) == TSK_OK);
    CHECK(truncate(p, file_size(p) - 1) == 0);
    CHECK_STATUS(tsk_bake_image_info(p, NULL, NULL, NULL, NULL), TSK_ERR_FORMAT, "c_0002.exr");
    CHECK(tsk_bake_write_image(p, 2, 7, a, 4 * W * H, W, H) == TSK_OK);
    flip_byte(side, 8); /* format version 1 -> 65 */
    CHECK_STATUS(tsk_bake_image_info(p, NULL, NULL, NULL, NULL), TSK_ERR_FORMAT, "another Tussock");
    FILE* f = fopen(side, "wb");
    fputs("not a sidecar, though about as long as one is", f);
    fclose(f);
    CHECK_STATUS(tsk_bake_image_info(p, NULL, NULL, NULL, NULL), TSK_ERR_FORMAT,
                 "not a Tussock image sidecar");
    unlink(side); /* an EXR whose sidecar never got written (killed between the two) */
    CHECK_STATUS(tsk_bake_image_info(p, NULL, NULL, NULL, NULL), TSK_ERR_IO, "c_0002.exr.tski");
    CHECK(tsk_bake_write_image(p, 2, 7, a, 4 * W * H, W, H) == TSK_OK);
    unlink(p);
    CHECK_STATUS(tsk_bake_image_info(p, NULL, NULL, NULL, NULL), TSK_ERR_IO, "c_0002.exr");
    free(a);
}

TEST(test_bad_image_arguments_are_refused) {
    float a[4 * 16] = {0};
    CHECK_STATUS(tsk_bake_write_image(tmp_path("x.png"), 1, 0, a, 64, 4, 4), TSK_ERR_ARGUMENT,
                 ".exr");
    CHECK_STATUS(tsk_bake_write_image(tmp_path("x.exr"), 1, 0, a, 60, 4, 4), TSK_ERR_ARGUMENT,
                 "rgba");
    CHECK_STATUS(tsk_bake_write_image(tmp_path("x.exr"), 1, 0, a, 64, 2, 8), TSK_ERR_ARGUMENT,
                 "width, height");
    a[17] = NAN;
    CHECK_STATUS(tsk_bake_write_image(tmp_path("x.exr"), 1, 0, a, 64, 4, 4), TSK_ERR_ARGUMENT,
                 "pixel 4");
    CHECK(access(tmp_path("x.exr"), F_OK) != 0);
    CHECK_STATUS(tsk_bake_image_info(NULL, NULL, NULL, NULL, NULL), TSK_ERR_ARGUMENT, "path");
}

#ifndef _WIN32 /* a file-size limit stands in for the full disk */
TEST(test_read_only_folder_and_full_disk_report_io_errors_for_images) {
    enum { W = 64, H = 64 };
    float* a = uv_image(W, H, 1);
    for (int i = 0; i < 4 * W * H; ++i) a[i] = tsk_rand01(3, (uint64_t)i, 0, 0); /* no ZIP gain */
    if (geteuid() != 0) {
        const char* ro = tmp_path("ro");
        mkdir(ro, 0555);
        char p[600];
        snprintf(p, sizeof p, "%s/f_0001.exr", ro);
        CHECK_STATUS(tsk_bake_write_image(p, 1, 0, a, 4 * W * H, W, H), TSK_ERR_IO,
                     "Permission denied");
    }
    CHECK_STATUS(tsk_bake_write_image("/sys/tussock_test_0001.exr", 1, 0, a, 4 * W * H, W, H),
                 TSK_ERR_IO, "cannot write");
    /* a full disk, simulated by a file-size limit (a quota): the write fails part-way */
    struct rlimit old;
    getrlimit(RLIMIT_FSIZE, &old);
    struct rlimit small = {1024, old.rlim_max};
    signal(SIGXFSZ, SIG_IGN);
    CHECK(setrlimit(RLIMIT_FSIZE, &small) == 0);
    tsk_status s = tsk_bake_write_image(tmp_path("full_0001.exr"), 1, 0, a, 4 * W * H, W, H);
    setrlimit(RLIMIT_FSIZE, &old);
    CHECK(s == TSK_ERR_IO);
    CHECK_MSG(strstr(tsk_last_error(), "cannot write") != NULL &&
                  strstr(tsk_last_error(), "full_0001.exr") != NULL,
              "%s", tsk_last_error());
    CHECK(access(tmp_path("full_0001.exr"), F_OK) != 0);
    DIR* d = opendir(g_dir);
    int leftovers = 0;
    for (struct dirent* e; d && (e = readdir(d)) != NULL;)
        leftovers += strstr(e->d_name, ".tmp") != NULL;
    if (d) closedir(d);
    CHECK(leftovers == 0);
    free(a);
}
#endif

TEST_MAIN(TEST_NEEDS(test_image_frame_round_trip_is_exact_and_deterministic, OpenCV),
          TEST_NEEDS(test_corrupt_foreign_and_missing_image_frames_are_refused, OpenCV),
          TEST_ENTRY(test_bad_image_arguments_are_refused),
          TEST_POSIX_NEEDS(test_read_only_folder_and_full_disk_report_io_errors_for_images, OpenCV))
