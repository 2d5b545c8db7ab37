/* Tests of the blade simulation: rest stays rest, collisions as hard constraints (sphere,
 * capsule, ground), recovery to the rest shape, segment lengths in contact, determinism across
 * thread counts, tile activation and release with memory freed, and argument checks. */
#include "test.h"
#include "tussock/meadow.h"
#include "tussock/sim.h"
#include "sim/sim_internal.h"

#include <float.h>
#include <stdint.h>

#if defined(__SANITIZE_ADDRESS__)
#define SLOW 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SLOW 0
#else
#define SLOW 1
#endif
#else
#define SLOW 1
#endif

#define K16 16

/* Every step of these tests is followed by a check of the simulation's tile lists and active
 * tiles (tsk_sim_lists_problem): a step that leaves them inconsistent fails the test that made
 * it. */
static int validated_steps;
static tsk_status step_and_validate(tsk_blade_sim* sim, float dt, const float* wind,
                                    tsk_wind_layout layout) {
    const tsk_status s = (tsk_blade_sim_step)(sim, dt, wind, layout);
    if (sim) {
        const char* problem = tsk_sim_lists_problem(sim);
        CHECK_MSG(problem == NULL, "after a step: %s", problem);
        ++validated_steps;
    }
    return s;
}
#define tsk_blade_sim_step step_and_validate

/* An analytic blade (the meadow's default shape): with t = k/(K-1), height H, lean e,
 * turned by `turn` about +z:  local (e H t^2, 0, H t), width W (1 - t^3). */
static void make_blade(int K, const float root[3], float H, float lean, float turn, float* knots,
                       float* widths, float* side) {
    const float c = tsk_cosf(turn), s = tsk_sinf(turn);
    for (int k = 0; k < K; ++k) {
        const float t = (float)k / (float)(K - 1);
        const float lx = lean * H * t * t, lz = H * t;
        knots[3 * k] = root[0] + c * lx;
        knots[3 * k + 1] = root[1] + s * lx;
        knots[3 * k + 2] = root[2] + lz;
        widths[k] = 0.008f * (1.0f - t * t * t);
    }
    if (side) side[0] = -s, side[1] = c, side[2] = 0.0f;
}

static float blade_length(int K, const float* knots) {
    float L = 0;
    for (int k = 1; k < K; ++k) {
        float d0 = knots[3 * k] - knots[3 * k - 3], d1 = knots[3 * k + 1] - knots[3 * k - 2],
              d2 = knots[3 * k + 2] - knots[3 * k - 1];
        L += sqrtf(d0 * d0 + d1 * d1 + d2 * d2);
    }
    return L;
}

static float seg_len(const float* a, const float* b) {
    float d0 = b[0] - a[0], d1 = b[1] - a[1], d2 = b[2] - a[2];
    return sqrtf(d0 * d0 + d1 * d1 + d2 * d2);
}

