/* Tests of the meadow: blade models, the patch, Perlin noise against an independent
 * reference, tile counts against the density map, offsets, wrapping runs, instances,
 * expansion widths/normals/UVs, determinism across seeds and threads, and bad inputs. */
#include "test.h"
#include "tussock/core.h"
#include "tussock/meadow.h"

#include <stdint.h>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TSK_SLOW_CHECKS 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define TSK_SLOW_CHECKS 1
#endif

static const double PI = 3.14159265358979323846;

static uint64_t fnv(const void* data, size_t n, uint64_t h) {
    const unsigned char* b = data;
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
    return h;
}

/* ---- blade models ------------------------------------------------------------------------ */

TEST(test_default_blade_matches_documented_formula) {
    tsk_blade_model m;
    CHECK(tsk_blade_model_default(&m, 11) == TSK_OK);
    CHECK(m.knot_count == 11);
    const double H = 0.30, W = 0.008;
    for (int k = 0; k < 11; ++k) {
        const double t = k / 10.0;
        CHECK_NEAR(m.xyz[3 * k], 0.25 * H * t * t, 1e-7);
        CHECK_NEAR(m.xyz[3 * k + 1], 0.0, 0.0);
        CHECK_NEAR(m.xyz[3 * k + 2], H * t, 1e-7);
        CHECK_NEAR(m.width[k], W * (1.0 - t * t * t), 1e-9);
    }
    CHECK(m.xyz[0] == 0.0f && m.xyz[2] == 0.0f); /* root at the origin */
    CHECK(m.width[10] == 0.0f); /* pointed tip */
    float side[3];
    tsk_blade_model_side(&m, side); /* leans +x -> side +y */
    CHECK_NEAR(side[0], 0.0, 1e-7);
    CHECK_NEAR(side[1], 1.0, 1e-7);
    CHECK_NEAR(side[2], 0.0, 0.0);
}

TEST(test_blade_model_set_moves_root_to_origin) {
    float xyz[9] = {1, 2, 3, 1, 2, 4, 2, 2, 5};
    float w[3] = {0.01f, 0.02f, 0.0f};
    tsk_blade_model m;
    CHECK(tsk_blade_model_set(&m, xyz, w, 3) == TSK_OK);
    CHECK(m.xyz[0] == 0 && m.xyz[1] == 0 && m.xyz[2] == 0);
    CHECK_NEAR(m.xyz[6], 1.0, 0);
    CHECK_NEAR(m.xyz[8], 2.0, 0);
    CHECK(m.width[1] == 0.02f);
    float side[3];
    tsk_blade_model_side(&m, side); /* lean along +x -> side +y */
    CHECK_NEAR(side[1], 1.0, 1e-7);
}

TEST(test_blade_model_rejects_bad_input) {
    tsk_blade_model m;
    float xyz[3 * 65] = {0}, w[65] = {0};
    for (int k = 0; k < 65; ++k) xyz[3 * k + 2] = 0.01f * k;
    CHECK_STATUS(tsk_blade_model_set(&m, xyz, w, 65), TSK_ERR_LIMIT, "knot_count");
    CHECK_STATUS(tsk_blade_model_set(&m, xyz, w, 1), TSK_ERR_ARGUMENT, "knot_count");
    CHECK_STATUS(tsk_blade_model_set(&m, NULL, w, 4), TSK_ERR_ARGUMENT, "xyz");
    xyz[5] = NAN;
    CHECK_STATUS(tsk_blade_model_set(&m, xyz, w, 4), TSK_ERR_ARGUMENT, "knot 1");
    xyz[5] = 0.01f;
    w[2] = -0.001f;
    CHECK_STATUS(tsk_blade_model_set(&m, xyz, w, 4), TSK_ERR_ARGUMENT, "width");
    w[2] = 0.0f;
    float flat[6] = {1, 1, 1, 1, 1, 1};
    CHECK_STATUS(tsk_blade_model_set(&m, flat, w, 2), TSK_ERR_ARGUMENT, "zero length");
    CHECK_STATUS(tsk_blade_model_default(&m, 100), TSK_ERR_LIMIT, "knot_count");
}

TEST(test_resample_spaces_knots_evenly_on_the_polyline) {
    /* an L-shaped blade: 0.2 m up then 0.1 m sideways, width linear in arc length */
    float xyz[9] = {0, 0, 0, 0, 0, 0.2f, 0.1f, 0, 0.2f};
    float w[3] = {0.03f, 0.01f, 0.0f};
    tsk_blade_model m, r;
    CHECK(tsk_blade_model_set(&m, xyz, w, 3) == TSK_OK);
    CHECK(tsk_blade_model_resample(&m, 7, &r) == TSK_OK);
    CHECK(r.knot_count == 7);
    for (int k = 0; k < 7; ++k) {
        const double s = 0.3 * k / 6.0; /* arc length of knot k */
        const double ex = s <= 0.2 ? 0.0 : s - 0.2, ez = s <= 0.2 ? s : 0.2;
        const double ew = s <= 0.2 ? 0.03 - 0.1 * s : 0.01 - 0.1 * (s - 0.2);
        CHECK_NEAR(r.xyz[3 * k], ex, 1e-6);
        CHECK_NEAR(r.xyz[3 * k + 2], ez, 1e-6);
        CHECK_NEAR(r.width[k], ew, 1e-7);
    }
    CHECK(r.xyz[18] == m.xyz[6] && r.xyz[20] == m.xyz[8]); /* tip kept exactly */
    tsk_blade_model same;
    CHECK(tsk_blade_model_resample(&m, 3, &same) == TSK_OK);
    CHECK(memcmp(&same, &m, sizeof m) == 0);
}

/* ---- patch ------------------------------------------------------------------------------- */

static tsk_patch* make_patch(uint64_t seed, int32_t n) {
    tsk_patch_def d = tsk_default_patch_def();
    d.seed = seed;
    d.blade_count = n;
    tsk_patch* p = NULL;
    CHECK(tsk_patch_create(&d, &p) == TSK_OK);
    return p;
}

TEST(test_patch_defaults_follow_seed) {
    tsk_patch_def d = tsk_default_patch_def();
    CHECK(d.blade_count == 16384);
    tsk_patch* p = make_patch(1, d.blade_count);
    CHECK(p != NULL);
    CHECK(tsk_patch_blade_count(p) == 16384);
    CHECK(tsk_patch_knot_count(p) == 16);
    CHECK(tsk_patch_model_count(p) == 1);
    tsk_patch_destroy(p);
}

TEST(test_patch_values_in_range_and_uniform) {
    enum { N = 16384, B = 16 };
    tsk_patch_def d = tsk_default_patch_def();
    d.scale_min = 0.5f;
    d.scale_max = 1.5f;
    d.seed = 77;
    tsk_patch* p = NULL;
    CHECK(tsk_patch_create(&d, &p) == TSK_OK);
    static float xy[2 * N], turn[N], scale[N];
    CHECK(tsk_patch_get_blades(p, xy, turn, scale, NULL) == TSK_OK);
    int hx[B] = {0}, hy[B] = {0}, ht[B] = {0}, hs[B] = {0}, h2[8][8] = {{0}};
    int bad = 0;
    double msum = 0;
    for (int b = 0; b < N; ++b) {
        const float x = xy[2 * b], y = xy[2 * b + 1];
        bad += !(x >= 0.0f && x < 1.0f && y >= 0.0f && y < 1.0f);
        bad += !(turn[b] >= 0.0f && turn[b] < (float)(2 * PI));
        bad += !(scale[b] >= 0.5f && scale[b] <= 1.5f);
        if (bad) break;
        hx[(int)(x * B)]++;
        hy[(int)(y * B)]++;
        ht[(int)(turn[b] / (2 * PI) * B)]++;
        hs[(int)((scale[b] - 0.5f) * B) < B ? (int)((scale[b] - 0.5f) * B) : B - 1]++;
        h2[(int)(x * 8)][(int)(y * 8)]++;
        msum += scale[b];
    }
    CHECK(bad == 0);
    /* expected N/B = 1024 per bin, sigma = sqrt(1024 * 15/16) = 31: allow 5 sigma */
    for (int k = 0; k < B; ++k) {
        CHECK_NEAR(hx[k], N / B, 155);
        CHECK_NEAR(hy[k], N / B, 155);
        CHECK_NEAR(ht[k], N / B, 155);
        CHECK_NEAR(hs[k], N / B, 155);
    }
    /* 8x8 joint bins: expected 256, sigma 16 */
    for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j) CHECK_NEAR(h2[i][j], N / 64, 80);
    CHECK_NEAR(msum / N, 1.0, 0.015); /* sigma of the mean = 0.289/128 = 0.0023 */
    tsk_patch_destroy(p);
}

