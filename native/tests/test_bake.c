/* Tests of bake caches: frame files round-trip exactly, corruption, truncation, other
 * versions, read-only folders and full disks are reported, and .pc2 assembly verifies
 * every frame and writes the layout Blender's Mesh Cache modifier reads. */
#define _DEFAULT_SOURCE
#include "test.h"
#define TSK_TEST_TMP_NAME "bake"
#include "test_tmp.h"
#include "tussock/bake.h"

#include <dirent.h>
#include <signal.h>
#include <stdint.h>
#ifndef _WIN32
#include <sys/resource.h>
#endif
#include <sys/stat.h>
#include <unistd.h>

static void fill(float* xyz, int n, int frame) {
    for (int i = 0; i < 3 * n; ++i) xyz[i] = (float)(i * 0.001 + frame * 0.5);
}

TEST(test_frame_round_trip_is_exact) {
    float a[300], b[300];
    fill(a, 100, 7);
    const char* p = tmp_path("f7.tskf");
    CHECK(tsk_bake_write_frame(p, 7, a, 100) == TSK_OK);
    int32_t frame = 0;
    uint32_t count = 0;
    CHECK(tsk_bake_frame_info(p, &frame, &count) == TSK_OK);
    CHECK(frame == 7 && count == 100);
    CHECK(tsk_bake_read_frame(p, b, 100) == TSK_OK);
    CHECK(memcmp(a, b, sizeof a) == 0);
    struct stat st;
    CHECK(stat(p, &st) == 0 && st.st_size == 32 + 1200);
}

static void flip_byte(const char* path, long offset) {
    FILE* f = fopen(path, "r+b");
    fseek(f, offset, SEEK_SET);
    int c = fgetc(f);
    fseek(f, offset, SEEK_SET);
    fputc(c ^ 0x40, f);
    fclose(f);
}

TEST(test_corrupt_truncated_and_foreign_frames_are_refused) {
    float a[30];
    fill(a, 10, 1);
    const char* p = tmp_path("c.tskf");
    CHECK(tsk_bake_write_frame(p, 1, a, 10) == TSK_OK);
    flip_byte(p, 32 + 17);
    CHECK_STATUS(tsk_bake_frame_info(p, NULL, NULL), TSK_ERR_FORMAT, "checksum");
    CHECK(tsk_bake_write_frame(p, 1, a, 10) == TSK_OK);
    CHECK(truncate(p, 32 + 100) == 0);
    CHECK_STATUS(tsk_bake_frame_info(p, NULL, NULL), TSK_ERR_FORMAT, "truncated");
    CHECK(tsk_bake_write_frame(p, 1, a, 10) == TSK_OK);
    flip_byte(p, 8); /* format version 1 -> 65 */
    CHECK_STATUS(tsk_bake_frame_info(p, NULL, NULL), TSK_ERR_FORMAT, "another Tussock");
    FILE* f = fopen(p, "wb");
    fputs("hello, not a frame at all, but long enough for a header", f);
    fclose(f);
    CHECK_STATUS(tsk_bake_frame_info(p, NULL, NULL), TSK_ERR_FORMAT, "not a Tussock bake frame");
    CHECK_STATUS(tsk_bake_frame_info(tmp_path("missing.tskf"), NULL, NULL), TSK_ERR_IO, "missing");
    float b[30];
    CHECK(tsk_bake_write_frame(p, 1, a, 10) == TSK_OK);
    CHECK_STATUS(tsk_bake_read_frame(p, b, 11), TSK_ERR_FORMAT, "expected 11");
}

TEST(test_non_finite_points_and_limits_are_refused) {
    float a[6] = {0, 0, 0, 1, NAN, 1};
    CHECK_STATUS(tsk_bake_write_frame(tmp_path("nan.tskf"), 1, a, 2), TSK_ERR_ARGUMENT, "point 1");
    CHECK_STATUS(tsk_bake_write_frame(tmp_path("big.tskf"), 1, a, TSK_BAKE_MAX_POINTS + 1),
                 TSK_ERR_LIMIT, "limit");
    CHECK(access(tmp_path("nan.tskf"), F_OK) != 0);
}

