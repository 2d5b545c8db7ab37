/* Tests of skeleton refining (seed 000 §4.4): eq. 1-3 against closed forms, Algorithm 1's
 * heap version against the naive O(K^2 F) reference kept here, the merging rules, thread
 * independence, bad input, tracking, resampling, and the bending model against the
 * Euler-Bernoulli cantilever. */
#include "test.h"
#include "tussock/core.h"
#include "tussock/refine.h"

#include <stdint.h>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TSK_TEST_SLOW 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define TSK_TEST_SLOW 1
#endif
#ifndef TSK_TEST_SLOW
#define TSK_TEST_SLOW 0
#endif

/* ---- a random blade ---------------------------------------------------------------------- */

typedef struct blade {
    size_t k, f;
    float* knots;
    float* widths;
    float* traj; /* [f][k][3] */
} blade;

static void blade_free(blade* b) {
    free(b->knots);
    free(b->widths);
    free(b->traj);
}

/* A wandering blade rising along z with random segment lengths and widths, moving by
 * smooth per-knot sways plus random jitter (all from tsk_rand01, keyed by seed). */
static blade random_blade(uint64_t seed, size_t k, size_t f) {
    blade b = {k, f, malloc(k * 3 * sizeof(float)), malloc(k * sizeof(float)),
               malloc(k * f * 3 * sizeof(float))};
    double x = 0, y = 0, z = 0, ax = 0, ay = 0;
    for (size_t j = 0; j < k; ++j) {
        if (j > 0) {
            double step = 0.002 * (0.5 + tsk_rand01(seed, 1, j, 0));
            ax += 0.3 * (tsk_rand01(seed, 2, j, 0) - 0.5);
            ay += 0.3 * (tsk_rand01(seed, 3, j, 0) - 0.5);
            x += step * sin(ax);
            y += step * sin(ay);
            z += step * cos(ax) * cos(ay);
        }
        b.knots[3 * j] = (float)x, b.knots[3 * j + 1] = (float)y, b.knots[3 * j + 2] = (float)z;
        b.widths[j] = 0.001f + 0.009f * tsk_rand01(seed, 4, j, 0);
    }
    for (size_t fr = 0; fr < f; ++fr)
        for (size_t j = 0; j < k; ++j) {
            double s = (double)j / (double)k;
            for (int c = 0; c < 3; ++c) {
                double sway = 0.01 * s * s * sin(0.7 * (double)fr + 2.0 * c + 3.0 * s);
                double jit = 0.0005 * (tsk_rand01(seed, 5 + c, j, fr) - 0.5);
                b.traj[(fr * k + j) * 3 + c] = (float)(b.knots[3 * j + c] + sway + jit);
            }
        }
    return b;
}

typedef struct outbuf {
    float knots[64 * 3];
    float widths[64];
    int32_t ranges[128];
    float* traj;
} outbuf;

static tsk_refine_input as_input(const blade* b) {
    tsk_refine_input in = {b->knots, b->widths, b->traj, b->k, b->f};
    return in;
}

static tsk_refine_output as_output(outbuf* o) {
    tsk_refine_output out = {o->knots, o->widths, o->ranges, o->traj};
    return out;
}

/* ---- the naive reference: Algorithm 1 as listed, O(K^2 F) -------------------------------- */

typedef struct naive_knot {
    float rest[3];
    float* traj; /* [f][3] */
    double wl, l;
    int32_t first, count;
} naive_knot;

static void naive_refine(int m, float mu, const blade* b, float* out_knots, float* out_widths,
                         int32_t* out_ranges, float* out_traj) {
    const size_t k = b->k, f = b->f;
    naive_knot* v = calloc(k, sizeof *v);
    double total = 0.0;
    for (size_t j = 0; j < k; ++j) v[j].l = 0.0;
    for (size_t j = 0; j + 1 < k; ++j) {
        const float* p = b->knots + 3 * j;
        const double dx = (double)p[3] - (double)p[0], dy = (double)p[4] - (double)p[1],
                     dz = (double)p[5] - (double)p[2];
        const double seg = sqrt(dx * dx + dy * dy + dz * dz);
        total += seg;
        v[j].l += 0.5 * seg;
        v[j + 1].l += 0.5 * seg;
    }
    const double inv_length = 1.0 / total;
    for (size_t j = 0; j < k; ++j) {
        memcpy(v[j].rest, b->knots + 3 * j, sizeof v[j].rest);
        v[j].traj = malloc(f * 3 * sizeof(float));
        for (size_t fr = 0; fr < f; ++fr)
            memcpy(v[j].traj + 3 * fr, b->traj + (fr * k + j) * 3, 3 * sizeof(float));
        v[j].wl = v[j].l * (double)b->widths[j];
        v[j].first = (int32_t)j;
        v[j].count = 1;
    }
    size_t n = k;
    while (n > (size_t)m) {
        size_t best = 0;
        double best_d = tsk_refine_difference(mu, v[0].traj, v[1].traj, f, inv_length);
        for (size_t i = 1; i + 1 < n; ++i) {
            double d = tsk_refine_difference(mu, v[i].traj, v[i + 1].traj, f, inv_length);
            if (d < best_d) best_d = d, best = i;
        }
        naive_knot* a = &v[best];
        naive_knot* c = &v[best + 1];
        if (best == 0) {
            /* root stays */
        } else if (best + 1 == n - 1) {
            memcpy(a->traj, c->traj, f * 3 * sizeof(float));
            memcpy(a->rest, c->rest, sizeof a->rest);
        } else {
            for (size_t q = 0; q < 3 * f; ++q) a->traj[q] = 0.5f * a->traj[q] + 0.5f * c->traj[q];
            for (int q = 0; q < 3; ++q) a->rest[q] = 0.5f * a->rest[q] + 0.5f * c->rest[q];
        }
        a->wl += c->wl;
        a->l += c->l;
        a->count += c->count;
        free(c->traj);
        memmove(&v[best + 1], &v[best + 2], (n - best - 2) * sizeof *v);
        --n;
    }
    for (size_t o = 0; o < n; ++o) {
        memcpy(out_knots + 3 * o, v[o].rest, 3 * sizeof(float));
        out_widths[o] = (float)(v[o].wl / v[o].l);
        out_ranges[2 * o] = v[o].first;
        out_ranges[2 * o + 1] = v[o].count;
        for (size_t fr = 0; fr < f; ++fr)
            memcpy(out_traj + (fr * n + o) * 3, v[o].traj + 3 * fr, 3 * sizeof(float));
        free(v[o].traj);
    }
    free(v);
}

