/* Fuzz target: the blade simulation. The bytes give a tsk_blade_sim_def (every field, edge
 * values included), validated at full range by tsk_blade_sim_create; an accepted definition
 * gets up to 4 colliders (spheres and capsules, fuzzed radius and ends, some placed over the
 * grid), the tiles they touch (and a fuzzed tile forced by tsk_blade_sim_activate_tile) are
 * given rest blades (0..40 per tile, 2..64 knots, occasionally an edge value in a knot,
 * width or side), and the simulation is stepped 1..8 times with a fuzzed dt and wind (every
 * layout), moving the colliders between steps. After every step that succeeds the contracts
 * are checked: every knot finite, no knot but the pinned roots below ground_height (within
 * float rounding), a provided tile starting at its rest pose (within rounding), info
 * consistent with the active list, ribbons made from the solver's blocks the same bits as
 * tsk_blades_expand makes of its knots, and nothing left allocated after destroy. Cost only: at
 * most 4 tiles are given blades. */
#include "fuzz.h"
#include "tussock/meadow.h"
#include "tussock/sim.h"

int LLVMFuzzerInitialize(int* argc, char*** argv) {
    (void)argc;
    (void)argv;
    fz_init();
    return 0;
}

enum { MAX_BLADES = 40, MAX_PROVIDED = 4, MAX_COLS = 4 };

static void fuzz_def(fz* r, tsk_blade_sim_def* d) {
    *d = tsk_default_blade_sim_def();
    d->tiles_x = d->tiles_y = 4;
    if (fz_u8(r) & 1) return; /* defaults (a 4 x 4 grid) */
    for (int c = 0; c < 3; ++c) d->origin[c] = fz_float(r, d->origin[c]);
    d->tile_size = fz_float(r, d->tile_size);
    d->tiles_x = fz_int(r, d->tiles_x);
    d->tiles_y = fz_int(r, d->tiles_y);
    d->knot_count = fz_int(r, (fz_u8(r) & 1) ? 4 : d->knot_count);
    for (int c = 0; c < 3; ++c) d->gravity[c] = fz_float(r, d->gravity[c]);
    d->gravity_preload = fz_float(r, d->gravity_preload);
    d->damping = fz_float(r, d->damping);
    d->wind_drag = fz_float(r, d->wind_drag);
    d->linear_density = fz_float(r, d->linear_density);
    d->global_stiffness_root = fz_float(r, d->global_stiffness_root);
    d->global_stiffness_tip = fz_float(r, d->global_stiffness_tip);
    d->local_stiffness = fz_float(r, d->local_stiffness);
    d->iterations = fz_int(r, d->iterations);
    d->ground_height = fz_float(r, d->ground_height);
    d->collision_margin = fz_float(r, d->collision_margin);
    d->activation_margin = fz_float(r, d->activation_margin);
    d->max_blade_height = fz_float(r, d->max_blade_height);
    d->rest_distance = fz_float(r, d->rest_distance);
    d->rest_speed = fz_float(r, d->rest_speed);
    d->rest_frames = fz_int(r, (fz_u8(r) & 1) ? 2 : d->rest_frames);
    d->blend_frames = fz_int(r, (fz_u8(r) & 1) ? 1 : d->blend_frames);
    d->settle_frames = fz_int(r, (fz_u8(r) & 1) ? 3 : d->settle_frames);
    d->settle_blend_frames = fz_int(r, (fz_u8(r) & 1) ? 2 : d->settle_blend_frames);
}

/* A point over the grid: tile (i, j) picked by the bytes, a fraction inside it. */
static float over_grid(fz* r, const tsk_blade_sim_def* d, int axis) {
    const int n = axis == 0 ? d->tiles_x : d->tiles_y;
    const int t = (int)(fz_u8(r) % (unsigned)(n < 8 ? n : 8));
    return d->origin[axis] + ((float)t + fz_u8(r) / 255.0f) * d->tile_size;
}

static void fuzz_colliders(fz* r, const tsk_blade_sim_def* d, tsk_blade_collider* c, int n) {
    for (int i = 0; i < n; ++i) {
        c[i].kind = (fz_u8(r) % 16) ? (int32_t)(fz_u8(r) & 1) : fz_int(r, 0);
        c[i].radius = fz_float(r, 0.05f + d->tile_size * 0.3f);
        for (int k = 0; k < 3; ++k) {
            const float base = k < 2 ? over_grid(r, d, k) : d->ground_height + 0.1f;
            c[i].a[k] = fz_float(r, base);
            c[i].b[k] = fz_float(r, base + (k == 0 ? 0.2f : 0.0f));
        }
    }
}