TEST(test_patch_same_seed_same_bytes_other_seed_differs) {
    enum { N = 4096 };
    static float a[2 * N], b[2 * N], ta[N], tb[N];
    tsk_patch* p1 = make_patch(5, N);
    tsk_patch* p2 = make_patch(5, N);
    tsk_patch* p3 = make_patch(6, N);
    CHECK(tsk_patch_get_blades(p1, a, ta, NULL, NULL) == TSK_OK);
    CHECK(tsk_patch_get_blades(p2, b, tb, NULL, NULL) == TSK_OK);
    CHECK(memcmp(a, b, sizeof a) == 0 && memcmp(ta, tb, sizeof ta) == 0);
    CHECK(tsk_patch_get_blades(p3, b, tb, NULL, NULL) == TSK_OK);
    int differ = 0;
    for (int i = 0; i < N; ++i) differ += a[2 * i] != b[2 * i];
    CHECK(differ > N * 99 / 100);
    tsk_patch_destroy(p1);
    tsk_patch_destroy(p2);
    tsk_patch_destroy(p3);
}

TEST(test_patch_blade_values_are_keyed_by_seed_and_blade) {
    /* blade b's position is tsk_rand01(seed, TSK_PATCH_STREAM, b, 3/4): a patch of 10 blades
     * is a prefix of a patch of 1000 */
    tsk_patch* small = make_patch(9, 10);
    tsk_patch* big = make_patch(9, 1000);
    float xs[20], xb[2000];
    CHECK(tsk_patch_get_blades(small, xs, NULL, NULL, NULL) == TSK_OK);
    CHECK(tsk_patch_get_blades(big, xb, NULL, NULL, NULL) == TSK_OK);
    CHECK(memcmp(xs, xb, sizeof xs) == 0);
    CHECK(xs[2 * 7 + 1] == tsk_rand01(9, TSK_PATCH_STREAM, 7, 4));
    tsk_patch_destroy(small);
    tsk_patch_destroy(big);
}

TEST(test_patch_model_choice_follows_weights) {
    enum { N = 20000 };
    tsk_blade_model models[2];
    CHECK(tsk_blade_model_default(&models[0], 8) == TSK_OK);
    CHECK(tsk_blade_model_default(&models[1], 12) == TSK_OK);
    const float weights[2] = {1.0f, 3.0f};
    tsk_patch_def d = tsk_default_patch_def();
    d.blade_count = N;
    d.models = models;
    d.model_count = 2;
    d.model_weights = weights;
    tsk_patch* p = NULL;
    CHECK(tsk_patch_create(&d, &p) == TSK_OK);
    CHECK(tsk_patch_knot_count(p) == 12); /* the most knots of any model */
    static int32_t model[N];
    CHECK(tsk_patch_get_blades(p, NULL, NULL, NULL, model) == TSK_OK);
    int ones = 0;
    for (int i = 0; i < N; ++i) ones += model[i] == 1;
    /* expected 0.75 N = 15000, sigma = sqrt(N * 0.1875) = 61 */
    CHECK_NEAR(ones, 15000, 330);
    tsk_blade_model r;
    CHECK(tsk_patch_get_model(p, 0, &r) == TSK_OK);
    CHECK(r.knot_count == 12);
    CHECK_NEAR(r.xyz[3 * 11 + 2], 0.30, 1e-6); /* resampled model keeps its tip */
    tsk_patch_destroy(p);
}

TEST(test_patch_rejects_bad_input) {
    tsk_patch* p = (tsk_patch*)1;
    tsk_patch_def d = tsk_default_patch_def();
    d.blade_count = TSK_PATCH_MAX_BLADES + 1;
    CHECK_STATUS(tsk_patch_create(&d, &p), TSK_ERR_LIMIT, "blade_count");
    CHECK(p == NULL);
    d = tsk_default_patch_def();
    d.blade_count = 0;
    CHECK_STATUS(tsk_patch_create(&d, &p), TSK_ERR_ARGUMENT, "blade_count");
    d = tsk_default_patch_def();
    d.scale_min = NAN;
    CHECK_STATUS(tsk_patch_create(&d, &p), TSK_ERR_ARGUMENT, "scale_min");
    d = tsk_default_patch_def();
    d.scale_min = 0.0f;
    CHECK_STATUS(tsk_patch_create(&d, &p), TSK_ERR_ARGUMENT, "scale_min");
    d = tsk_default_patch_def();
    d.scale_max = 0.5f;
    CHECK_STATUS(tsk_patch_create(&d, &p), TSK_ERR_ARGUMENT, "scale_max");
    d = tsk_default_patch_def();
    d.model_count = 2;
    CHECK_STATUS(tsk_patch_create(&d, &p), TSK_ERR_ARGUMENT, "models");
    tsk_blade_model m;
    CHECK(tsk_blade_model_default(&m, 8) == TSK_OK);
    m.width[3] = NAN;
    d.models = &m;
    d.model_count = 1;
    CHECK_STATUS(tsk_patch_create(&d, &p), TSK_ERR_ARGUMENT, "model 0");
    CHECK(tsk_blade_model_default(&m, 8) == TSK_OK);
    const float zero = 0.0f;
    d.model_weights = &zero;
    CHECK_STATUS(tsk_patch_create(&d, &p), TSK_ERR_ARGUMENT, "model_weights");
    CHECK_STATUS(tsk_patch_create(NULL, &p), TSK_ERR_ARGUMENT, "def");
}

/* ---- Perlin noise against an independent reference ---------------------------------------- */

/* Reference written from the textbook definition (Perlin 2002): the value at p is the sum
 * over the four lattice corners c of fade-weights w(p_x - c_x) w(p_y - c_y) times the dot of
 * the corner's gradient with (p - c), where w(d) = 1 - fade(|d|). Gradients: angle h*45
 * degrees, length sqrt(2), h = P[P[c_x] + c_y] mod 8 with P the seeded permutation. */
typedef struct ref_noise {
    int p[256];
} ref_noise;

static void ref_init(ref_noise* r, uint64_t seed) {
    for (int i = 0; i < 256; ++i) r->p[i] = i;
    for (int i = 255; i > 0; --i) {
        int j = (int)(tsk_hash4(seed, TSK_NOISE_STREAM, (uint64_t)i, 0) % (uint64_t)(i + 1));
        int t = r->p[i];
        r->p[i] = r->p[j];
        r->p[j] = t;
    }
}

static double ref_fade(double t) { return 6 * pow(t, 5) - 15 * pow(t, 4) + 10 * pow(t, 3); }

static int ref_wrap(long long v) { return (int)(((v % 256) + 256) % 256); }

static double ref_perlin(const ref_noise* r, double x, double y) {
    const long long X = (long long)floor(x), Y = (long long)floor(y);
    double sum = 0;
    for (int cx = 0; cx < 2; ++cx)
        for (int cy = 0; cy < 2; ++cy) {
            const long long gx = X + cx, gy = Y + cy;
            const int h = r->p[ref_wrap(r->p[ref_wrap(gx)] + ref_wrap(gy))] % 8;
            const double ang = h * PI / 4;
            const double g0 = sqrt(2.0) * cos(ang), g1 = sqrt(2.0) * sin(ang);
            const double dx = x - (double)gx, dy = y - (double)gy;
            const double w = (1 - ref_fade(fabs(dx))) * (1 - ref_fade(fabs(dy)));
            sum += w * (g0 * dx + g1 * dy);
        }
    return sum;
}

static double ref_fbm(const ref_noise* r, double x, double y, int oct, double pers) {
    double s = 0, n = 0;
    for (int o = 0; o < oct; ++o) {
        s += pow(pers, o) * ref_perlin(r, x * pow(2, o), y * pow(2, o));
        n += pow(pers, o);
    }
    return s / n;
}

TEST(test_noise_matches_textbook_reference) {
    tsk_noise n;
    ref_noise r;
    tsk_noise_init(&n, 1234);
    ref_init(&r, 1234);
    int perm_ok = 1;
    for (int i = 0; i < 512; ++i) perm_ok &= n.perm[i] == r.p[i & 255];
    CHECK(perm_ok);
    double worst = 0;
    for (int i = 0; i < 20000; ++i) {
        const double x = (tsk_rand01(3, 0, i, 0) - 0.5) * 1200.0;
        const double y = (tsk_rand01(3, 1, i, 0) - 0.5) * 1200.0;
        const double e = fabs(tsk_noise_perlin2(&n, x, y) - ref_perlin(&r, x, y));
        if (e > worst) worst = e;
    }
    CHECK_MSG(worst < 1e-12, "worst difference %g", worst);
    CHECK_NEAR(tsk_noise_fbm2(&n, 3.3, -7.1, 4, 0.5), ref_fbm(&r, 3.3, -7.1, 4, 0.5), 1e-12);
}