/* ---- eq. 1-3 -------------------------------------------------------------------------------- */

TEST(test_refine_difference_matches_closed_form) {
    /* d_i = i + 1 for i = 0..n-1: mean (n+1)/2, variance (n^2 - 1)/12 */
    enum { N = 9 };
    float a[3 * N], b[3 * N];
    for (int i = 0; i < N; ++i) {
        a[3 * i] = 0.0f, a[3 * i + 1] = 1.0f, a[3 * i + 2] = 2.0f;
        b[3 * i] = 0.6f * (float)(i + 1), b[3 * i + 1] = 1.0f + 0.8f * (float)(i + 1);
        b[3 * i + 2] = 2.0f;
    }
    const double dis = (N + 1) / 2.0, var = (N * N - 1) / 12.0;
    for (int q = 0; q <= 4; ++q) {
        float mu = 0.25f * (float)q;
        CHECK_NEAR(tsk_refine_difference(mu, a, b, N, 1.0), mu * dis + (1 - mu) * var, 1e-5);
    }
    /* inv_length scales d: dis by s, variance by s^2 */
    CHECK_NEAR(tsk_refine_difference(0.0f, a, b, N, 0.5), 0.25 * var, 1e-6);
    CHECK_NEAR(tsk_refine_difference(1.0f, a, b, N, 0.5), 0.5 * dis, 1e-6);
    /* a constant distance has zero variance: mu = 0 gives 0 */
    CHECK_NEAR(tsk_refine_difference(0.0f, a, a + 0, 1, 1.0), 0.0, 0.0);
    CHECK(isnan(tsk_refine_difference(0.5f, a, b, 0, 1.0)));
}

/* ---- Algorithm 1: properties ---------------------------------------------------------------- */

TEST(test_refine_keeps_root_and_tip) {
    for (uint64_t seed = 1; seed <= 6; ++seed) {
        size_t k = 20 + 37 * seed, f = 5;
        blade b = random_blade(seed, k, f);
        for (int m = 2; m <= 64 && (size_t)m <= k; m += 7) {
            outbuf o;
            o.traj = malloc(f * (size_t)m * 3 * sizeof(float));
            tsk_refine_def def = tsk_default_refine_def();
            def.target_knots = m;
            def.mu = 0.2f * (float)(seed % 5);
            tsk_refine_input in = as_input(&b);
            tsk_refine_output out = as_output(&o);
            CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
            CHECK(memcmp(o.knots, b.knots, 3 * sizeof(float)) == 0);
            CHECK(memcmp(o.knots + 3 * (m - 1), b.knots + 3 * (k - 1), 3 * sizeof(float)) == 0);
            for (size_t fr = 0; fr < f; ++fr) {
                CHECK(memcmp(o.traj + fr * m * 3, b.traj + fr * k * 3, 12) == 0);
                CHECK(memcmp(o.traj + (fr * m + m - 1) * 3, b.traj + (fr * k + k - 1) * 3, 12) ==
                      0);
            }
            free(o.traj);
        }
        blade_free(&b);
    }
}

TEST(test_refine_exact_count_and_ranges_partition_blade) {
    blade b = random_blade(77, 150, 4);
    for (int m = 2; m <= 64; ++m) {
        outbuf o = {.traj = NULL};
        for (int i = 0; i < 128; ++i) o.ranges[i] = -7; /* poison beyond m */
        tsk_refine_def def = {m, 0.5f};
        tsk_refine_input in = as_input(&b);
        tsk_refine_output out = as_output(&o);
        CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
        int32_t next = 0;
        int ok = 1;
        for (int q = 0; q < m; ++q) {
            ok &= o.ranges[2 * q] == next && o.ranges[2 * q + 1] >= 1;
            next += o.ranges[2 * q + 1];
            /* a merged knot is a convex combination of its sources: inside their box */
            for (int c = 0; c < 3; ++c) {
                float lo = INFINITY, hi = -INFINITY;
                for (int32_t j = o.ranges[2 * q]; j < o.ranges[2 * q] + o.ranges[2 * q + 1]; ++j) {
                    lo = fminf(lo, b.knots[3 * j + c]);
                    hi = fmaxf(hi, b.knots[3 * j + c]);
                }
                ok &= o.knots[3 * q + c] >= lo && o.knots[3 * q + c] <= hi;
            }
        }
        CHECK_MSG(ok && next == 150, "m = %d: ranges do not partition 0..149 in order", m);
        if (m < 64) CHECK(o.ranges[2 * m] == -7); /* nothing written past m knots */
    }
    blade_free(&b);
}

