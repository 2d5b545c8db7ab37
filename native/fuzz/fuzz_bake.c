/* Fuzz target: bake caches, the files Tussock reads back from disk. The first byte picks:
 *   0: the rest as a frame file (.tskf): tsk_bake_frame_info, tsk_bake_read_frame with the
 *      claimed and a wrong count, and tsk_bake_assemble_pc2 of it;
 *   1: the rest as a .pc2 file: tsk_pc2_info, tsk_pc2_read_sample at fuzzed indices;
 *   2, 3: 1..5 frame files whose header fields (magic, version, frame, count, reserved)
 *      and points are fuzzed, with a correct checksum unless a bit says otherwise, some
 *      truncated or lengthened; then tsk_bake_assemble_pc2 with a fuzzed frame count, start
 *      frame and sample rate (the bake job's parameters), and for an accepted assembly
 *      tsk_pc2_info and every sample read back and compared with the frames' points;
 *   4: a .pc2 whose header fields are fuzzed behind a correct magic, with as many data
 *      bytes as the header claims (or a fuzzed number), then as in 1;
 *   5: tsk_bake_write_frame of fuzzed points (non-finite ones must be refused) and the
 *      round trip.
 * Every status must be TSK_OK or a documented error, every accepted read finite where the
 * contract says so, and nothing left allocated. */
#include "fuzz.h"
#include "tussock/bake.h"

int LLVMFuzzerInitialize(int* argc, char*** argv) {
    (void)argc;
    (void)argv;
    fz_init();
    return 0;
}

enum { MAX_FRAMES = 5, MAX_POINTS = 64 };

static void temp_name(char* path, size_t n, int k, const char* ext) {
    snprintf(path, n, "/tmp/tsk_fuzz_bake_%ld_%d.%s", (long)getpid(), k, ext);
}

static int write_file(const char* path, const void* data, size_t size) {
    FILE* f = fopen(path, "wb");
    if (f == NULL) return 0;
    const size_t w = size ? fwrite(data, 1, size, f) : 0;
    fclose(f);
    return w == size;
}

static void put_u32(unsigned char* p, uint32_t v) {
    for (int i = 0; i < 4; ++i) p[i] = (unsigned char)(v >> (8 * i));
}
static void put_u64(unsigned char* p, uint64_t v) {
    for (int i = 0; i < 8; ++i) p[i] = (unsigned char)(v >> (8 * i));
}

static void check_finite(const float* v, size_t n, const char* what) {
    for (size_t i = 0; i < n; ++i)
        if (!isfinite(v[i])) {
            fprintf(stderr, "bake: %s value %zu is %g\n", what, i, (double)v[i]);
            abort();
        }
}

/* A frame file the library accepted: read it back. */
static void read_frame_back(const char* path) {
    int32_t frame = 0;
    uint32_t count = 0;
    if (tsk_bake_frame_info(path, &frame, &count) != TSK_OK) return;
    if (count > TSK_BAKE_MAX_POINTS) abort();
    float* xyz = tsk_alloc((size_t)count * 12 + 12, "fuzz");
    if (tsk_bake_read_frame(path, xyz, count) != TSK_OK) abort();
    check_finite(xyz, (size_t)count * 3, "frame");
    if (tsk_bake_read_frame(path, xyz, count + 1) == TSK_OK) abort();
    tsk_free(xyz);
}

/* A .pc2 file: info, then samples at a few indices (the valid first and last and a fuzzed
 * one, which must be refused when out of range). */
static void read_pc2_back(fz* r, const char* path) {
    uint32_t points = 0, samples = 0;
    float start = 0, rate = 0;
    if (tsk_pc2_info(path, &points, &start, &rate, &samples) != TSK_OK) return;
    if (points > TSK_BAKE_MAX_POINTS || !isfinite(start) || !(rate > 0) || !isfinite(rate)) {
        fprintf(stderr, "pc2: accepted a header with %u points, start %g, rate %g\n", points,
                (double)start, (double)rate);
        abort();
    }
    /* A header may claim 2^28 points with no samples (a 32-byte file): then no read may
       touch the buffer, so a small one does (ASan would see a read that did). */
    const size_t room = samples > 0 ? (size_t)points : (points < 4096 ? points : 4096);
    float* xyz = tsk_alloc(room * 12 + 12, "fuzz");
    uint32_t idx[3] = {0, samples ? samples - 1 : 0, fz_u32(r)};
    for (int i = 0; i < 3; ++i) {
        const tsk_status s = tsk_pc2_read_sample(path, idx[i], xyz, points);
        /* out of range: refused; in range: read, or refused only for a non-finite point */
        if (idx[i] >= samples ? s == TSK_OK : (s != TSK_OK && s != TSK_ERR_FORMAT)) abort();
        if (s == TSK_OK) check_finite(xyz, (size_t)points * 3, "pc2 sample");
    }
    if (points > 0 && tsk_pc2_read_sample(path, 0, xyz, points - 1) == TSK_OK) abort();
    tsk_free(xyz);
}