#ifndef _WIN32 /* a file-size limit stands in for the full disk */
TEST(test_read_only_folder_and_full_disk_report_io_errors) {
    float a[3] = {1, 2, 3};
    if (geteuid() != 0) { /* root ignores permissions: only check as a normal user */
        const char* ro = tmp_path("ro");
        mkdir(ro, 0555);
        char p[600];
        snprintf(p, sizeof p, "%s/f.tskf", ro);
        CHECK_STATUS(tsk_bake_write_frame(p, 1, a, 1), TSK_ERR_IO, "cannot write");
    }
    /* a full disk, simulated by a file-size limit (a quota): the write fails part-way */
    static float big[3 * 1000];
    fill(big, 1000, 3);
    struct rlimit old;
    getrlimit(RLIMIT_FSIZE, &old);
    struct rlimit small = {4096, old.rlim_max};
    signal(SIGXFSZ, SIG_IGN);
    CHECK(setrlimit(RLIMIT_FSIZE, &small) == 0);
    tsk_status s = tsk_bake_write_frame(tmp_path("full.tskf"), 3, big, 1000);
    setrlimit(RLIMIT_FSIZE, &old);
    CHECK(s == TSK_ERR_IO);
    CHECK_MSG(strstr(tsk_last_error(), "cannot write") != NULL, "%s", tsk_last_error());
    CHECK(access(tmp_path("full.tskf"), F_OK) != 0); /* no half frame */
    DIR* d = opendir(g_dir); /* and no temporary file left */
    int leftovers = 0;
    for (struct dirent* e; d && (e = readdir(d)) != NULL;)
        leftovers += strstr(e->d_name, ".tmp") != NULL;
    if (d) closedir(d);
    CHECK(leftovers == 0);
    CHECK_STATUS(tsk_bake_write_frame("/proc/no/such/dir/f.tskf", 1, a, 1), TSK_ERR_IO,
                 "cannot write");
    /* sysfs refuses new files even to root: a read-only place whoever runs the tests */
    CHECK_STATUS(tsk_bake_write_frame("/sys/tussock_test.tskf", 1, a, 1), TSK_ERR_IO,
                 "Permission denied");
}
#endif

TEST(test_pc2_assembly_matches_frames_and_header) {
    enum { N = 50, F = 5 };
    static float frames[F][N * 3], got[N * 3];
    const char* paths[F];
    char names[F][64];
    for (int f = 0; f < F; ++f) {
        fill(frames[f], N, f + 10);
        snprintf(names[f], sizeof names[f], "p%d.tskf", f);
        paths[f] = strdup(tmp_path(names[f]));
        CHECK(tsk_bake_write_frame(paths[f], 10 + f, frames[f], N) == TSK_OK);
    }
    const char* pc2 = tmp_path("out.pc2");
    CHECK(tsk_bake_assemble_pc2(pc2, paths, F, 10.0f, 1.0f) == TSK_OK);
    uint32_t points, samples;
    float start, rate;
    CHECK(tsk_pc2_info(pc2, &points, &start, &rate, &samples) == TSK_OK);
    CHECK(points == N && samples == F && start == 10.0f && rate == 1.0f);
    for (int f = 0; f < F; ++f) {
        CHECK(tsk_pc2_read_sample(pc2, (uint32_t)f, got, N) == TSK_OK);
        CHECK(memcmp(got, frames[f], sizeof got) == 0);
    }
    /* the header, byte by byte, as the Point Cache 2 format defines it */
    FILE* fp = fopen(pc2, "rb");
    unsigned char h[32];
    CHECK(fread(h, 1, 32, fp) == 32);
    fclose(fp);
    CHECK(memcmp(h, "POINTCACHE2\0", 12) == 0);
    int32_t v;
    memcpy(&v, h + 12, 4);
    CHECK(v == 1);
    memcpy(&v, h + 16, 4);
    CHECK(v == N);
    memcpy(&v, h + 28, 4);
    CHECK(v == F);
    /* a missing or out-of-order frame: refused, and the old .pc2 is left as it was */
    const char* swapped[F] = {paths[0], paths[2], paths[1], paths[3], paths[4]};
    CHECK_STATUS(tsk_bake_assemble_pc2(pc2, swapped, F, 10.0f, 1.0f), TSK_ERR_FORMAT,
                 "expected frame 11");
    unlink(paths[3]);
    CHECK_STATUS(tsk_bake_assemble_pc2(pc2, paths, F, 10.0f, 1.0f), TSK_ERR_IO, "p3.tskf");
    CHECK(tsk_pc2_info(pc2, &points, NULL, NULL, &samples) == TSK_OK && samples == F);
    for (int f = 0; f < F; ++f) free((void*)paths[f]);
}