TEST(test_refine_widths_positive_and_length_weighted) {
    blade b = random_blade(5, 200, 6);
    /* the arc length each source knot owns, computed here independently */
    double l[200] = {0};
    for (int j = 0; j + 1 < 200; ++j) {
        double dx = b.knots[3 * j + 3] - b.knots[3 * j],
               dy = b.knots[3 * j + 4] - b.knots[3 * j + 1],
               dz = b.knots[3 * j + 5] - b.knots[3 * j + 2];
        double seg = sqrt(dx * dx + dy * dy + dz * dz);
        l[j] += seg / 2, l[j + 1] += seg / 2;
    }
    for (int m = 2; m <= 64; m *= 2) {
        outbuf o = {.traj = NULL};
        tsk_refine_def def = {m, 0.7f};
        tsk_refine_input in = as_input(&b);
        tsk_refine_output out = as_output(&o);
        CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
        for (int q = 0; q < m; ++q) {
            double wl = 0, ll = 0;
            for (int32_t j = o.ranges[2 * q]; j < o.ranges[2 * q] + o.ranges[2 * q + 1]; ++j)
                wl += l[j] * b.widths[j], ll += l[j];
            CHECK(o.widths[q] > 0.0f);
            CHECK_NEAR(o.widths[q], wl / ll, 1e-6 * wl / ll);
        }
    }
    blade_free(&b);
}

TEST(test_refine_ties_go_to_root_side_and_root_absorbs) {
    /* integer spacing, no movement: every D is the same, so the first pair (root) merges */
    float knots[15], widths[5] = {1, 2, 3, 4, 5}, traj[15];
    for (int j = 0; j < 5; ++j) {
        knots[3 * j] = 0, knots[3 * j + 1] = 0, knots[3 * j + 2] = (float)j;
    }
    memcpy(traj, knots, sizeof traj);
    tsk_refine_input in = {knots, widths, traj, 5, 1};
    outbuf o = {.traj = NULL};
    tsk_refine_output out = as_output(&o);
    tsk_refine_def def = {4, 1.0f};
    CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
    int32_t want4[8] = {0, 2, 2, 1, 3, 1, 4, 1};
    CHECK(memcmp(o.ranges, want4, sizeof want4) == 0);
    CHECK(o.knots[2] == 0.0f); /* merged into the root */
    CHECK_NEAR(o.widths[0], (0.5 * 1 + 1 * 2) / 1.5, 1e-6); /* l = 1/2, 1 */
    /* m = 3: now D(root, 2) = 2 > D(2, 3) = 1 = D(3, 4); the tie goes to (2, 3) */
    def.target_knots = 3;
    CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
    int32_t want3[6] = {0, 2, 2, 2, 4, 1};
    CHECK(memcmp(o.ranges, want3, sizeof want3) == 0);
    CHECK_NEAR(o.knots[5], 2.5, 0.0); /* midpoint */
}

TEST(test_refine_mu_one_merges_closest_pair_and_tip_absorbs) {
    float z[6] = {0, 1, 2, 2.25f, 3, 4};
    float knots[18], widths[6] = {1, 1, 1, 1, 1, 1}, traj[18];
    for (int j = 0; j < 6; ++j) knots[3 * j] = 1, knots[3 * j + 1] = 2, knots[3 * j + 2] = z[j];
    memcpy(traj, knots, sizeof traj);
    tsk_refine_input in = {knots, widths, traj, 6, 1};
    outbuf o = {.traj = NULL};
    tsk_refine_output out = as_output(&o);
    tsk_refine_def def = {5, 1.0f};
    CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
    CHECK(o.ranges[4] == 2 && o.ranges[5] == 2);
    CHECK_NEAR(o.knots[3 * 2 + 2], 2.125, 0.0);
    CHECK_NEAR(o.knots[3 * 2], 1.0, 0.0);
    /* a short last segment merges into the tip, which stays put */
    float z2[4] = {0, 1, 2, 2.1f};
    for (int j = 0; j < 4; ++j) knots[3 * j + 2] = z2[j];
    memcpy(traj, knots, sizeof traj);
    tsk_refine_input in2 = {knots, widths, traj, 4, 1};
    def.target_knots = 3;
    CHECK(tsk_refine_blade(&def, &in2, &out) == TSK_OK);
    CHECK(o.ranges[4] == 2 && o.ranges[5] == 2);
    CHECK(o.knots[3 * 2 + 2] == 2.1f);
}

TEST(test_refine_variance_keeps_knots_that_move_differently) {
    /* evenly spaced knots; the pair (3,4) changes its distance over time, the others keep it.
     * With mu = 0 the variance decides: the stiff pairs merge first and (3,4) never. */
    enum { K = 8, F = 4 };
    float knots[3 * K], widths[K], traj[F * K * 3];
    for (int j = 0; j < K; ++j) {
        knots[3 * j] = 0, knots[3 * j + 1] = 0, knots[3 * j + 2] = (float)j;
        widths[j] = 1;
    }
    for (int fr = 0; fr < F; ++fr)
        for (int j = 0; j < K; ++j) {
            float stretch = j >= 4 ? 0.25f * (float)(fr % 2) : 0.0f;
            traj[(fr * K + j) * 3] = 0, traj[(fr * K + j) * 3 + 1] = 0;
            traj[(fr * K + j) * 3 + 2] = (float)j + stretch;
        }
    tsk_refine_input in = {knots, widths, traj, K, F};
    outbuf o = {.traj = NULL};
    tsk_refine_output out = as_output(&o);
    tsk_refine_def def = {4, 0.0f};
    CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
    /* the boundary between source knots 3 and 4 survives: some range ends at 3 */
    int split = 0;
    for (int q = 0; q < 4; ++q) split |= o.ranges[2 * q] + o.ranges[2 * q + 1] == 4;
    CHECK(split);
}