/* Distance from p to segment a-b. */
static double dist_segment(const float* p, const float* a, const float* b) {
    double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]},
           ap[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
    double ab2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    double t = ab2 > 0 ? (ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / ab2 : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    double d[3] = {ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]};
    return sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

/* A row of n blades along x at y = y0, spacing dx, starting at x0; varied lean and turn. */
static void make_row(int K, int n, float x0, float dx, float y0, float* knots, float* widths,
                     float* sides) {
    for (int b = 0; b < n; ++b) {
        float root[3] = {x0 + dx * (float)b, y0, 0.0f};
        make_blade(K, root, 0.3f + 0.02f * (float)(b % 3), 0.25f * (float)(b % 4) / 3.0f,
                   0.7f * (float)b, knots + (size_t)b * K * 3, widths + (size_t)b * K,
                   sides + 3 * b);
    }
}

/* One big tile holding everything, kept active for the whole test. */
static tsk_blade_sim* one_tile_sim(tsk_blade_sim_def def, int n, const float* knots,
                                   const float* widths, const float* sides) {
    tsk_blade_sim* sim = NULL;
    CHECK(tsk_blade_sim_create(&def, &sim) == TSK_OK);
    if (!sim) return NULL;
    CHECK(tsk_blade_sim_activate_tile(sim, 0) == TSK_OK);
    CHECK(tsk_blade_sim_pending_count(sim) == 1);
    CHECK(tsk_blade_sim_provide_tile(sim, 0, n, knots, widths, sides) == TSK_OK);
    return sim;
}

static tsk_blade_sim_def big_tile_def(void) {
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    def.origin[0] = def.origin[1] = -1.0f;
    def.tile_size = 4.0f;
    def.tiles_x = def.tiles_y = 1;
    def.collision_margin = 0.0f;
    def.rest_frames = def.settle_frames = 1000000; /* never release during these tests */
    return def;
}

TEST(test_sim_starts_exactly_at_rest_pose) {
    enum { N = 20 };
    static float knots[N * K16 * 3], widths[N * K16], sides[N * 3], out[N * K16 * 3];
    make_row(K16, N, 0.0f, 0.05f, 0.0f, knots, widths, sides);
    tsk_blade_sim* sim = one_tile_sim(big_tile_def(), N, knots, widths, sides);
    CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
    double worst = 0;
    for (int i = 0; i < N * K16 * 3; ++i) worst = fmax(worst, fabs(out[i] - knots[i]));
    CHECK_MSG(worst < 2e-6, "activation pops by %g m", worst);
    tsk_blade_sim_destroy(sim);
}

TEST(test_sim_blade_at_rest_stays_at_rest) {
    enum { N = 20 };
    static float knots[N * K16 * 3], widths[N * K16], sides[N * 3], start[N * K16 * 3],
        out[N * K16 * 3];
    make_row(K16, N, 0.0f, 0.05f, 0.0f, knots, widths, sides);
    tsk_blade_sim_def def = big_tile_def();
    CHECK(def.gravity[2] < -9.0f); /* gravity on */
    tsk_blade_sim* sim = one_tile_sim(def, N, knots, widths, sides);
    CHECK(tsk_blade_sim_get_tile_knots(sim, 0, start) == TSK_OK);
    double worst = 0;
    for (int s = 0; s < 1000; ++s) {
        CHECK(tsk_blade_sim_step(sim, 1.0f / 60.0f, NULL, TSK_WIND_NONE) == TSK_OK);
        CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
        for (int i = 0; i < N * K16 * 3; ++i) worst = fmax(worst, fabs(out[i] - start[i]));
    }
    CHECK_MSG(worst < 1e-5, "drift %g m over 1000 steps", worst);
    tsk_blade_sim_destroy(sim);
}

TEST(test_sim_without_preload_gravity_bends_blades_down) {
    /* the preload is what holds the rest pose: without it the same blade sags */
    enum { N = 4 };
    static float knots[N * K16 * 3], widths[N * K16], sides[N * 3], out[N * K16 * 3];
    make_row(K16, N, 0.0f, 0.05f, 0.0f, knots, widths, sides);
    tsk_blade_sim_def def = big_tile_def();
    def.gravity_preload = 0.0f;
    tsk_blade_sim* sim = one_tile_sim(def, N, knots, widths, sides);
    for (int s = 0; s < 120; ++s)
        CHECK(tsk_blade_sim_step(sim, 1.0f / 60.0f, NULL, TSK_WIND_NONE) == TSK_OK);
    CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
    for (int b = 1; b < N; ++b) { /* blade 0 stands straight up: gravity cannot bend it */
        const int tip = (b * K16 + K16 - 1) * 3;
        CHECK_MSG(out[tip + 2] < knots[tip + 2] - 1e-3, "blade %d tip z %g vs rest %g", b,
                  out[tip + 2], knots[tip + 2]);
    }
    tsk_blade_sim_destroy(sim);
}

TEST(test_sim_free_blade_hangs_and_follows_wind) {
    /* No shape constraints: a 2-knot blade is a pendulum. Gravity alone hangs it straight down
       from the root; a strong horizontal wind with no gravity turns it along the wind. */
    float knots[6] = {0.5f, 0.5f, 1.0f, 0.6f, 0.5f, 1.2f}, widths[2] = {0.01f, 0.01f};
    const float L = sqrtf(0.01f + 0.04f);
    tsk_blade_sim_def def = big_tile_def();
    def.knot_count = 2;
    def.global_stiffness_root = def.global_stiffness_tip = 0.0f;
    def.local_stiffness = 0.0f;
    def.gravity_preload = 0.0f;
    tsk_blade_sim* sim = one_tile_sim(def, 1, knots, widths, NULL);
    float out[6];
    for (int s = 0; s < 600; ++s)
        CHECK(tsk_blade_sim_step(sim, 1.0f / 60.0f, NULL, TSK_WIND_NONE) == TSK_OK);
    CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
    CHECK_NEAR(out[3], 0.5f, 2e-3);
    CHECK_NEAR(out[4], 0.5f, 2e-3);
    CHECK_NEAR(out[5], 1.0f - L, 2e-3);
    CHECK_NEAR(out[0], 0.5f, 0.0); /* the root is pinned */
    tsk_blade_sim_destroy(sim);

    def.gravity[2] = 0.0f;
    sim = one_tile_sim(def, 1, knots, widths, NULL);
    const float wind[3] = {0.0f, 8.0f, 0.0f};
    for (int s = 0; s < 600; ++s)
        CHECK(tsk_blade_sim_step(sim, 1.0f / 60.0f, wind, TSK_WIND_UNIFORM) == TSK_OK);
    CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
    CHECK_NEAR(out[3], 0.5f, 2e-3);
    CHECK_NEAR(out[4], 0.5f + L, 2e-3);
    CHECK_NEAR(out[5], 1.0f, 2e-3);
    tsk_blade_sim_destroy(sim);
}

TEST(test_sim_wind_bends_downwind_more_with_stronger_wind) {
    enum { N = 8 };
    static float knots[N * K16 * 3], widths[N * K16], sides[N * 3], out[N * K16 * 3];
    make_row(K16, N, 0.0f, 0.05f, 0.0f, knots, widths, sides);
    double push[2];
    for (int w = 0; w < 2; ++w) {
        tsk_blade_sim* sim = one_tile_sim(big_tile_def(), N, knots, widths, sides);
        const float wind[3] = {0.0f, w == 0 ? 3.0f : 8.0f, 0.0f};
        for (int s = 0; s < 240; ++s)
            CHECK(tsk_blade_sim_step(sim, 1.0f / 60.0f, wind, TSK_WIND_UNIFORM) == TSK_OK);
        CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
        push[w] = 1e9;
        for (int b = 0; b < N; ++b) {
            const int tip = (b * K16 + K16 - 1) * 3;
            push[w] = fmin(push[w], out[tip + 1] - knots[tip + 1]);
        }
        tsk_blade_sim_destroy(sim);
    }
    CHECK_MSG(push[0] > 0.005, "3 m/s moved tips by %g m", push[0]);
    CHECK_MSG(push[1] > push[0] * 1.5, "8 m/s %g vs 3 m/s %g", push[1], push[0]);
}

/* Pushes a collider along +x through a row of blades: every step no knot inside, no knot below
 * the ground, segment lengths within 1 %; then the blades recover within 1 % of blade length. */
static void collider_pass(int capsule) {
    enum { N = 32 };
    static float knots[N * K16 * 3], widths[N * K16], sides[N * 3], out[N * K16 * 3];
    make_row(K16, N, 0.0f, 0.04f, 0.5f, knots, widths, sides);
    tsk_blade_sim_def def = big_tile_def();
    tsk_blade_sim* sim = one_tile_sim(def, N, knots, widths, sides);
    const float r = 0.12f, dt = 1.0f / 60.0f;
    double worst_in = 0, worst_len = 0, lowest = 1e9;
    int touched_knots = 0;
    for (int s = 0; s < 150; ++s) {
        tsk_blade_collider c;
        memset(&c, 0, sizeof c);
        c.radius = r;
        const float x = -0.3f + 1.2f * dt * (float)s; /* 1.2 m/s */
        if (capsule) {
            c.kind = TSK_COLLIDER_CAPSULE;
            c.a[0] = x, c.a[1] = 0.3f, c.a[2] = r + 0.01f;
            c.b[0] = x, c.b[1] = 0.7f, c.b[2] = r + 0.01f;
        } else {
            c.kind = TSK_COLLIDER_SPHERE;
            c.a[0] = x, c.a[1] = 0.5f, c.a[2] = r + 0.01f;
            c.b[0] = c.b[1] = c.b[2] = 0.0f;
        }
        CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
        CHECK(tsk_blade_sim_step(sim, dt, NULL, TSK_WIND_NONE) == TSK_OK);
        CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
        const float* b_end = capsule ? c.b : c.a;
        for (int b = 0; b < N; ++b) {
            for (int k = 0; k < K16; ++k) {
                const float* p = out + (size_t)(b * K16 + k) * 3;
                const double d = dist_segment(p, c.a, b_end);
                if (k > 0) worst_in = fmax(worst_in, r - d);
                if (d < r * 1.05) ++touched_knots;
                lowest = fmin(lowest, p[2]);
                if (k > 0) {
                    const float L0 = seg_len(knots + (size_t)(b * K16 + k - 1) * 3,
                                             knots + (size_t)(b * K16 + k) * 3);
                    const float L1 = seg_len(p - 3, p);
                    worst_len = fmax(worst_len, fabs(L1 - L0) / L0);
                }
            }
        }
    }
    CHECK_MSG(touched_knots > 1000, "the collider touched only %d knot-steps", touched_knots);
    CHECK_MSG(worst_in <= 1e-6, "a knot was %g m inside the collider", worst_in);
    CHECK_MSG(lowest >= 0.0, "a knot went below the ground to z = %g", lowest);
    CHECK_MSG(worst_len <= 0.01, "segment length off by %.3g %% during contact", 100 * worst_len);
    /* the collider is gone: the blades recover */
    CHECK(tsk_blade_sim_set_colliders(sim, NULL, 0) == TSK_OK);
    for (int s = 0; s < 300; ++s) CHECK(tsk_blade_sim_step(sim, dt, NULL, TSK_WIND_NONE) == TSK_OK);
    CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
    double worst_rel = 0;
    for (int b = 0; b < N; ++b) {
        const float Lb = blade_length(K16, knots + (size_t)b * K16 * 3);
        for (int k = 0; k < K16; ++k) {
            const float* p = out + (size_t)(b * K16 + k) * 3;
            const float* q = knots + (size_t)(b * K16 + k) * 3;
            worst_rel = fmax(worst_rel, seg_len(p, q) / Lb);
        }
    }
    CHECK_MSG(worst_rel < 0.01, "after 5 s a knot is %.3g %% of its blade's length from rest",
              100 * worst_rel);
    tsk_blade_sim_destroy(sim);
}

TEST(test_sim_sphere_never_inside_and_blades_recover) { collider_pass(0); }
TEST(test_sim_capsule_never_inside_and_blades_recover) { collider_pass(1); }

TEST(test_sim_contact_holds_for_5_to_64_knots) {
    /* a capsule sweeps back and forth through 37 blades (two blocks, one partly padded) of 5, 32
       and 64 knots: every step no knot inside it or under the ground, lengths within 1 % */
    static const int Ks[3] = {5, 32, 64};
    enum { N = 37 };
    static float knots[N * 64 * 3], widths[N * 64], out[N * 64 * 3];
    for (int ki = 0; ki < 3; ++ki) {
        const int K = Ks[ki];
        for (int b = 0; b < N; ++b) {
            float root[3] = {0.5f * tsk_rand01(4, (uint64_t)b, 0, 0),
                             0.5f * tsk_rand01(4, (uint64_t)b, 1, 0), 0.0f};
            make_blade(K, root, 0.3f, 0.3f, 6.28f * tsk_rand01(4, (uint64_t)b, 2, 0),
                       knots + (size_t)b * K * 3, widths + (size_t)b * K, NULL);
        }
        tsk_blade_sim_def def = big_tile_def();
        def.knot_count = K;
        tsk_blade_sim* sim = one_tile_sim(def, N, knots, widths, NULL);
        double worst_in = 0, worst_len = 0, lowest = 1e9;
        for (int s = 0; s < 120; ++s) {
            const float x = 0.25f + 0.6f * tsk_sinf(0.05f * (float)s);
            tsk_blade_collider c = {
                TSK_COLLIDER_CAPSULE, 0.1f, {x, -0.2f, 0.12f}, {x, 0.7f, 0.12f}};
            CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
            CHECK(tsk_blade_sim_step(sim, 1.0f / 24.0f, NULL, TSK_WIND_NONE) == TSK_OK);
            CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
            for (int b = 0; b < N; ++b)
                for (int k = 1; k < K; ++k) {
                    const float* p = out + (size_t)(b * K + k) * 3;
                    worst_in = fmax(worst_in, 0.1 - dist_segment(p, c.a, c.b));
                    lowest = fmin(lowest, p[2]);
                    const float L0 = seg_len(knots + (size_t)(b * K + k - 1) * 3,
                                             knots + (size_t)(b * K + k) * 3);
                    worst_len = fmax(worst_len, fabs(seg_len(p - 3, p) - L0) / L0);
                }
        }
        CHECK_MSG(worst_in <= 1e-6, "K=%d: a knot was %g m inside", K, worst_in);
        CHECK_MSG(lowest >= 0.0, "K=%d: a knot reached z = %g", K, lowest);
        CHECK_MSG(worst_len <= 0.01, "K=%d: segment length off by %.3g %%", K, 100 * worst_len);
        tsk_blade_sim_destroy(sim);
    }
}

TEST(test_sim_local_shape_alone_restores_bend) {
    /* global shape off: only local (parent-frame) constraints hold the shape, so recovering
       the rest pose means the bending directions were kept relative to the blade's frames */
    enum { N = 16 };
    static float knots[N * K16 * 3], widths[N * K16], sides[N * 3], out[N * K16 * 3];
    make_row(K16, N, 0.0f, 0.05f, 0.5f, knots, widths, sides);
    tsk_blade_sim_def def = big_tile_def();
    def.global_stiffness_root = def.global_stiffness_tip = 0.0f;
    def.gravity[2] = 0.0f; /* soft local constraints alone do not hold a blade up against gravity */
    tsk_blade_sim* sim = one_tile_sim(def, N, knots, widths, sides);
    const float dt = 1.0f / 60.0f;
    for (int s = 0; s < 60; ++s) {
        tsk_blade_collider c = {
            TSK_COLLIDER_SPHERE, 0.1f, {-0.2f + 1.0f * dt * (float)s, 0.5f, 0.12f}, {0, 0, 0}};
        CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
        CHECK(tsk_blade_sim_step(sim, dt, NULL, TSK_WIND_NONE) == TSK_OK);
    }
    CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
    double disturbed = 0;
    for (int i = 0; i < N * K16 * 3; ++i) disturbed = fmax(disturbed, fabs(out[i] - knots[i]));
    CHECK_MSG(disturbed > 0.02, "the sphere moved knots by only %g m", disturbed);
    CHECK(tsk_blade_sim_set_colliders(sim, NULL, 0) == TSK_OK);
    for (int s = 0; s < 600; ++s) CHECK(tsk_blade_sim_step(sim, dt, NULL, TSK_WIND_NONE) == TSK_OK);
    CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
    double worst_rel = 0;
    for (int b = 0; b < N; ++b) {
        const float Lb = blade_length(K16, knots + (size_t)b * K16 * 3);
        for (int k = 0; k < K16; ++k)
            worst_rel = fmax(
                worst_rel,
                seg_len(out + (size_t)(b * K16 + k) * 3, knots + (size_t)(b * K16 + k) * 3) / Lb);
    }
    CHECK_MSG(worst_rel < 0.01, "local shape alone left %.3g %% of blade length", 100 * worst_rel);
    tsk_blade_sim_destroy(sim);
}

TEST(test_sim_ground_never_penetrated) {
    /* a heavy downward wind and no preload press the blades flat: none goes below ground */
    enum { N = 16 };
    static float knots[N * K16 * 3], widths[N * K16], sides[N * 3], out[N * K16 * 3];
    make_row(K16, N, 0.0f, 0.05f, 0.5f, knots, widths, sides);
    tsk_blade_sim_def def = big_tile_def();
    def.gravity_preload = 0.0f;
    def.global_stiffness_root = 2.0f;
    def.local_stiffness = 5.0f;
    def.ground_height = 0.05f; /* roots sit below the ground plane's height: only knots >= 1 */
    tsk_blade_sim* sim = one_tile_sim(def, N, knots, widths, sides);
    const float wind[3] = {3.0f, 0.0f, -30.0f};
    double lowest = 1e9;
    for (int s = 0; s < 200; ++s) {
        CHECK(tsk_blade_sim_step(sim, 1.0f / 60.0f, wind, TSK_WIND_UNIFORM) == TSK_OK);
        CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
        for (int b = 0; b < N; ++b)
            for (int k = 1; k < K16; ++k) lowest = fmin(lowest, out[(size_t)(b * K16 + k) * 3 + 2]);
    }
    CHECK_MSG(lowest >= 0.05, "a knot reached z = %.9g below the ground 0.05", lowest);
    CHECK_MSG(lowest < 0.0501, "the blades never reached the ground (lowest %g)", lowest);
    tsk_blade_sim_destroy(sim);
}

/* A 6 x 6 grid of tiles, all active, 40 blades each, three spheres and per-knot wind. */
static void run_scene(int threads, float* out, size_t* out_count) {
    CHECK(tsk_set_threads(threads) == TSK_OK);
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    def.tiles_x = def.tiles_y = 6;
    def.rest_frames = def.settle_frames = 1000000;
    tsk_blade_sim* sim = NULL;
    CHECK(tsk_blade_sim_create(&def, &sim) == TSK_OK);
    enum { NB = 40 };
    static float knots[NB * K16 * 3], widths[NB * K16], sides[NB * 3];
    for (int t = 0; t < 36; ++t) {
        for (int b = 0; b < NB; ++b) {
            float root[3] = {
                0.5f * (float)(t % 6) + 0.5f * tsk_rand01(7, (uint64_t)t, (uint64_t)b, 0),
                0.5f * (float)(t / 6) + 0.5f * tsk_rand01(7, (uint64_t)t, (uint64_t)b, 1), 0.0f};
            make_blade(K16, root, 0.25f + 0.1f * tsk_rand01(7, (uint64_t)t, (uint64_t)b, 2), 0.25f,
                       6.28f * tsk_rand01(7, (uint64_t)t, (uint64_t)b, 3),
                       knots + (size_t)b * K16 * 3, widths + (size_t)b * K16, sides + 3 * b);
        }
        CHECK(tsk_blade_sim_activate_tile(sim, t) == TSK_OK);
        CHECK(tsk_blade_sim_provide_tile(sim, t, NB, knots, widths, sides) == TSK_OK);
    }
    const size_t nk = (size_t)36 * NB * K16;
    float* wind = malloc(sizeof(float) * 3 * nk);
    for (int s = 0; s < (SLOW ? 60 : 20); ++s) {
        tsk_blade_collider c[3];
        for (int i = 0; i < 3; ++i) {
            c[i].kind = i == 2 ? TSK_COLLIDER_CAPSULE : TSK_COLLIDER_SPHERE;
            c[i].radius = 0.15f;
            c[i].a[0] = 0.3f + 0.9f * (float)i + 0.03f * (float)s, c[i].a[1] = 1.5f,
            c[i].a[2] = 0.12f;
            c[i].b[0] = c[i].a[0], c[i].b[1] = 2.2f, c[i].b[2] = 0.12f;
        }
        CHECK(tsk_blade_sim_set_colliders(sim, c, 3) == TSK_OK);
        CHECK(tsk_blade_sim_get_knots(sim, out) == TSK_OK);
        for (size_t i = 0; i < nk; ++i) { /* a wind field sampled at the knots */
            wind[3 * i] = 2.0f * tsk_sinf(out[3 * i] * 3.0f + 0.1f * (float)s);
            wind[3 * i + 1] = 1.0f + tsk_cosf(out[3 * i + 1] * 2.0f);
            wind[3 * i + 2] = 0.0f;
        }
        CHECK(tsk_blade_sim_step(sim, 1.0f / 60.0f, wind, TSK_WIND_PER_KNOT) == TSK_OK);
    }
    CHECK(tsk_blade_sim_get_knots(sim, out) == TSK_OK);
    *out_count = nk * 3;
    free(wind);
    tsk_blade_sim_destroy(sim);
    CHECK(tsk_set_threads(0) == TSK_OK);
}

TEST(test_sim_identical_bytes_with_1_and_2_threads) {
    const size_t n = (size_t)36 * 40 * K16 * 3;
    float* a = malloc(sizeof(float) * n);
    float* b = malloc(sizeof(float) * n);
    size_t na = 0, nb = 0;
    run_scene(1, a, &na);
    run_scene(2, b, &nb);
    CHECK(na == n && nb == n);
    CHECK(memcmp(a, b, sizeof(float) * n) == 0);
    /* and something moved */
    run_scene(1, b, &nb);
    CHECK(memcmp(a, b, sizeof(float) * n) == 0);
    free(a);
    free(b);
}

/* Wind given once per blade acts as the same wind given at each of its knots. */
TEST(test_sim_wind_per_blade_equals_wind_per_knot) {
    enum { N = 40 };
    static float knots[N * K16 * 3], widths[N * K16], sides[N * 3], a[N * K16 * 3], b[N * K16 * 3];
    static float wb[N * 3], wk[N * K16 * 3];
    make_row(K16, N, 0.0f, 0.05f, 0.5f, knots, widths, sides);
    for (int i = 0; i < N; ++i) {
        wb[3 * i] = 3.0f * tsk_sinf((float)i), wb[3 * i + 1] = 2.0f + tsk_cosf((float)i),
               wb[3 * i + 2] = 0.1f;
        for (int k = 0; k < K16; ++k)
            memcpy(wk + (size_t)(i * K16 + k) * 3, wb + 3 * i, sizeof(float) * 3);
    }
    for (int layout = 0; layout < 2; ++layout) {
        tsk_blade_sim* sim = one_tile_sim(big_tile_def(), N, knots, widths, sides);
        for (int s = 0; s < 60; ++s)
            CHECK(tsk_blade_sim_step(sim, 1.0f / 60.0f, layout ? wk : wb,
                                     layout ? TSK_WIND_PER_KNOT : TSK_WIND_PER_BLADE) == TSK_OK);
        CHECK(tsk_blade_sim_get_tile_knots(sim, 0, layout ? b : a) == TSK_OK);
        tsk_blade_sim_destroy(sim);
    }
    CHECK(memcmp(a, b, sizeof a) == 0);
    double moved = 0;
    for (int i = 0; i < N * K16 * 3; ++i) moved = fmax(moved, fabs(a[i] - knots[i]));
    CHECK_MSG(moved > 1e-3, "the wind moved the knots by only %g m", moved);
}

/* The AVX-512, AVX2 and portable kernels (those the CPU has; the portable one alone in a
 * TSK_NO_SIMD build), with 1 and 2 threads, give one fixed set of bytes: only IEEE operations
 * (fused multiply-adds written out, each rounded once) and exact conversions. */
/* run_scene's knots (see tsk_test_fnv): after 60 steps, or the 20 of sanitizer builds */
static const uint64_t SIM_GOLDEN = SLOW ? 0x5315aee473583325ull : 0x013325305ae16b92ull;

TEST(test_sim_kernel_paths_give_identical_bytes) {
    const size_t n = (size_t)36 * 40 * K16 * 3;
    float* a = malloc(sizeof(float) * n);
    static const int paths[] = {TSK_SIMD_BEST, TSK_SIMD_PORTABLE, TSK_SIMD_AT_MOST_AVX2};
    static const char* names[] = {"best", "portable", "at most AVX2"};
    for (int p = 0; p < 3; ++p) {
        tsk_simd_force(paths[p]);
        for (int threads = 1; threads <= 2; ++threads) {
            size_t na = 0;
            run_scene(threads, a, &na);
            CHECK(na == n);
            const uint64_t h = tsk_test_fnv(a, sizeof(float) * na, TSK_TEST_FNV_START);
            CHECK_MSG(h == SIM_GOLDEN,
                      "%s kernel (%d), %d threads: the solver's bytes changed: hash %#018llx",
                      names[p], tsk_simd_isa(), threads, (unsigned long long)h);
        }
    }
    tsk_simd_force(TSK_SIMD_BEST);
    free(a);
}

/* Rest blades of tile t in a grid with the given def: n blades inside the tile square. */
static void tile_blades(const tsk_blade_sim_def* def, int t, int n, float* knots, float* widths,
                        float* sides) {
    const int i = t % def->tiles_x, j = t / def->tiles_x;
    for (int b = 0; b < n; ++b) {
        float root[3] = {def->origin[0] + def->tile_size * ((float)i + tsk_rand01(3, (uint64_t)t,
                                                                                  (uint64_t)b, 0)),
                         def->origin[1] + def->tile_size * ((float)j + tsk_rand01(3, (uint64_t)t,
                                                                                  (uint64_t)b, 1)),
                         def->ground_height};
        make_blade(def->knot_count, root, 0.3f, 0.2f,
                   6.28f * tsk_rand01(3, (uint64_t)t, (uint64_t)b, 2),
                   knots + (size_t)b * def->knot_count * 3, widths + (size_t)b * def->knot_count,
                   sides + 3 * b);
    }
}

TEST(test_sim_tile_activates_then_releases_and_frees_memory) {
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    def.tiles_x = def.tiles_y = 8;
    def.rest_frames = 20;
    def.blend_frames = 5;
    const size_t before = tsk_allocated_bytes();
    tsk_blade_sim* sim = NULL;
    CHECK(tsk_blade_sim_create(&def, &sim) == TSK_OK);
    const size_t baseline = tsk_allocated_bytes();
    tsk_blade_sim_info info;
    CHECK(tsk_blade_sim_get_info(sim, &info) == TSK_OK);
    CHECK(info.active_tiles == 0 && info.state_bytes == 0 && info.pending_tiles == 0);
    /* a sphere in the middle of tile (3, 3): it and, through the margin, no other tile */
    tsk_blade_collider c = {TSK_COLLIDER_SPHERE, 0.1f, {1.75f, 1.75f, 0.2f}, {0, 0, 0}};
    CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
    CHECK(tsk_blade_sim_pending_count(sim) == 1);
    int32_t pend[16];
    CHECK(tsk_blade_sim_get_pending(sim, pend) == TSK_OK);
    CHECK(pend[0] == 3 * 8 + 3);
    CHECK(tsk_blade_sim_tile_state(sim, 27) == 2);
    CHECK(tsk_blade_sim_tile_state(sim, 26) == 0);
    /* moving to the corner of four tiles touches all four */
    c.a[0] = 2.0f, c.a[1] = 2.0f;
    CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
    CHECK(tsk_blade_sim_pending_count(sim) == 4);
    CHECK(tsk_blade_sim_get_pending(sim, pend) == TSK_OK);
    CHECK(pend[0] == 27 && pend[1] == 28 && pend[2] == 35 && pend[3] == 36);
    enum { NB = 64 };
    static float knots[NB * K16 * 3], widths[NB * K16], sides[NB * 3];
    for (int i = 0; i < 4; ++i) {
        tile_blades(&def, pend[i], NB, knots, widths, sides);
        CHECK(tsk_blade_sim_provide_tile(sim, pend[i], NB, knots, widths, sides) == TSK_OK);
    }
    CHECK(tsk_blade_sim_get_info(sim, &info) == TSK_OK);
    CHECK(info.active_tiles == 4 && info.active_blades == 4 * NB && info.pending_tiles == 0);
    CHECK(info.state_bytes > (size_t)4 * NB * K16 * 3 * sizeof(float));
    CHECK(tsk_allocated_bytes() >= baseline + info.state_bytes);
    /* the sphere presses for a while, then leaves */
    for (int s = 0; s < 30; ++s) {
        c.a[2] = 0.2f - 0.003f * (float)s;
        CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
        CHECK(tsk_blade_sim_step(sim, 1.0f / 60.0f, NULL, TSK_WIND_NONE) == TSK_OK);
    }
    CHECK(tsk_blade_sim_get_info(sim, &info) == TSK_OK);
    CHECK(info.active_tiles == 4 && info.blending_tiles == 0);
    CHECK(tsk_blade_sim_set_colliders(sim, NULL, 0) == TSK_OK);
    int released_at = -1, saw_blend = 0;
    float* last = malloc(sizeof(float) * NB * K16 * 3);
    for (int s = 0; s < 3000 && released_at < 0; ++s) {
        CHECK(tsk_blade_sim_step(sim, 1.0f / 60.0f, NULL, TSK_WIND_NONE) == TSK_OK);
        CHECK(tsk_blade_sim_get_info(sim, &info) == TSK_OK);
        saw_blend |= info.blending_tiles > 0;
        if (tsk_blade_sim_tile_state(sim, 27) == 1)
            CHECK(tsk_blade_sim_get_tile_knots(sim, 27, last) == TSK_OK);
        if (info.active_tiles == 0) released_at = s;
    }
    CHECK_MSG(released_at > def.rest_frames, "released after %d steps", released_at);
    CHECK(saw_blend);
    /* the last state before release was blended to within a tiny distance of the rest pose */
    tile_blades(&def, 27, NB, knots, widths, sides);
    double worst = 0;
    for (int i = 0; i < NB * K16 * 3; ++i) worst = fmax(worst, fabs(last[i] - knots[i]));
    CHECK_MSG(worst < 1e-3, "released %g m away from rest", worst);
    CHECK(tsk_allocated_bytes() == baseline);
    CHECK(info.state_bytes == 0);
    free(last);
    tsk_blade_sim_destroy(sim);
    CHECK(tsk_allocated_bytes() == before);
}

/* In a steady breeze a touched tile never gets quiet (its blades stay bent more than
 * rest_distance), yet once untouched for settle_frames steps it blends back to rest over
 * settle_blend_frames steps, without a jump, and is freed: the simulated set does not only
 * grow as colliders pass through a windy meadow. */
TEST(test_sim_tile_in_steady_wind_settles_and_is_freed) {
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    def.tiles_x = def.tiles_y = 4;
    def.settle_frames = 120;
    def.settle_blend_frames = 40;
    tsk_blade_sim* sim = NULL;
    CHECK(tsk_blade_sim_create(&def, &sim) == TSK_OK);
    if (!sim) return;
    const size_t baseline = tsk_allocated_bytes();
    tsk_blade_collider c = {TSK_COLLIDER_SPHERE, 0.1f, {0.75f, 0.75f, 0.2f}, {0, 0, 0}};
    CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
    CHECK(tsk_blade_sim_pending_count(sim) == 1);
    enum { NB = 32 };
    static float knots[NB * K16 * 3], rest[NB * K16 * 3], widths[NB * K16], sides[NB * 3];
    static float now[NB * K16 * 3], prev[NB * K16 * 3];
    const int32_t tile = 1 * 4 + 1;
    tile_blades(&def, tile, NB, knots, widths, sides);
    memcpy(rest, knots, sizeof rest);
    CHECK(tsk_blade_sim_provide_tile(sim, tile, NB, knots, widths, sides) == TSK_OK);
    const float wind[3] = {6.0f, 0.0f, 0.0f};
    const float dt = 1.0f / 48.0f;
    for (int s = 0; s < 20; ++s)
        CHECK(tsk_blade_sim_step(sim, dt, wind, TSK_WIND_UNIFORM) == TSK_OK);
    CHECK(tsk_blade_sim_set_colliders(sim, NULL, 0) == TSK_OK);
    int released_at = -1, blend_began = -1;
    double bent = 0.0, jump = 0.0, wind_step = 0.0, last_gap = 1.0;
    tsk_blade_sim_info info;
    CHECK(tsk_blade_sim_get_tile_knots(sim, tile, prev) == TSK_OK);
    for (int s = 0; s < 400 && released_at < 0; ++s) {
        CHECK(tsk_blade_sim_step(sim, dt, wind, TSK_WIND_UNIFORM) == TSK_OK);
        CHECK(tsk_blade_sim_get_info(sim, &info) == TSK_OK);
        if (info.active_tiles == 0) {
            released_at = s;
            break;
        }
        CHECK(tsk_blade_sim_get_tile_knots(sim, tile, now) == TSK_OK);
        double gap = 0.0, step = 0.0;
        for (int i = 0; i < NB * K16 * 3; ++i) {
            gap = fmax(gap, fabs(now[i] - rest[i]));
            step = fmax(step, fabs(now[i] - prev[i]));
        }
        if (info.blending_tiles > 0) {
            if (blend_began < 0) blend_began = s;
            jump = fmax(jump, step);
        } else if (s > 60) {
            bent = fmax(bent, gap); /* settled in the wind, still untouched */
            wind_step = fmax(wind_step, step);
        }
        last_gap = gap;
        memcpy(prev, now, sizeof prev);
    }
    CHECK_MSG(bent > 5.0 * def.rest_distance, "the wind bent the blades only %g m", bent);
    CHECK_MSG(blend_began >= def.settle_frames - 1 && blend_began <= def.settle_frames + 1,
              "blend began after %d untouched steps", blend_began);
    CHECK_MSG(released_at == blend_began + def.settle_blend_frames,
              "released at step %d, blend began at %d", released_at, blend_began);
    /* linear blend: no step moves a knot much more than 1/40 of the bend (plus the wind's own
     * motion), and the last blended state is at rest */
    CHECK_MSG(jump < bent / def.settle_blend_frames * 2.0 + wind_step + 1e-4,
              "a knot jumped %g m in one blended step (bend %g m)", jump, bent);
    CHECK_MSG(last_gap < 1e-3, "released %g m from rest", last_gap);
    CHECK(info.state_bytes == 0 && tsk_allocated_bytes() == baseline);
    /* touched again later: simulated again, from rest */
    c.a[2] = 0.2f;
    CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
    CHECK(tsk_blade_sim_pending_count(sim) == 1);
    tsk_blade_sim_destroy(sim);
}

/* tsk_blade_sim_get_knots (all tiles, in parallel) gives each active tile's knots, as
 * tsk_blade_sim_get_tile_knots does, in tsk_blade_sim_get_active's order: tiles with full
 * and partial blocks of blades. */
TEST(test_sim_all_knots_are_the_tiles_knots_in_order) {
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    def.tiles_x = def.tiles_y = 4;
    tsk_blade_sim* sim = NULL;
    CHECK(tsk_blade_sim_create(&def, &sim) == TSK_OK);
    if (!sim) return;
    const int32_t want[3] = {5, 6, 10};
    const int32_t counts[3] = {70, 1, 64};
    enum { NB = 70 };
    static float knots[NB * K16 * 3], widths[NB * K16], sides[NB * 3];
    for (int i = 0; i < 3; ++i) CHECK(tsk_blade_sim_activate_tile(sim, want[i]) == TSK_OK);
    int32_t pend[16];
    const int32_t np = tsk_blade_sim_pending_count(sim);
    CHECK(np == 3 && tsk_blade_sim_get_pending(sim, pend) == TSK_OK);
    for (int i = 0; i < np && i < 3; ++i) {
        const int32_t n = pend[i] == 5 ? counts[0] : pend[i] == 6 ? counts[1] : counts[2];
        tile_blades(&def, pend[i], n, knots, widths, sides);
        CHECK(tsk_blade_sim_provide_tile(sim, pend[i], n, knots, widths, sides) == TSK_OK);
    }
    const float wind[3] = {3.0f, 1.0f, 0.0f};
    for (int s = 0; s < 3; ++s)
        CHECK(tsk_blade_sim_step(sim, 1.0f / 48.0f, wind, TSK_WIND_UNIFORM) == TSK_OK);
    tsk_blade_sim_info info;
    CHECK(tsk_blade_sim_get_info(sim, &info) == TSK_OK);
    CHECK(info.active_tiles == 3 && info.active_blades == 135);
    int32_t tiles[3], tcounts[3];
    CHECK(tsk_blade_sim_get_active(sim, tiles, tcounts) == TSK_OK);
    float* all = malloc(sizeof(float) * 135 * K16 * 3);
    float* one = malloc(sizeof(float) * NB * K16 * 3);
    CHECK(tsk_blade_sim_get_knots(sim, all) == TSK_OK);
    size_t off = 0, bad = 0;
    for (int i = 0; i < 3; ++i) {
        CHECK(tsk_blade_sim_get_tile_knots(sim, tiles[i], one) == TSK_OK);
        bad += memcmp(all + off, one, sizeof(float) * (size_t)tcounts[i] * K16 * 3) != 0;
        off += (size_t)tcounts[i] * K16 * 3;
    }
    CHECK_MSG(bad == 0 && off == (size_t)135 * K16 * 3, "%zu tiles differ", bad);
    free(all), free(one);
    tsk_blade_sim_destroy(sim);
}

/* Ribbons made from the solver's blocks are the bytes tsk_blades_expand makes from the knots
 * tsk_blade_sim_get_knots gives, for any range of the active blades (tiles of 70, 1 and 64
 * blades: ranges that start and end inside blocks and tiles), with every kernel; bad widths
 * and sides are reported for the first bad blade, ranges beyond the active blades refused. */
/* tsk_sim_validate accepts the lists a meadow's steps leave (active, forced, pending and touched
 * tiles, a collider moving across the grid) and names each list that is corrupted: out of order,
 * outside the grid, an active tile still pending, blocks that do not match the blades. */
TEST(test_sim_validate_finds_corrupt_tile_lists) {
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    def.tiles_x = def.tiles_y = 6;
    tsk_blade_sim* sim = NULL;
    CHECK(tsk_blade_sim_create(&def, &sim) == TSK_OK);
    if (!sim) return;
    enum { NB = 40 };
    static float knots[NB * K16 * 3], widths[NB * K16], sides[NB * 3];
    const int32_t want[] = {1, 2, 7, 20, 33};
    for (int i = 0; i < 5; ++i) CHECK(tsk_blade_sim_activate_tile(sim, want[i]) == TSK_OK);
    for (int i = 0; i < 3; ++i) { /* 20 and 33 stay forced and pending */
        tile_blades(&def, want[i], NB - 7 * i, knots, widths, sides);
        CHECK(tsk_blade_sim_provide_tile(sim, want[i], NB - 7 * i, knots, widths, sides) == TSK_OK);
    }
    const int before = validated_steps;
    const float wind[3] = {2.0f, 0.5f, 0.0f};
    for (int s = 0; s < 8; ++s) { /* a capsule rolling over tiles 12.. 16 */
        tsk_blade_collider c = {TSK_COLLIDER_CAPSULE,
                                0.2f,
                                {0.2f + 0.25f * (float)s, 1.2f, 0.1f},
                                {0.6f + 0.25f * (float)s, 1.3f, 0.1f}};
        CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
        CHECK(tsk_blade_sim_step(sim, 1.0f / 48.0f, wind, TSK_WIND_UNIFORM) == TSK_OK);
    }
    CHECK_MSG(validated_steps == before + 8, "%d steps validated", validated_steps - before);
    CHECK_MSG(sim->tile_count == 3 && sim->forced_count == 2 && sim->touched_count >= 2 &&
                  sim->pending_count >= 4,
              "scene: %d active, %d forced, %d touched, %d pending", sim->tile_count,
              sim->forced_count, sim->touched_count, sim->pending_count);
    CHECK(tsk_sim_validate(sim) == TSK_OK);
    if (sim->tile_count < 2 || sim->forced_count < 2 || sim->touched_count < 2 ||
        sim->pending_count < 2) {
        tsk_blade_sim_destroy(sim);
        return;
    }
    int32_t* lists[3] = {sim->pending, sim->forced, sim->touched};
    const char* names[3] = {"pending", "forced", "touched"};
    for (int l = 0; l < 3; ++l) {
        int32_t* v = lists[l];
        const int32_t a = v[0], b = v[1];
        v[0] = b, v[1] = a; /* out of order */
        CHECK_STATUS(tsk_sim_validate(sim), TSK_ERR_INTERNAL, names[l]);
        v[0] = b, v[1] = b; /* a tile twice */
        CHECK_STATUS(tsk_sim_validate(sim), TSK_ERR_INTERNAL, "ascend");
        v[0] = -1, v[1] = b; /* outside the grid */
        CHECK_STATUS(tsk_sim_validate(sim), TSK_ERR_INTERNAL, "outside");
        v[0] = a, v[1] = b;
        CHECK(tsk_sim_validate(sim) == TSK_OK);
    }
    sim_tile* t = sim->tiles;
    const int32_t i0 = t[0].index, i1 = t[1].index;
    t[0].index = i1, t[1].index = i0;
    CHECK_STATUS(tsk_sim_validate(sim), TSK_ERR_INTERNAL, "active tiles");
    t[0].index = i0, t[1].index = i1;
    t[1].block_count += 1;
    CHECK_STATUS(tsk_sim_validate(sim), TSK_ERR_INTERNAL, "block count");
    t[1].block_count -= 1;
    const int32_t p0 = sim->pending[0], np = sim->pending_count;
    sim->pending[0] = i0, sim->pending_count = 1; /* an active tile pending */
    CHECK_STATUS(tsk_sim_validate(sim), TSK_ERR_INTERNAL, "active tile is pending");
    sim->pending[0] = p0, sim->pending_count = np;
    CHECK(tsk_sim_validate(sim) == TSK_OK);
    CHECK_STATUS(tsk_sim_validate(NULL), TSK_ERR_INTERNAL, "no simulation");
    tsk_blade_sim_destroy(sim);
}

TEST(test_sim_ribbons_are_the_expanded_knots) {
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    def.tiles_x = def.tiles_y = 4;
    tsk_blade_sim* sim = NULL;
    CHECK(tsk_blade_sim_create(&def, &sim) == TSK_OK);
    if (!sim) return;
    enum { NB = 70, NA = 135 };
    static float knots[NB * K16 * 3], widths[NB * K16], sides[NB * 3];
    const int32_t want[3] = {5, 6, 10};
    for (int i = 0; i < 3; ++i) CHECK(tsk_blade_sim_activate_tile(sim, want[i]) == TSK_OK);
    int32_t pend[16];
    const int32_t np = tsk_blade_sim_pending_count(sim);
    CHECK(np == 3 && tsk_blade_sim_get_pending(sim, pend) == TSK_OK);
    for (int i = 0; i < np && i < 3; ++i) {
        const int32_t n = pend[i] == 5 ? 70 : pend[i] == 6 ? 1 : 64;
        tile_blades(&def, pend[i], n, knots, widths, sides);
        CHECK(tsk_blade_sim_provide_tile(sim, pend[i], n, knots, widths, sides) == TSK_OK);
    }
    static float rest[NA * K16 * 3];
    CHECK(tsk_blade_sim_get_knots(sim, rest) == TSK_OK);
    /* a sphere pressing the first tile's blades, and wind: knots away from any rest pose */
    tsk_blade_collider c = {TSK_COLLIDER_SPHERE, 0.2f, {0.3f, 0.4f, 0.15f}, {0, 0, 0}};
    CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
    const float wind[3] = {4.0f, -1.0f, 0.0f};
    for (int s = 0; s < 12; ++s)
        CHECK(tsk_blade_sim_step(sim, 1.0f / 48.0f, wind, TSK_WIND_UNIFORM) == TSK_OK);
    tsk_blade_sim_info info;
    CHECK(tsk_blade_sim_get_info(sim, &info) == TSK_OK);
    CHECK(info.active_blades == NA);
    static float all[NA * K16 * 3], w[NA * K16], sd[NA * 3], want_pos[NA * K16 * 6],
        got[NA * K16 * 6];
    CHECK(tsk_blade_sim_get_knots(sim, all) == TSK_OK);
    for (int b = 0; b < NA; ++b) { /* widths of every size and zero, sides of any length */
        for (int k = 0; k < K16; ++k)
            w[b * K16 + k] = 0.02f * tsk_rand01(5, (uint64_t)b, (uint64_t)k, 0);
        w[b * K16 + K16 - 1] = 0.0f;
        const float a = 6.28f * tsk_rand01(5, (uint64_t)b, 0, 1),
                    l = 0.1f + 3.0f * tsk_rand01(5, (uint64_t)b, 0, 2);
        sd[3 * b] = l * tsk_cosf(a), sd[3 * b + 1] = l * tsk_sinf(a), sd[3 * b + 2] = 0.3f * l;
    }
    sd[3 * 7] = 0.0f, sd[3 * 7 + 1] = 0.0f, sd[3 * 7 + 2] = 1.0f; /* along the blade */
    const int64_t ranges[][2] = {{0, NA}, {3, 70}, {69, 2}, {70, 1}, {100, 35}, {134, 1}, {31, 34}};
    size_t moved = 0;
    for (int path = 0; path <= 2; ++path) {
        tsk_simd_force(path); /* 0 the best, 1 portable, 2 at most AVX2 */
        for (size_t r = 0; r < sizeof ranges / sizeof ranges[0]; ++r) {
            const int64_t f = ranges[r][0], n = ranges[r][1];
            CHECK(tsk_blades_expand(all + f * K16 * 3, w + f * K16, sd + 3 * f, (size_t)n, K16,
                                    want_pos, NULL, NULL) == TSK_OK);
            memset(got, 0xff, sizeof got);
            CHECK(tsk_blade_sim_get_ribbons(sim, f, n, w + f * K16, sd + 3 * f, got) == TSK_OK);
            CHECK_MSG(memcmp(got, want_pos, sizeof(float) * (size_t)n * K16 * 6) == 0,
                      "path %d, blades %lld + %lld differ from tsk_blades_expand", path,
                      (long long)f, (long long)n);
            if (n < NA) { /* got has room for NA blades: nothing after the n asked for */
                uint32_t past;
                memcpy(&past, got + n * K16 * 6, sizeof past);
                CHECK_MSG(past == 0xffffffffu, "wrote past blade %lld", (long long)(f + n));
            }
        }
    }
    tsk_simd_force(TSK_SIMD_BEST);
    for (int i = 0; i < NA * K16 * 3; ++i) moved += all[i] != rest[i];
    CHECK_MSG(moved > NA * K16, "only %zu knot coordinates moved", moved);
    { /* runs in any order, across blocks and tiles, empty ones and one blade twice: run by run
         the bytes of tsk_blades_expand on each run's knots */
        const int64_t starts[] = {100, 0, 69, 31, 3, 134, 134}, counts[] = {35, 3, 2, 34, 0, 1, 1};
        enum { NR = sizeof starts / sizeof starts[0] };
        static float rw[NA * K16], rs[NA * 3];
        int64_t at = 0;
        for (int r = 0; r < NR; at += counts[r++]) {
            memcpy(rw + at * K16, w + starts[r] * K16, sizeof(float) * (size_t)(counts[r] * K16));
            memcpy(rs + at * 3, sd + starts[r] * 3, sizeof(float) * (size_t)(counts[r] * 3));
            CHECK(tsk_blades_expand(all + starts[r] * K16 * 3, w + starts[r] * K16,
                                    sd + 3 * starts[r], (size_t)counts[r], K16,
                                    want_pos + at * K16 * 6, NULL, NULL) == TSK_OK);
        }
        memset(got, 0xff, sizeof got);
        CHECK(tsk_blade_sim_get_ribbon_runs(sim, starts, counts, NR, rw, rs, got) == TSK_OK);
        CHECK_MSG(memcmp(got, want_pos, sizeof(float) * (size_t)at * K16 * 6) == 0,
                  "the runs' ribbons differ from tsk_blades_expand");
        uint32_t past;
        memcpy(&past, got + at * K16 * 6, sizeof past);
        CHECK_MSG(past == 0xffffffffu, "wrote past the runs' %lld blades", (long long)at);
        CHECK(tsk_blade_sim_get_ribbon_runs(sim, NULL, NULL, 0, NULL, NULL, NULL) == TSK_OK);
        const int64_t bad_s[] = {0, 130}, bad_c[] = {2, 6}, neg_s[] = {-1}, one[] = {1};
        CHECK_STATUS(tsk_blade_sim_get_ribbon_runs(sim, bad_s, bad_c, 2, rw, rs, got),
                     TSK_ERR_ARGUMENT, "run 1: 6 blades from blade 130 on");
        CHECK_STATUS(tsk_blade_sim_get_ribbon_runs(sim, neg_s, one, 1, rw, rs, got),
                     TSK_ERR_ARGUMENT, "run 0");
        CHECK_STATUS(tsk_blade_sim_get_ribbon_runs(sim, NULL, one, 1, rw, rs, got),
                     TSK_ERR_ARGUMENT, "starts");
        CHECK_STATUS(tsk_blade_sim_get_ribbon_runs(sim, one, one, -1, rw, rs, got),
                     TSK_ERR_ARGUMENT, "run_count");
        CHECK_STATUS(tsk_blade_sim_get_ribbon_runs(sim, one, one, 1, rw, rs, NULL),
                     TSK_ERR_ARGUMENT, "positions");
        rw[40 * K16 + 2] = -1.0f; /* blade 40 of the runs' arrays (run 3, blade 31 + 2) */
        CHECK_STATUS(tsk_blade_sim_get_ribbon_runs(sim, starts, counts, NR, rw, rs, got),
                     TSK_ERR_ARGUMENT, "width 2 of blade 40");
    }
    /* bad input: the first bad blade, in the caller's numbering */
    w[80 * K16 + 3] = -1.0f;
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, 0, NA, w, sd, got), TSK_ERR_ARGUMENT,
                 "width 3 of blade 80");
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, 10, NA - 10, w + 10 * K16, sd + 30, got),
                 TSK_ERR_ARGUMENT, "width 3 of blade 70");
    w[80 * K16 + 3] = NAN;
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, 0, NA, w, sd, got), TSK_ERR_ARGUMENT,
                 "width 3 of blade 80");
    w[80 * K16 + 3] = 0.01f;
    sd[3 * 120] = sd[3 * 120 + 1] = sd[3 * 120 + 2] = 0.0f;
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, 0, NA, w, sd, got), TSK_ERR_ARGUMENT,
                 "side of blade 120");
    sd[3 * 120] = INFINITY;
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, 100, 35, w + 100 * K16, sd + 300, got),
                 TSK_ERR_ARGUMENT, "side of blade 20");
    CHECK(tsk_blade_sim_get_ribbons(sim, 0, 100, w, sd, got) == TSK_OK); /* blade 120 not asked */
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, -1, 2, w, sd, got), TSK_ERR_ARGUMENT,
                 "active ones");
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, 100, 36, w, sd, got), TSK_ERR_ARGUMENT,
                 "active ones");
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, NA + 1, 0, w, sd, got), TSK_ERR_ARGUMENT,
                 "active ones");
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, 0, INT64_MAX, w, sd, got), TSK_ERR_ARGUMENT,
                 "active ones");
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, 100, INT64_MAX, w, sd, got), TSK_ERR_ARGUMENT,
                 "from blade 100 on");
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, INT64_MAX, INT64_MAX, w, sd, got), TSK_ERR_ARGUMENT,
                 "active ones");
    CHECK(tsk_blade_sim_get_ribbons(sim, NA, 0, NULL, NULL, NULL) == TSK_OK);
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, 0, 1, NULL, sd, got), TSK_ERR_ARGUMENT, "widths");
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, 0, 1, w, NULL, got), TSK_ERR_ARGUMENT, "sides");
    CHECK_STATUS(tsk_blade_sim_get_ribbons(sim, 0, 1, w, sd, NULL), TSK_ERR_ARGUMENT, "positions");
    CHECK_STATUS(tsk_blade_sim_get_ribbons(NULL, 0, 1, w, sd, got), TSK_ERR_ARGUMENT, "sim");
    tsk_blade_sim_destroy(sim);
}