/* Writes a frame file by hand (the writer refuses what these tests need): the header as
 * frames.c lays it out and a correct checksum of `xyz`. */
static void forge_frame(const char* path, int32_t frame, const float* xyz, uint32_t count) {
    unsigned char h[32];
    memcpy(h, "TSKFRAME", 8);
    uint32_t v[4] = {TSK_BAKE_FORMAT_VERSION, (uint32_t)frame, count, 0};
    for (int k = 0; k < 4; ++k)
        for (int i = 0; i < 4; ++i) h[8 + 4 * k + i] = (unsigned char)(v[k] >> (8 * i));
    uint64_t sum = tsk_bake_checksum(xyz, (size_t)count * 12);
    for (int i = 0; i < 8; ++i) h[24 + i] = (unsigned char)(sum >> (8 * i));
    FILE* f = fopen(path, "wb");
    fwrite(h, 1, 32, f);
    fwrite(xyz, 12, count, f);
    fclose(f);
}

/* fuzz_bake: a frame whose checksum matches but which holds NaN was read as valid, and a
 * .pc2 sample with NaN was returned as is: both are refused now. */
TEST(test_frames_and_samples_with_non_finite_points_are_refused) {
    float a[6] = {0, 0, 0, 1, NAN, 1}, b[6];
    const char* p = tmp_path("forged_nan.tskf");
    forge_frame(p, 4, a, 2);
    CHECK_STATUS(tsk_bake_frame_info(p, NULL, NULL), TSK_ERR_FORMAT, "non-finite");
    CHECK_STATUS(tsk_bake_read_frame(p, b, 2), TSK_ERR_FORMAT, "non-finite");
    a[4] = 1.0f; /* the same file with finite points is accepted: the checksum was right */
    forge_frame(p, 4, a, 2);
    int32_t fr = 0;
    uint32_t n = 0;
    CHECK(tsk_bake_frame_info(p, &fr, &n) == TSK_OK && fr == 4 && n == 2);
    /* a .pc2 of one sample whose second point is inf */
    const char* pc2 = tmp_path("inf.pc2");
    FILE* f = fopen(pc2, "wb");
    int32_t head[5] = {1, 2, 0, 0, 1};
    float start = 1.0f, rate = 1.0f, pts[6] = {0, 0, 0, INFINITY, 0, 0};
    memcpy(&head[2], &start, 4);
    memcpy(&head[3], &rate, 4);
    fwrite("POINTCACHE2", 1, 12, f);
    fwrite(head, 4, 5, f);
    fwrite(pts, 4, 6, f);
    fclose(f);
    uint32_t points = 0, samples = 0;
    CHECK(tsk_pc2_info(pc2, &points, NULL, NULL, &samples) == TSK_OK && points == 2);
    CHECK_STATUS(tsk_pc2_read_sample(pc2, 0, b, 2), TSK_ERR_FORMAT, "non-finite");
    CHECK_STATUS(tsk_pc2_read_sample(pc2, 0, NULL, 2), TSK_ERR_ARGUMENT, "xyz");
}

/* fuzz_bake: a .pc2 header with a NaN or infinite start frame or a zero, negative or NaN
 * sample rate was accepted (the add-on's int(start_frame) then raised), and the assembly
 * wrote such headers for an infinite start or rate. */