TEST(test_refine_heap_matches_naive_bitwise) {
    static const size_t sizes[] = {2, 3, 4, 5, 8, 17, 33, 64, 65, 100, 128, 200, 256};
    static const size_t frames[] = {1, 3, 16};
    static const float mus[] = {0.0f, 0.5f, 1.0f, 0.03f};
    int cases = 0, mismatches = 0;
    const int mstep = TSK_TEST_SLOW ? 9 : 3;
    for (size_t si = 0; si < sizeof sizes / sizeof sizes[0]; ++si)
        for (size_t fi = 0; fi < 3; ++fi)
            for (size_t mi = 0; mi < 4; ++mi) {
                const size_t k = sizes[si], f = frames[fi];
                blade b = random_blade(1000 + si * 10 + fi, k, f);
                for (int m = 2; m <= 64 && (size_t)m <= k; m += mstep) {
                    outbuf o, r;
                    o.traj = malloc(f * (size_t)m * 3 * sizeof(float));
                    r.traj = malloc(f * (size_t)m * 3 * sizeof(float));
                    tsk_refine_def def = {m, mus[mi]};
                    tsk_refine_input in = as_input(&b);
                    tsk_refine_output out = as_output(&o);
                    CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
                    naive_refine(m, mus[mi], &b, r.knots, r.widths, r.ranges, r.traj);
                    const size_t mm = (size_t)m;
                    int same = memcmp(o.knots, r.knots, mm * 3 * sizeof(float)) == 0 &&
                               memcmp(o.widths, r.widths, mm * sizeof(float)) == 0 &&
                               memcmp(o.ranges, r.ranges, mm * 2 * sizeof(int32_t)) == 0 &&
                               memcmp(o.traj, r.traj, f * mm * 3 * sizeof(float)) == 0;
                    if (!same) {
                        if (mismatches < 5)
                            fprintf(stderr, "  mismatch k=%zu f=%zu mu=%g m=%d\n", k, f,
                                    (double)mus[mi], m);
                        ++mismatches;
                    }
                    ++cases;
                    free(o.traj);
                    free(r.traj);
                }
                blade_free(&b);
            }
    /* and blades full of exact ties: integer spacing, no movement */
    for (size_t k = 2; k <= 90; k += 11) {
        blade b = random_blade(1, k, 2);
        for (size_t j = 0; j < k; ++j) {
            b.knots[3 * j] = 0, b.knots[3 * j + 1] = 0, b.knots[3 * j + 2] = (float)j;
            for (size_t fr = 0; fr < 2; ++fr)
                memcpy(b.traj + (fr * k + j) * 3, b.knots + 3 * j, 12);
        }
        for (int m = 2; m <= 64 && (size_t)m <= k; m += 5) {
            outbuf o, r;
            o.traj = malloc(2 * (size_t)m * 3 * sizeof(float));
            r.traj = malloc(2 * (size_t)m * 3 * sizeof(float));
            tsk_refine_def def = {m, 0.5f};
            tsk_refine_input in = as_input(&b);
            tsk_refine_output out = as_output(&o);
            CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
            naive_refine(m, 0.5f, &b, r.knots, r.widths, r.ranges, r.traj);
            const size_t mm = (size_t)m;
            if (memcmp(o.ranges, r.ranges, mm * 8) != 0 || memcmp(o.knots, r.knots, mm * 12) != 0 ||
                memcmp(o.widths, r.widths, mm * 4) != 0 || memcmp(o.traj, r.traj, mm * 24) != 0) {
                if (mismatches < 5) fprintf(stderr, "  tie mismatch k=%zu m=%d\n", k, m);
                ++mismatches;
            }
            ++cases;
            free(o.traj);
            free(r.traj);
        }
        blade_free(&b);
    }
    CHECK_MSG(mismatches == 0, "%d of %d cases differ", mismatches, cases);
    CHECK(cases > 300);
}

TEST(test_refine_is_scale_invariant) {
    /* distances are in blade lengths: scaling by 4 (exact in float) changes nothing */
    blade b = random_blade(9, 120, 8), c = random_blade(9, 120, 8);
    for (size_t q = 0; q < 120 * 3; ++q) c.knots[q] *= 4.0f;
    for (size_t q = 0; q < 120 * 8 * 3; ++q) c.traj[q] *= 4.0f;
    outbuf o1 = {.traj = NULL}, o2 = {.traj = NULL};
    tsk_refine_def def = {16, 0.05f};
    tsk_refine_input i1 = as_input(&b), i2 = as_input(&c);
    tsk_refine_output r1 = as_output(&o1), r2 = as_output(&o2);
    CHECK(tsk_refine_blade(&def, &i1, &r1) == TSK_OK);
    CHECK(tsk_refine_blade(&def, &i2, &r2) == TSK_OK);
    CHECK(memcmp(o1.ranges, o2.ranges, 16 * 2 * sizeof(int32_t)) == 0);
    CHECK_NEAR(o2.knots[3 * 8 + 2], 4.0 * o1.knots[3 * 8 + 2], 1e-6);
    blade_free(&b);
    blade_free(&c);
}

static uint64_t fnv(const void* p, size_t n, uint64_t h) {
    const unsigned char* c = p;
    for (size_t i = 0; i < n; ++i) h = (h ^ c[i]) * 1099511628211ull;
    return h;
}

TEST(test_refine_batch_identical_1_and_2_threads) {
    enum { B = 97, M = 12 };
    const size_t k = 90, f = 6;
    blade bl[8];
    for (int i = 0; i < 8; ++i) bl[i] = random_blade(300 + i, k, f);
    tsk_refine_input in[B];
    tsk_refine_output out[B];
    static float knots[2][B][M * 3], widths[2][B][M], traj[2][B][6 * M * 3];
    static int32_t ranges[2][B][2 * M];
    uint64_t h[2];
    for (int run = 0; run < 2; ++run) {
        CHECK(tsk_set_threads(run + 1) == TSK_OK);
        for (int i = 0; i < B; ++i) {
            in[i] = as_input(&bl[i % 8]);
            out[i] =
                (tsk_refine_output){knots[run][i], widths[run][i], ranges[run][i], traj[run][i]};
        }
        tsk_refine_def def = {M, 0.25f};
        CHECK(tsk_refine_blades(&def, in, out, B) == TSK_OK);
        h[run] = fnv(knots[run], sizeof knots[run], 1469598103934665603ull);
        h[run] = fnv(widths[run], sizeof widths[run], h[run]);
        h[run] = fnv(ranges[run], sizeof ranges[run], h[run]);
        h[run] = fnv(traj[run], sizeof traj[run], h[run]);
    }
    CHECK(h[0] == h[1]);
    /* and each equals the single-blade call */
    outbuf o;
    o.traj = malloc(f * M * 3 * sizeof(float));
    tsk_refine_def def = {M, 0.25f};
    tsk_refine_input one = as_input(&bl[50 % 8]);
    tsk_refine_output oo = as_output(&o);
    CHECK(tsk_refine_blade(&def, &one, &oo) == TSK_OK);
    CHECK(memcmp(o.knots, knots[1][50], sizeof knots[1][50]) == 0);
    CHECK(memcmp(o.traj, traj[1][50], sizeof traj[1][50]) == 0);
    free(o.traj);
    /* an error in blade 41 is reported as that blade's, whatever the thread count */
    float nan_knots[90 * 3];
    memcpy(nan_knots, bl[0].knots, sizeof nan_knots);
    nan_knots[3 * 10 + 1] = NAN;
    in[41].knots = nan_knots;
    CHECK_STATUS(tsk_refine_blades(&def, in, out, B), TSK_ERR_ARGUMENT, "blades[41]: knots");
    for (int i = 0; i < 8; ++i) blade_free(&bl[i]);
    CHECK(tsk_set_threads(0) == TSK_OK);
}

