/* Tests of the core: errors, allocation, counter-based RNG, parallel-for determinism. */
#define _DEFAULT_SOURCE /* lstat, mkfifo, sockets for the file tests */
#include <pthread.h>

#include "test.h"
#include "tussock/core.h"
#include "core/exr_header.h"
#include "core/simd.h"
#include "core/file.h"

#include <stdint.h>
#include <string.h>
#ifndef _WIN32
#include <sys/socket.h>
#include <sys/un.h>
#endif
#include <time.h>

#define TSK_TEST_TMP_NAME "core"
#include "test_tmp.h"

TEST(test_error_names_argument) {
    tsk_status s = tsk_error_arg(TSK_ERR_ARGUMENT, "near", "must be positive, got %g", -1.0);
    CHECK(s == TSK_ERR_ARGUMENT);
    CHECK(strcmp(tsk_last_error(), "near: must be positive, got -1") == 0);
    tsk_clear_error();
    CHECK(tsk_last_error()[0] == '\0');
    CHECK(strcmp(tsk_status_name(TSK_ERR_IO), "io") == 0);
}

TEST(test_error_long_message_truncates) {
    char big[4000];
    memset(big, 'x', sizeof big - 1);
    big[sizeof big - 1] = '\0';
    tsk_error_arg(TSK_ERR_IO, "file", "%s", big);
    size_t n = strlen(tsk_last_error());
    CHECK(n > 100 && n < 1024);
    CHECK(strncmp(tsk_last_error(), "file: xxx", 9) == 0);
}

TEST(test_alloc_is_aligned_and_counted) {
    size_t before = tsk_allocated_bytes();
    float* a = tsk_alloc(1000 * sizeof(float), "test");
    CHECK(a != NULL);
    CHECK(((uintptr_t)a & 63u) == 0);
    CHECK(tsk_allocated_bytes() == before + 1000 * sizeof(float));
    tsk_free(a);
    CHECK(tsk_allocated_bytes() == before);
}

TEST(test_calloc_overflow_is_refused) {
    tsk_clear_error();
    void* p = tsk_calloc(SIZE_MAX / 2, 16, "huge");
    CHECK(p == NULL);
    CHECK(strstr(tsk_last_error(), "huge") != NULL);
    void* q = tsk_alloc(SIZE_MAX - 8, "huge2");
    CHECK(q == NULL);
}

static int g_hook_calls;
static void* counting_alloc(size_t size, void* user) {
    ++*(int*)user;
    return malloc(size);
}
static void counting_free(void* p, void* user) {
    ++*(int*)user;
    free(p);
}

TEST(test_allocator_hooks_are_used) {
    g_hook_calls = 0;
    tsk_set_allocator(counting_alloc, counting_free, &g_hook_calls);
    void* p = tsk_alloc(10, "x");
    tsk_free(p);
    tsk_set_allocator(NULL, NULL, NULL);
    CHECK(g_hook_calls == 2);
}