TEST(test_noise_in_range_zero_at_lattice_and_continuous) {
    tsk_noise n;
    tsk_noise_init(&n, 99);
    double lo = 1, hi = -1, sum = 0, sum2 = 0;
    int lattice_nonzero = 0;
    for (int i = -300; i < 300; ++i)
        for (int j = -300; j < 300; j += 7) {
            lattice_nonzero += tsk_noise_perlin2(&n, i, j) != 0.0;
            const double x = i * 0.173 + 0.05, y = j * 0.131 + 0.02;
            const double v = tsk_noise_perlin2(&n, x, y);
            lo = v < lo ? v : lo;
            hi = v > hi ? v : hi;
            sum += v;
            sum2 += v * v;
        }
    CHECK(lattice_nonzero == 0);
    CHECK(lo >= -1.0 && hi <= 1.0);
    CHECK(hi - lo > 1.0); /* it really varies */
    const double cnt = 600.0 * 86;
    CHECK_NEAR(sum / cnt, 0.0, 0.02); /* mean about 0 */
    CHECK(sqrt(sum2 / cnt) > 0.1);
    /* Lipschitz continuity: |grad| <= 2 * sqrt(2) * max|fade'| bound, use 5 */
    double worst_slope = 0;
    for (int i = 0; i < 5000; ++i) {
        const double x = tsk_rand01(4, 0, i, 0) * 50, y = tsk_rand01(4, 1, i, 0) * 50, h = 1e-6;
        const double s = fabs(tsk_noise_perlin2(&n, x + h, y) - tsk_noise_perlin2(&n, x, y)) / h;
        if (s > worst_slope) worst_slope = s;
    }
    CHECK(worst_slope < 5.0);
    /* the maximum 1 is reached at a cell centre whose four gradients point at it */
    tsk_noise_init(&n, 5);
    double best = 0;
    for (int i = 0; i < 256; ++i)
        for (int j = 0; j < 256; ++j) {
            double v = fabs(tsk_noise_perlin2(&n, i + 0.5, j + 0.5));
            best = v > best ? v : best;
        }
    CHECK(best <= 1.0 + 1e-12);
    CHECK(best > 0.9);
    /* other seeds give other noise */
    tsk_noise m;
    tsk_noise_init(&m, 6);
    CHECK(tsk_noise_perlin2(&n, 10.3, 4.7) != tsk_noise_perlin2(&m, 10.3, 4.7));
}

/* ---- meadow tiles -------------------------------------------------------------------------- */

static tsk_meadow* make_meadow(const tsk_meadow_def* d) {
    tsk_meadow* m = NULL;
    tsk_status s = tsk_meadow_create(d, &m);
    CHECK_MSG(s == TSK_OK, "create: %s", tsk_last_error());
    return m;
}

/* Expected count of tile (i, j) from the reference noise; sets *tie when the value is within
 * 1e-9 of a rounding boundary (where double rounding could differ). */
static int32_t ref_count(const tsk_meadow_def* d, const ref_noise* r, int i, int j, int* tie) {
    const double cx = d->origin[0] + (i + 0.5) * (double)d->tile_size;
    const double cy = d->origin[1] + (j + 0.5) * (double)d->tile_size;
    const double n =
        ref_fbm(r, (cx - d->origin[0]) / d->noise_scale, (cy - d->origin[1]) / d->noise_scale,
                d->noise_octaves, d->noise_persistence);
    double v = (1 + d->noise_contrast * n) / 2, t = d->noise_threshold;
    v = v < 0 ? 0 : v > 1 ? 1 : v;
    double dens = (v - t) / (1 - t);
    dens = dens < 0 ? 0 : dens > 1 ? 1 : dens;
    const double q = d->blades_per_tile * dens / d->chunk_blades + 0.5;
    *tie = fabs(q - floor(q + 0.5)) < 1e-9;
    int32_t c = d->chunk_blades * (int32_t)floor(q);
    const int32_t cap = d->chunk_blades * (d->blades_per_tile / d->chunk_blades);
    return c > cap ? cap : c;
}

TEST(test_meadow_count_matches_density_map) {
    tsk_meadow_def d = tsk_default_meadow_def();
    d.origin[0] = -37.5f;
    d.origin[1] = 12.25f;
    d.size[0] = 80.0f;
    d.size[1] = 60.3f; /* not a multiple: the last 0.3 m strip stays empty */
    d.tile_size = 0.5f;
    d.blades_per_tile = 100;
    d.seed = 4242;
    d.noise_scale = 6.0f;
    d.noise_octaves = 4;
    d.noise_threshold = 0.35f;
    d.noise_contrast = 1.7f;
    tsk_meadow* m = make_meadow(&d);
    tsk_meadow_info info;
    CHECK(tsk_meadow_get_info(m, &info) == TSK_OK);
    CHECK(info.tiles_x == 160 && info.tiles_y == 120);
    const int64_t T = info.tile_count;
    int32_t* counts = malloc((size_t)T * sizeof(int32_t));
    CHECK(tsk_meadow_get_tiles(m, counts, NULL, NULL) == TSK_OK);
    ref_noise r;
    ref_init(&r, d.seed);
    int64_t expected = 0, got = 0, ties = 0, mismatches = 0, zero = 0, full = 0;
    for (int j = 0; j < info.tiles_y; ++j)
        for (int i = 0; i < info.tiles_x; ++i) {
            int tie;
            const int32_t e = ref_count(&d, &r, i, j, &tie);
            const int32_t c = counts[(int64_t)j * info.tiles_x + i];
            expected += e;
            got += c;
            ties += tie;
            mismatches += c != e && !tie;
            zero += c == 0;
            full += c == 100;
        }
    CHECK(mismatches == 0);
    CHECK(ties < 5);
    CHECK_MSG(llabs(got - expected) <= ties, "got %lld expected %lld", (long long)got,
              (long long)expected);
    CHECK(info.blade_count == got);
    CHECK(zero > 0 && zero < T); /* the threshold leaves bare patches, not bare everything */
    CHECK(got > T * 5 && got < T * 95);
    CHECK(full > 0 && full < T); /* the contrast reaches full density somewhere */
    free(counts);
    tsk_meadow_destroy(m);
}

TEST(test_meadow_uniform_count_is_tiles_times_blades) {
    tsk_meadow_def d = tsk_default_meadow_def();
    d.density = TSK_DENSITY_UNIFORM;
    d.size[0] = 12.0f;
    d.size[1] = 7.9f;
    d.tile_size = 1.0f;
    d.blades_per_tile = 37;
    tsk_meadow* m = make_meadow(&d);
    tsk_meadow_info info;
    CHECK(tsk_meadow_get_info(m, &info) == TSK_OK);
    CHECK(info.tiles_x == 12 && info.tiles_y == 7);
    CHECK(info.blade_count == 12 * 7 * 37);
    CHECK(info.nonempty_tiles == 84);
    int64_t c = 0;
    CHECK(tsk_meadow_blade_count(m, 10, 20, &c) == TSK_OK);
    CHECK(c == 370);
    tsk_meadow_destroy(m);
}

TEST(test_meadow_image_density_is_bilinear_at_tile_centres) {
    /* a 4 x 2 image over an 8 x 4 m meadow of 1 m tiles */
    const float img[8] = {0.0f, 0.25f, 0.5f, 1.0f, /* row 0: y near origin */
                          1.0f, 1.0f,  0.0f, 0.0f};
    tsk_meadow_def d = tsk_default_meadow_def();
    d.density = TSK_DENSITY_IMAGE;
    d.size[0] = 8.0f;
    d.size[1] = 4.0f;
    d.tile_size = 1.0f;
    d.blades_per_tile = 1000;
    d.image = img;
    d.image_width = 4;
    d.image_height = 2;
    tsk_meadow* m = make_meadow(&d);
    int32_t counts[32];
    float dens[32];
    CHECK(tsk_meadow_get_tiles(m, counts, NULL, dens) == TSK_OK);
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 8; ++i) {
            /* pixel coordinates of the tile centre, clamped to the pixel-centre range */
            double px = (i + 0.5) / 8.0 * 4 - 0.5, py = (j + 0.5) / 4.0 * 2 - 0.5;
            px = px < 0 ? 0 : px > 3 ? 3 : px;
            py = py < 0 ? 0 : py > 1 ? 1 : py;
            const int x0 = (int)px, y0 = (int)py;
            const int x1 = x0 < 3 ? x0 + 1 : 3, y1 = y0 < 1 ? y0 + 1 : 1;
            const double fx = px - x0, fy = py - y0;
            const double e = (1 - fy) * ((1 - fx) * img[y0 * 4 + x0] + fx * img[y0 * 4 + x1]) +
                             fy * ((1 - fx) * img[y1 * 4 + x0] + fx * img[y1 * 4 + x1]);
            CHECK_NEAR(dens[j * 8 + i], e, 1e-6);
            CHECK(counts[j * 8 + i] == (int32_t)floor(1000 * e + 0.5));
        }
    CHECK(counts[0] == 0); /* corner pixel 0 */
    CHECK(counts[7] == 1000); /* corner pixel 1 */
    tsk_meadow_destroy(m);
}

TEST(test_tile_offsets_follow_hash_of_tile_coordinates) {
    tsk_meadow_def d = tsk_default_meadow_def();
    d.size[0] = 20.0f;
    d.size[1] = 10.0f;
    d.seed = 31;
    d.chunk_blades = 16;
    tsk_meadow* m = make_meadow(&d);
    tsk_meadow_info info;
    CHECK(tsk_meadow_get_info(m, &info) == TSK_OK);
    int32_t* off = malloc((size_t)info.tile_count * sizeof(int32_t));
    CHECK(tsk_meadow_get_tiles(m, NULL, off, NULL) == TSK_OK);
    int ok = 1;
    int hist[8] = {0};
    for (int j = 0; j < info.tiles_y; ++j)
        for (int i = 0; i < info.tiles_x; ++i) {
            const int32_t o = off[j * info.tiles_x + i];
            ok &= o == (int32_t)(16 * (tsk_hash4(31, TSK_TILE_STREAM, i, j) % 1024));
            ok &= o >= 0 && o < 16384 && o % 16 == 0;
            hist[o / 2048]++;
        }
    CHECK(ok);
    for (int k = 0; k < 8; ++k) CHECK_NEAR(hist[k], 800 / 8, 50); /* 800 tiles, spread */
    free(off);
    tsk_meadow_destroy(m);
}