TEST(test_refine_bad_input_names_argument) {
    blade b = random_blade(3, 30, 4);
    outbuf o = {.traj = NULL};
    tsk_refine_output out = as_output(&o);
    tsk_refine_def def = tsk_default_refine_def();
    tsk_refine_input in = as_input(&b);
    CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
    in.knot_count = 1;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "knot_count");
    in.knot_count = 0;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "knot_count");
    in = as_input(&b);
    in.frame_count = 0;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "frame_count");
    in = as_input(&b);
    def.target_knots = 1;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "target_knots");
    def.target_knots = 65;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "target_knots");
    def.target_knots = 31; /* more than the blade has */
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "target_knots");
    def = tsk_default_refine_def();
    def.mu = -0.01f;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "mu");
    def.mu = 1.5f;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "mu");
    def.mu = NAN;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "mu");
    def = tsk_default_refine_def();
    float save = b.knots[3 * 7 + 2];
    b.knots[3 * 7 + 2] = NAN;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "knots: knot 7");
    b.knots[3 * 7 + 2] = INFINITY;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "knots: knot 7");
    b.knots[3 * 7 + 2] = save;
    float save3[3];
    memcpy(save3, b.knots + 3 * 8, 12);
    memcpy(b.knots + 3 * 8, b.knots + 3 * 7, 12);
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "duplicate");
    memcpy(b.knots + 3 * 8, save3, 12);
    b.traj[(2 * 30 + 5) * 3 + 1] = NAN;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT,
                 "trajectories: frame 2, knot 5");
    b.traj[(2 * 30 + 5) * 3 + 1] = 0.0f;
    b.widths[4] = -1.0f;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "widths");
    b.widths[4] = NAN;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "widths");
    b.widths[4] = 0.004f;
    in.knots = NULL;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "knots");
    in = as_input(&b);
    in.knot_count = TSK_REFINE_MAX_KNOTS + 1;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_LIMIT, "knot_count");
    in = as_input(&b);
    out.ranges = NULL;
    CHECK_STATUS(tsk_refine_blade(&def, &in, &out), TSK_ERR_ARGUMENT, "out.ranges");
    CHECK_STATUS(tsk_refine_blade(NULL, &in, &out), TSK_ERR_ARGUMENT, "def");
    out = as_output(&o);
    CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK); /* the blade is fine again */
    blade_free(&b);
}

TEST(test_refine_target_equal_to_knot_count_changes_nothing) {
    blade b = random_blade(21, 10, 3);
    outbuf o;
    o.traj = malloc(3 * 10 * 3 * sizeof(float));
    tsk_refine_def def = {10, 0.5f};
    tsk_refine_input in = as_input(&b);
    tsk_refine_output out = as_output(&o);
    CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
    CHECK(memcmp(o.knots, b.knots, 10 * 3 * sizeof(float)) == 0);
    CHECK(memcmp(o.traj, b.traj, 3 * 10 * 3 * sizeof(float)) == 0);
    for (int j = 0; j < 10; ++j) {
        CHECK(o.ranges[2 * j] == j && o.ranges[2 * j + 1] == 1);
        CHECK_NEAR(o.widths[j], b.widths[j], 1e-7 * b.widths[j]);
    }
    CHECK(tsk_refine_blades(&def, &in, &out, 0) == TSK_OK); /* nothing to do */
    CHECK_STATUS(tsk_refine_blades(&def, NULL, &out, 1), TSK_ERR_ARGUMENT, "blades");
    free(o.traj);
    blade_free(&b);
}

/* Two interior knots far out but finite (0.9 and 0.8 FLT_MAX in x) merge into their midpoint,
 * not into the overflow of their sum (found by fuzz_refine): the merge runs root (0, 1) first,
 * then (2, 3), whose halves are added as 0.5 a + 0.5 b. */
TEST(test_refine_merge_of_huge_knots_stays_finite) {
    const float big = 3.4e38f;
    float knots[5 * 3] = {0,    0,          0,          0,    0, 0.1f, 0.9f * big, 0.9f * big,
                          0.2f, 0.8f * big, 0.9f * big, 0.3f, 0, 0,    0.4f};
    float widths[5] = {0.01f, 0.01f, 0.01f, 0.01f, 0.01f};
    float ok[3 * 3], ow[3], otraj[3 * 3];
    int32_t rg[3 * 2];
    tsk_refine_def def = {3, 0.5f};
    tsk_refine_input in = {knots, widths, knots, 5, 1};
    tsk_refine_output out = {ok, ow, rg, otraj};
    CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
    CHECK(rg[0] == 0 && rg[1] == 2 && rg[2] == 2 && rg[3] == 2 && rg[4] == 4 && rg[5] == 1);
    for (int i = 0; i < 9; ++i) CHECK_MSG(isfinite(ok[i]) && isfinite(otraj[i]), "value %d", i);
    CHECK(ok[3] == 0.5f * knots[6] + 0.5f * knots[9] && ok[3] > 0.84f * big);
    CHECK(ok[4] == knots[7] && ok[5] == 0.25f);
    for (int i = 0; i < 3; ++i) CHECK_NEAR(ow[i], 0.01f, 1e-8);
}