TEST(test_pc2_headers_with_bad_start_or_rate_are_refused) {
    const char* pc2 = tmp_path("hdr.pc2");
    const float starts[] = {NAN, INFINITY, -INFINITY, 1.0f, 1.0f, 1.0f, 1.0f};
    const float rates[] = {1.0f, 1.0f, 1.0f, 0.0f, -1.0f, NAN, INFINITY};
    for (int c = 0; c < 7; ++c) {
        FILE* f = fopen(pc2, "wb");
        int32_t head[5] = {1, 0, 0, 0, 0}; /* no points, no samples: only the header */
        memcpy(&head[2], &starts[c], 4);
        memcpy(&head[3], &rates[c], 4);
        fwrite("POINTCACHE2", 1, 12, f);
        fwrite(head, 4, 5, f);
        fclose(f);
        CHECK_STATUS(tsk_pc2_info(pc2, NULL, NULL, NULL, NULL), TSK_ERR_FORMAT, "bad .pc2 header");
    }
    float a[3] = {1, 2, 3};
    const char* fp = tmp_path("one.tskf");
    CHECK(tsk_bake_write_frame(fp, 1, a, 1) == TSK_OK);
    const char* list[1] = {fp};
    const char* out = tmp_path("never.pc2");
    CHECK_STATUS(tsk_bake_assemble_pc2(out, list, 1, INFINITY, 1.0f), TSK_ERR_ARGUMENT,
                 "start_frame");
    CHECK_STATUS(tsk_bake_assemble_pc2(out, list, 1, NAN, 1.0f), TSK_ERR_ARGUMENT, "start_frame");
    CHECK_STATUS(tsk_bake_assemble_pc2(out, list, 1, 1.0f, INFINITY), TSK_ERR_ARGUMENT,
                 "sample_rate");
    CHECK_STATUS(tsk_bake_assemble_pc2(out, list, 1, 1.0f, 0.0f), TSK_ERR_ARGUMENT, "sample_rate");
    CHECK(access(out, F_OK) != 0);
    CHECK(tsk_bake_assemble_pc2(out, list, 1, -3.5f, 0.5f) == TSK_OK);
    float st = 0, rt = 0;
    CHECK(tsk_pc2_info(out, NULL, &st, &rt, NULL) == TSK_OK && st == -3.5f && rt == 0.5f);
}

/* Frame numbers near INT32_MAX: the consecutiveness check computed first + i in 32 bits
 * (signed overflow, undefined behaviour); a frame INT32_MIN after INT32_MAX is not the next. */
TEST(test_assembly_frame_numbers_at_int32_limits) {
    float a[3] = {1, 2, 3};
    const char* p0 = strdup(tmp_path("max0.tskf"));
    const char* p1 = strdup(tmp_path("max1.tskf"));
    CHECK(tsk_bake_write_frame(p0, INT32_MAX, a, 1) == TSK_OK);
    CHECK(tsk_bake_write_frame(p1, INT32_MIN, a, 1) == TSK_OK);
    const char* list[2] = {p0, p1};
    CHECK_STATUS(tsk_bake_assemble_pc2(tmp_path("max.pc2"), list, 2, 0.0f, 1.0f), TSK_ERR_FORMAT,
                 "expected frame 2147483648");
    CHECK(tsk_bake_write_frame(p0, INT32_MAX - 1, a, 1) == TSK_OK);
    CHECK(tsk_bake_write_frame(p1, INT32_MAX, a, 1) == TSK_OK);
    CHECK(tsk_bake_assemble_pc2(tmp_path("max.pc2"), list, 2, 0.0f, 1.0f) == TSK_OK);
    free((void*)p0);
    free((void*)p1);
}

/* The assembly holds the whole .pc2 in memory: above the memory budget it is refused with
 * a message instead of allocating. Verifying a frame needs no memory of its size. */
TEST(test_assembly_over_memory_budget_is_refused) {
    enum { N = 20000 };
    static float a[3 * N];
    fill(a, N, 1);
    const char* p = tmp_path("budget.tskf");
    CHECK(tsk_bake_write_frame(p, 1, a, N) == TSK_OK);
    const char* list[1] = {p};
    tsk_set_memory_budget(64 << 10); /* 64 KiB < 240 KB of points */
    CHECK(tsk_bake_frame_info(p, NULL, NULL) == TSK_OK);
    CHECK_STATUS(tsk_bake_assemble_pc2(tmp_path("budget.pc2"), list, 1, 1.0f, 1.0f), TSK_ERR_LIMIT,
                 "memory budget");
    tsk_set_memory_budget(0);
    CHECK(access(tmp_path("budget.pc2"), F_OK) != 0);
    CHECK(tsk_bake_assemble_pc2(tmp_path("budget.pc2"), list, 1, 1.0f, 1.0f) == TSK_OK);
}

TEST_MAIN(TEST_ENTRY(test_frame_round_trip_is_exact),
          TEST_ENTRY(test_corrupt_truncated_and_foreign_frames_are_refused),
          TEST_ENTRY(test_non_finite_points_and_limits_are_refused),
          TEST_POSIX(test_read_only_folder_and_full_disk_report_io_errors),
          TEST_ENTRY(test_pc2_assembly_matches_frames_and_header),
          TEST_ENTRY(test_frames_and_samples_with_non_finite_points_are_refused),
          TEST_ENTRY(test_pc2_headers_with_bad_start_or_rate_are_refused),
          TEST_ENTRY(test_assembly_frame_numbers_at_int32_limits),
          TEST_ENTRY(test_assembly_over_memory_budget_is_refused))