static uint64_t meadow_digest(int threads, const tsk_meadow_def* d) {
    CHECK(tsk_set_threads(threads) == TSK_OK);
    tsk_meadow* m = make_meadow(d);
    tsk_meadow_info info;
    CHECK(tsk_meadow_get_info(m, &info) == TSK_OK);
    const size_t T = (size_t)info.tile_count;
    int32_t* a = malloc(T * sizeof(int32_t));
    int32_t* b = malloc(T * sizeof(int32_t));
    float* c = malloc(T * sizeof(float));
    CHECK(tsk_meadow_get_tiles(m, a, b, c) == TSK_OK);
    uint64_t h = fnv(a, T * 4, 1469598103934665603ull);
    h = fnv(b, T * 4, h);
    h = fnv(c, T * 4, h);
    h = fnv(&info.blade_count, sizeof info.blade_count, h);
    free(a);
    free(b);
    free(c);
    tsk_meadow_destroy(m);
    tsk_set_threads(0);
    return h;
}

TEST(test_tiles_identical_across_runs_and_threads) {
    tsk_meadow_def d = tsk_default_meadow_def();
#ifdef TSK_SLOW_CHECKS
    d.size[0] = 60.0f;
    d.size[1] = 60.0f;
#else
    d.size[0] = 200.0f;
    d.size[1] = 150.0f;
#endif
    d.seed = 8;
    const uint64_t h1 = meadow_digest(1, &d);
    const uint64_t h2 = meadow_digest(2, &d);
    const uint64_t h1b = meadow_digest(1, &d);
    CHECK(h1 == h2);
    CHECK(h1 == h1b);
    d.seed = 9;
    CHECK(meadow_digest(2, &d) != h1);
}

TEST(test_tile_runs_are_contiguous_and_wrap_at_patch_end) {
    enum { P = 256 };
    tsk_patch* p = make_patch(3, P);
    tsk_meadow_def d = tsk_default_meadow_def();
    d.density = TSK_DENSITY_UNIFORM;
    d.size[0] = 10.0f;
    d.size[1] = 10.0f;
    d.tile_size = 1.0f;
    d.blades_per_tile = 100;
    d.patch_blades = P;
    tsk_meadow* m = make_meadow(&d);
    int32_t off[100], cnt[100];
    CHECK(tsk_meadow_get_tiles(m, cnt, off, NULL) == TSK_OK);
    static int32_t idx[100 * 100];
    static float xyz[3 * 100 * 100], turn[100 * 100], scale[100 * 100];
    CHECK(tsk_meadow_realise(m, p, 0, 100, xyz, turn, scale, idx) == TSK_OK);
    float pxy[2 * P], pturn[P], pscale[P];
    CHECK(tsk_patch_get_blades(p, pxy, pturn, pscale, NULL) == TSK_OK);
    int wrapped = 0, ok = 1;
    for (int t = 0; t < 100; ++t) {
        const int i = t % 10, j = t / 10;
        wrapped += off[t] + cnt[t] > P;
        for (int k = 0; k < cnt[t]; ++k) {
            const int o = t * 100 + k, b = (off[t] + k) % P;
            ok &= idx[o] == b;
            ok &= turn[o] == pturn[b] && scale[o] == pscale[b];
            ok &= fabsf(xyz[3 * o] - (i + pxy[2 * b])) < 1e-5f;
            ok &= fabsf(xyz[3 * o + 1] - (j + pxy[2 * b + 1])) < 1e-5f;
            ok &= xyz[3 * o] >= i && xyz[3 * o] <= i + 1 && xyz[3 * o + 1] >= j &&
                  xyz[3 * o + 1] <= j + 1 && xyz[3 * o + 2] == 0.0f;
        }
    }
    CHECK(ok);
    CHECK(wrapped > 10); /* with 100 of 256 blades per tile, ~39% of runs wrap */
    /* a sub-range starts at that range's first blade */
    int32_t sub[300];
    int64_t n = 0;
    CHECK(tsk_meadow_blade_count(m, 40, 43, &n) == TSK_OK);
    CHECK(n == 300);
    CHECK(tsk_meadow_realise(m, p, 40, 43, NULL, NULL, NULL, sub) == TSK_OK);
    CHECK(memcmp(sub, &idx[4000], sizeof sub) == 0);
    tsk_meadow_destroy(m);
    tsk_patch_destroy(p);
}

TEST(test_chunk_instances_reproduce_the_realised_meadow) {
    tsk_patch* p = make_patch(11, 16384);
    tsk_meadow_def d = tsk_default_meadow_def();
    d.size[0] = 30.0f;
    d.size[1] = 20.0f;
    d.chunk_blades = 8;
    d.seed = 12;
    tsk_meadow* m = make_meadow(&d);
    tsk_meadow_info info;
    CHECK(tsk_meadow_get_info(m, &info) == TSK_OK);
    CHECK(info.blade_count % 8 == 0);
    CHECK(info.chunk_instances == info.blade_count / 8);
    const size_t N = (size_t)info.blade_count, I = (size_t)info.chunk_instances;
    int32_t* idx = malloc(N * sizeof(int32_t));
    float* xyz = malloc(3 * N * sizeof(float));
    int32_t* chunk = malloc(I * sizeof(int32_t));
    float* org = malloc(3 * I * sizeof(float));
    CHECK(tsk_meadow_realise(m, p, 0, info.tile_count, xyz, NULL, NULL, idx) == TSK_OK);
    int32_t* ctile = malloc(I * sizeof(int32_t));
    CHECK(tsk_meadow_chunk_instances(m, org, chunk, ctile) == TSK_OK);
    float pxy[2 * 16384];
    CHECK(tsk_patch_get_blades(p, pxy, NULL, NULL, NULL) == TSK_OK);
    int ok = 1;
    for (size_t n = 0; n < I; ++n)
        for (int k = 0; k < 8; ++k) {
            const size_t o = 8 * n + k;
            ok &= idx[o] == chunk[n] * 8 + k; /* blade k of chunk = the realised blade */
            /* the chunk's tile is the tile whose blade range holds blade o */
            int64_t before = 0, upto = 0;
            CHECK(tsk_meadow_blade_count(m, 0, ctile[n], &before) == TSK_OK);
            CHECK(tsk_meadow_blade_count(m, 0, ctile[n] + 1, &upto) == TSK_OK);
            ok &= (int64_t)o >= before && (int64_t)o < upto;
            ok &= fabsf(org[3 * n] + pxy[2 * idx[o]] * d.tile_size - xyz[3 * o]) < 1e-4f;
            ok &=
                fabsf(org[3 * n + 1] + pxy[2 * idx[o] + 1] * d.tile_size - xyz[3 * o + 1]) < 1e-4f;
        }
    CHECK(ok);
    /* the per-tile instance data agrees with the tiles */
    const size_t T = (size_t)info.tile_count;
    float* torg = malloc(3 * T * sizeof(float));
    int32_t* toff = malloc(T * sizeof(int32_t));
    int32_t* tcnt = malloc(T * sizeof(int32_t));
    CHECK(tsk_meadow_instances(m, torg, toff, tcnt) == TSK_OK);
    int64_t sum = 0;
    for (size_t t = 0; t < T; ++t) {
        sum += tcnt[t];
        ok &= tcnt[t] % 8 == 0 && toff[t] % 8 == 0;
        ok &= fabsf(torg[3 * t] - (float)(t % (size_t)info.tiles_x) * 0.5f) < 1e-5f;
        ok &= fabsf(torg[3 * t + 1] - (float)(t / (size_t)info.tiles_x) * 0.5f) < 1e-5f;
    }
    CHECK(ok);
    CHECK(sum == info.blade_count);
    free(idx);
    free(xyz);
    free(chunk);
    free(ctile);
    free(org);
    free(torg);
    free(toff);
    free(tcnt);
    tsk_meadow_destroy(m);
    tsk_patch_destroy(p);
}