/* ---- tracking and resampling ------------------------------------------------------------ */

/* A planar arc of length L and curvature kappa, parametrised by arc length s. */
static void arc_point(double kappa, double s, double* p) {
    if (fabs(kappa) < 1e-12) {
        p[0] = 0, p[1] = 0, p[2] = s;
        return;
    }
    p[0] = (1.0 - cos(kappa * s)) / kappa, p[1] = 0, p[2] = sin(kappa * s) / kappa;
}

TEST(test_track_matches_knots_by_arc_length) {
    enum { K = 21, F = 5 };
    const double L = 0.3;
    float ref[3 * K];
    for (int j = 0; j < K; ++j) {
        double s = L * pow((double)j / (K - 1), 1.3), p[3]; /* uneven knots */
        arc_point(0.0, s, p);
        for (int c = 0; c < 3; ++c) ref[3 * j + c] = (float)p[c];
    }
    /* frames: the blade bent into arcs of growing curvature, captured with different knot
     * counts, every other frame listed tip to root */
    int32_t offsets[F + 1] = {0};
    static float fk[F * 400 * 3];
    for (int fr = 0; fr < F; ++fr) {
        int n = 150 + 50 * fr;
        double kappa = 2.0 * fr;
        for (int i = 0; i < n; ++i) {
            int ii = fr % 2 ? n - 1 - i : i;
            double p[3];
            arc_point(kappa, L * ii / (n - 1), p);
            for (int c = 0; c < 3; ++c) fk[3 * (offsets[fr] + i) + c] = (float)p[c];
        }
        offsets[fr + 1] = offsets[fr] + n;
    }
    static float traj[F * K * 3];
    CHECK(tsk_refine_track(ref, K, fk, offsets, F, traj) == TSK_OK);
    double worst = 0;
    for (int fr = 0; fr < F; ++fr)
        for (int j = 0; j < K; ++j) {
            double s = L * pow((double)j / (K - 1), 1.3), p[3];
            arc_point(2.0 * fr, s, p);
            for (int c = 0; c < 3; ++c)
                worst = fmax(worst, fabs(traj[(fr * K + j) * 3 + c] - p[c]));
        }
    CHECK_MSG(worst < 2e-4, "worst tracking error %g m", worst); /* chords of 150+ knots */
    CHECK(traj[0] == 0.0f && traj[1] == 0.0f && traj[2] == 0.0f);
    /* bad input */
    offsets[2] = offsets[1] + 1;
    CHECK_STATUS(tsk_refine_track(ref, K, fk, offsets, F, traj), TSK_ERR_ARGUMENT, "frame_knots");
    CHECK_STATUS(tsk_refine_track(ref, K, fk, offsets, 0, traj), TSK_ERR_ARGUMENT, "frame_count");
    CHECK_STATUS(tsk_refine_track(ref, 1, fk, offsets, F, traj), TSK_ERR_ARGUMENT, "ref_count");
}

TEST(test_resample_is_uniform_in_arc_length) {
    float knots[3 * 5] = {0, 0, 0, 0, 0, 0.1f, 0, 0, 0.15f, 0, 0, 0.7f, 0, 0, 1.0f};
    float widths[5] = {1, 0.9f, 0.85f, 0.3f, 0};
    float ok[3 * 11], ow[11];
    CHECK(tsk_refine_resample(knots, widths, 5, 11, ok, ow) == TSK_OK);
    for (int j = 0; j < 11; ++j) {
        CHECK_NEAR(ok[3 * j + 2], 0.1 * j, 1e-6);
        CHECK_NEAR(ow[j], 1.0 - 1.0 * 0.1 * j, 1e-6); /* widths are linear in z here */
    }
    CHECK_STATUS(tsk_refine_resample(knots, widths, 5, 1, ok, ow), TSK_ERR_ARGUMENT, "out_count");
}

/* ---- the bending model ---------------------------------------------------------------------- */

TEST(test_bend_cantilever_matches_euler_bernoulli) {
    /* A straight horizontal blade of uniform width, clamped at x = 0, under its own weight
     * with small gravity: w(x) = q x^2 (6L^2 - 4Lx + x^2) / (24 EI), tip q L^4 / (8 EI). */
    const int K = TSK_TEST_SLOW ? 21 : 41; /* fewer knots under the sanitizers */
    const double L = 0.2, width = 0.005;
    float knots[3 * 41], widths[41], traj[3 * 41];
    for (int j = 0; j < K; ++j) {
        knots[3 * j] = (float)(L * j / (K - 1)), knots[3 * j + 1] = 0, knots[3 * j + 2] = 0;
        widths[j] = (float)width;
    }
    tsk_refine_bend_def d = tsk_default_refine_bend_def();
    d.wind_speed = 0;
    d.gravity_prestress = 0;
    d.gravity[2] = -0.05f;
    const double EI = (double)d.youngs_modulus * width * pow(d.thickness, 3) / 12.0;
    const double q = (double)d.density * width * d.thickness * 0.05;
    const double mu = (double)d.density * width * d.thickness;
    const double omega1 = 1.875104 * 1.875104 * sqrt(EI / (mu * pow(L, 4)));
    d.damping = (float)(2.0 * omega1); /* critically damped first mode */
    d.warmup = (float)(25.0 / omega1);
    CHECK(tsk_refine_simulate(&d, knots, widths, K, 1, traj) == TSK_OK);
    const double tip = q * pow(L, 4) / (8.0 * EI);
    CHECK_NEAR(-traj[3 * (K - 1) + 2], tip, 0.01 * tip);
    if (getenv("TSK_VERBOSE"))
        fprintf(stderr, "  cantilever tip %g m, analytic %g m\n", -traj[3 * (K - 1) + 2], tip);
    double worst = 0;
    for (int j = 0; j < K; ++j) {
        double x = L * j / (K - 1);
        double w = q * x * x * (6 * L * L - 4 * L * x + x * x) / (24.0 * EI);
        worst = fmax(worst, fabs(-traj[3 * j + 2] - w));
    }
    CHECK_MSG(worst < 0.01 * tip, "deflection curve off by %g of the tip's %g", worst, tip);
    CHECK(tip > 1e-4 && tip < 0.01 * L); /* small deflection, as the linear theory needs */
}