TEST(test_sim_touched_tile_never_releases) {
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    def.tiles_x = def.tiles_y = 2;
    def.rest_frames = 3;
    def.blend_frames = 2;
    tsk_blade_sim* sim = NULL;
    CHECK(tsk_blade_sim_create(&def, &sim) == TSK_OK);
    tsk_blade_collider c = {TSK_COLLIDER_SPHERE, 0.05f, {0.25f, 0.25f, 0.9f}, {0, 0, 0}};
    CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
    CHECK(tsk_blade_sim_pending_count(sim) == 1);
    CHECK(tsk_blade_sim_provide_tile(sim, 0, 0, NULL, NULL, NULL) == TSK_OK); /* an empty tile */
    for (int s = 0; s < 50; ++s)
        CHECK(tsk_blade_sim_step(sim, 0.02f, NULL, TSK_WIND_NONE) == TSK_OK);
    CHECK(tsk_blade_sim_tile_state(sim, 0) == 1);
    c.a[2] = 5.0f; /* above max_blade_height: touches nothing */
    CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
    CHECK(tsk_blade_sim_pending_count(sim) == 0);
    for (int s = 0; s < 5; ++s)
        CHECK(tsk_blade_sim_step(sim, 0.02f, NULL, TSK_WIND_NONE) == TSK_OK);
    CHECK(tsk_blade_sim_tile_state(sim, 0) == 0);
    tsk_blade_sim_destroy(sim);
}