TEST(test_realised_knots_are_the_turned_scaled_model) {
    tsk_patch* p = make_patch(21, 512);
    tsk_meadow_def d = tsk_default_meadow_def();
    d.density = TSK_DENSITY_UNIFORM;
    d.size[0] = 2.0f;
    d.size[1] = 2.0f;
    d.origin[2] = 1.5f;
    d.blades_per_tile = 50;
    d.patch_blades = 512;
    tsk_meadow* m = make_meadow(&d);
    enum { N = 200, K = 16 };
    static float knots[3 * K * N], widths[K * N], sides[3 * N], xyz[3 * N], turn[N], scale[N];
    CHECK(tsk_meadow_realise(m, p, 0, 4, xyz, turn, scale, NULL) == TSK_OK);
    CHECK(tsk_meadow_realise_knots(m, p, 0, 4, knots, widths, sides) == TSK_OK);
    tsk_blade_model bm;
    CHECK(tsk_blade_model_default(&bm, K) == TSK_OK);
    double worst = 0;
    for (int b = 0; b < N; ++b) {
        const double c = cos(turn[b]), s = sin(turn[b]);
        for (int k = 0; k < K; ++k) {
            const double ex = xyz[3 * b] + scale[b] * (c * bm.xyz[3 * k]);
            const double ey = xyz[3 * b + 1] + scale[b] * (s * bm.xyz[3 * k]);
            const double ez = 1.5 + scale[b] * bm.xyz[3 * k + 2];
            const float* q = &knots[3 * (K * b + k)];
            worst = fmax(worst, fabs(q[0] - ex) + fabs(q[1] - ey) + fabs(q[2] - ez));
            worst = fmax(worst, fabs(widths[K * b + k] - scale[b] * bm.width[k]));
        }
        worst = fmax(worst, fabs(sides[3 * b] + s) + fabs(sides[3 * b + 1] - c)); /* R(turn) y */
    }
    CHECK_MSG(worst < 2e-6, "worst %g", worst);
    tsk_meadow_destroy(m);
    tsk_patch_destroy(p);
}

TEST(test_realise_identical_bytes_1_and_2_threads) {
    tsk_patch* p = make_patch(4, 16384);
    tsk_meadow_def d = tsk_default_meadow_def();
    d.size[0] = 40.0f;
    d.size[1] = 25.0f;
    d.chunk_blades = 4;
    uint64_t h[2];
    for (int r = 0; r < 2; ++r) {
        CHECK(tsk_set_threads(r + 1) == TSK_OK);
        tsk_meadow* m = make_meadow(&d);
        tsk_meadow_info info;
        CHECK(tsk_meadow_get_info(m, &info) == TSK_OK);
        const size_t n = (size_t)info.blade_count, I = (size_t)info.chunk_instances;
        float* xyz = malloc(3 * n * sizeof(float));
        float* knots = malloc(3 * 16 * n * sizeof(float));
        float* org = malloc(3 * I * sizeof(float));
        int32_t* chunk = malloc(I * sizeof(int32_t));
        CHECK(tsk_meadow_realise(m, p, 0, info.tile_count, xyz, NULL, NULL, NULL) == TSK_OK);
        CHECK(tsk_meadow_realise_knots(m, p, 0, info.tile_count, knots, NULL, NULL) == TSK_OK);
        CHECK(tsk_meadow_chunk_instances(m, org, chunk, NULL) == TSK_OK);
        h[r] = fnv(xyz, 3 * n * sizeof(float), 1469598103934665603ull);
        h[r] = fnv(knots, 3 * 16 * n * sizeof(float), h[r]);
        h[r] = fnv(org, 3 * I * sizeof(float), h[r]);
        h[r] = fnv(chunk, I * sizeof(int32_t), h[r]);
        free(xyz);
        free(knots);
        free(org);
        free(chunk);
        tsk_meadow_destroy(m);
    }
    tsk_set_threads(0);
    CHECK(h[0] == h[1]);
    tsk_patch_destroy(p);
}

/* ---- expansion ------------------------------------------------------------------------------ */

TEST(test_expansion_widths_equal_model_widths_times_scale) {
    tsk_blade_model models[2];
    CHECK(tsk_blade_model_default(&models[0], 16) == TSK_OK);
    /* a second model: a tilted helix-ish blade with its own widths */
    float xyz[3 * 16], w[16];
    for (int k = 0; k < 16; ++k) {
        xyz[3 * k] = 0.02f * sinf(0.3f * k);
        xyz[3 * k + 1] = 0.03f * (1 - cosf(0.2f * k));
        xyz[3 * k + 2] = 0.025f * k;
        w[k] = 0.012f - 0.0007f * k;
    }
    CHECK(tsk_blade_model_set(&models[1], xyz, w, 16) == TSK_OK);
    tsk_patch_def pd = tsk_default_patch_def();
    pd.blade_count = 2000;
    pd.models = models;
    pd.model_count = 2;
    tsk_patch* p = NULL;
    CHECK(tsk_patch_create(&pd, &p) == TSK_OK);
    size_t nv = 0, nt = 0;
    CHECK(tsk_patch_mesh_counts(p, &nv, &nt) == TSK_OK);
    CHECK(nv == 2000 * 32 && nt == 2000 * 30);
    float* pos = malloc(nv * 3 * sizeof(float));
    float* nrm = malloc(nv * 3 * sizeof(float));
    float* uv = malloc(nv * 2 * sizeof(float));
    int32_t* tris = malloc(nt * 3 * sizeof(int32_t));
    int32_t* bid = malloc(nv * sizeof(int32_t));
    CHECK(tsk_patch_expand(p, 0.5f, pos, nrm, uv, tris, bid) == TSK_OK);
    int32_t model[2000];
    float scale[2000], bxy[4000], turn[2000];
    CHECK(tsk_patch_get_blades(p, bxy, turn, scale, model) == TSK_OK);
    double worst_w = 0, worst_mid = 0, worst_n = 0, worst_dot = 0, worst_wind = -1;
    int uv_ok = 1, bid_ok = 1, tri_ok = 1;
    for (int b = 0; b < 2000; ++b) {
        const tsk_blade_model* bm = &models[model[b]];
        const double c = cos(turn[b]), s = sin(turn[b]);
        for (int k = 0; k < 16; ++k) {
            const float* l = &pos[3 * (32 * b + 2 * k)];
            const float* r = l + 3;
            const double dw = sqrt(pow(r[0] - l[0], 2) + pow(r[1] - l[1], 2) + pow(r[2] - l[2], 2));
            worst_w = fmax(worst_w, fabs(dw - bm->width[k] * scale[b]));
            /* the midpoint is the placed knot */
            const double kx =
                bxy[2 * b] * 0.5 + scale[b] * (c * bm->xyz[3 * k] - s * bm->xyz[3 * k + 1]);
            const double ky =
                bxy[2 * b + 1] * 0.5 + scale[b] * (s * bm->xyz[3 * k] + c * bm->xyz[3 * k + 1]);
            const double kz = scale[b] * bm->xyz[3 * k + 2];
            worst_mid =
                fmax(worst_mid, fabs(0.5 * (l[0] + r[0]) - kx) + fabs(0.5 * (l[1] + r[1]) - ky) +
                                    fabs(0.5 * (l[2] + r[2]) - kz));
            const float* nn = &nrm[3 * (32 * b + 2 * k)];
            const double nl = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
            /* normal is unit and perpendicular to the width direction */
            /* (metres: the width vector's component along the normal) */
            const double dot =
                nn[0] * (r[0] - l[0]) + nn[1] * (r[1] - l[1]) + nn[2] * (r[2] - l[2]);
            worst_n = fmax(worst_n, fabs(nl - 1));
            worst_dot = fmax(worst_dot, fabs(dot));
            const float* u = &uv[2 * (32 * b + 2 * k)];
            uv_ok &= u[0] == 0.0f && u[2] == 1.0f && u[1] == u[3];
            uv_ok &= k == 0 ? u[1] == 0.0f : (u[1] > u[-3] && u[1] <= 1.0f);
            uv_ok &= k == 15 ? u[1] == 1.0f : 1;
            bid_ok &= bid[32 * b + 2 * k] == b && bid[32 * b + 2 * k + 1] == b;
        }
        for (int t = 0; t < 30; ++t) {
            const int32_t* q = &tris[3 * (30 * b + t)];
            for (int a = 0; a < 3; ++a) tri_ok &= q[a] >= 32 * b && q[a] < 32 * (b + 1);
            /* winding agrees with the vertex normal (where the triangle is not degenerate) */
            const float *A = &pos[3 * q[0]], *B = &pos[3 * q[1]], *C = &pos[3 * q[2]];
            const double e1[3] = {B[0] - A[0], B[1] - A[1], B[2] - A[2]};
            const double e2[3] = {C[0] - A[0], C[1] - A[1], C[2] - A[2]};
            const double cr[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                                  e1[0] * e2[1] - e1[1] * e2[0]};
            const double cl = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
            const float* na = &nrm[3 * q[0]];
            if (cl > 1e-9)
                worst_wind =
                    fmax(worst_wind, -(cr[0] * na[0] + cr[1] * na[1] + cr[2] * na[2]) / cl);
        }
    }
    CHECK_MSG(worst_w < 1e-7, "width error %g m", worst_w);
    CHECK_MSG(worst_mid < 2e-6, "midpoint error %g m", worst_mid);
    CHECK_MSG(worst_n < 1e-6, "normal length error %g", worst_n);
    /* positions are float near 0.5 m (rounding 3e-8 m): the width vector has no component
     * along the normal beyond rounding */
    CHECK_MSG(worst_dot < 2e-7, "width along normal %g m", worst_dot);
    /* every triangle's face normal within 60 degrees of its first vertex's normal */
    CHECK_MSG(worst_wind < -0.5, "a triangle faces away from its normal (%g)", worst_wind);
    CHECK(uv_ok);
    CHECK(bid_ok);
    CHECK(tri_ok);
    free(pos);
    free(nrm);
    free(uv);
    free(tris);
    free(bid);
    tsk_patch_destroy(p);
}