/* Reference SplitMix64 finaliser written out again, to pin the hash's definition. */
static uint64_t ref_mix(uint64_t z) {
    z ^= z >> 30;
    z *= 0xBF58476D1CE4E5B9ull;
    z ^= z >> 27;
    z *= 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

TEST(test_hash_matches_definition) {
    uint64_t seed = 42, a = 7, b = 9, c = 11;
    uint64_t h = ref_mix(seed ^ 0x9E3779B97F4A7C15ull);
    h = ref_mix(h + a);
    h = ref_mix(h + b + 0x632BE59BD9B4E019ull);
    h = ref_mix(h + c + 0x8CB92BA72F3D8DD7ull);
    CHECK(tsk_hash4(seed, a, b, c) == h);
    CHECK(tsk_hash4(seed, a, b, c) != tsk_hash4(seed, b, a, c));
}

TEST(test_rand_uniform_statistics) {
    enum { N = 200000 };
    static float v[N];
    CHECK(tsk_rand_fill(1, 2, v, N) == TSK_OK);
    double sum = 0, sum2 = 0;
    int bins[10] = {0};
    for (int i = 0; i < N; ++i) {
        CHECK(v[i] >= 0.0f && v[i] < 1.0f);
        sum += v[i];
        sum2 += (double)v[i] * v[i];
        bins[(int)(v[i] * 10)]++;
    }
    double mean = sum / N, var = sum2 / N - mean * mean;
    CHECK_NEAR(mean, 0.5, 0.005); /* 0.5 ± ~7σ (σ = 0.29/sqrt(N) = 0.00065) */
    CHECK_NEAR(var, 1.0 / 12.0, 0.002);
    for (int k = 0; k < 10; ++k) CHECK_NEAR(bins[k], N / 10, 600); /* ±~4.5σ */
}

typedef struct sum_ctx {
    const float* v;
    double* partial;
} sum_ctx;

static void sum_chunk(size_t b, size_t e, size_t chunk, void* vctx) {
    sum_ctx* ctx = vctx;
    double s = 0;
    for (size_t i = b; i < e; ++i) s += ctx->v[i] * 1.000001;
    ctx->partial[chunk] = s;
}

static uint64_t run_with_threads(int threads, float* v, size_t n, double* total) {
    CHECK(tsk_set_threads(threads) == TSK_OK);
    CHECK(tsk_rand_fill(99, 3, v, n) == TSK_OK);
    size_t chunks = tsk_chunk_count(n, 1000);
    double* partial = calloc(chunks, sizeof(double));
    sum_ctx ctx = {v, partial};
    tsk_parallel_for(n, 1000, sum_chunk, &ctx);
    double s = 0;
    for (size_t c = 0; c < chunks; ++c) s += partial[c];
    free(partial);
    *total = s;
    uint64_t h = 1469598103934665603ull; /* FNV-1a over the bytes */
    const unsigned char* bytes = (const unsigned char*)v;
    for (size_t i = 0; i < n * sizeof(float); ++i) h = (h ^ bytes[i]) * 1099511628211ull;
    return h;
}

TEST(test_parallel_for_identical_bytes_1_and_2_threads) {
    enum { N = 123457 };
    static float v1[N], v2[N];
    double s1 = 0, s2 = 0;
    uint64_t h1 = run_with_threads(1, v1, N, &s1);
    uint64_t h2 = run_with_threads(2, v2, N, &s2);
    CHECK(h1 == h2);
    CHECK(memcmp(v1, v2, sizeof v1) == 0);
    CHECK(memcmp(&s1, &s2, sizeof s1) == 0);
    CHECK(tsk_set_threads(0) == TSK_OK);
}

static void mark(size_t b, size_t e, size_t c, void* vctx) {
    (void)c;
    int* h = *(int**)vctx;
    for (size_t i = b; i < e; ++i) h[i]++;
}

TEST(test_parallel_for_covers_every_index_once) {
    enum { N = 10007 };
    static int hits[N];
    memset(hits, 0, sizeof hits);
    tsk_set_threads(2);
    struct {
        int* h;
    } ctx = {hits};
    tsk_parallel_for(N, 64, mark, &ctx);
    int ok = 1;
    for (int i = 0; i < N; ++i) ok &= hits[i] == 1;
    CHECK(ok);
    CHECK(tsk_chunk_count(N, 64) == (N + 63) / 64);
    CHECK(tsk_chunk_count(0, 64) == 0);
    tsk_set_threads(0);
}

/* A loop started inside a chunk runs (serially) and still covers its range once. */
typedef struct nest_ctx {
    int* hits; /* 64 x 97 */
} nest_ctx;

static void inner(size_t b, size_t e, size_t c, void* vctx) {
    (void)c;
    int* row = vctx;
    for (size_t i = b; i < e; ++i) row[i]++;
}

static void outer(size_t b, size_t e, size_t c, void* vctx) {
    (void)c;
    nest_ctx* ctx = vctx;
    for (size_t r = b; r < e; ++r) tsk_parallel_for(97, 5, inner, ctx->hits + 97 * r);
}

TEST(test_parallel_for_nested_covers_every_index_once) {
    static int hits[64 * 97];
    memset(hits, 0, sizeof hits);
    tsk_set_threads(2);
    nest_ctx ctx = {hits};
    tsk_parallel_for(64, 1, outer, &ctx);
    int ok = 1;
    for (int i = 0; i < 64 * 97; ++i) ok &= hits[i] == 1;
    CHECK(ok);
    tsk_set_threads(0);
}

/* Two threads running loops at the same time (one of them gets the workers, the other runs
 * serially) and thousands of back-to-back small loops: every index once, no hang. */
typedef struct many_ctx {
    int* hits;
    int n, loops;
} many_ctx;

static void* many_loops(void* arg) {
    many_ctx* m = arg;
    struct {
        int* h;
    } ctx = {m->hits};
    for (int k = 0; k < m->loops; ++k) tsk_parallel_for((size_t)m->n, 16, mark, &ctx);
    return NULL;
}

TEST(test_parallel_for_concurrent_callers_and_many_loops) {
    enum { N = 257, LOOPS = 2000 };
    static int a[N], b[N];
    memset(a, 0, sizeof a);
    memset(b, 0, sizeof b);
    tsk_set_threads(3);
    many_ctx ma = {a, N, LOOPS}, mb = {b, N, LOOPS};
    pthread_t th;
    CHECK(pthread_create(&th, NULL, many_loops, &mb) == 0);
    many_loops(&ma);
    pthread_join(th, NULL);
    int ok = 1;
    for (int i = 0; i < N; ++i) ok &= a[i] == LOOPS && b[i] == LOOPS;
    CHECK(ok);
    tsk_set_threads(0);
}

TEST(test_set_threads_rejects_out_of_range) {
    CHECK_STATUS(tsk_set_threads(-1), TSK_ERR_ARGUMENT, "threads");
    CHECK_STATUS(tsk_set_threads(1000), TSK_ERR_ARGUMENT, "threads");
    CHECK(tsk_get_threads() >= 1);
}

/* Bounds of points on many chunks, against a loop here; the same with 1 and 2 threads;
 * a non-finite point is named and no points is refused. */
TEST(test_vec3_bounds_of_many_points) {
    const size_t n = 100003;
    float* xyz = malloc(3 * n * sizeof(float));
    float want_lo[3] = {INFINITY, INFINITY, INFINITY},
          want_hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < 3 * n; ++i) {
        xyz[i] = (float)((double)((i * 2654435761u) % 1000003u) / 1000.0 - 500.0) *
                 (1.0f + (float)(i % 3));
        const int q = (int)(i % 3);
        want_lo[q] = fminf(want_lo[q], xyz[i]), want_hi[q] = fmaxf(want_hi[q], xyz[i]);
    }
    for (int threads = 1; threads <= 2; ++threads) {
        CHECK(tsk_set_threads(threads) == TSK_OK);
        float lo[3], hi[3];
        CHECK(tsk_vec3_bounds(xyz, n, lo, hi) == TSK_OK);
        for (int q = 0; q < 3; ++q) CHECK(lo[q] == want_lo[q] && hi[q] == want_hi[q]);
        CHECK(tsk_vec3_bounds(xyz + 3 * 7, 1, lo, hi) == TSK_OK); /* one point: itself */
        for (int q = 0; q < 3; ++q) CHECK(lo[q] == xyz[21 + q] && hi[q] == xyz[21 + q]);
    }
    tsk_set_threads(0);
    float lo[3], hi[3];
    xyz[3 * 70000 + 1] = NAN;
    CHECK_STATUS(tsk_vec3_bounds(xyz, n, lo, hi), TSK_ERR_ARGUMENT, "point 70000");
    CHECK_STATUS(tsk_vec3_bounds(xyz, 0, lo, hi), TSK_ERR_ARGUMENT, "count");
    CHECK_STATUS(tsk_vec3_bounds(NULL, 3, lo, hi), TSK_ERR_ARGUMENT, "xyz");
    xyz[3 * 70000 + 1] = 0.0f;
    xyz[3 * 90001 + 2] = -INFINITY; /* a later chunk: the earlier point is still named */
    xyz[3 * 5 + 0] = INFINITY;
    CHECK_STATUS(tsk_vec3_bounds(xyz, n, lo, hi), TSK_ERR_ARGUMENT, "point 5 ");
    free(xyz);
}