/* A scene with two tiles activated by a moving sphere, stepped `steps` times from step `from`. */
static void clone_scene_steps(tsk_blade_sim* sim, int from, int steps) {
    for (int s = from; s < from + steps; ++s) {
        tsk_blade_collider c = {
            TSK_COLLIDER_SPHERE, 0.12f, {0.3f + 0.02f * (float)s, 0.4f, 0.12f}, {0, 0, 0}};
        CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
        int32_t pend[16];
        const int32_t n = tsk_blade_sim_pending_count(sim);
        CHECK(n <= 16);
        CHECK(tsk_blade_sim_get_pending(sim, pend) == TSK_OK);
        enum { NB = 40 };
        static float knots[NB * K16 * 3], widths[NB * K16], sides[NB * 3];
        tsk_blade_sim_def def = tsk_default_blade_sim_def();
        def.tiles_x = def.tiles_y = 4;
        for (int i = 0; i < n && i < 16; ++i) {
            tile_blades(&def, pend[i], NB, knots, widths, sides);
            CHECK(tsk_blade_sim_provide_tile(sim, pend[i], NB, knots, widths, sides) == TSK_OK);
        }
        const float wind[3] = {2.0f, 0.5f, 0.0f};
        CHECK(tsk_blade_sim_step(sim, 1.0f / 48.0f, wind, TSK_WIND_UNIFORM) == TSK_OK);
    }
}