TEST(test_blade_expand_straight_blade_closed_form) {
    /* a straight vertical blade with side +x: vertices at (+-w/2, 0, z), normal = x cross z = -y,
     * v = z / length */
    float knots[12] = {0, 0, 0, 0, 0, 0.1f, 0, 0, 0.3f, 0, 0, 0.4f};
    float widths[4] = {0.02f, 0.01f, 0.004f, 0.0f};
    const float side[3] = {3, 0, 0};
    float pos[24], nrm[24], uv[16];
    CHECK(tsk_blade_expand(knots, widths, 4, side, pos, nrm, uv) == TSK_OK);
    for (int k = 0; k < 4; ++k) {
        CHECK_NEAR(pos[6 * k], -widths[k] / 2, 1e-9);
        CHECK_NEAR(pos[6 * k + 3], widths[k] / 2, 1e-9);
        CHECK_NEAR(pos[6 * k + 2], knots[3 * k + 2], 0);
        CHECK_NEAR(nrm[6 * k + 1], -1.0, 1e-7);
        CHECK_NEAR(uv[4 * k + 1], knots[3 * k + 2] / 0.4, 1e-6);
    }
    int32_t tris[18];
    CHECK(tsk_blade_indices(4, 10, tris) == TSK_OK);
    const int32_t want[6] = {10, 11, 13, 10, 13, 12};
    CHECK(memcmp(tris, want, sizeof want) == 0);
    CHECK(tris[17] == 10 + 6);
    int32_t many[3 * 18];
    CHECK(tsk_blades_indices(4, 3, many) == TSK_OK);
    for (int i = 0; i < 18; ++i) CHECK(many[36 + i] == tris[i] - 10 + 16); /* blade 2 at 16 */
    CHECK_STATUS(tsk_blades_indices(64, (size_t)1 << 30, many), TSK_ERR_LIMIT, "blade_count");
    CHECK(tsk_blade_vertex_count(4) == 8 && tsk_blade_triangle_count(4) == 6);
    const float zero[3] = {0, 0, 0};
    CHECK_STATUS(tsk_blade_expand(knots, widths, 4, zero, pos, nrm, uv), TSK_ERR_ARGUMENT, "side");
    widths[1] = NAN;
    CHECK_STATUS(tsk_blade_expand(knots, widths, 4, side, pos, nrm, uv), TSK_ERR_ARGUMENT,
                 "widths");
    CHECK_STATUS(tsk_blade_expand(knots, widths, 70, side, pos, nrm, uv), TSK_ERR_LIMIT,
                 "knot_count");
}

/* Bent blades of every length from 2 to 19 knots (the four-knot SIMD steps and the scalar
 * tail), with repeated knots (no tangent) and tangents along the side, against the ribbon's
 * definition recomputed here in double: tangent by central differences, side made
 * perpendicular to it and unit, vertices half a width either side, normal = side x tangent. */
TEST(test_blades_expand_follows_the_ribbon_definition) {
    enum { NB = 6, KMAX = 19 };
    uint64_t state = 12345;
    float knots[NB * KMAX * 3], widths[NB * KMAX], sides[NB * 3];
    float pos[NB * KMAX * 6], nrm[NB * KMAX * 6];
    for (int K = 2; K <= KMAX; ++K) {
        for (int b = 0; b < NB; ++b) {
            for (int k = 0; k < K; ++k) {
                const float z = 0.05f * (float)k;
                float* q = &knots[3 * (K * b + k)];
                q[0] = 0.3f * (float)b + 0.4f * z * z * (float)(b % 3 - 1);
                q[1] = 0.02f *
                       (float)((state = state * 6364136223846793005ull + 1442695040888963407ull) >>
                               40) /
                       (float)(1 << 24);
                q[2] = b == 4 ? 0.0f : z; /* blade 4: along +x below */
                if (b == 4) q[0] = z;
                if (b == 5 && k >= K / 2) memcpy(q, q - 3, 3 * sizeof(float)); /* repeated knots */
                widths[K * b + k] = 0.01f * (float)(K - k) / (float)K;
            }
            sides[3 * b] = 1.0f, sides[3 * b + 2] = 0.0f;
            sides[3 * b + 1] = b == 4 ? 0.0f : 0.3f * (float)b; /* 4: along its tangent */
        }
        CHECK(tsk_blades_expand(knots, widths, sides, NB, K, pos, nrm, NULL) == TSK_OK);
        for (int b = 0; b < NB; ++b)
            for (int k = 0; k < K; ++k) {
                const int a = k > 0 ? k - 1 : 0, c = k < K - 1 ? k + 1 : K - 1;
                const float* P = &knots[3 * K * b];
                double t[3], s0[3], s[3], tl = 0, sl = 0, d = 0;
                for (int q = 0; q < 3; ++q) t[q] = (double)P[3 * c + q] - (double)P[3 * a + q];
                for (int q = 0; q < 3; ++q) tl += t[q] * t[q];
                if (tl > 0)
                    for (int q = 0; q < 3; ++q) t[q] /= sqrt(tl);
                else t[0] = 0, t[1] = 0, t[2] = 1;
                for (int q = 0; q < 3; ++q) sl += (double)sides[3 * b + q] * sides[3 * b + q];
                for (int q = 0; q < 3; ++q) s0[q] = sides[3 * b + q] / sqrt(sl);
                for (int q = 0; q < 3; ++q) d += s0[q] * t[q];
                double ssl = 0;
                for (int q = 0; q < 3; ++q) s[q] = s0[q] - d * t[q], ssl += s[q] * s[q];
                for (int q = 0; q < 3; ++q) s[q] = ssl > 1e-12 ? s[q] / sqrt(ssl) : s0[q];
                const double h = 0.5 * widths[K * b + k];
                const double n[3] = {s[1] * t[2] - s[2] * t[1], s[2] * t[0] - s[0] * t[2],
                                     s[0] * t[1] - s[1] * t[0]};
                const float* v = &pos[6 * (K * b + k)];
                const float* m = &nrm[6 * (K * b + k)];
                for (int q = 0; q < 3; ++q) {
                    CHECK_NEAR(v[q], P[3 * k + q] - h * s[q], 1e-6);
                    CHECK_NEAR(v[3 + q], P[3 * k + q] + h * s[q], 1e-6);
                    CHECK_NEAR(m[q], n[q], 1e-5);
                    CHECK_NEAR(m[3 + q], n[q], 1e-5);
                }
            }
    }
}

static uint64_t patch_digest(int threads, uint64_t seed) {
    CHECK(tsk_set_threads(threads) == TSK_OK);
    tsk_patch* p = make_patch(seed, 16384);
    size_t nv = 0, nt = 0;
    CHECK(tsk_patch_mesh_counts(p, &nv, &nt) == TSK_OK);
    float* pos = malloc(nv * 3 * sizeof(float));
    float* nrm = malloc(nv * 3 * sizeof(float));
    int32_t* tris = malloc(nt * 3 * sizeof(int32_t));
    CHECK(tsk_patch_expand(p, 0.5f, pos, nrm, NULL, tris, NULL) == TSK_OK);
    uint64_t h = fnv(pos, nv * 12, 1469598103934665603ull);
    h = fnv(nrm, nv * 12, h);
    h = fnv(tris, nt * 12, h);
    free(pos);
    free(nrm);
    free(tris);
    tsk_patch_destroy(p);
    tsk_set_threads(0);
    return h;
}

TEST(test_patch_mesh_identical_bytes_1_and_2_threads) {
    const uint64_t a = patch_digest(1, 17), b = patch_digest(2, 17);
    CHECK(a == b);
    CHECK(patch_digest(2, 18) != a);
}