/* Every short count (whole four-point steps and tails), with the extremes of each component
 * and then a non-finite value at every point in turn: the extremes are found wherever they
 * sit, and the bad point is the one named. */
TEST(test_vec3_bounds_every_position) {
    float xyz[3 * 19];
    char want[32];
    for (size_t n = 1; n <= 19; ++n)
        for (size_t j = 0; j < n; ++j) {
            for (size_t i = 0; i < 3 * n; ++i) xyz[i] = (float)(i % 7) - 3.0f;
            for (int q = 0; q < 3; ++q)
                xyz[3 * j + q] = (q == 1 ? -100.0f : 100.0f) * (float)(q + 1);
            float lo[3], hi[3];
            CHECK(tsk_vec3_bounds(xyz, n, lo, hi) == TSK_OK);
            float wl[3] = {INFINITY, INFINITY, INFINITY}, wh[3] = {-INFINITY, -INFINITY, -INFINITY};
            for (size_t i = 0; i < 3 * n; ++i)
                wl[i % 3] = fminf(wl[i % 3], xyz[i]), wh[i % 3] = fmaxf(wh[i % 3], xyz[i]);
            for (int q = 0; q < 3; ++q) CHECK(lo[q] == wl[q] && hi[q] == wh[q]);
            CHECK(hi[0] == 100.0f && lo[1] == -200.0f && hi[2] == 300.0f);
            xyz[3 * j + (j % 3)] = (j % 2) ? NAN : INFINITY;
            snprintf(want, sizeof want, "point %zu ", j);
            CHECK_STATUS(tsk_vec3_bounds(xyz, n, lo, hi), TSK_ERR_ARGUMENT, want);
        }
}