/* Rest blades for tile t: leaning analytic blades rooted inside the tile. */
static int make_tile(fz* r, const tsk_blade_sim_def* d, int32_t t, int n, float* knots,
                     float* widths, float* sides) {
    const int K = d->knot_count;
    const float x0 = d->origin[0] + (float)(t % d->tiles_x) * d->tile_size;
    const float y0 = d->origin[1] + (float)(t / d->tiles_x) * d->tile_size;
    for (int b = 0; b < n; ++b) {
        const float u = fz_u8(r) / 255.0f, v = fz_u8(r) / 255.0f;
        const float H = 0.05f + 0.5f * (fz_u8(r) / 255.0f);
        const float lean = (fz_u8(r) / 255.0f) - 0.5f, turn = 0.05f * (float)fz_u8(r);
        const float c = cosf(turn), s = sinf(turn);
        for (int k = 0; k < K; ++k) {
            const float q = (float)k / (float)(K - 1);
            float* x = knots + ((size_t)b * K + k) * 3;
            x[0] = x0 + u * d->tile_size + c * lean * H * q * q;
            x[1] = y0 + v * d->tile_size + s * lean * H * q * q;
            x[2] = d->ground_height + H * q;
            widths[(size_t)b * K + k] = 0.008f * (1.0f - q * q * q);
        }
        sides[3 * b] = -s, sides[3 * b + 1] = c, sides[3 * b + 2] = 0.0f;
    }
    if (n > 0 && fz_u8(r) % 8 == 0) { /* one edge value somewhere */
        const size_t kn = (size_t)n * K * 3, wn = (size_t)n * K;
        const uint32_t which = fz_u32(r);
        const int what = fz_u8(r) % 3;
        float* v = what == 0   ? &knots[which % kn]
                   : what == 1 ? &widths[which % wn]
                               : &sides[which % ((size_t)n * 3)];
        *v = fz_float(r, what == 2 ? 1.0f : *v);
        if (getenv("TSK_FUZZ_VERBOSE"))
            fprintf(stderr, "tile %d: %s value %u set to %g\n", t,
                    what == 0   ? "knot"
                    : what == 1 ? "width"
                                : "side",
                    (unsigned)(which % (what == 0   ? kn
                                        : what == 1 ? wn
                                                    : (size_t)n * 3)),
                    (double)*v);
    }
    return fz_u8(r) % 8 != 0; /* pass sides (else NULL) */
}

static void dump_def(const tsk_blade_sim_def* d) {
    fprintf(stderr,
            "def: origin %g %g %g tile %g tiles %d x %d K %d gravity %g %g %g preload %g "
            "damping %g drag %g density %g stiff %g %g local %g it %d ground %g margin %g "
            "act %g maxh %g rest %g %g frames %d %d settle %d %d\n",
            (double)d->origin[0], (double)d->origin[1], (double)d->origin[2], (double)d->tile_size,
            d->tiles_x, d->tiles_y, d->knot_count, (double)d->gravity[0], (double)d->gravity[1],
            (double)d->gravity[2], (double)d->gravity_preload, (double)d->damping,
            (double)d->wind_drag, (double)d->linear_density, (double)d->global_stiffness_root,
            (double)d->global_stiffness_tip, (double)d->local_stiffness, d->iterations,
            (double)d->ground_height, (double)d->collision_margin, (double)d->activation_margin,
            (double)d->max_blade_height, (double)d->rest_distance, (double)d->rest_speed,
            d->rest_frames, d->blend_frames, d->settle_frames, d->settle_blend_frames);
}