static void curved_blade(size_t k, double L, float* knots, float* widths) {
    for (size_t j = 0; j < k; ++j) {
        double s = L * (double)j / (double)(k - 1), p[3];
        arc_point(3.0, s, p); /* leaning over towards +x */
        for (int c = 0; c < 3; ++c) knots[3 * j + c] = (float)p[c];
        double u = (double)j / (double)(k - 1);
        widths[j] = (float)(0.006 * (1.0 - u * u) + 0.0003);
    }
}

TEST(test_bend_keeps_segment_lengths_and_root) {
    enum { F = 12 };
    const int K = TSK_TEST_SLOW ? 24 : 48;
    float knots[3 * 48], widths[48];
    static float traj[F * 48 * 3];
    curved_blade(K, 0.2, knots, widths);
    tsk_refine_bend_def d = tsk_default_refine_bend_def();
    d.warmup = 0.25f;
    d.wind_speed = 6.0f;
    CHECK(tsk_refine_simulate(&d, knots, widths, K, F, traj) == TSK_OK);
    double worst = 0, moved = 0;
    for (int fr = 0; fr < F; ++fr) {
        const float* p = traj + fr * K * 3;
        CHECK(memcmp(p, knots, 12) == 0); /* the root is clamped */
        for (int j = 0; j + 1 < K; ++j) {
            double a = 0, b = 0;
            for (int c = 0; c < 3; ++c) {
                a += pow(p[3 * j + 3 + c] - p[3 * j + c], 2);
                b += pow(knots[3 * j + 3 + c] - knots[3 * j + c], 2);
            }
            worst = fmax(worst, fabs(sqrt(a) / sqrt(b) - 1.0));
        }
        moved = fmax(moved, fabs(p[3 * (K - 1)] - knots[3 * (K - 1)]));
    }
    CHECK_MSG(worst < 2e-5, "segment length changed by %g", worst);
    CHECK_MSG(moved > 0.005, "the wind moved the tip only %g m", moved);
}

TEST(test_bend_prestress_holds_rest_shape) {
    const int K = TSK_TEST_SLOW ? 16 : 32;
    float knots[3 * 32], widths[32], traj[3 * 32], sag[3 * 32];
    curved_blade(K, 0.2, knots, widths);
    tsk_refine_bend_def d = tsk_default_refine_bend_def();
    d.wind_speed = 0;
    d.warmup = 1.0f;
    d.damping = 20.0f;
    CHECK(tsk_refine_simulate(&d, knots, widths, K, 1, traj) == TSK_OK);
    d.gravity_prestress = 0;
    CHECK(tsk_refine_simulate(&d, knots, widths, K, 1, sag) == TSK_OK);
    double held = 0, sagged = 0;
    for (int c = 0; c < 3; ++c) {
        held += pow(traj[3 * (K - 1) + c] - knots[3 * (K - 1) + c], 2);
        sagged += pow(sag[3 * (K - 1) + c] - knots[3 * (K - 1) + c], 2);
    }
    held = sqrt(held), sagged = sqrt(sagged);
    CHECK_MSG(sagged > 0.005, "without prestress the tip sagged only %g m", sagged);
    CHECK_MSG(held < 0.01 * sagged, "with prestress the tip moved %g m (sag %g m)", held, sagged);
}

TEST(test_bend_wind_is_the_documented_sum_of_sines) {
    tsk_refine_bend_def d = tsk_default_refine_bend_def();
    d.wind_direction[0] = 0, d.wind_direction[1] = 2, d.wind_direction[2] = 0; /* +y */
    const double pi2 = 2.0 * 3.14159265358979323846;
    double lo = 1e9;
    for (int i = 0; i < 400; ++i) {
        double t = 0.05 * i;
        float w[3];
        tsk_refine_wind_at(&d, t, w);
        double along = d.wind_speed *
                       (1 + d.gust * (0.6 * sin(pi2 * 0.31 * t) + 0.3 * sin(pi2 * 0.87 * t + 1.1) +
                                      0.1 * sin(pi2 * 2.3 * t + 2.3)));
        double across = d.wind_speed * d.gust * 0.25 * sin(pi2 * 0.53 * t + 0.4);
        CHECK_NEAR(w[1], along, 1e-5);
        CHECK_NEAR(w[0], -across, 1e-5); /* z x (+y) = -x */
        CHECK_NEAR(w[2], 0.0, 0.0);
        lo = fmin(lo, along);
    }
    CHECK(lo >= 0.0);
}