TEST(test_vec3_lengths_and_nonfinite_rejected) {
    float xyz[6] = {3, 4, 0, 1, 2, 2};
    float out[2];
    CHECK(tsk_vec3_lengths(xyz, 2, out) == TSK_OK);
    CHECK_NEAR(out[0], 5.0, 1e-6);
    CHECK_NEAR(out[1], 3.0, 1e-6);
    xyz[4] = NAN;
    CHECK_STATUS(tsk_vec3_lengths(xyz, 2, out), TSK_ERR_ARGUMENT, "vector 1");
}

/* Reference for tsk_mesh_edges: distinct unordered pairs in first-appearance order, by a
 * quadratic search (small meshes only). */
static size_t naive_edges(const int32_t* corners, size_t nf, int fs, int32_t* edges, int32_t* ce) {
    size_t ne = 0;
    for (size_t c = 0; c < nf * (size_t)fs; ++c) {
        const int32_t a = corners[c], b = corners[c / fs * fs + (c % fs + 1) % fs];
        size_t e = 0;
        while (e < ne && !((edges[2 * e] == a && edges[2 * e + 1] == b) ||
                           (edges[2 * e] == b && edges[2 * e + 1] == a)))
            ++e;
        if (e == ne) {
            edges[2 * ne] = a;
            edges[2 * ne + 1] = b;
            ++ne;
        }
        ce[c] = (int32_t)e;
    }
    return ne;
}

TEST(test_mesh_edges_match_the_reference_and_count_a_tube) {
    /* a tube of R rings of S vertices: S*R ring edges and S*(R-1) along it */
    enum { S = 7, R = 9, NF = S * (R - 1) };
    static int32_t quads[NF * 4], edges[NF * 8], ce[NF * 4], redges[NF * 8], rce[NF * 4];
    for (int r = 0; r < R - 1; ++r)
        for (int k = 0; k < S; ++k) {
            int32_t* q = quads + 4 * (r * S + k);
            q[0] = r * S + k;
            q[1] = r * S + (k + 1) % S;
            q[2] = q[1] + S;
            q[3] = q[0] + S;
        }
    size_t ne = 0;
    CHECK(tsk_mesh_edges(quads, NF, 4, S * R, edges, ce, &ne) == TSK_OK);
    CHECK(ne == (size_t)(S * R + S * (R - 1)));
    CHECK(naive_edges(quads, NF, 4, redges, rce) == ne);
    CHECK(memcmp(edges, redges, ne * 2 * sizeof(int32_t)) == 0);
    CHECK(memcmp(ce, rce, sizeof ce) == 0);
    /* random triangles over few vertices: many shared edges, both directions */
    enum { NT = 400, NV = 40 };
    static int32_t tris[NT * 3], e2[NT * 6], c2[NT * 3], r2[NT * 6], rc2[NT * 3];
    for (int t = 0; t < NT; ++t) {
        int32_t a = (int32_t)(tsk_hash4(5, (uint64_t)t, 0, 0) % NV);
        int32_t b = (int32_t)(tsk_hash4(5, (uint64_t)t, 1, 0) % NV);
        int32_t c = (int32_t)(tsk_hash4(5, (uint64_t)t, 2, 0) % NV);
        if (b == a) b = (a + 1) % NV;
        if (c == a || c == b) c = (b + 1) % NV == a ? (b + 2) % NV : (b + 1) % NV;
        tris[3 * t] = a, tris[3 * t + 1] = b, tris[3 * t + 2] = c;
    }
    CHECK(tsk_mesh_edges(tris, NT, 3, NV, e2, c2, &ne) == TSK_OK);
    CHECK(ne == naive_edges(tris, NT, 3, r2, rc2) && ne < NT * 3);
    CHECK(memcmp(e2, r2, ne * 2 * sizeof(int32_t)) == 0);
    CHECK(memcmp(c2, rc2, sizeof c2) == 0);
    /* every corner's edge joins it to the next corner */
    int ok = 1;
    for (int c = 0; c < NT * 3; ++c) {
        const int32_t a = tris[c], b = tris[c / 3 * 3 + (c % 3 + 1) % 3], e = c2[c];
        ok &= (e2[2 * e] == a && e2[2 * e + 1] == b) || (e2[2 * e] == b && e2[2 * e + 1] == a);
    }
    CHECK(ok);
    CHECK(tsk_allocated_bytes() == 0);
    /* bad input */
    int32_t bad[4] = {0, 1, 2, 9};
    CHECK_STATUS(tsk_mesh_edges(bad, 1, 4, 4, edges, ce, &ne), TSK_ERR_ARGUMENT, "vertex 9");
    int32_t rep[4] = {0, 1, 1, 2};
    CHECK_STATUS(tsk_mesh_edges(rep, 1, 4, 4, edges, ce, &ne), TSK_ERR_ARGUMENT, "zero-length");
    CHECK_STATUS(tsk_mesh_edges(quads, 1, 2, 4, edges, ce, &ne), TSK_ERR_ARGUMENT, "face_size");
    CHECK_STATUS(tsk_mesh_edges(quads, 1, 4, S * R, NULL, ce, &ne), TSK_ERR_ARGUMENT, "edges");
    CHECK(tsk_mesh_edges(NULL, 0, 4, 0, NULL, NULL, &ne) == TSK_OK && ne == 0);
}