static float* all_knots(const tsk_blade_sim* sim, tsk_blade_sim_info* info) {
    CHECK(tsk_blade_sim_get_info(sim, info) == TSK_OK);
    float* k = malloc(sizeof(float) * (size_t)(info->active_blades * K16 * 3 + 1));
    CHECK(tsk_blade_sim_get_knots(sim, k) == TSK_OK);
    return k;
}

TEST(test_sim_clone_resumes_with_identical_bytes) {
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    def.tiles_x = def.tiles_y = 4;
    tsk_blade_sim* a = NULL;
    CHECK(tsk_blade_sim_create(&def, &a) == TSK_OK);
    clone_scene_steps(a, 0, 12);
    tsk_blade_sim_info ia, ib;
    CHECK(tsk_blade_sim_get_info(a, &ia) == TSK_OK);
    CHECK(ia.active_tiles >= 2 && ia.collider_count == 1);
    const size_t before = tsk_allocated_bytes();
    tsk_blade_sim* b = NULL;
    CHECK(tsk_blade_sim_clone(a, &b) == TSK_OK && b != NULL);
    CHECK(tsk_allocated_bytes() - before >= ia.state_bytes);
    CHECK(tsk_blade_sim_get_info(b, &ib) == TSK_OK);
    CHECK(memcmp(&ia, &ib, sizeof ia) == 0);
    /* the original goes on (new tiles activate on the way); the clone is untouched by it */
    float* kb0 = all_knots(b, &ib);
    const int64_t n0 = ib.active_blades;
    int32_t first_tile = -1, first_count = 0;
    CHECK(tsk_blade_sim_get_active(b, NULL, NULL) == TSK_OK);
    {
        int32_t tiles[64], counts[64];
        CHECK(ib.active_tiles <= 64);
        CHECK(tsk_blade_sim_get_active(b, tiles, counts) == TSK_OK);
        first_tile = tiles[0], first_count = counts[0];
    }
    float* tile0 = malloc(sizeof(float) * (size_t)first_count * K16 * 3 + 4);
    float* tile1 = malloc(sizeof(float) * (size_t)first_count * K16 * 3 + 4);
    CHECK(tsk_blade_sim_get_tile_knots(b, first_tile, tile0) == TSK_OK);
    clone_scene_steps(a, 12, 20);
    float* kb1 = all_knots(b, &ib);
    CHECK(ib.active_blades == n0 && memcmp(kb0, kb1, sizeof(float) * (size_t)(n0 * K16 * 3)) == 0);
    /* the clone, stepped the same way, reaches the same bytes (and the same tiles) */
    clone_scene_steps(b, 12, 20);
    float* ka = all_knots(a, &ia);
    float* kb = all_knots(b, &ib);
    CHECK(ia.active_tiles == ib.active_tiles && ia.active_blades == ib.active_blades &&
          ia.pending_tiles == ib.pending_tiles && ia.state_bytes == ib.state_bytes);
    CHECK(ia.active_blades > 0 &&
          memcmp(ka, kb, sizeof(float) * (size_t)(ia.active_blades * K16 * 3)) == 0);
    /* and the blades moved meanwhile, so equal bytes say something */
    CHECK(tsk_blade_sim_get_tile_knots(b, first_tile, tile1) == TSK_OK);
    CHECK(first_count > 0 &&
          memcmp(tile0, tile1, sizeof(float) * (size_t)first_count * K16 * 3) != 0);
    free(tile0);
    free(tile1);
    free(ka);
    free(kb);
    free(kb0);
    free(kb1);
    const size_t with_b = tsk_allocated_bytes();
    tsk_blade_sim_destroy(b);
    CHECK(with_b - tsk_allocated_bytes() >= ib.state_bytes); /* the clone's memory is freed */
    /* an allocation failing at any point: an error, *out NULL, nothing leaked */
    const size_t held = tsk_allocated_bytes();
    int failures = 0;
    for (int n = 0; n < 64; ++n) {
        int allocs_left = n;
        tsk_set_allocator(tsk_test_failing_alloc, tsk_test_plain_free, &allocs_left);
        tsk_blade_sim* c = (tsk_blade_sim*)&failures; /* not NULL before the call */
        tsk_status s = tsk_blade_sim_clone(a, &c);
        tsk_set_allocator(NULL, NULL, NULL);
        if (s == TSK_OK) {
            tsk_blade_sim_destroy(c);
            break;
        }
        ++failures;
        CHECK(s == TSK_ERR_MEMORY && c == NULL);
        CHECK(tsk_allocated_bytes() == held);
    }
    CHECK_MSG(failures >= 4 && failures < 64, "%d failing allocations", failures);
    CHECK_STATUS(tsk_blade_sim_clone(NULL, &b), TSK_ERR_ARGUMENT, "sim");
    CHECK_STATUS(tsk_blade_sim_clone(a, NULL), TSK_ERR_ARGUMENT, "out");
    tsk_blade_sim_destroy(a);
}