TEST(test_realised_tile_expands_to_the_patch_mesh_moved_to_the_tile) {
    /* two routes to the same geometry: the patch mesh (tile-local) moved to tile t's corner,
     * and the tile's realised rest skeletons expanded by tsk_blades_expand */
    enum { P = 1024, K = 16 };
    tsk_patch* p = make_patch(41, P);
    tsk_meadow_def d = tsk_default_meadow_def();
    d.size[0] = 5.0f;
    d.size[1] = 3.0f;
    d.patch_blades = P;
    d.seed = 2;
    tsk_meadow* m = make_meadow(&d);
    const size_t nv = (size_t)P * 2 * K;
    float* mesh = malloc(nv * 3 * sizeof(float));
    float* mesh_n = malloc(nv * 3 * sizeof(float));
    CHECK(tsk_patch_expand(p, d.tile_size, mesh, mesh_n, NULL, NULL, NULL) == TSK_OK);
    const int64_t t = 17; /* tile (7, 1) */
    int64_t n = 0;
    CHECK(tsk_meadow_blade_count(m, t, t + 1, &n) == TSK_OK);
    CHECK(n > 0);
    float* knots = malloc((size_t)n * 3 * K * sizeof(float));
    float* widths = malloc((size_t)n * K * sizeof(float));
    float* sides = malloc((size_t)n * 3 * sizeof(float));
    int32_t* idx = malloc((size_t)n * sizeof(int32_t));
    float* pos = malloc((size_t)n * 6 * K * sizeof(float));
    float* nrm = malloc((size_t)n * 6 * K * sizeof(float));
    CHECK(tsk_meadow_realise_knots(m, p, t, t + 1, knots, widths, sides) == TSK_OK);
    CHECK(tsk_meadow_realise(m, p, t, t + 1, NULL, NULL, NULL, idx) == TSK_OK);
    CHECK(tsk_blades_expand(knots, widths, sides, (size_t)n, K, pos, nrm, NULL) == TSK_OK);
    const float cx = 7 * d.tile_size, cy = 1 * d.tile_size;
    double worst = 0, worst_n = 0;
    for (int64_t b = 0; b < n; ++b)
        for (int v = 0; v < 2 * K; ++v) {
            const float* a = &pos[3 * (2 * K * b + v)];
            const float* e = &mesh[3 * (2 * K * (size_t)idx[b] + v)];
            worst = fmax(worst,
                         fabs(a[0] - (e[0] + cx)) + fabs(a[1] - (e[1] + cy)) + fabs(a[2] - e[2]));
            const float* an = &nrm[3 * (2 * K * b + v)];
            const float* en = &mesh_n[3 * (2 * K * (size_t)idx[b] + v)];
            worst_n =
                fmax(worst_n, fabs(an[0] - en[0]) + fabs(an[1] - en[1]) + fabs(an[2] - en[2]));
        }
    CHECK_MSG(worst < 1e-5, "position difference %g m", worst);
    CHECK_MSG(worst_n < 1e-3, "normal difference %g", worst_n);
    sides[0] = NAN;
    CHECK_STATUS(tsk_blades_expand(knots, widths, sides, (size_t)n, K, pos, NULL, NULL),
                 TSK_ERR_ARGUMENT, "sides");
    free(mesh);
    free(mesh_n);
    free(knots);
    free(widths);
    free(sides);
    free(idx);
    free(pos);
    free(nrm);
    tsk_meadow_destroy(m);
    tsk_patch_destroy(p);
}

/* tsk_blades_expand checks every blade before writing anything (in parallel) and reports
 * the first bad blade in blade order, whichever input of it is bad. */
TEST(test_blades_expand_reports_first_bad_blade_and_writes_nothing) {
    enum { N = 1000, K = 6 };
    float* knots = malloc(sizeof(float) * N * K * 3);
    float* widths = malloc(sizeof(float) * N * K);
    float* sides = malloc(sizeof(float) * N * 3);
    float* pos = malloc(sizeof(float) * N * K * 6);
    for (int b = 0; b < N; ++b) {
        for (int k = 0; k < K; ++k) {
            knots[3 * (b * K + k)] = (float)b, knots[3 * (b * K + k) + 1] = 0.0f;
            knots[3 * (b * K + k) + 2] = 0.05f * (float)k;
            widths[b * K + k] = 0.01f;
        }
        sides[3 * b] = 0.0f, sides[3 * b + 1] = 1.0f, sides[3 * b + 2] = 0.0f;
    }
    CHECK(tsk_blades_expand(knots, widths, sides, N, K, pos, NULL, NULL) == TSK_OK);
    CHECK(pos[6 * K * 999 + 1] == -0.005f && pos[6 * K * 999 + 4] == 0.005f);
    knots[3 * (700 * K + 2) + 1] = NAN; /* a later blade's knot */
    widths[300 * K + 4] = -1.0f; /* an earlier blade's width */
    for (int i = 0; i < N * K * 6; ++i) pos[i] = 7.0f;
    CHECK_STATUS(tsk_blades_expand(knots, widths, sides, N, K, pos, NULL, NULL), TSK_ERR_ARGUMENT,
                 "width 4 of blade 300");
    int untouched = 1;
    for (int i = 0; i < N * K * 6; ++i) untouched &= pos[i] == 7.0f;
    CHECK(untouched);
    widths[300 * K + 4] = 0.01f;
    CHECK_STATUS(tsk_blades_expand(knots, widths, sides, N, K, pos, NULL, NULL), TSK_ERR_ARGUMENT,
                 "knot 2 of blade 700");
    knots[3 * (700 * K + 2) + 1] = 0.0f;
    /* each kind of bad value alone, wherever it sits in a chunk of the parallel check */
    const int at[4] = {0, 255, 256, 999};
    for (int i = 0; i < 4; ++i) {
        const int b = at[i];
        char want[64];
        knots[3 * (b * K + K - 1) + 2] = -INFINITY;
        snprintf(want, sizeof want, "knot %d of blade %d ", K - 1, b);
        CHECK_STATUS(tsk_blades_expand(knots, widths, sides, N, K, pos, NULL, NULL),
                     TSK_ERR_ARGUMENT, want);
        knots[3 * (b * K + K - 1) + 2] = 0.05f * (K - 1);
        widths[b * K] = NAN;
        snprintf(want, sizeof want, "width 0 of blade %d ", b);
        CHECK_STATUS(tsk_blades_expand(knots, widths, sides, N, K, pos, NULL, NULL),
                     TSK_ERR_ARGUMENT, want);
        widths[b * K] = 0.0f; /* a zero width is fine */
        sides[3 * b + 1] = 0.0f;
        snprintf(want, sizeof want, "side of blade %d ", b);
        CHECK_STATUS(tsk_blades_expand(knots, widths, sides, N, K, pos, NULL, NULL),
                     TSK_ERR_ARGUMENT, want);
        sides[3 * b + 1] = INFINITY;
        CHECK_STATUS(tsk_blades_expand(knots, widths, sides, N, K, pos, NULL, NULL),
                     TSK_ERR_ARGUMENT, want);
        sides[3 * b + 1] = 1.0f;
        CHECK(tsk_blades_expand(knots, widths, sides, N, K, pos, NULL, NULL) == TSK_OK);
    }
    free(knots), free(widths), free(sides), free(pos);
}

TEST(test_models_from_flat_arrays_split_by_knot_counts) {
    const float xyz[3 * 5] = {1, 1, 0, 1, 1, 0.1f, /* model 0: 2 knots, root moved to 0 */
                              0, 0, 0, 0, 0, 0.2f, 0.1f, 0, 0.3f};
    const float w[5] = {0.01f, 0.0f, 0.02f, 0.01f, 0.0f};
    const int32_t counts[2] = {2, 3};
    tsk_blade_model ms[2];
    CHECK(tsk_blade_models_set(ms, 2, xyz, w, counts, 5) == TSK_OK);
    CHECK(ms[0].knot_count == 2 && ms[1].knot_count == 3);
    CHECK_NEAR(ms[0].xyz[5], 0.1, 1e-7);
    CHECK(ms[0].xyz[3] == 0.0f);
    CHECK(ms[1].width[1] == 0.01f);
    CHECK_STATUS(tsk_blade_models_set(ms, 2, xyz, w, counts, 6), TSK_ERR_ARGUMENT, "knot_counts");
    const int32_t too_many[2] = {2, 4};
    CHECK_STATUS(tsk_blade_models_set(ms, 2, xyz, w, too_many, 5), TSK_ERR_ARGUMENT, "knot_counts");
    const int32_t one[2] = {1, 4};
    CHECK_STATUS(tsk_blade_models_set(ms, 2, xyz, w, one, 5), TSK_ERR_ARGUMENT, "model 0");
}

/* ---- bad meadow inputs ----------------------------------------------------------------------- */