TEST(test_version_is_semver) {
    int a, b, c;
    CHECK(sscanf(tsk_version(), "%d.%d.%d", &a, &b, &c) == 3);
}

/* The default budget is TSK_MEMORY_FRACTION of MemTotal (read here from /proc/meminfo,
 * independently of sysconf); a set budget overrides it; estimates over it, and NaN, are
 * refused with TSK_ERR_LIMIT and a message naming the request. */
TEST(test_memory_budget_is_half_of_physical_memory_and_refuses_more) {
    FILE* f = fopen("/proc/meminfo", "r");
    unsigned long long kb = 0;
    if (f != NULL) {
        char line[256];
        while (fgets(line, sizeof line, f))
            if (sscanf(line, "MemTotal: %llu kB", &kb) == 1) break;
        fclose(f);
    }
    tsk_set_memory_budget(0);
    if (kb > 0 && getenv("TSK_MEMORY_BUDGET_MB") == NULL) {
        const double expect = 0.5 * (double)kb * 1024.0;
        CHECK_NEAR((double)tsk_memory_budget(), expect, 0.01 * expect);
        CHECK_NEAR((double)tsk_physical_memory(), (double)kb * 1024.0, 0.01 * kb * 1024.0);
    }
    tsk_set_memory_budget((uint64_t)1 << 20);
    CHECK(tsk_memory_budget() == ((uint64_t)1 << 20));
    CHECK(tsk_memory_check(1048576.0, "exact") == TSK_OK);
    CHECK_STATUS(tsk_memory_check(1048577.0, "big thing"), TSK_ERR_LIMIT, "big thing: needs");
    CHECK_STATUS(tsk_memory_check(1e30, "huge"), TSK_ERR_LIMIT, "memory budget of 1 MiB");
    CHECK_STATUS(tsk_memory_check(NAN, "nan"), TSK_ERR_LIMIT, "nan");
    tsk_set_memory_budget(0);
    CHECK(tsk_memory_check(1e6, "small") == TSK_OK);
}

/* ---- OpenEXR headers (core/exr_header.c) ----------------------------------------------- */

typedef struct exr_buf {
    uint8_t b[70000];
    size_t n;
} exr_buf;

static void exr_put32(exr_buf* e, int32_t v) {
    for (int k = 0; k < 4; ++k) e->b[e->n++] = (uint8_t)((uint32_t)v >> (8 * k));
}

static void exr_begin(exr_buf* e, uint32_t flags) {
    const uint8_t magic[4] = {0x76, 0x2f, 0x31, 0x01};
    e->n = 0;
    memcpy(e->b, magic, 4);
    e->n = 4;
    e->b[e->n++] = 2;
    for (int k = 0; k < 3; ++k) e->b[e->n++] = (uint8_t)(flags >> (8 * k));
}

/* name\0 type\0 size value (the value's bytes as given) */
static void exr_attr(exr_buf* e, const char* name, const char* type, const void* value,
                     int32_t size) {
    memcpy(e->b + e->n, name, strlen(name) + 1);
    e->n += strlen(name) + 1;
    memcpy(e->b + e->n, type, strlen(type) + 1);
    e->n += strlen(type) + 1;
    exr_put32(e, size);
    memcpy(e->b + e->n, value, (size_t)size);
    e->n += (size_t)size;
}

static void exr_box(exr_buf* e, const char* name, int32_t x0, int32_t y0, int32_t x1, int32_t y1) {
    exr_buf v = {.n = 0};
    exr_put32(&v, x0), exr_put32(&v, y0), exr_put32(&v, x1), exr_put32(&v, y1);
    exr_attr(e, name, "box2i", v.b, 16);
}