TEST(test_sim_bad_input_names_the_argument) {
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    tsk_blade_sim* sim = NULL;
    def.knot_count = 65;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_LIMIT, "knot_count");
    def.knot_count = 1;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "knot_count");
    def = tsk_default_blade_sim_def();
    def.tile_size = 0.0f;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "tile_size");
    def = tsk_default_blade_sim_def();
    def.damping = NAN;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "damping");
    def = tsk_default_blade_sim_def();
    def.tiles_x = 1 << 13, def.tiles_y = 1 << 13;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_LIMIT, "tiles_x");
    def = tsk_default_blade_sim_def();
    def.iterations = 0;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "iterations");
    def = tsk_default_blade_sim_def();
    def.settle_frames = 0;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "settle_frames");
    def = tsk_default_blade_sim_def();
    def.settle_blend_frames = -3;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "settle_blend_frames");
    CHECK(sim == NULL);
    CHECK_STATUS(tsk_blade_sim_create(NULL, &sim), TSK_ERR_ARGUMENT, "def");

    def = tsk_default_blade_sim_def();
    CHECK(tsk_blade_sim_create(&def, &sim) == TSK_OK);
    CHECK_STATUS(tsk_blade_sim_step(sim, -0.01f, NULL, TSK_WIND_NONE), TSK_ERR_ARGUMENT, "dt");
    CHECK_STATUS(tsk_blade_sim_step(sim, NAN, NULL, TSK_WIND_NONE), TSK_ERR_ARGUMENT, "dt");
    CHECK_STATUS(tsk_blade_sim_step(sim, 0.01f, NULL, TSK_WIND_UNIFORM), TSK_ERR_ARGUMENT, "wind");
    const float bad_wind[3] = {0, NAN, 0};
    CHECK_STATUS(tsk_blade_sim_step(sim, 0.01f, bad_wind, TSK_WIND_UNIFORM), TSK_ERR_ARGUMENT,
                 "wind");
    CHECK_STATUS(tsk_blade_sim_step(sim, 0.01f, NULL, (tsk_wind_layout)9), TSK_ERR_ARGUMENT,
                 "layout");

    static tsk_blade_collider many[TSK_BLADE_SIM_MAX_COLLIDERS + 1];
    for (int i = 0; i <= TSK_BLADE_SIM_MAX_COLLIDERS; ++i)
        many[i] = (tsk_blade_collider){TSK_COLLIDER_SPHERE, 0.1f, {0, 0, 0}, {0, 0, 0}};
    CHECK_STATUS(tsk_blade_sim_set_colliders(sim, many, TSK_BLADE_SIM_MAX_COLLIDERS + 1),
                 TSK_ERR_LIMIT, "count");
    many[2].radius = -1.0f;
    CHECK_STATUS(tsk_blade_sim_set_colliders(sim, many, 3), TSK_ERR_ARGUMENT, "colliders");
    many[2].radius = 0.1f;
    many[1].a[1] = INFINITY;
    CHECK_STATUS(tsk_blade_sim_set_colliders(sim, many, 3), TSK_ERR_ARGUMENT, "colliders");
    many[1].a[1] = 0.0f;
    many[1].kind = 7;
    CHECK_STATUS(tsk_blade_sim_set_colliders(sim, many, 3), TSK_ERR_ARGUMENT, "colliders");
    CHECK_STATUS(tsk_blade_sim_set_colliders(sim, NULL, 2), TSK_ERR_ARGUMENT, "colliders");

    float knots[K16 * 3], widths[K16], side[3];
    const float root[3] = {0.1f, 0.1f, 0.0f};
    make_blade(K16, root, 0.3f, 0.2f, 0.0f, knots, widths, side);
    CHECK_STATUS(tsk_blade_sim_activate_tile(sim, 400), TSK_ERR_ARGUMENT, "tile");
    CHECK_STATUS(tsk_blade_sim_provide_tile(sim, -1, 1, knots, widths, side), TSK_ERR_ARGUMENT,
                 "tile");
    knots[3 * 5 + 1] = NAN;
    CHECK_STATUS(tsk_blade_sim_provide_tile(sim, 0, 1, knots, widths, side), TSK_ERR_ARGUMENT,
                 "knots");
    make_blade(K16, root, 0.3f, 0.2f, 0.0f, knots, widths, side);
    knots[3 * 6] = knots[3 * 5], knots[3 * 6 + 1] = knots[3 * 5 + 1],
              knots[3 * 6 + 2] = knots[3 * 5 + 2];
    CHECK_STATUS(tsk_blade_sim_provide_tile(sim, 0, 1, knots, widths, side), TSK_ERR_ARGUMENT,
                 "zero length");
    make_blade(K16, root, 0.3f, 0.2f, 0.0f, knots, widths, side);
    widths[3] = -0.001f;
    CHECK_STATUS(tsk_blade_sim_provide_tile(sim, 0, 1, knots, widths, side), TSK_ERR_ARGUMENT,
                 "widths");
    widths[3] = 0.001f;
    side[0] = NAN;
    CHECK_STATUS(tsk_blade_sim_provide_tile(sim, 0, 1, knots, widths, side), TSK_ERR_ARGUMENT,
                 "sides");
    CHECK_STATUS(tsk_blade_sim_provide_tile(sim, 0, TSK_BLADE_SIM_MAX_BLADES_PER_TILE + 1, knots,
                                            widths, NULL),
                 TSK_ERR_LIMIT, "blade_count");
    CHECK_STATUS(tsk_blade_sim_provide_tile(sim, 0, 1, NULL, widths, NULL), TSK_ERR_ARGUMENT,
                 "knots");
    CHECK(tsk_blade_sim_provide_tile(sim, 0, 1, knots, widths, NULL) == TSK_OK);
    CHECK_STATUS(tsk_blade_sim_provide_tile(sim, 0, 1, knots, widths, NULL), TSK_ERR_ARGUMENT,
                 "already active");
    CHECK_STATUS(tsk_blade_sim_get_tile_knots(sim, 1, knots), TSK_ERR_ARGUMENT, "not active");
    tsk_blade_sim_destroy(sim);
}