static void structured_frames(fz* r) {
    const int nf = 1 + fz_u8(r) % MAX_FRAMES;
    char paths[MAX_FRAMES][96];
    const char* list[MAX_FRAMES];
    static float pts[MAX_FRAMES][MAX_POINTS * 3];
    static unsigned char file[32 + MAX_POINTS * 12 + 64];
    const uint32_t count = fz_u8(r) % (MAX_POINTS + 1);
    const int32_t first = fz_int(r, 1);
    int clean = 1; /* every file as the writer makes it, frames consecutive */
    for (int f = 0; f < nf; ++f) {
        temp_name(paths[f], sizeof paths[f], f, "tskf");
        list[f] = paths[f];
        for (uint32_t i = 0; i < count * 3; ++i)
            pts[f][i] = (fz_u8(r) % 8) ? (float)(f + 1) * 0.01f * (float)i : fz_float(r, 1.0f);
        for (uint32_t i = 0; i < count * 3; ++i) clean &= isfinite(pts[f][i]) != 0;
        memcpy(file, "TSKFRAME", 8);
        const uint8_t lie = fz_u8(r);
        uint32_t version = TSK_BAKE_FORMAT_VERSION, c = count, reserved = 0;
        int64_t frame = (int64_t)first + f;
        if (lie % 16 == 1) file[fz_u8(r) % 8] ^= (unsigned char)(1 + fz_u8(r) % 255);
        if (lie % 16 == 2) version = (uint32_t)fz_int(r, 2);
        if (lie % 16 == 3) frame = fz_int(r, (int)frame);
        if (lie % 16 == 4) c = fz_u32(r);
        if (lie % 16 == 5) reserved = fz_u32(r);
        if (lie % 16 >= 1 && lie % 16 <= 5) clean = 0;
        put_u32(file + 8, version);
        put_u32(file + 12, (uint32_t)frame);
        put_u32(file + 16, c);
        put_u32(file + 20, reserved);
        uint64_t sum = tsk_bake_checksum(pts[f], (size_t)count * 12);
        if (lie % 16 == 6) sum ^= 1ull << (fz_u8(r) % 64), clean = 0;
        put_u64(file + 24, sum);
        memcpy(file + 32, pts[f], (size_t)count * 12);
        size_t len = 32 + (size_t)count * 12;
        if (lie % 16 == 7) len = fz_u8(r) % (len + 1), clean = 0; /* truncated */
        if (lie % 16 == 8) len += 1 + fz_u8(r) % 60, clean = 0; /* too long */
        if (!write_file(paths[f], file, len)) abort();
        if ((int64_t)first + f > INT32_MAX) clean = 0;
        read_frame_back(paths[f]);
    }
    int32_t fc = nf;
    if (fz_u8(r) % 16 == 0) fc = fz_int(r, nf);
    const int bad_count = fc < 1 || fc > nf;
    float start = (float)first, rate = 1.0f;
    if (fz_u8(r) % 4 == 0) start = fz_float(r, start);
    if (fz_u8(r) % 4 == 0) rate = fz_float(r, rate);
    char out[96];
    temp_name(out, sizeof out, 99, "pc2");
    /* a wrong count that is too large would read past `list`: pass a NULL list then */
    const tsk_status s = tsk_bake_assemble_pc2(out, fc > nf ? NULL : list, fc, start, rate);
    const int good_params = !bad_count && isfinite(start) && isfinite(rate) && rate > 0;
    if (clean && good_params && s != TSK_OK) {
        fprintf(stderr, "bake: clean frames refused: %s\n", tsk_last_error());
        abort();
    }
    if (s == TSK_OK) {
        if (bad_count) abort();
        uint32_t points = 0, samples = 0;
        float st = 0, rt = 0;
        if (tsk_pc2_info(out, &points, &st, &rt, &samples) != TSK_OK) abort();
        if (points != count || samples != (uint32_t)fc || memcmp(&st, &start, 4) != 0 ||
            memcmp(&rt, &rate, 4) != 0)
            abort();
        float* xyz = tsk_alloc((size_t)count * 12 + 12, "fuzz");
        for (int32_t f = 0; f < fc; ++f) {
            if (tsk_pc2_read_sample(out, (uint32_t)f, xyz, count) != TSK_OK) abort();
            if (memcmp(xyz, pts[f], (size_t)count * 12) != 0) {
                fprintf(stderr, "bake: sample %d differs from its frame\n", f);
                abort();
            }
        }
        tsk_free(xyz);
        read_pc2_back(r, out);
        unlink(out);
    } else if (access(out, F_OK) == 0) {
        fprintf(stderr, "bake: a refused assembly left '%s'\n", out);
        abort();
    }
    for (int f = 0; f < nf; ++f) unlink(paths[f]);
}