/* `count` channels "c0", "c1"... of pixel type `type` (0 uint, 1 half, 2 float) */
static void exr_channels(exr_buf* e, int count, int type) {
    exr_buf v = {.n = 0};
    for (int c = 0; c < count; ++c) {
        v.n += (size_t)snprintf((char*)v.b + v.n, 8, "c%d", c) + 1;
        exr_put32(&v, type);
        exr_put32(&v, 0); /* pLinear, reserved */
        exr_put32(&v, 1), exr_put32(&v, 1);
    }
    v.b[v.n++] = 0;
    exr_attr(e, "channels", "chlist", v.b, (int32_t)v.n);
}

static void exr_compression(exr_buf* e, uint8_t c) {
    exr_attr(e, "compression", "compression", &c, 1);
}

/* The header is read as OpenEXR reads it, so that OpenEXR's buffers (sized from the header
 * alone) stay bounded: fuzz_depth_files found a file whose first dataWindow claimed 272 bytes
 * (OpenEXR reads 16, a 33-million-pixel-wide window, and allocated 2.2 GB for ZIP blocks) while
 * the old check skipped it and read a second, small one. */
TEST(test_exr_header_is_read_as_openexr_reads_it) {
    static exr_buf e;
    tsk_exr_header h;
    exr_begin(&e, 0);
    exr_channels(&e, 1, 2);
    exr_compression(&e, 3);
    exr_box(&e, "dataWindow", 0, 0, 9, 7);
    exr_box(&e, "displayWindow", 0, 0, 9, 7);
    e.b[e.n++] = 0;
    CHECK(tsk_exr_check_header(e.b, e.n, "good.exr", &h) == TSK_OK);
    CHECK(h.width == 10 && h.height == 8 && h.channels == 1 && !h.tiled);
    /* the header ends past the bytes given: not guessed */
    CHECK_STATUS(tsk_exr_check_header(e.b, e.n - 1, "cut.exr", &h), TSK_ERR_FORMAT, "truncated");
    /* the finding: a box2i of 272 bytes, then a small dataWindow */
    exr_begin(&e, 0);
    exr_channels(&e, 1, 2);
    exr_compression(&e, 3);
    {
        uint8_t big[272] = {0};
        const int32_t w[4] = {-16777138, -256, 16777215, 1};
        memcpy(big, w, sizeof w);
        exr_attr(&e, "dataWindow", "box2i", big, 272);
    }
    exr_box(&e, "dataWindow", 0, 0, 47, 39);
    e.b[e.n++] = 0;
    CHECK_STATUS(tsk_exr_check_header(e.b, e.n, "finding.exr", &h), TSK_ERR_FORMAT, "wrong size");
    /* two well-formed dataWindows: which one OpenEXR keeps is not this check's guess */
    exr_begin(&e, 0);
    exr_box(&e, "dataWindow", 0, 0, 47, 39);
    exr_box(&e, "dataWindow", 0, 0, 9, 9);
    e.b[e.n++] = 0;
    CHECK_STATUS(tsk_exr_check_header(e.b, e.n, "two.exr", &h), TSK_ERR_FORMAT,
                 "second dataWindow");
    /* 200 float channels 8192 wide: ZIP packs 16 lines (100 MiB), DWAB 256 (1.6 GiB) */
    for (int c = 0; c < 2; ++c) {
        exr_begin(&e, 0);
        exr_channels(&e, 200, 2);
        exr_compression(&e, c == 0 ? 3 : 9);
        exr_box(&e, "dataWindow", 0, 0, 8191, 99);
        e.b[e.n++] = 0;
        if (c == 0) {
            CHECK(tsk_exr_check_header(e.b, e.n, "wide.exr", &h) == TSK_OK && h.channels == 200);
        } else {
            CHECK_STATUS(tsk_exr_check_header(e.b, e.n, "wide.exr", &h), TSK_ERR_LIMIT,
                         "block of its scan lines");
        }
    }
    /* unknown compression, multi-part, a preview of the wrong size */
    exr_begin(&e, 0);
    exr_compression(&e, 10);
    exr_box(&e, "dataWindow", 0, 0, 9, 9);
    e.b[e.n++] = 0;
    CHECK_STATUS(tsk_exr_check_header(e.b, e.n, "c.exr", &h), TSK_ERR_FORMAT,
                 "unknown compression");
    exr_begin(&e, 0x1000);
    exr_box(&e, "dataWindow", 0, 0, 9, 9);
    e.b[e.n++] = 0;
    CHECK_STATUS(tsk_exr_check_header(e.b, e.n, "mp.exr", &h), TSK_ERR_FORMAT, "multi-part");
    exr_begin(&e, 0);
    {
        const int32_t pv[3] = {100000, 100000, 0}; /* claims 40 GB of preview pixels */
        exr_attr(&e, "preview", "preview", pv, 12);
    }
    exr_box(&e, "dataWindow", 0, 0, 9, 9);
    e.b[e.n++] = 0;
    CHECK_STATUS(tsk_exr_check_header(e.b, e.n, "pv.exr", &h), TSK_ERR_FORMAT, "bad preview");
    /* a string vector whose second string claims 2 GB (OpenEXR would make room for it), and
     * one that fits: (3, "abc"), (0, "") */
    for (int c = 0; c < 2; ++c) {
        exr_begin(&e, 0);
        exr_buf sv = {.n = 0};
        exr_put32(&sv, 3);
        memcpy(sv.b + sv.n, "abc", 3), sv.n += 3;
        exr_put32(&sv, c == 0 ? INT32_MAX : 0);
        exr_attr(&e, "multiView", "stringvector", sv.b, (int32_t)sv.n);
        exr_box(&e, "dataWindow", 0, 0, 9, 9);
        e.b[e.n++] = 0;
        if (c == 0) {
            CHECK_STATUS(tsk_exr_check_header(e.b, e.n, "sv.exr", &h), TSK_ERR_FORMAT,
                         "bad string vector");
        } else {
            CHECK(tsk_exr_check_header(e.b, e.n, "sv.exr", &h) == TSK_OK && h.width == 10);
        }
    }
    /* tiled: a tile of 65536 x 65536 floats would be 16 GiB */
    exr_begin(&e, 0x200);
    exr_channels(&e, 1, 2);
    exr_box(&e, "dataWindow", 0, 0, 9, 9);
    {
        uint8_t td[9] = {0};
        const int32_t t[2] = {65536, 65536};
        memcpy(td, t, 8);
        exr_attr(&e, "tiles", "tiledesc", td, 9);
    }
    e.b[e.n++] = 0;
    CHECK_STATUS(tsk_exr_check_header(e.b, e.n, "tiled.exr", &h), TSK_ERR_LIMIT, "tile would take");
}