/* fuzz_sim: a sphere of radius 3.4e38 (finite, so accepted) centred at 3.4e38 made every knot
 * of every blade NaN (r^2 and the squared distance overflow to inf, inf - inf is NaN). Sizes
 * and positions beyond TSK_BLADE_SIM_MAX_COORD, gravity and wind beyond their bounds are
 * refused now, naming the argument; the largest accepted ones keep every knot finite. */
TEST(test_sim_huge_colliders_and_values_are_refused_not_nan) {
    enum { N = 8 };
    static float knots[N * K16 * 3], widths[N * K16], sides[N * 3], out[N * K16 * 3];
    make_row(K16, N, 0.0f, 0.05f, 0.0f, knots, widths, sides);
    tsk_blade_sim* sim = one_tile_sim(big_tile_def(), N, knots, widths, sides);
    tsk_blade_collider c = {TSK_COLLIDER_SPHERE, FLT_MAX, {FLT_MAX, FLT_MAX, 0.1f}, {0, 0, 0}};
    CHECK_STATUS(tsk_blade_sim_set_colliders(sim, &c, 1), TSK_ERR_ARGUMENT, "colliders");
    c = (tsk_blade_collider){TSK_COLLIDER_CAPSULE, 0.1f, {0, 0, 0}, {0, -2e6f, 0}};
    CHECK_STATUS(tsk_blade_sim_set_colliders(sim, &c, 1), TSK_ERR_ARGUMENT, "colliders");
    /* the largest accepted: a sphere of radius 1e6 m whose surface passes through the blades */
    c = (tsk_blade_collider){TSK_COLLIDER_SPHERE,
                             TSK_BLADE_SIM_MAX_COORD,
                             {0.1f, 0.0f, 0.1f - TSK_BLADE_SIM_MAX_COORD},
                             {0, 0, 0}};
    CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
    float wind[3] = {TSK_BLADE_SIM_MAX_WIND, 0, 0};
    for (int i = 0; i < 5; ++i)
        CHECK(tsk_blade_sim_step(sim, 1.0f / 48, wind, TSK_WIND_UNIFORM) == TSK_OK);
    CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
    int finite = 1;
    for (int i = 0; i < N * K16 * 3; ++i) finite &= isfinite(out[i]) != 0;
    CHECK_MSG(finite, "a knot is not finite after stepping with the largest collider and wind");
    /* blades deep inside a capsule of 200 km (fuzz_sim): pushed out 200 km in one step, a
       displacement beyond binary16's range; it is clamped, so nothing becomes NaN */
    tsk_blade_sim_destroy(sim);
    make_row(K16, N, 0.0f, 0.05f, 0.0f, knots, widths, sides);
    sim = one_tile_sim(big_tile_def(), N, knots, widths, sides);
    c = (tsk_blade_collider){TSK_COLLIDER_CAPSULE, 2e5f, {5.8e5f, 0.0f, 0.1f}, {0.0f, 0.0f, 0.1f}};
    CHECK(tsk_blade_sim_set_colliders(sim, &c, 1) == TSK_OK);
    for (int i = 0; i < 3; ++i)
        CHECK(tsk_blade_sim_step(sim, 1.0f / 48, NULL, TSK_WIND_NONE) == TSK_OK);
    CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
    for (int i = 0; i < N * K16 * 3; ++i) finite &= isfinite(out[i]) != 0;
    CHECK_MSG(finite, "a knot is not finite after a push of 200 km");
    wind[0] = 2 * TSK_BLADE_SIM_MAX_WIND;
    CHECK_STATUS(tsk_blade_sim_step(sim, 1.0f / 48, wind, TSK_WIND_UNIFORM), TSK_ERR_ARGUMENT,
                 "wind");
    wind[0] = FLT_MAX;
    CHECK_STATUS(tsk_blade_sim_step(sim, 1.0f / 48, wind, TSK_WIND_UNIFORM), TSK_ERR_ARGUMENT,
                 "wind");
    tsk_blade_sim_destroy(sim);
    /* a blade folding back on itself (a knot thrown 10 m sideways and back, fuzz_sim): its
       rest frames are undefined at the fold, so it is refused rather than started from a
       pose centimetres away from the one given */
    {
        tsk_blade_sim_def fd = tsk_default_blade_sim_def();
        tsk_blade_sim* fs = NULL;
        CHECK(tsk_blade_sim_create(&fd, &fs) == TSK_OK);
        CHECK(tsk_blade_sim_activate_tile(fs, 0) == TSK_OK);
        make_row(K16, 1, 0.0f, 0.05f, 0.0f, knots, widths, sides);
        knots[3 * 3 + 1] = 10.0f;
        CHECK_STATUS(tsk_blade_sim_provide_tile(fs, 0, 1, knots, widths, sides), TSK_ERR_ARGUMENT,
                     "folds back on itself at knot 3");
        make_row(K16, 1, 0.0f, 0.05f, 0.0f, knots, widths, sides);
        CHECK(tsk_blade_sim_provide_tile(fs, 0, 1, knots, widths, sides) == TSK_OK);
        tsk_blade_sim_destroy(fs);
    }
    /* a knot 2000 km up */
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    CHECK(tsk_blade_sim_create(&def, &sim) == TSK_OK);
    knots[3 * 4 + 2] = 2e6f;
    CHECK_STATUS(tsk_blade_sim_provide_tile(sim, 0, 1, knots, widths, NULL), TSK_ERR_ARGUMENT,
                 "knots");
    tsk_blade_sim_destroy(sim);
    /* definition fields */
    def.collision_margin = FLT_MAX;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "collision_margin");
    def = tsk_default_blade_sim_def();
    def.activation_margin = 3e30f;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "activation_margin");
    def = tsk_default_blade_sim_def();
    def.gravity[2] = -1e30f;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "gravity");
    def = tsk_default_blade_sim_def();
    def.origin[0] = 5e6f;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "origin");
    def = tsk_default_blade_sim_def();
    def.ground_height = -FLT_MAX;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "ground_height");
    def = tsk_default_blade_sim_def();
    def.tile_size = 1e7f;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "tile_size");
    def = tsk_default_blade_sim_def();
    def.max_blade_height = FLT_MAX;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "max_blade_height");
    CHECK(sim == NULL);
}