static void check_state(const tsk_blade_sim* sim, const tsk_blade_sim_def* d) {
    tsk_blade_sim_info info;
    if (tsk_blade_sim_get_info(sim, &info) != TSK_OK) abort();
    if (info.knot_count != d->knot_count || info.active_tiles < 0 || info.active_blades < 0)
        abort();
    int32_t tiles[64], counts[64];
    if (info.active_tiles > 64) abort(); /* never more than MAX_PROVIDED + forced */
    if (tsk_blade_sim_get_active(sim, tiles, counts) != TSK_OK) abort();
    int64_t sum = 0;
    for (int32_t i = 0; i < info.active_tiles; ++i) {
        if (i > 0 && tiles[i] <= tiles[i - 1]) abort();
        if (tsk_blade_sim_tile_state(sim, tiles[i]) != 1) abort();
        sum += counts[i];
    }
    if (sum != info.active_blades) abort();
    if ((info.active_blades == 0) != (info.state_bytes == 0) && info.active_blades > 0) abort();
    const size_t n = (size_t)info.active_blades * d->knot_count * 3;
    if (n == 0) return;
    float* knots = malloc(n * sizeof *knots);
    if (tsk_blade_sim_get_knots(sim, knots) != TSK_OK) abort();
    const float tol = 1e-4f * (1.0f + fabsf(d->ground_height));
    for (size_t i = 0; i < n; ++i) {
        if (!isfinite(knots[i])) {
            size_t blade = i / 3 / (size_t)d->knot_count;
            int32_t at = 0;
            while (at < info.active_tiles && blade >= (size_t)counts[at]) blade -= counts[at++];
            fprintf(stderr, "sim: knot value %zu of %zu is %g (tile %d, blade %zu, knot %zu)\n", i,
                    n, (double)knots[i], at < info.active_tiles ? tiles[at] : -1, blade,
                    i / 3 % (size_t)d->knot_count);
            dump_def(d);
            abort();
        }
        /* roots (knot 0) are pinned where they were provided, even below the ground */
        if (i % 3 == 2 && (i / 3) % (size_t)d->knot_count != 0 &&
            knots[i] < d->ground_height - tol) {
            fprintf(stderr, "sim: knot %zu below the ground: z %g < %g\n", i / 3, (double)knots[i],
                    (double)d->ground_height);
            dump_def(d);
            abort();
        }
    }
    /* the ribbons made from the blocks are those tsk_blades_expand makes of the knots (same
     * bits; where a huge value overflowed, NaN in both) for a range not starting at 0 */
    const size_t nb = (size_t)info.active_blades, K = (size_t)d->knot_count;
    const size_t f = nb / 3, c = nb - f;
    float* w = malloc(nb * K * sizeof *w);
    float* sd = malloc(nb * 3 * sizeof *sd);
    float* ra = malloc(c * K * 6 * sizeof *ra);
    float* rb = malloc(c * K * 6 * sizeof *rb);
    for (size_t i = 0; i < nb * K; ++i) w[i] = 0.002f * (float)(i % 7);
    for (size_t b = 0; b < nb; ++b) sd[3 * b] = 1.0f, sd[3 * b + 1] = 0.5f, sd[3 * b + 2] = 0.0f;
    if (tsk_blade_sim_get_ribbons(sim, (int64_t)f, (int64_t)c, w + f * K, sd + 3 * f, ra) !=
            TSK_OK ||
        tsk_blades_expand(knots + f * K * 3, w + f * K, sd + 3 * f, c, (int32_t)K, rb, NULL,
                          NULL) != TSK_OK) {
        fprintf(stderr, "sim: ribbons refused: %s\n", tsk_last_error());
        abort();
    }
    for (size_t i = 0; i < c * K * 6; ++i)
        if (memcmp(&ra[i], &rb[i], sizeof(float)) != 0 && !(isnan(ra[i]) && isnan(rb[i]))) {
            fprintf(stderr, "sim: ribbon value %zu is %g, tsk_blades_expand says %g\n", i,
                    (double)ra[i], (double)rb[i]);
            dump_def(d);
            abort();
        }
    free(w), free(sd), free(ra), free(rb);
    free(knots);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fz r = {data, size};
    tsk_blade_sim_def d;
    fuzz_def(&r, &d);
    tsk_blade_sim* sim = NULL;
    if (tsk_blade_sim_create(&d, &sim) != TSK_OK) {
        if (sim != NULL) abort();
        fz_check_leaks("sim (refused)");
        return 0;
    }
    const int K = d.knot_count;
    float* knots = malloc((size_t)MAX_BLADES * K * 3 * sizeof *knots);
    float* widths = malloc((size_t)MAX_BLADES * K * sizeof *widths);
    float* sides = malloc((size_t)MAX_BLADES * 3 * sizeof *sides);
    float* wind = NULL;
    tsk_blade_collider cols[MAX_COLS];
    int ncol = 1 + fz_u8(&r) % MAX_COLS;
    fuzz_colliders(&r, &d, cols, ncol);
    int32_t count = ncol;
    if (fz_u8(&r) % 32 == 0) count = fz_int(&r, ncol);
    if (count > ncol) count = ncol + 1 + TSK_BLADE_SIM_MAX_COLLIDERS; /* refused: too many */
    (void)tsk_blade_sim_set_colliders(sim, count > ncol ? NULL : cols, count);
    if (fz_u8(&r) % 4 == 0) (void)tsk_blade_sim_activate_tile(sim, fz_int(&r, 0));
    const int steps = 1 + fz_u8(&r) % 8;
    int provided = 0;
    for (int step = 0; step < steps; ++step) {
        int32_t pending[256];
        int32_t np = tsk_blade_sim_pending_count(sim);
        if (np < 0) abort();
        if (np > 0 && np <= 256) {
            if (tsk_blade_sim_get_pending(sim, pending) != TSK_OK) abort();
            for (int32_t i = 0; i < np; ++i) {
                if (i > 0 && pending[i] <= pending[i - 1]) abort();
                if (tsk_blade_sim_tile_state(sim, pending[i]) != 2) abort();
                if (provided >= MAX_PROVIDED) break;
                const int n = fz_u8(&r) % (MAX_BLADES + 1);
                const int with_sides = make_tile(&r, &d, pending[i], n, knots, widths, sides);
                const tsk_status s = tsk_blade_sim_provide_tile(sim, pending[i], n, knots, widths,
                                                                with_sides ? sides : NULL);
                if (s == TSK_OK) {
                    ++provided;
                    if (tsk_blade_sim_tile_state(sim, pending[i]) != 1) abort();
                    float* back = malloc(((size_t)n * K * 3 + 1) * sizeof *back);
                    if (tsk_blade_sim_get_tile_knots(sim, pending[i], back) != TSK_OK) abort();
                    /* the rest pose is rebuilt from directions and lengths: equal to the
                       knots up to rounding (test_sim: < 2e-6 m for ordinary blades) */
                    /* rounding grows with coordinates and with the blades' length */
                    float big = 0.0f, arc = 0.0f;
                    for (size_t q = 0; q < (size_t)n * K * 3; ++q)
                        big = fmaxf(big, fabsf(knots[q]));
                    for (int b = 0; b < n; ++b) {
                        float a = 0.0f;
                        for (int k = 1; k < K; ++k) {
                            const float* x = knots + ((size_t)b * K + k) * 3;
                            a += sqrtf((x[0] - x[-3]) * (x[0] - x[-3]) +
                                       (x[1] - x[-2]) * (x[1] - x[-2]) +
                                       (x[2] - x[-1]) * (x[2] - x[-1]));
                        }
                        arc = fmaxf(arc, a);
                    }
                    const float tol = 1e-4f * (1.0f + big + (float)K * arc);
                    for (size_t q = 0; q < (size_t)n * K * 3; ++q)
                        if (!(fabsf(back[q] - knots[q]) <= tol)) {
                            fprintf(stderr, "sim: provided knot %zu starts at %g, not %g\n", q / 3,
                                    (double)back[q], (double)knots[q]);
                            abort();
                        }
                    free(back);
                }
            }
        }
        tsk_blade_sim_info info;
        if (tsk_blade_sim_get_info(sim, &info) != TSK_OK) abort();
        int layout = fz_u8(&r) % 4;
        /* room for the largest layout: a fuzzed layout below may pick any of them (the step
           cannot know the buffer's size; a short one is the caller's bug) */
        const size_t nw = 3 + (size_t)info.active_blades * K * 3;
        free(wind);
        wind = malloc((nw + 1) * sizeof *wind);
        const float wx = fz_float(&r, 1.0f), wy = fz_float(&r, 0.5f);
        for (size_t i = 0; i < nw; ++i) wind[i] = i % 3 == 0 ? wx : i % 3 == 1 ? wy : 0.0f;
        if (fz_u8(&r) % 16 == 0) layout = fz_int(&r, layout); /* unknown layouts are refused */
        const float dt = (fz_u8(&r) % 4) ? 1.0f / 48.0f : fz_float(&r, 1.0f / 48.0f);
        const tsk_status s = tsk_blade_sim_step(sim, dt, layout == TSK_WIND_NONE ? NULL : wind,
                                                (tsk_wind_layout)layout);
        if (getenv("TSK_FUZZ_VERBOSE")) {
            fprintf(stderr, "step %d: dt %g wind %d (%g, %g) -> %d; colliders", step, (double)dt,
                    layout, (double)wx, (double)wy, (int)s);
            for (int i = 0; i < ncol; ++i)
                fprintf(stderr, " [%d r %g a %g %g %g b %g %g %g]", cols[i].kind,
                        (double)cols[i].radius, (double)cols[i].a[0], (double)cols[i].a[1],
                        (double)cols[i].a[2], (double)cols[i].b[0], (double)cols[i].b[1],
                        (double)cols[i].b[2]);
            fprintf(stderr, "\n");
        }
        if (s == TSK_OK) check_state(sim, &d);
        /* move the colliders (a step of a walking foot) */
        for (int i = 0; i < ncol; ++i) {
            const float dx = (float)(int8_t)fz_u8(&r) * 0.01f * d.tile_size;
            cols[i].a[0] += dx;
            cols[i].b[0] += dx;
        }
        (void)tsk_blade_sim_set_colliders(sim, cols, ncol);
    }
    free(wind);
    free(knots);
    free(widths);
    free(sides);
    tsk_blade_sim_destroy(sim);
    fz_check_leaks("sim");
    return 0;
}