static double now_seconds(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* A FIFO with no writer, a listening socket, a character device and a folder are refused
 * at once with a message saying what they are; opened with fopen, the FIFO would wait for a
 * writer for ever and /dev/zero would never end. A regular file opens and reads. (Windows: a
 * named pipe waiting for a client, the NUL device and a folder.) */
TEST(test_fopen_regular_refuses_what_would_block_or_never_end) {
    FILE* f = NULL;
#ifndef _WIN32
    const char* fifo = tmp_path("pipe.png");
    CHECK(mkfifo(fifo, 0600) == 0);
    const char* sock = tmp_path("sock.png");
    const int sfd = socket(AF_UNIX, SOCK_STREAM, 0);
    struct sockaddr_un addr = {.sun_family = AF_UNIX};
    snprintf(addr.sun_path, sizeof addr.sun_path, "%s", sock);
    CHECK(sfd >= 0 && bind(sfd, (struct sockaddr*)&addr, sizeof addr) == 0 && listen(sfd, 1) == 0);
#else
    char pipe_name[64];
    snprintf(pipe_name, sizeof pipe_name, "\\\\.\\pipe\\tsk_test_core_%d", (int)getpid());
    HANDLE server = CreateNamedPipeA(pipe_name, PIPE_ACCESS_OUTBOUND, PIPE_TYPE_BYTE | PIPE_WAIT, 1,
                                     0, 4096, 0, NULL);
    CHECK(server != INVALID_HANDLE_VALUE);
#endif
    const struct {
        const char* path;
        tsk_status status;
        const char* needle;
    } cases[] = {
#ifndef _WIN32
        {fifo, TSK_ERR_IO, "a pipe (FIFO)"},
        {sock, TSK_ERR_IO, "a socket"},
        {"/dev/zero", TSK_ERR_IO, "a character device"},
#else
        {pipe_name, TSK_ERR_IO, "a pipe"},
        {"NUL", TSK_ERR_IO, "a character device"},
#endif
        {tmp_path(""), TSK_ERR_IO, "a folder"},
        {tmp_path("missing.png"), TSK_ERR_IO, "cannot open"},
        {"", TSK_ERR_ARGUMENT, "is empty"}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        const double t0 = now_seconds();
        CHECK_STATUS(tsk_fopen_regular(cases[i].path, "path", &f), cases[i].status,
                     cases[i].needle);
        CHECK(f == NULL);
        CHECK_MSG(now_seconds() - t0 < 1.0, "%s took %.2f s", cases[i].path, now_seconds() - t0);
    }
#ifndef _WIN32
    if (sfd >= 0) close(sfd);
#else
    if (server != INVALID_HANDLE_VALUE) CloseHandle(server);
#endif
    const char* plain = tmp_path("plain.bin");
    FILE* w = fopen(plain, "wb");
    CHECK(w != NULL && fwrite("tussock", 1, 7, w) == 7 && fclose(w) == 0);
    CHECK(tsk_fopen_regular(plain, "path", &f) == TSK_OK && f != NULL);
    char buf[8] = {0};
    CHECK(f != NULL && fread(buf, 1, 8, f) == 7 && memcmp(buf, "tussock", 7) == 0);
    if (f != NULL) fclose(f);
}

/* TSK_SIMD in the environment narrows the kernel units the library runs (core/simd.h):
 * "portable" the portable one, "avx2" at most AVX2; unset or not understood, the widest the CPU
 * has; tsk_simd_force wins over it. */
TEST(test_simd_variable_forces_the_kernel_path) {
    const char* outer = getenv("TSK_SIMD"); /* a run that narrows every test keeps its choice */
    char saved[32] = "";
    if (outer) snprintf(saved, sizeof saved, "%s", outer);
    CHECK(unsetenv("TSK_SIMD") == 0);
    tsk_simd_force(-1);
    const int best = tsk_simd_isa();
    static const struct {
        const char* value;
        int most;
    } cases[] = {
        {"portable", TSK_ISA_PORTABLE}, {"avx2", TSK_ISA_AVX2}, {"avx-9000", TSK_ISA_AVX512}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        CHECK(setenv("TSK_SIMD", cases[i].value, 1) == 0);
        tsk_simd_force(-1); /* read the variable again */
        const int want = best < cases[i].most ? best : cases[i].most;
        CHECK_MSG(tsk_simd_isa() == want, "TSK_SIMD=%s: kernel %d, expected %d", cases[i].value,
                  tsk_simd_isa(), want);
    }
    tsk_simd_force(TSK_SIMD_BEST);
    CHECK(tsk_simd_isa() == best);
    CHECK(unsetenv("TSK_SIMD") == 0);
    tsk_simd_force(-1);
    CHECK(tsk_simd_isa() == best);
#if TSK_SIMD_X86_PATHS && __GNUC__ >= 12
    /* the library's own cpuid reading agrees with GCC's (core/simd.c says why it has one) */
    CHECK(best == (__builtin_cpu_supports("x86-64-v4")   ? TSK_ISA_AVX512
                   : __builtin_cpu_supports("x86-64-v3") ? TSK_ISA_AVX2
                                                         : TSK_ISA_PORTABLE));
#elif TSK_SIMD_X86_PATHS
    /* GCC before 12 knows the features, not the levels */
    const int v4 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                   __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
                   __builtin_cpu_supports("avx512vl");
    const int v3 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
                   __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2");
    CHECK(best == (v3 && v4 ? TSK_ISA_AVX512 : v3 ? TSK_ISA_AVX2 : TSK_ISA_PORTABLE));
#else
    CHECK(best == TSK_ISA_PORTABLE);
#endif
    if (outer) CHECK(setenv("TSK_SIMD", saved, 1) == 0);
    tsk_simd_force(-1);
}

TEST_MAIN(TEST_ENTRY(test_memory_budget_is_half_of_physical_memory_and_refuses_more),
          TEST_ENTRY(test_mesh_edges_match_the_reference_and_count_a_tube),
          TEST_ENTRY(test_error_names_argument), TEST_ENTRY(test_error_long_message_truncates),
          TEST_ENTRY(test_alloc_is_aligned_and_counted),
          TEST_ENTRY(test_calloc_overflow_is_refused), TEST_ENTRY(test_allocator_hooks_are_used),
          TEST_ENTRY(test_hash_matches_definition), TEST_ENTRY(test_rand_uniform_statistics),
          TEST_ENTRY(test_parallel_for_identical_bytes_1_and_2_threads),
          TEST_ENTRY(test_parallel_for_covers_every_index_once),
          TEST_ENTRY(test_parallel_for_nested_covers_every_index_once),
          TEST_ENTRY(test_parallel_for_concurrent_callers_and_many_loops),
          TEST_ENTRY(test_set_threads_rejects_out_of_range),
          TEST_ENTRY(test_vec3_lengths_and_nonfinite_rejected),
          TEST_ENTRY(test_vec3_bounds_of_many_points), TEST_ENTRY(test_vec3_bounds_every_position),
          TEST_ENTRY(test_version_is_semver),
          TEST_ENTRY(test_exr_header_is_read_as_openexr_reads_it),
          TEST_ENTRY(test_fopen_regular_refuses_what_would_block_or_never_end),
          TEST_ENTRY(test_simd_variable_forces_the_kernel_path))