/* fuzz_sim: wind_drag 3.4e38 (finite, >= 0, so accepted) made the per-step drag inf, and
 * inf times the zero width of a blade's tip is NaN: the blade became NaN. The ratio
 * wind_drag / linear_density is bounded now; at the bound, zero-width tips stay finite. */
TEST(test_sim_huge_wind_drag_is_refused_and_the_largest_stays_finite) {
    tsk_blade_sim_def def = big_tile_def();
    tsk_blade_sim* sim = NULL;
    def.wind_drag = FLT_MAX;
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "wind_drag");
    def.wind_drag = 0.2f;
    def.linear_density = FLT_MIN; /* 0.2 / 1.2e-38: beyond the bound too */
    CHECK_STATUS(tsk_blade_sim_create(&def, &sim), TSK_ERR_ARGUMENT, "wind_drag");
    CHECK(sim == NULL);
    enum { N = 4 };
    static float knots[N * K16 * 3], widths[N * K16], sides[N * 3], out[N * K16 * 3];
    make_row(K16, N, 0.0f, 0.05f, 0.0f, knots, widths, sides); /* tip widths are 0 */
    CHECK(widths[K16 - 1] == 0.0f);
    def = big_tile_def();
    def.wind_drag = 1e27f;
    def.linear_density = 1e-3f; /* ratio 1e30: the largest accepted */
    sim = one_tile_sim(def, N, knots, widths, sides);
    const float wind[3] = {5.0f, 0.0f, 0.0f};
    for (int i = 0; i < 4; ++i)
        CHECK(tsk_blade_sim_step(sim, 1.0f / 48, wind, TSK_WIND_UNIFORM) == TSK_OK);
    CHECK(tsk_blade_sim_get_tile_knots(sim, 0, out) == TSK_OK);
    int finite = 1;
    for (int i = 0; i < N * K16 * 3; ++i) finite &= isfinite(out[i]) != 0;
    CHECK_MSG(finite, "a knot is not finite with the largest accepted drag");
    tsk_blade_sim_destroy(sim);
}

/* The per-tile state counts against the memory budget: a tile that would take the state past
 * it is refused with a message, stays pending, and nothing is held for it. */
TEST(test_sim_tile_over_memory_budget_is_refused) {
    enum { N = 100 };
    static float knots[N * K16 * 3], widths[N * K16], sides[N * 3];
    make_row(K16, N, 0.0f, 0.004f, 0.0f, knots, widths, sides);
    tsk_blade_sim_def def = big_tile_def();
    def.tiles_x = 2;
    tsk_blade_sim* sim = NULL;
    CHECK(tsk_blade_sim_create(&def, &sim) == TSK_OK);
    CHECK(tsk_blade_sim_activate_tile(sim, 0) == TSK_OK);
    CHECK(tsk_blade_sim_activate_tile(sim, 1) == TSK_OK);
    const size_t before = tsk_allocated_bytes();
    /* room for two and a half blocks of 32 blades: 100 blades need 4 */
    const size_t block_bytes = (SIM_BLOCK_FLOATS(K16) + 6) * sizeof(float);
    tsk_set_memory_budget(block_bytes * 5 / 2);
    CHECK_STATUS(tsk_blade_sim_provide_tile(sim, 0, N, knots, widths, sides), TSK_ERR_LIMIT,
                 "memory budget");
    CHECK(tsk_blade_sim_tile_state(sim, 0) == 2);
    CHECK(tsk_allocated_bytes() == before);
    CHECK(tsk_blade_sim_provide_tile(sim, 0, 32, knots, widths, sides) == TSK_OK); /* one block */
    CHECK_STATUS(tsk_blade_sim_provide_tile(sim, 1, 64, knots, widths, sides), TSK_ERR_LIMIT,
                 "memory budget"); /* 1 + 2 blocks: past the budget together */
    tsk_set_memory_budget(0);
    CHECK(tsk_blade_sim_provide_tile(sim, 1, 64, knots, widths, sides) == TSK_OK);
    tsk_blade_sim_destroy(sim);
}

TEST_MAIN(TEST_ENTRY(test_sim_starts_exactly_at_rest_pose),
          TEST_ENTRY(test_sim_blade_at_rest_stays_at_rest),
          TEST_ENTRY(test_sim_without_preload_gravity_bends_blades_down),
          TEST_ENTRY(test_sim_free_blade_hangs_and_follows_wind),
          TEST_ENTRY(test_sim_wind_bends_downwind_more_with_stronger_wind),
          TEST_ENTRY(test_sim_sphere_never_inside_and_blades_recover),
          TEST_ENTRY(test_sim_capsule_never_inside_and_blades_recover),
          TEST_ENTRY(test_sim_contact_holds_for_5_to_64_knots),
          TEST_ENTRY(test_sim_local_shape_alone_restores_bend),
          TEST_ENTRY(test_sim_ground_never_penetrated),
          TEST_ENTRY(test_sim_identical_bytes_with_1_and_2_threads),
          TEST_ENTRY(test_sim_kernel_paths_give_identical_bytes),
          TEST_ENTRY(test_sim_validate_finds_corrupt_tile_lists),
          TEST_ENTRY(test_sim_wind_per_blade_equals_wind_per_knot),
          TEST_ENTRY(test_sim_tile_activates_then_releases_and_frees_memory),
          TEST_ENTRY(test_sim_touched_tile_never_releases),
          TEST_ENTRY(test_sim_all_knots_are_the_tiles_knots_in_order),
          TEST_ENTRY(test_sim_ribbons_are_the_expanded_knots),
          TEST_ENTRY(test_sim_tile_in_steady_wind_settles_and_is_freed),
          TEST_ENTRY(test_sim_clone_resumes_with_identical_bytes),
          TEST_ENTRY(test_sim_bad_input_names_the_argument),
          TEST_ENTRY(test_sim_huge_colliders_and_values_are_refused_not_nan),
          TEST_ENTRY(test_sim_tile_over_memory_budget_is_refused),
          TEST_ENTRY(test_sim_huge_wind_drag_is_refused_and_the_largest_stays_finite))