static void structured_pc2(fz* r) {
    static unsigned char file[32 + MAX_POINTS * 12 * MAX_FRAMES + 64];
    memcpy(file, "POINTCACHE2", 12);
    int32_t version = (fz_u8(r) % 8) ? 1 : fz_int(r, 1);
    int32_t points = (int32_t)(fz_u8(r) % (MAX_POINTS + 1));
    float start = fz_float(r, 1.0f), rate = fz_float(r, 1.0f);
    int32_t samples = (int32_t)(fz_u8(r) % (MAX_FRAMES + 1));
    size_t len = 32 + (size_t)points * 12 * (size_t)samples;
    if (fz_u8(r) % 8 == 0) points = fz_int(r, points);
    if (fz_u8(r) % 8 == 0) samples = fz_int(r, samples);
    if (fz_u8(r) % 8 == 0) len = fz_u8(r) % (len + 64);
    memcpy(file + 12, &version, 4);
    memcpy(file + 16, &points, 4);
    memcpy(file + 20, &start, 4);
    memcpy(file + 24, &rate, 4);
    memcpy(file + 28, &samples, 4);
    for (size_t i = 32; i < len; i += 4) {
        const float v = (fz_u8(r) % 8) ? (float)i : fz_float(r, 1.0f);
        memcpy(file + i, &v, len - i < 4 ? len - i : 4);
    }
    char path[96];
    temp_name(path, sizeof path, 0, "pc2");
    if (!write_file(path, file, len)) abort();
    read_pc2_back(r, path);
    unlink(path);
}

static void write_round_trip(fz* r) {
    const uint32_t count = fz_u8(r) % (MAX_POINTS + 1);
    float pts[MAX_POINTS * 3], back[MAX_POINTS * 3 + 1];
    int finite = 1;
    for (uint32_t i = 0; i < count * 3; ++i) {
        pts[i] = fz_float(r, 0.1f * (float)i);
        finite &= isfinite(pts[i]) != 0;
    }
    const int32_t frame = fz_int(r, 1);
    char path[96];
    temp_name(path, sizeof path, 0, "tskf");
    const tsk_status s = tsk_bake_write_frame(path, frame, count ? pts : NULL, count);
    if ((s == TSK_OK) != finite) abort();
    if (s == TSK_OK) {
        int32_t fr = 0;
        uint32_t n = 0;
        if (tsk_bake_frame_info(path, &fr, &n) != TSK_OK || fr != frame || n != count) abort();
        if (tsk_bake_read_frame(path, back, count) != TSK_OK) abort();
        if (memcmp(back, pts, (size_t)count * 12) != 0) abort();
        unlink(path);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    fz r = {data + 1, size - 1};
    char path[96];
    switch (data[0] % 6) {
        case 0: {
            temp_name(path, sizeof path, 0, "tskf");
            if (!write_file(path, data + 1, size - 1)) abort();
            read_frame_back(path);
            const char* list[2] = {path, path};
            char out[96];
            temp_name(out, sizeof out, 99, "pc2");
            if (tsk_bake_assemble_pc2(out, list, 1, 1.0f, 1.0f) == TSK_OK) {
                read_pc2_back(&r, out);
                unlink(out);
            }
            /* the same frame twice is not two consecutive frames */
            if (tsk_bake_assemble_pc2(out, list, 2, 1.0f, 1.0f) == TSK_OK) abort();
            unlink(path);
            break;
        }
        case 1:
            temp_name(path, sizeof path, 0, "pc2");
            if (!write_file(path, data + 1, size - 1)) abort();
            read_pc2_back(&r, path);
            unlink(path);
            break;
        case 2:
        case 3:
            structured_frames(&r);
            break;
        case 4:
            structured_pc2(&r);
            break;
        default:
            write_round_trip(&r);
            break;
    }
    fz_check_leaks("bake");
    return 0;
}