TEST(test_meadow_rejects_bad_input_with_messages) {
    tsk_meadow* m = (tsk_meadow*)1;
    tsk_meadow_def d = tsk_default_meadow_def();
#define BAD(field, value, status, needle)                        \
    do {                                                         \
        d = tsk_default_meadow_def();                            \
        d.field = value;                                         \
        CHECK_STATUS(tsk_meadow_create(&d, &m), status, needle); \
        CHECK(m == NULL);                                        \
    } while (0)
    BAD(size[0], 0.0f, TSK_ERR_ARGUMENT, "size.x");
    BAD(size[1], -3.0f, TSK_ERR_ARGUMENT, "size.y");
    BAD(size[0], NAN, TSK_ERR_ARGUMENT, "size.x");
    BAD(origin[2], INFINITY, TSK_ERR_ARGUMENT, "origin.z");
    BAD(tile_size, 0.0f, TSK_ERR_ARGUMENT, "tile_size");
    BAD(tile_size, NAN, TSK_ERR_ARGUMENT, "tile_size");
    BAD(tile_size, 11.0f, TSK_ERR_ARGUMENT, "larger than the meadow");
    BAD(blades_per_tile, 0, TSK_ERR_ARGUMENT, "blades_per_tile");
    BAD(blades_per_tile, -5, TSK_ERR_ARGUMENT, "blades_per_tile");
    BAD(blades_per_tile, 20000, TSK_ERR_ARGUMENT, "blades_per_tile"); /* > patch */
    BAD(blades_per_tile, 1 << 20, TSK_ERR_LIMIT, "blades_per_tile");
    BAD(patch_blades, TSK_PATCH_MAX_BLADES * 2, TSK_ERR_LIMIT, "patch_blades");
    BAD(patch_blades, 0, TSK_ERR_ARGUMENT, "patch_blades");
    BAD(chunk_blades, 3, TSK_ERR_ARGUMENT, "chunk_blades"); /* does not divide 16384 */
    BAD(chunk_blades, 128, TSK_ERR_ARGUMENT, "chunk_blades"); /* > blades_per_tile */
    BAD(noise_scale, -1.0f, TSK_ERR_ARGUMENT, "noise_scale");
    BAD(noise_octaves, 0, TSK_ERR_ARGUMENT, "noise_octaves");
    BAD(noise_threshold, 1.0f, TSK_ERR_ARGUMENT, "noise_threshold");
    BAD(noise_contrast, -1.0f, TSK_ERR_ARGUMENT, "noise_contrast");
    BAD(noise_persistence, NAN, TSK_ERR_ARGUMENT, "noise_persistence");
    BAD(density, (tsk_density_kind)7, TSK_ERR_ARGUMENT, "density");
    BAD(size[0], 1e9f, TSK_ERR_LIMIT, "size.x");
    /* absurd counts: 20 km x 20 km of 0.5 m tiles = 1.6e9 tiles */
    d = tsk_default_meadow_def();
    d.size[0] = d.size[1] = 20000.0f;
    CHECK_STATUS(tsk_meadow_create(&d, &m), TSK_ERR_LIMIT, "limit");
    /* 4000 x 4000 m of 1 m tiles (16 M tiles, allowed) x 64 blades = 1e9 blades > 200 M */
    d.size[0] = d.size[1] = 4000.0f;
    d.tile_size = 1.0f;
    CHECK_STATUS(tsk_meadow_create(&d, &m), TSK_ERR_LIMIT, "200000000");
    /* images */
    d = tsk_default_meadow_def();
    d.density = TSK_DENSITY_IMAGE;
    CHECK_STATUS(tsk_meadow_create(&d, &m), TSK_ERR_ARGUMENT, "image");
    float img[4] = {0, 1, NAN, 0};
    d.image = img;
    d.image_width = 2;
    d.image_height = 2;
    CHECK_STATUS(tsk_meadow_create(&d, &m), TSK_ERR_ARGUMENT, "pixel 2");
    d.image_width = 100000;
    CHECK_STATUS(tsk_meadow_create(&d, &m), TSK_ERR_LIMIT, "image");
    CHECK_STATUS(tsk_meadow_create(NULL, &m), TSK_ERR_ARGUMENT, "def");
#undef BAD
    /* realise: mismatched patch and out-of-range tiles */
    d = tsk_default_meadow_def();
    m = make_meadow(&d);
    tsk_patch* p = make_patch(1, 1000);
    float xyz[3];
    CHECK_STATUS(tsk_meadow_realise(m, p, 0, 1, xyz, NULL, NULL, NULL), TSK_ERR_ARGUMENT, "patch");
    tsk_patch_destroy(p);
    p = make_patch(1, 16384);
    CHECK_STATUS(tsk_meadow_realise(m, p, 5, 2, xyz, NULL, NULL, NULL), TSK_ERR_ARGUMENT, "tile");
    CHECK_STATUS(tsk_meadow_realise(m, p, 0, 1000000, xyz, NULL, NULL, NULL), TSK_ERR_ARGUMENT,
                 "tile");
    int64_t n;
    CHECK_STATUS(tsk_meadow_blade_count(m, -1, 3, &n), TSK_ERR_ARGUMENT, "tile");
    CHECK_STATUS(tsk_patch_expand(p, NAN, xyz, NULL, NULL, NULL, NULL), TSK_ERR_ARGUMENT,
                 "tile_size");
    tsk_patch_destroy(p);
    tsk_meadow_destroy(m);
}

TEST(test_meadow_and_patch_release_their_memory) {
    const size_t before = tsk_allocated_bytes();
    tsk_patch* p = make_patch(2, 16384);
    tsk_meadow_def d = tsk_default_meadow_def();
    tsk_meadow* m = make_meadow(&d);
    CHECK(tsk_allocated_bytes() > before + 16384 * 20);
    tsk_meadow_destroy(m);
    tsk_patch_destroy(p);
    CHECK(tsk_allocated_bytes() == before);
}

TEST(test_ten_million_blade_meadow_lays_out) {
    /* the headline size: ~10 M blades at 64 per 0.5 m tile -> 400 x 400 m, 640,000 tiles */
    tsk_meadow_def d = tsk_default_meadow_def();
    d.density = TSK_DENSITY_UNIFORM;
#ifdef TSK_SLOW_CHECKS
    d.size[0] = d.size[1] = 100.0f;
#else
    d.size[0] = d.size[1] = 400.0f;
#endif
    d.blades_per_tile = 64;
    tsk_meadow* m = make_meadow(&d);
    tsk_meadow_info info;
    CHECK(tsk_meadow_get_info(m, &info) == TSK_OK);
    CHECK(info.blade_count == info.tile_count * 64);
    CHECK(info.tile_count == (int64_t)(d.size[0] / 0.5f) * (int64_t)(d.size[1] / 0.5f));
    int64_t n = 0;
    CHECK(tsk_meadow_blade_count(m, 0, info.tile_count, &n) == TSK_OK);
    CHECK(n == info.blade_count);
    tsk_meadow_destroy(m);
}

/* A meadow whose tiles and instances (20 + 20 * blades_per_tile / chunk bytes per tile)
 * exceed the memory budget is refused before allocation; the same def fits the default. */
TEST(test_meadow_and_patch_over_memory_budget_are_refused) {
    tsk_meadow_def d = tsk_default_meadow_def();
    d.size[0] = d.size[1] = 100.0f;
    d.tile_size = 0.5f; /* 40000 tiles x 64 blades x 20 B = 51 MB of instances */
    d.blades_per_tile = 64;
    d.chunk_blades = 1;
    d.density = TSK_DENSITY_UNIFORM;
    tsk_set_memory_budget((uint64_t)16 << 20);
    tsk_meadow* m = NULL;
    CHECK_STATUS(tsk_meadow_create(&d, &m), TSK_ERR_LIMIT, "meadow: needs about");
    CHECK(m == NULL);
    tsk_patch_def pd = tsk_default_patch_def(); /* 16384 blades x 32 vertices: > 16 MiB */
    tsk_patch* p = NULL;
    CHECK_STATUS(tsk_patch_create(&pd, &p), TSK_ERR_LIMIT, "blade_count: needs about");
    CHECK(p == NULL);
    tsk_set_memory_budget(0);
    CHECK(tsk_meadow_create(&d, &m) == TSK_OK);
    tsk_meadow_destroy(m);
    CHECK(tsk_allocated_bytes() == 0);
}

TEST_MAIN(TEST_ENTRY(test_meadow_and_patch_over_memory_budget_are_refused),
          TEST_ENTRY(test_default_blade_matches_documented_formula),
          TEST_ENTRY(test_blade_model_set_moves_root_to_origin),
          TEST_ENTRY(test_blade_model_rejects_bad_input),
          TEST_ENTRY(test_resample_spaces_knots_evenly_on_the_polyline),
          TEST_ENTRY(test_patch_defaults_follow_seed),
          TEST_ENTRY(test_patch_values_in_range_and_uniform),
          TEST_ENTRY(test_patch_same_seed_same_bytes_other_seed_differs),
          TEST_ENTRY(test_patch_blade_values_are_keyed_by_seed_and_blade),
          TEST_ENTRY(test_patch_model_choice_follows_weights),
          TEST_ENTRY(test_patch_rejects_bad_input),
          TEST_ENTRY(test_noise_matches_textbook_reference),
          TEST_ENTRY(test_noise_in_range_zero_at_lattice_and_continuous),
          TEST_ENTRY(test_meadow_count_matches_density_map),
          TEST_ENTRY(test_meadow_uniform_count_is_tiles_times_blades),
          TEST_ENTRY(test_meadow_image_density_is_bilinear_at_tile_centres),
          TEST_ENTRY(test_tile_offsets_follow_hash_of_tile_coordinates),
          TEST_ENTRY(test_tiles_identical_across_runs_and_threads),
          TEST_ENTRY(test_tile_runs_are_contiguous_and_wrap_at_patch_end),
          TEST_ENTRY(test_chunk_instances_reproduce_the_realised_meadow),
          TEST_ENTRY(test_realised_knots_are_the_turned_scaled_model),
          TEST_ENTRY(test_realise_identical_bytes_1_and_2_threads),
          TEST_ENTRY(test_expansion_widths_equal_model_widths_times_scale),
          TEST_ENTRY(test_blade_expand_straight_blade_closed_form),
          TEST_ENTRY(test_blades_expand_follows_the_ribbon_definition),
          TEST_ENTRY(test_patch_mesh_identical_bytes_1_and_2_threads),
          TEST_ENTRY(test_realised_tile_expands_to_the_patch_mesh_moved_to_the_tile),
          TEST_ENTRY(test_blades_expand_reports_first_bad_blade_and_writes_nothing),
          TEST_ENTRY(test_models_from_flat_arrays_split_by_knot_counts),
          TEST_ENTRY(test_meadow_rejects_bad_input_with_messages),
          TEST_ENTRY(test_meadow_and_patch_release_their_memory),
          TEST_ENTRY(test_ten_million_blade_meadow_lays_out))