TEST(test_bend_bad_input_names_argument) {
    float knots[9] = {0, 0, 0, 0, 0, 0.1f, 0, 0, 0.2f}, widths[3] = {0.01f, 0.01f, 0.0f};
    float traj[9 * 2];
    tsk_refine_bend_def d = tsk_default_refine_bend_def();
    d.warmup = 0;
    CHECK(tsk_refine_simulate(&d, knots, widths, 3, 2, traj) == TSK_OK);
    d.fps = 0;
    CHECK_STATUS(tsk_refine_simulate(&d, knots, widths, 3, 2, traj), TSK_ERR_ARGUMENT, "fps");
    d = tsk_default_refine_bend_def();
    d.thickness = -1;
    CHECK_STATUS(tsk_refine_simulate(&d, knots, widths, 3, 2, traj), TSK_ERR_ARGUMENT, "thickness");
    d = tsk_default_refine_bend_def();
    d.gust = 2;
    CHECK_STATUS(tsk_refine_simulate(&d, knots, widths, 3, 2, traj), TSK_ERR_ARGUMENT, "gust");
    d = tsk_default_refine_bend_def();
    d.gravity[1] = NAN;
    CHECK_STATUS(tsk_refine_simulate(&d, knots, widths, 3, 2, traj), TSK_ERR_ARGUMENT, "gravity");
    d = tsk_default_refine_bend_def();
    CHECK_STATUS(tsk_refine_simulate(&d, knots, widths, 3, 0, traj), TSK_ERR_ARGUMENT,
                 "frame_count");
    CHECK_STATUS(tsk_refine_simulate(&d, knots, widths, 1, 2, traj), TSK_ERR_ARGUMENT,
                 "knot_count");
    knots[5] = 0;
    CHECK_STATUS(tsk_refine_simulate(&d, knots, widths, 3, 2, traj), TSK_ERR_ARGUMENT, "duplicate");
    knots[5] = 0.1f;
    float zero[3] = {0, 0, 0};
    CHECK_STATUS(tsk_refine_simulate(&d, knots, zero, 3, 2, traj), TSK_ERR_ARGUMENT, "widths");
    /* an absurd amount of work is refused, not run */
    d.time_step = 1e-9f;
    d.warmup = 10;
    CHECK_STATUS(tsk_refine_simulate(&d, knots, widths, 3, 2, traj), TSK_ERR_LIMIT, "knot_count");
}

TEST(test_refine_simulated_blade_end_to_end) {
    /* a still capture: simulate the full blade, then refine it; memory is returned */
    enum { F = 16, M = 8 };
    const int K = TSK_TEST_SLOW ? 24 : 64;
    size_t before = tsk_allocated_bytes();
    float knots[3 * 64], widths[64];
    static float traj[F * 64 * 3];
    curved_blade(K, 0.2, knots, widths);
    tsk_refine_bend_def d = tsk_default_refine_bend_def();
    d.warmup = 0.5f;
    CHECK(tsk_refine_simulate(&d, knots, widths, K, F, traj) == TSK_OK);
    tsk_refine_input in = {knots, widths, traj, (size_t)K, F};
    outbuf o = {.traj = NULL};
    tsk_refine_output out = as_output(&o);
    tsk_refine_def def = {M, 0.5f};
    CHECK(tsk_refine_blade(&def, &in, &out) == TSK_OK);
    CHECK(o.ranges[0] == 0 && o.ranges[2 * (M - 1)] + o.ranges[2 * M - 1] == K);
    CHECK(tsk_allocated_bytes() == before);
}

/* Fuzz finding (fuzz_refine): with one frame and no warmup the work check counted a single
 * step, so a blade whose stable step is tiny (knots 1e-12 m apart) passed, and the steps per
 * frame (~1e22) were converted to size_t: undefined behaviour. The steps of one frame now
 * count against the limit too; a normal one-frame request still runs. */
TEST(test_refine_simulate_one_frame_with_tiny_step_is_refused) {
    float knots[9] = {0, 0, 0, 0, 0, 1e-12f, 0, 0, 2e-12f};
    float widths[3] = {0.005f, 0.005f, 0.005f};
    float traj[9];
    tsk_refine_bend_def d = tsk_default_refine_bend_def();
    d.warmup = 0.0f;
    CHECK_STATUS(tsk_refine_simulate(&d, knots, widths, 3, 1, traj), TSK_ERR_LIMIT, "knot_count");
    float ok[9] = {0, 0, 0, 0, 0, 0.05f, 0, 0, 0.1f};
    CHECK(tsk_refine_simulate(&d, ok, widths, 3, 1, traj) == TSK_OK);
    for (int i = 0; i < 9; ++i) CHECK(isfinite(traj[i]));
}

TEST_MAIN(TEST_ENTRY(test_refine_simulate_one_frame_with_tiny_step_is_refused),
          TEST_ENTRY(test_refine_difference_matches_closed_form),
          TEST_ENTRY(test_refine_keeps_root_and_tip),
          TEST_ENTRY(test_refine_exact_count_and_ranges_partition_blade),
          TEST_ENTRY(test_refine_widths_positive_and_length_weighted),
          TEST_ENTRY(test_refine_ties_go_to_root_side_and_root_absorbs),
          TEST_ENTRY(test_refine_mu_one_merges_closest_pair_and_tip_absorbs),
          TEST_ENTRY(test_refine_variance_keeps_knots_that_move_differently),
          TEST_ENTRY(test_refine_heap_matches_naive_bitwise),
          TEST_ENTRY(test_refine_is_scale_invariant),
          TEST_ENTRY(test_refine_batch_identical_1_and_2_threads),
          TEST_ENTRY(test_refine_bad_input_names_argument),
          TEST_ENTRY(test_refine_target_equal_to_knot_count_changes_nothing),
          TEST_ENTRY(test_refine_merge_of_huge_knots_stays_finite),
          TEST_ENTRY(test_track_matches_knots_by_arc_length),
          TEST_ENTRY(test_resample_is_uniform_in_arc_length),
          TEST_ENTRY(test_bend_cantilever_matches_euler_bernoulli),
          TEST_ENTRY(test_bend_keeps_segment_lengths_and_root),
          TEST_ENTRY(test_bend_prestress_holds_rest_shape),
          TEST_ENTRY(test_bend_wind_is_the_documented_sum_of_sines),
          TEST_ENTRY(test_bend_bad_input_names_argument),
          TEST_ENTRY(test_refine_simulated_blade_end_to_end))
