/* Tile management of the blade simulation (Fan et al. 2015 as seed 000 §3 and §4.5 use it):
 * colliders touch tiles, touched tiles wait for their rest blades, active tiles are stepped in
 * parallel block by block, and quiet tiles blend back to rest and are freed, so a tile that is
 * not active holds no memory. */
#include "core/invariant.h"
#include "meadow/ribbon_input.h"
#include "sim/sim_internal.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* cos of the sharpest turn allowed between two consecutive rest segments: 170 degrees */
#define SIM_MAX_FOLD_COS (-0.98480775301220802)

/* ---- small sorted int arrays --------------------------------------------------------------- */

static int cmp_i32(const void* a, const void* b) {
    int32_t x = *(const int32_t*)a, y = *(const int32_t*)b;
    return (x > y) - (x < y);
}

static int32_t find_i32(const int32_t* v, int32_t n, int32_t key) {
    int32_t lo = 0, hi = n;
    while (lo < hi) {
        int32_t mid = lo + (hi - lo) / 2;
        if (v[mid] < key) lo = mid + 1;
        else hi = mid;
    }
    return (lo < n && v[lo] == key) ? lo : -1;
}

static int32_t find_tile(const tsk_blade_sim* sim, int32_t key) {
    int32_t lo = 0, hi = sim->tile_count;
    while (lo < hi) {
        int32_t mid = lo + (hi - lo) / 2;
        if (sim->tiles[mid].index < key) lo = mid + 1;
        else hi = mid;
    }
    return (lo < sim->tile_count && sim->tiles[lo].index == key) ? lo : -1;
}

/* Inserts key into a sorted array (reallocated through tsk_alloc); returns 0 on failure. */
static int insert_i32(int32_t** v, int32_t* n, int32_t key) {
    if (find_i32(*v, *n, key) >= 0) return 1;
    int32_t* nv = tsk_alloc(sizeof(int32_t) * (size_t)(*n + 1), "tile list");
    if (!nv) return 0;
    int32_t i = 0;
    for (; i < *n && (*v)[i] < key; ++i) nv[i] = (*v)[i];
    nv[i] = key;
    for (; i < *n; ++i) nv[i + 1] = (*v)[i];
    tsk_free(*v);
    *v = nv;
    ++*n;
    return 1;
}

static void remove_i32(int32_t** v, int32_t* n, int32_t key) {
    int32_t i = find_i32(*v, *n, key);
    if (i < 0) return;
    memmove(*v + i, *v + i + 1, sizeof(int32_t) * (size_t)(*n - i - 1));
    if (--*n == 0) {
        tsk_free(*v);
        *v = NULL;
    }
}

/* pending = (touched U forced) \ active */
static tsk_status rebuild_pending(tsk_blade_sim* sim) {
    tsk_free(sim->pending);
    sim->pending = NULL;
    sim->pending_count = 0;
    int32_t cap = sim->touched_count + sim->forced_count;
    if (cap == 0) return TSK_OK;
    int32_t* out = tsk_alloc(sizeof(int32_t) * (size_t)cap, "pending tiles");
    if (!out) return TSK_ERR_MEMORY;
    int32_t n = 0, i = 0, j = 0;
    while (i < sim->touched_count || j < sim->forced_count) {
        int32_t key;
        if (j >= sim->forced_count || (i < sim->touched_count && sim->touched[i] < sim->forced[j]))
            key = sim->touched[i++];
        else if (i >= sim->touched_count || sim->forced[j] < sim->touched[i])
            key = sim->forced[j++];
        else key = sim->touched[i++], ++j;
        if (find_tile(sim, key) < 0) out[n++] = key;
    }
    if (n == 0) {
        tsk_free(out);
        out = NULL;
    }
    sim->pending = out;
    sim->pending_count = n;
    return TSK_OK;
}

/* ---- invariants ------------------------------------------------------------------------------ */

/* NULL if v[0..n) ascends strictly within [0, tiles) and is allocated when n > 0 */
static const char* list_problem(const int32_t* v, int32_t n, int32_t tiles) {
    if (n < 0) return "has a negative count";
    if (n > 0 && v == NULL) return "has entries but no array";
    for (int32_t i = 0; i < n; ++i) {
        if (v[i] < 0 || v[i] >= tiles) return "holds a tile outside the grid";
        if (i > 0 && v[i] <= v[i - 1]) return "does not ascend strictly";
    }
    return NULL;
}

const char* tsk_sim_lists_problem(const tsk_blade_sim* sim) {
    if (sim == NULL) return "no simulation";
    const int32_t tiles = sim->def.tiles_x * sim->def.tiles_y;
    static _Thread_local char msg[96];
    const char* p;
    if ((p = list_problem(sim->pending, sim->pending_count, tiles)))
        return snprintf(msg, sizeof msg, "the pending list %s", p), msg;
    if ((p = list_problem(sim->forced, sim->forced_count, tiles)))
        return snprintf(msg, sizeof msg, "the forced list %s", p), msg;
    if ((p = list_problem(sim->touched, sim->touched_count, tiles)))
        return snprintf(msg, sizeof msg, "the touched list %s", p), msg;
    if (sim->tile_count < 0 || sim->tile_count > sim->tile_cap ||
        (sim->tile_count > 0 && !sim->tiles))
        return "active tiles: count beyond the array";
    const size_t bf = SIM_BLOCK_FLOATS(sim->K);
    for (int32_t i = 0; i < sim->tile_count; ++i) {
        const sim_tile* t = &sim->tiles[i];
        if (t->index < 0 || t->index >= tiles) return "active tiles: a tile outside the grid";
        if (i > 0 && t->index <= sim->tiles[i - 1].index)
            return "active tiles: not ascending strictly";
        if (t->blade_count < 0 || t->block_count != (t->blade_count + SIM_W - 1) / SIM_W)
            return "active tiles: block count does not match the blade count";
        const int has_blocks = t->block_count > 0;
        if (has_blocks != (t->blocks != NULL) || has_blocks != (t->bounds != NULL))
            return "active tiles: blocks allocated without blades, or blades without blocks";
        if (t->bytes != (size_t)t->block_count * (bf + 6) * sizeof(float))
            return "active tiles: bytes held do not match the blocks";
        if (find_i32(sim->forced, sim->forced_count, t->index) >= 0)
            return "an active tile is forced";
        if (find_i32(sim->pending, sim->pending_count, t->index) >= 0)
            return "an active tile is pending";
    }
    for (int32_t i = 0; i < sim->pending_count; ++i)
        if (find_i32(sim->touched, sim->touched_count, sim->pending[i]) < 0 &&
            find_i32(sim->forced, sim->forced_count, sim->pending[i]) < 0)
            return "a pending tile is neither touched nor forced";
    return NULL;
}

tsk_status tsk_sim_validate(const tsk_blade_sim* sim) {
    const char* p = tsk_sim_lists_problem(sim);
    return p ? tsk_error(TSK_ERR_INTERNAL, "blade simulation: %s", p) : TSK_OK;
}

/* ---- create / destroy ---------------------------------------------------------------------- */

tsk_status tsk_blade_sim_create(const tsk_blade_sim_def* def, tsk_blade_sim** out) {
    if (!out) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    tsk_status s = tsk_sim_check_def(def);
    if (s != TSK_OK) return s;
    tsk_blade_sim* sim = tsk_calloc(1, sizeof *sim, "blade simulation");
    if (!sim) return TSK_ERR_MEMORY;
    sim->def = *def;
    sim->K = def->knot_count;
    *out = sim;
    return TSK_OK;
}

static void free_tile(sim_tile* t) {
    tsk_free(t->blocks);
    tsk_free(t->bounds);
    t->blocks = NULL;
    t->bounds = NULL;
}

void tsk_blade_sim_destroy(tsk_blade_sim* sim) {
    if (!sim) return;
    for (int32_t i = 0; i < sim->tile_count; ++i) free_tile(&sim->tiles[i]);
    tsk_free(sim->tiles);
    tsk_free(sim->pending);
    tsk_free(sim->forced);
    tsk_free(sim->touched);
    tsk_free(sim->cols);
    tsk_free(sim);
}

/* A copy of n int32 (NULL for n == 0); returns 0 on failure. */
static int copy_i32(int32_t** dst, const int32_t* src, int32_t n) {
    *dst = NULL;
    if (n <= 0) return 1;
    *dst = tsk_alloc(sizeof(int32_t) * (size_t)n, "tile list");
    if (!*dst) return 0;
    memcpy(*dst, src, sizeof(int32_t) * (size_t)n);
    return 1;
}

tsk_status tsk_blade_sim_clone(const tsk_blade_sim* sim, tsk_blade_sim** out) {
    if (!out) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    if (!sim) return tsk_error_arg(TSK_ERR_ARGUMENT, "sim", "is NULL");
    tsk_blade_sim* c = tsk_calloc(1, sizeof *c, "blade simulation");
    if (!c) return TSK_ERR_MEMORY;
    c->def = sim->def;
    c->K = sim->K;
    c->bin_pad = sim->bin_pad;
    /* every list is copied with its count only once it is complete, so that destroy frees
       exactly what was copied when a later allocation fails */
    if (!copy_i32(&c->pending, sim->pending, sim->pending_count)) goto fail;
    c->pending_count = sim->pending ? sim->pending_count : 0;
    if (!copy_i32(&c->forced, sim->forced, sim->forced_count)) goto fail;
    c->forced_count = sim->forced ? sim->forced_count : 0;
    if (!copy_i32(&c->touched, sim->touched, sim->touched_count)) goto fail;
    c->touched_count = sim->touched ? sim->touched_count : 0;
    if (sim->collider_count > 0) {
        c->cols = tsk_alloc(sizeof(sim_collider) * (size_t)sim->collider_count, "colliders");
        if (!c->cols) goto fail;
        memcpy(c->cols, sim->cols, sizeof(sim_collider) * (size_t)sim->collider_count);
        c->collider_count = sim->collider_count;
    }
    if (sim->tile_count > 0) {
        c->tiles = tsk_calloc((size_t)sim->tile_count, sizeof(sim_tile), "active tiles");
        if (!c->tiles) goto fail;
        c->tile_cap = sim->tile_count;
        const size_t bf = SIM_BLOCK_FLOATS(sim->K);
        for (int32_t i = 0; i < sim->tile_count; ++i) {
            const sim_tile* t = &sim->tiles[i];
            sim_tile copy = *t;
            copy.blocks = NULL;
            copy.bounds = NULL;
            if (t->block_count > 0) {
                copy.blocks = tsk_alloc(sizeof(float) * bf * (size_t)t->block_count, "tile state");
                copy.bounds = tsk_alloc(sizeof(float) * 6 * (size_t)t->block_count, "tile bounds");
                if (!copy.blocks || !copy.bounds) {
                    free_tile(&copy);
                    goto fail;
                }
                memcpy(copy.blocks, t->blocks, sizeof(float) * bf * (size_t)t->block_count);
                memcpy(copy.bounds, t->bounds, sizeof(float) * 6 * (size_t)t->block_count);
            }
            c->tiles[i] = copy;
            c->tile_count = i + 1;
        }
    }
    *out = c;
    return TSK_OK;
fail:
    tsk_blade_sim_destroy(c);
    return TSK_ERR_MEMORY;
}

/* ---- colliders and activation -------------------------------------------------------------- */

static int finite3(const float* v) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }
/* finite and within TSK_BLADE_SIM_MAX_COORD (false for NaN) */
static int bounded3(const float* v) {
    return fabsf(v[0]) <= TSK_BLADE_SIM_MAX_COORD && fabsf(v[1]) <= TSK_BLADE_SIM_MAX_COORD &&
           fabsf(v[2]) <= TSK_BLADE_SIM_MAX_COORD;
}

/* Both lists ascend, so one merge marks them (a search per active tile took 0.3 ms a frame at
 * 15,625 tiles). */
static void mark_touched(tsk_blade_sim* sim) {
    int32_t j = 0;
    for (int32_t i = 0; i < sim->tile_count; ++i) {
        sim_tile* t = &sim->tiles[i];
        TSK_ASSERT(i == 0 || sim->tiles[i - 1].index < t->index);
        while (j < sim->touched_count && sim->touched[j] < t->index) ++j;
        TSK_ASSERT(j == 0 || j >= sim->touched_count || sim->touched[j - 1] < sim->touched[j]);
        t->touched = (t->touched & 2) | (j < sim->touched_count && sim->touched[j] == t->index);
    }
}

tsk_status tsk_blade_sim_set_colliders(tsk_blade_sim* sim, const tsk_blade_collider* colliders,
                                       int32_t count) {
    if (!sim) return tsk_error_arg(TSK_ERR_ARGUMENT, "sim", "is NULL");
    if (count < 0) return tsk_error_arg(TSK_ERR_ARGUMENT, "count", "must be >= 0, got %d", count);
    if (count > TSK_BLADE_SIM_MAX_COLLIDERS)
        return tsk_error_arg(TSK_ERR_LIMIT, "count", "at most %d colliders, got %d",
                             TSK_BLADE_SIM_MAX_COLLIDERS, count);
    if (count > 0 && !colliders) return tsk_error_arg(TSK_ERR_ARGUMENT, "colliders", "is NULL");
    for (int32_t i = 0; i < count; ++i) {
        const tsk_blade_collider* c = &colliders[i];
        if (c->kind != TSK_COLLIDER_SPHERE && c->kind != TSK_COLLIDER_CAPSULE)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "colliders", "collider %d has unknown kind %d",
                                 i, c->kind);
        if (!(isfinite(c->radius) && c->radius > 0))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "colliders",
                                 "collider %d radius must be positive and finite, got %g", i,
                                 (double)c->radius);
        if (!finite3(c->a) || (c->kind == TSK_COLLIDER_CAPSULE && !finite3(c->b)))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "colliders",
                                 "collider %d position is not finite", i);
        if (c->radius > TSK_BLADE_SIM_MAX_COORD || !bounded3(c->a) ||
            (c->kind == TSK_COLLIDER_CAPSULE && !bounded3(c->b)))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "colliders",
                                 "collider %d: radius and ends must be within %g m", i,
                                 (double)TSK_BLADE_SIM_MAX_COORD);
    }
    const tsk_blade_sim_def* d = &sim->def;
    /* prepared colliders */
    sim_collider* cols = NULL;
    if (count > 0) {
        cols = tsk_alloc(sizeof(sim_collider) * (size_t)count, "colliders");
        if (!cols) return TSK_ERR_MEMORY;
    }
    int64_t touched_cap = 0;
    for (int32_t i = 0; i < count; ++i) {
        const tsk_blade_collider* c = &colliders[i];
        sim_collider* p = &cols[i];
        const int cap = c->kind == TSK_COLLIDER_CAPSULE;
        double ab2 = 0;
        for (int k = 0; k < 3; ++k) {
            p->a[k] = c->a[k];
            p->ab[k] = cap ? c->b[k] - c->a[k] : 0.0f;
            ab2 += (double)p->ab[k] * p->ab[k];
        }
        p->inv_ab2 = ab2 > 1e-20 ? (float)(1.0 / ab2) : 0.0f;
        if (p->inv_ab2 == 0.0f) p->ab[0] = p->ab[1] = p->ab[2] = 0.0f;
        p->r = c->radius + d->collision_margin;
        for (int k = 0; k < 3; ++k) {
            float lo = p->a[k] < p->a[k] + p->ab[k] ? p->a[k] : p->a[k] + p->ab[k];
            float hi = p->a[k] > p->a[k] + p->ab[k] ? p->a[k] : p->a[k] + p->ab[k];
            p->lo[k] = lo - p->r;
            p->hi[k] = hi + p->r;
        }
        /* tiles touched: the collider box grown by activation_margin against tile squares between
           the ground and max_blade_height */
        const float m = d->activation_margin;
        if (p->hi[2] + m < d->ground_height ||
            p->lo[2] - m > d->ground_height + d->max_blade_height)
            continue;
        double i0 = floor((p->lo[0] - m - d->origin[0]) / d->tile_size);
        double i1 = floor((p->hi[0] + m - d->origin[0]) / d->tile_size);
        double j0 = floor((p->lo[1] - m - d->origin[1]) / d->tile_size);
        double j1 = floor((p->hi[1] + m - d->origin[1]) / d->tile_size);
        if (i1 < 0 || j1 < 0 || i0 >= d->tiles_x || j0 >= d->tiles_y) continue;
        i0 = i0 < 0 ? 0 : i0, j0 = j0 < 0 ? 0 : j0;
        i1 = i1 >= d->tiles_x ? d->tiles_x - 1 : i1, j1 = j1 >= d->tiles_y ? d->tiles_y - 1 : j1;
        touched_cap += (int64_t)(i1 - i0 + 1) * (int64_t)(j1 - j0 + 1);
    }
    if (touched_cap > TSK_BLADE_SIM_MAX_TILES) touched_cap = TSK_BLADE_SIM_MAX_TILES;
    int32_t* touched = NULL;
    int32_t tn = 0;
    if (touched_cap > 0) {
        touched = tsk_alloc(sizeof(int32_t) * (size_t)touched_cap, "touched tiles");
        if (!touched) {
            tsk_free(cols);
            return TSK_ERR_MEMORY;
        }
        for (int32_t i = 0; i < count; ++i) {
            const sim_collider* p = &cols[i];
            const float m = d->activation_margin;
            if (p->hi[2] + m < d->ground_height ||
                p->lo[2] - m > d->ground_height + d->max_blade_height)
                continue;
            double i0 = floor((p->lo[0] - m - d->origin[0]) / d->tile_size);
            double i1 = floor((p->hi[0] + m - d->origin[0]) / d->tile_size);
            double j0 = floor((p->lo[1] - m - d->origin[1]) / d->tile_size);
            double j1 = floor((p->hi[1] + m - d->origin[1]) / d->tile_size);
            if (i1 < 0 || j1 < 0 || i0 >= d->tiles_x || j0 >= d->tiles_y) continue;
            int32_t a0 = i0 < 0 ? 0 : (int32_t)i0, b0 = j0 < 0 ? 0 : (int32_t)j0;
            int32_t a1 = i1 >= d->tiles_x ? d->tiles_x - 1 : (int32_t)i1;
            int32_t b1 = j1 >= d->tiles_y ? d->tiles_y - 1 : (int32_t)j1;
            for (int32_t j = b0; j <= b1; ++j)
                for (int32_t ii = a0; ii <= a1 && tn < touched_cap; ++ii)
                    touched[tn++] = j * d->tiles_x + ii;
        }
        qsort(touched, (size_t)tn, sizeof(int32_t), cmp_i32);
        int32_t u = 0;
        for (int32_t i = 0; i < tn; ++i)
            if (u == 0 || touched[u - 1] != touched[i]) touched[u++] = touched[i];
        tn = u;
        if (tn == 0) {
            tsk_free(touched);
            touched = NULL;
        }
    }
    tsk_free(sim->cols);
    sim->cols = cols;
    sim->collider_count = count;
    tsk_free(sim->touched);
    sim->touched = touched;
    sim->touched_count = tn;
    mark_touched(sim);
    return rebuild_pending(sim);
}

static tsk_status check_tile(const tsk_blade_sim* sim, int32_t tile) {
    int64_t n = (int64_t)sim->def.tiles_x * sim->def.tiles_y;
    if (tile < 0 || tile >= n)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "tile", "must be in [0, %lld), got %d", (long long)n,
                             tile);
    return TSK_OK;
}

tsk_status tsk_blade_sim_activate_tile(tsk_blade_sim* sim, int32_t tile) {
    if (!sim) return tsk_error_arg(TSK_ERR_ARGUMENT, "sim", "is NULL");
    tsk_status s = check_tile(sim, tile);
    if (s != TSK_OK) return s;
    int32_t slot = find_tile(sim, tile);
    if (slot >= 0) {
        sim->tiles[slot].touched |= 2;
        sim->tiles[slot].blend_left = 0;
        sim->tiles[slot].quiet_frames = 0;
        sim->tiles[slot].untouched = 0;
        return TSK_OK;
    }
    if (!insert_i32(&sim->forced, &sim->forced_count, tile)) return TSK_ERR_MEMORY;
    return rebuild_pending(sim);
}

int32_t tsk_blade_sim_pending_count(const tsk_blade_sim* sim) {
    return sim ? sim->pending_count : 0;
}

tsk_status tsk_blade_sim_get_pending(const tsk_blade_sim* sim, int32_t* tiles) {
    if (!sim) return tsk_error_arg(TSK_ERR_ARGUMENT, "sim", "is NULL");
    if (sim->pending_count > 0 && !tiles)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "tiles", "is NULL");
    if (sim->pending_count > 0)
        memcpy(tiles, sim->pending, sizeof(int32_t) * (size_t)sim->pending_count);
    return TSK_OK;
}

int32_t tsk_blade_sim_tile_state(const tsk_blade_sim* sim, int32_t tile) {
    if (!sim || tile < 0 || tile >= (int64_t)sim->def.tiles_x * sim->def.tiles_y) return -1;
    if (find_tile(sim, tile) >= 0) return 1;
    if (find_i32(sim->pending, sim->pending_count, tile) >= 0) return 2;
    return 0;
}

/* ---- providing rest data ------------------------------------------------------------------- */

/* How far a tile's reach boxes extend beyond its square. */
static float tile_pad(const tsk_blade_sim* sim, const sim_tile* t) {
    const tsk_blade_sim_def* d = &sim->def;
    const float x0 = d->origin[0] + (float)(t->index % d->tiles_x) * d->tile_size;
    const float y0 = d->origin[1] + (float)(t->index / d->tiles_x) * d->tile_size;
    float pad = 0.0f;
    for (int32_t b = 0; b < t->block_count; ++b) {
        const float* bb = t->bounds + 6 * b;
        float e[4] = {x0 - bb[0], y0 - bb[1], bb[3] - (x0 + d->tile_size),
                      bb[4] - (y0 + d->tile_size)};
        for (int c = 0; c < 4; ++c) pad = pad > e[c] ? pad : e[c];
    }
    return pad;
}

/* After releases: the largest pad of the tiles left. */
static void update_bin_pad(tsk_blade_sim* sim) {
    float pad = 0.0f;
    for (int32_t i = 0; i < sim->tile_count; ++i) {
        const float p = tile_pad(sim, &sim->tiles[i]);
        pad = pad > p ? pad : p;
    }
    sim->bin_pad = pad;
}

tsk_status tsk_blade_sim_provide_tile(tsk_blade_sim* sim, int32_t tile, int32_t blade_count,
                                      const float* knots, const float* widths, const float* sides) {
    if (!sim) return tsk_error_arg(TSK_ERR_ARGUMENT, "sim", "is NULL");
    tsk_status s = check_tile(sim, tile);
    if (s != TSK_OK) return s;
    if (find_tile(sim, tile) >= 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "tile", "tile %d is already active", tile);
    if (blade_count < 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "blade_count", "must be >= 0, got %d", blade_count);
    if (blade_count > TSK_BLADE_SIM_MAX_BLADES_PER_TILE)
        return tsk_error_arg(TSK_ERR_LIMIT, "blade_count", "at most %d blades per tile, got %d",
                             TSK_BLADE_SIM_MAX_BLADES_PER_TILE, blade_count);
    const int32_t K = sim->K;
    if (blade_count > 0) {
        if (!knots) return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "is NULL");
        if (!widths) return tsk_error_arg(TSK_ERR_ARGUMENT, "widths", "is NULL");
    }
    for (int32_t b = 0; b < blade_count; ++b) {
        const float* x = knots + (size_t)b * K * 3;
        for (int32_t k = 0; k < K; ++k) {
            if (!finite3(x + 3 * k))
                return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "blade %d knot %d is not finite", b,
                                     k);
            if (!bounded3(x + 3 * k))
                return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "blade %d knot %d is beyond %g m",
                                     b, k, (double)TSK_BLADE_SIM_MAX_COORD);
            const float w = widths[(size_t)b * K + k];
            if (!(isfinite(w) && w >= 0))
                return tsk_error_arg(TSK_ERR_ARGUMENT, "widths",
                                     "blade %d knot %d: width must be >= 0 and finite, got %g", b,
                                     k, (double)w);
            if (k > 0) {
                double d0 = (double)x[3 * k] - x[3 * k - 3],
                       d1 = (double)x[3 * k + 1] - x[3 * k - 2],
                       d2 = (double)x[3 * k + 2] - x[3 * k - 1];
                if (!(d0 * d0 + d1 * d1 + d2 * d2 > 1e-18))
                    return tsk_error_arg(TSK_ERR_ARGUMENT, "knots",
                                         "blade %d segment %d has zero length", b, k - 1);
                if (k > 1) { /* the rest frames are carried from segment to segment: a blade
                                folding back on itself has no defined frame at the fold */
                    const double e0 = (double)x[3 * k - 3] - x[3 * k - 6],
                                 e1 = (double)x[3 * k - 2] - x[3 * k - 5],
                                 e2 = (double)x[3 * k - 1] - x[3 * k - 4];
                    const double dot = d0 * e0 + d1 * e1 + d2 * e2;
                    const double nn =
                        sqrt((d0 * d0 + d1 * d1 + d2 * d2) * (e0 * e0 + e1 * e1 + e2 * e2));
                    if (dot < SIM_MAX_FOLD_COS * nn)
                        return tsk_error_arg(TSK_ERR_ARGUMENT, "knots",
                                             "blade %d folds back on itself at knot %d (more "
                                             "than 170 degrees between its segments)",
                                             b, k - 1);
                }
            }
        }
        if (sides && !finite3(sides + 3 * (size_t)b))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "sides", "blade %d side is not finite", b);
    }
    sim_tile t;
    memset(&t, 0, sizeof t);
    t.index = tile;
    t.blade_count = blade_count;
    t.block_count = (blade_count + SIM_W - 1) / SIM_W;
    if (t.block_count > 0) { /* the state of every active tile with this one: within the budget */
        double held = 0;
        for (int32_t i = 0; i < sim->tile_count; ++i) held += (double)sim->tiles[i].bytes;
        s = tsk_memory_check(
            held + (double)t.block_count * (SIM_BLOCK_FLOATS(K) + 6) * sizeof(float),
            "blade_count");
        if (s != TSK_OK) return s;
    }
    if (t.block_count > 0) {
        const size_t bf = SIM_BLOCK_FLOATS(K);
        t.blocks = tsk_calloc((size_t)t.block_count * bf, sizeof(float), "tile state");
        t.bounds = tsk_alloc(sizeof(float) * 6 * (size_t)t.block_count, "tile bounds");
        if (!t.blocks || !t.bounds) {
            free_tile(&t);
            return TSK_ERR_MEMORY;
        }
        t.bytes =
            (size_t)t.block_count * bf * sizeof(float) + sizeof(float) * 6 * (size_t)t.block_count;
        for (int32_t blk = 0; blk < t.block_count; ++blk) {
            float* block = t.blocks + (size_t)blk * bf;
            float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
            float reach = 0.0f;
            for (int l = 0; l < SIM_W; ++l) {
                int32_t b = blk * SIM_W + l;
                if (b >= blade_count) b = 0; /* padding lanes copy the first blade */
                const float* x = knots + (size_t)b * K * 3;
                tsk_sim_block_load_lane(K, block, l, x, widths + (size_t)b * K,
                                        sides ? sides + 3 * (size_t)b : NULL);
                const float len = block[SIM_OFF_LT(K) + l]; /* total rest length */
                reach = reach > len ? reach : len;
                for (int c = 0; c < 3; ++c) {
                    lo[c] = lo[c] < x[c] ? lo[c] : x[c];
                    hi[c] = hi[c] > x[c] ? hi[c] : x[c];
                }
            }
            tsk_sim_block_rest(K, block);
            /* a knot stays within the blade's length of its root */
            reach *= 1.02f;
            for (int c = 0; c < 3; ++c) {
                t.bounds[6 * blk + c] = lo[c] - reach;
                t.bounds[6 * blk + 3 + c] = hi[c] + reach;
            }
        }
    }
    if (sim->tile_count == sim->tile_cap) {
        int32_t cap = sim->tile_cap ? 2 * sim->tile_cap : 16;
        sim_tile* nt = tsk_alloc(sizeof(sim_tile) * (size_t)cap, "active tiles");
        if (!nt) {
            free_tile(&t);
            return TSK_ERR_MEMORY;
        }
        if (sim->tile_count) memcpy(nt, sim->tiles, sizeof(sim_tile) * (size_t)sim->tile_count);
        tsk_free(sim->tiles);
        sim->tiles = nt;
        sim->tile_cap = cap;
    }
    int32_t pos = 0;
    while (pos < sim->tile_count && sim->tiles[pos].index < tile) ++pos;
    memmove(sim->tiles + pos + 1, sim->tiles + pos,
            sizeof(sim_tile) * (size_t)(sim->tile_count - pos));
    t.touched = (find_i32(sim->touched, sim->touched_count, tile) >= 0) |
                (find_i32(sim->forced, sim->forced_count, tile) >= 0 ? 2 : 0);
    sim->tiles[pos] = t;
    ++sim->tile_count;
    remove_i32(&sim->forced, &sim->forced_count, tile);
    remove_i32(&sim->pending, &sim->pending_count, tile);
    const float pad = tile_pad(sim, &sim->tiles[pos]);
    sim->bin_pad = sim->bin_pad > pad ? sim->bin_pad : pad;
    TSK_ASSERT(tsk_sim_lists_problem(sim) == NULL);
    return TSK_OK;
}

/* ---- stepping ------------------------------------------------------------------------------ */

typedef struct step_ctx {
    tsk_blade_sim* sim;
    sim_step_params params;
    const int32_t* blk_slot; /* per work block: active tile slot */
    const int32_t* blk_index; /* per work block: block within the tile */
    const int64_t* first_blade; /* per slot: index of its first blade among active blades */
    const int32_t* col_start; /* per slot: start in col_list; col_start[slot+1] is the end */
    const int32_t* col_list;
    const float* wind;
    tsk_wind_layout layout;
    sim_block_stats* stats;
} step_ctx;

static int box_overlap(const float* lo, const float* hi, const sim_collider* c) {
    return !(c->hi[0] < lo[0] || c->lo[0] > hi[0] || c->hi[1] < lo[1] || c->lo[1] > hi[1] ||
             c->hi[2] < lo[2] || c->lo[2] > hi[2]);
}

/* Blocks per chunk of the step's parallel loop. A chunk's blocks run in order, each prefetching
 * the next while it computes, so only a chunk's first block comes from memory unannounced
 * (chunks of 4 would leave a quarter of the blocks cold at 1M blades, and a cold block is
 * markedly slower: docs/performance.md, "Blade solver"). Long chunks, but 16
 * per thread where there are blocks enough, so that the threads still finish together; never
 * fewer than 4 blocks. */
static size_t step_grain(int64_t blocks) {
    const int64_t g = blocks / (16 * (int64_t)tsk_get_threads());
    return (size_t)(g < 4 ? 4 : g > 256 ? 256 : g);
}

static void step_blocks(size_t begin, size_t end, size_t chunk, void* vctx) {
    (void)chunk;
    step_ctx* ctx = vctx;
    tsk_blade_sim* sim = ctx->sim;
    const int32_t K = sim->K;
    const size_t bf = SIM_BLOCK_FLOATS(K);
    float wind[TSK_BLADE_SIM_MAX_KNOTS * 3 * SIM_W];
    const sim_collider* cols[TSK_BLADE_SIM_MAX_COLLIDERS];
    for (size_t w = begin; w < end; ++w) {
        const int32_t slot = ctx->blk_slot[w], blk = ctx->blk_index[w];
        sim_tile* t = &sim->tiles[slot];
        float* block = t->blocks + (size_t)blk * bf;
        const float* bb = t->bounds + 6 * blk;
        int ncol = 0;
        for (int32_t i = ctx->col_start[slot]; i < ctx->col_start[slot + 1]; ++i) {
            const sim_collider* c = &sim->cols[ctx->col_list[i]];
            if (box_overlap(bb, bb + 3, c)) cols[ncol++] = c;
        }
        const float* wp = NULL;
        if (ctx->layout == TSK_WIND_PER_KNOT) {
            for (int l = 0; l < SIM_W; ++l) {
                int32_t b = blk * SIM_W + l;
                if (b >= t->blade_count) b = 0;
                const float* src = ctx->wind + 3 * ((ctx->first_blade[slot] + b) * K);
                for (int32_t k = 0; k < K; ++k)
                    for (int c = 0; c < 3; ++c)
                        wind[((size_t)k * 3 + c) * SIM_W + l] = src[3 * k + c];
            }
            wp = wind;
        } else if (ctx->layout != TSK_WIND_NONE) {
            /* one velocity per lane, the same at every knot */
            for (int l = 0; l < SIM_W; ++l) {
                int32_t b = blk * SIM_W + l;
                if (b >= t->blade_count) b = 0;
                const float* src = ctx->layout == TSK_WIND_UNIFORM
                                       ? ctx->wind
                                       : ctx->wind + 3 * (ctx->first_blade[slot] + b);
                for (int c = 0; c < 3; ++c) wind[(size_t)c * SIM_W + l] = src[c];
            }
            wp = wind;
        }
        if (wp != NULL && t->blend_left > 0) {
            /* a blending tile feels the wind fade out with the blend, so that its blades come
             * to rest smoothly rather than being pulled back by the wind until the last step */
            const float fade = (float)(t->blend_left - 1) / (float)t->blend_total;
            const size_t nw = (size_t)(ctx->layout == TSK_WIND_PER_KNOT ? K : 1) * 3 * SIM_W;
            for (size_t i = 0; i < nw; ++i) wind[i] *= fade;
        }
        const float blend = t->blend_left > 0 ? 1.0f / (float)t->blend_left : 0.0f;
        /* the next block of this chunk, for the kernel to prefetch */
        const float* next = NULL;
        if (w + 1 < end)
            next = sim->tiles[ctx->blk_slot[w + 1]].blocks + (size_t)ctx->blk_index[w + 1] * bf;
        tsk_sim_block_step(&ctx->params, block, wp,
                           ctx->layout == TSK_WIND_PER_KNOT ? (size_t)3 * SIM_W : 0, cols, ncol,
                           blend, next, &ctx->stats[w]);
    }
}

typedef struct finite_ctx {
    const float* v;
    int* bad; /* per chunk */
} finite_ctx;

static void check_finite_chunk(size_t begin, size_t end, size_t chunk, void* vctx) {
    finite_ctx* ctx = vctx;
    int bad = 0;
    for (size_t i = begin; i < end; ++i) bad |= !(fabsf(ctx->v[i]) <= TSK_BLADE_SIM_MAX_WIND);
    ctx->bad[chunk] = bad;
}

static void release_tile(tsk_blade_sim* sim, int32_t slot) {
    free_tile(&sim->tiles[slot]);
    memmove(sim->tiles + slot, sim->tiles + slot + 1,
            sizeof(sim_tile) * (size_t)(sim->tile_count - slot - 1));
    if (--sim->tile_count == 0) {
        tsk_free(sim->tiles);
        sim->tiles = NULL;
        sim->tile_cap = 0;
    }
}

tsk_status tsk_blade_sim_step(tsk_blade_sim* sim, float dt, const float* wind,
                              tsk_wind_layout layout) {
    if (!sim) return tsk_error_arg(TSK_ERR_ARGUMENT, "sim", "is NULL");
    if (!(isfinite(dt) && dt > 0.0f && dt <= 1.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "dt", "must be in (0, 1] seconds, got %g",
                             (double)dt);
    if (layout < TSK_WIND_NONE || layout > TSK_WIND_PER_KNOT)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "layout", "unknown wind layout %d", (int)layout);
    const int32_t K = sim->K;
    int64_t blades = 0, blocks = 0;
    for (int32_t i = 0; i < sim->tile_count; ++i) {
        blades += sim->tiles[i].blade_count;
        blocks += sim->tiles[i].block_count;
    }
    if (layout != TSK_WIND_NONE) {
        if (!wind) return tsk_error_arg(TSK_ERR_ARGUMENT, "wind", "is NULL");
        size_t n = layout == TSK_WIND_UNIFORM     ? 3
                   : layout == TSK_WIND_PER_BLADE ? (size_t)(3 * blades)
                                                  : (size_t)(3 * blades * K);
        const size_t grain = 1 << 16;
        size_t chunks = tsk_chunk_count(n, grain);
        if (chunks > 0) {
            int* bad = tsk_calloc(chunks, sizeof(int), "wind check");
            if (!bad) return TSK_ERR_MEMORY;
            finite_ctx fc = {wind, bad};
            tsk_parallel_for(n, grain, check_finite_chunk, &fc);
            int any = 0;
            for (size_t c = 0; c < chunks; ++c) any |= bad[c];
            tsk_free(bad);
            if (any)
                return tsk_error_arg(TSK_ERR_ARGUMENT, "wind",
                                     "contains a non-finite value or one beyond %g m/s",
                                     (double)TSK_BLADE_SIM_MAX_WIND);
        }
    }
    const tsk_blade_sim_def* d = &sim->def;
    step_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.sim = sim;
    ctx.params = tsk_sim_step_params(d, dt);
    ctx.wind = wind;
    ctx.layout = layout;

    tsk_status status = TSK_OK;
    const int32_t nt = sim->tile_count;
    int32_t* blk_slot = NULL;
    int32_t* blk_index = NULL;
    int64_t* first = NULL;
    int32_t* col_start = NULL;
    int32_t* col_list = NULL;
    sim_block_stats* stats = NULL;
    if (nt > 0) {
        blk_slot = tsk_alloc(sizeof(int32_t) * (size_t)(blocks + 1), "step blocks");
        blk_index = tsk_alloc(sizeof(int32_t) * (size_t)(blocks + 1), "step blocks");
        first = tsk_alloc(sizeof(int64_t) * (size_t)nt, "step tiles");
        col_start = tsk_calloc((size_t)nt + 1, sizeof(int32_t), "step colliders");
        stats = tsk_calloc((size_t)(blocks + 1), sizeof(sim_block_stats), "step stats");
        if (!blk_slot || !blk_index || !first || !col_start || !stats) {
            status = TSK_ERR_MEMORY;
            goto done;
        }
        int64_t w = 0, fb = 0;
        for (int32_t i = 0; i < nt; ++i) {
            first[i] = fb;
            fb += sim->tiles[i].blade_count;
            for (int32_t b = 0; b < sim->tiles[i].block_count; ++b)
                blk_slot[w] = i, blk_index[w++] = b;
        }
        /* per-tile collider lists: bin each collider into the tiles whose reach it may meet */
        for (int pass = 0; pass < 2; ++pass) {
            if (pass == 1) {
                for (int32_t i = 0; i < nt; ++i) col_start[i + 1] += col_start[i];
                if (col_start[nt] > 0) {
                    col_list = tsk_alloc(sizeof(int32_t) * (size_t)col_start[nt], "step colliders");
                    if (!col_list) {
                        status = TSK_ERR_MEMORY;
                        goto done;
                    }
                }
            }
            int32_t* fill = NULL;
            if (pass == 1 && col_start[nt] > 0) {
                fill = tsk_alloc(sizeof(int32_t) * (size_t)nt, "step colliders");
                if (!fill) {
                    status = TSK_ERR_MEMORY;
                    goto done;
                }
                memcpy(fill, col_start, sizeof(int32_t) * (size_t)nt);
            }
            if (pass == 1 && col_start[nt] == 0) break;
            for (int32_t ci = 0; ci < sim->collider_count; ++ci) {
                const sim_collider* c = &sim->cols[ci];
                const float pad = sim->bin_pad;
                double i0 = floor((c->lo[0] - pad - d->origin[0]) / d->tile_size);
                double i1 = floor((c->hi[0] + pad - d->origin[0]) / d->tile_size);
                double j0 = floor((c->lo[1] - pad - d->origin[1]) / d->tile_size);
                double j1 = floor((c->hi[1] + pad - d->origin[1]) / d->tile_size);
                if (i1 < 0 || j1 < 0 || i0 >= d->tiles_x || j0 >= d->tiles_y) continue;
                int32_t a0 = i0 < 0 ? 0 : (int32_t)i0, b0 = j0 < 0 ? 0 : (int32_t)j0;
                int32_t a1 = i1 >= d->tiles_x ? d->tiles_x - 1 : (int32_t)i1;
                int32_t b1 = j1 >= d->tiles_y ? d->tiles_y - 1 : (int32_t)j1;
                const int64_t area = (int64_t)(a1 - a0 + 1) * (b1 - b0 + 1);
                if (area > nt) { /* walk whichever is smaller: active tiles or the range */
                    for (int32_t s = 0; s < nt; ++s) {
                        const int32_t ti = sim->tiles[s].index;
                        const int32_t ii = ti % d->tiles_x, jj = ti / d->tiles_x;
                        if (ii < a0 || ii > a1 || jj < b0 || jj > b1) continue;
                        if (pass == 0) ++col_start[s + 1];
                        else {
                            TSK_ASSERT(fill[s] < col_start[s + 1]); /* pass 0 counted it */
                            col_list[fill[s]++] = ci;
                        }
                    }
                } else {
                    for (int32_t jj = b0; jj <= b1; ++jj)
                        for (int32_t ii = a0; ii <= a1; ++ii) {
                            const int32_t s = find_tile(sim, jj * d->tiles_x + ii);
                            if (s < 0) continue;
                            if (pass == 0) ++col_start[s + 1];
                            else {
                                TSK_ASSERT(fill[s] < col_start[s + 1]);
                                col_list[fill[s]++] = ci;
                            }
                        }
                }
            }
            tsk_free(fill);
        }
        ctx.blk_slot = blk_slot;
        ctx.blk_index = blk_index;
        ctx.first_blade = first;
        ctx.col_start = col_start;
        ctx.col_list = col_list;
        ctx.stats = stats;
        tsk_parallel_for((size_t)blocks, step_grain(blocks), step_blocks, &ctx);

        /* rest detection and release, in tile order */
        const float rd2 = d->rest_distance * d->rest_distance;
        const float rs2 = d->rest_speed * dt * d->rest_speed * dt;
        int64_t wb = 0;
        int32_t i = 0;
        for (int32_t s = 0; s < nt; ++s) {
            sim_tile* t = &sim->tiles[i];
            float md = 0.0f, ms = 0.0f;
            for (int32_t b = 0; b < t->block_count; ++b, ++wb) {
                md = md > stats[wb].max_disp2 ? md : stats[wb].max_disp2;
                ms = ms > stats[wb].max_step2 ? ms : stats[wb].max_step2;
            }
            int release = 0;
            if (t->touched) {
                t->quiet_frames = 0;
                t->untouched = 0;
                t->blend_left = 0;
            } else if (t->blend_left > 0) {
                release = --t->blend_left == 0;
            } else {
                t->quiet_frames = (md < rd2 && ms < rs2) ? t->quiet_frames + 1 : 0;
                t->untouched += t->untouched < INT32_MAX;
                if (t->quiet_frames >= d->rest_frames) t->blend_left = d->blend_frames;
                else if (t->untouched >= d->settle_frames) /* wind keeps it from resting */
                    t->blend_left = d->settle_blend_frames;
                t->blend_total = t->blend_left;
            }
            t->touched &= 1; /* a forced touch lasts one step */
            if (release) release_tile(sim, i);
            else ++i;
        }
        if (sim->tile_count != nt) {
            update_bin_pad(sim);
            status = rebuild_pending(sim);
        }
    }
done:
    TSK_ASSERT(tsk_sim_lists_problem(sim) == NULL);
    tsk_free(blk_slot);
    tsk_free(blk_index);
    tsk_free(first);
    tsk_free(col_start);
    tsk_free(col_list);
    tsk_free(stats);
    return status;
}

/* ---- queries ------------------------------------------------------------------------------- */

tsk_status tsk_blade_sim_get_info(const tsk_blade_sim* sim, tsk_blade_sim_info* info) {
    if (!sim) return tsk_error_arg(TSK_ERR_ARGUMENT, "sim", "is NULL");
    if (!info) return tsk_error_arg(TSK_ERR_ARGUMENT, "info", "is NULL");
    memset(info, 0, sizeof *info);
    info->knot_count = sim->K;
    info->active_tiles = sim->tile_count;
    info->pending_tiles = sim->pending_count;
    info->collider_count = sim->collider_count;
    for (int32_t i = 0; i < sim->tile_count; ++i) {
        info->active_blades += sim->tiles[i].blade_count;
        info->blending_tiles += sim->tiles[i].blend_left > 0;
        info->state_bytes += sim->tiles[i].bytes;
    }
    return TSK_OK;
}

tsk_status tsk_blade_sim_get_active(const tsk_blade_sim* sim, int32_t* tiles,
                                    int32_t* blade_counts) {
    if (!sim) return tsk_error_arg(TSK_ERR_ARGUMENT, "sim", "is NULL");
    for (int32_t i = 0; i < sim->tile_count; ++i) {
        if (tiles) tiles[i] = sim->tiles[i].index;
        if (blade_counts) blade_counts[i] = sim->tiles[i].blade_count;
    }
    return TSK_OK;
}

static void copy_tile_knots(const tsk_blade_sim* sim, const sim_tile* t, float* out) {
    const int32_t K = sim->K;
    const size_t bf = SIM_BLOCK_FLOATS(K), row = (size_t)K * 3;
    /* block by block, each stored row (knot k, axis c) of SIM_W lanes read in order and
     * scattered to its blades: a block's output (SIM_W x 3K floats) stays in cache */
    for (int32_t b0 = 0; b0 < t->blade_count; b0 += SIM_W) {
        const float* P = t->blocks + (size_t)(b0 / SIM_W) * bf + SIM_OFF_P(K);
        const int nl = t->blade_count - b0 < SIM_W ? t->blade_count - b0 : SIM_W;
        float* o = out + (size_t)b0 * row;
        for (size_t r = 0; r < row; ++r) {
            const float* src = P + r * SIM_W;
            for (int l = 0; l < nl; ++l) o[(size_t)l * row + r] = src[l];
        }
    }
}

typedef struct knots_ctx {
    const tsk_blade_sim* sim;
    const int64_t* offset; /* first float of each tile's knots */
    float* out;
} knots_ctx;

static void copy_knots_range(size_t begin, size_t end, size_t chunk, void* vctx) {
    (void)chunk;
    const knots_ctx* c = vctx;
    for (size_t i = begin; i < end; ++i)
        copy_tile_knots(c->sim, &c->sim->tiles[i], c->out + c->offset[i]);
}

tsk_status tsk_blade_sim_get_knots(const tsk_blade_sim* sim, float* knots) {
    if (!sim) return tsk_error_arg(TSK_ERR_ARGUMENT, "sim", "is NULL");
    const size_t nt = (size_t)sim->tile_count;
    int64_t total = 0;
    for (size_t i = 0; i < nt; ++i) total += sim->tiles[i].blade_count;
    if (total > 0 && !knots) return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "is NULL");
    int64_t* offset = nt ? tsk_alloc(nt * sizeof *offset, "knot offsets") : NULL;
    int64_t off = 0;
    for (size_t i = 0; i < nt; ++i) {
        if (offset == NULL) { /* no memory for the table: one tile after another */
            copy_tile_knots(sim, &sim->tiles[i], knots + off);
        } else {
            offset[i] = off;
        }
        off += (int64_t)sim->tiles[i].blade_count * sim->K * 3;
    }
    if (offset != NULL) {
        knots_ctx c = {sim, offset, knots};
        tsk_parallel_for(nt, 8, copy_knots_range, &c);
        tsk_free(offset);
    }
    return TSK_OK;
}

typedef struct ribbon_job {
    int32_t slot, block, l0, l1;
    int64_t at; /* index, in the caller's widths and sides, of lane l0's blade */
} ribbon_job;

typedef struct ribbons_ctx {
    const tsk_blade_sim* sim;
    const ribbon_job* jobs;
    const float *widths, *sides;
    float* out;
    int* bad; /* per job */
} ribbons_ctx;

static void ribbons_range(size_t begin, size_t end, size_t chunk, void* vctx) {
    (void)chunk;
    const ribbons_ctx* c = vctx;
    const int32_t K = c->sim->K;
    const size_t bf = SIM_BLOCK_FLOATS(K);
    for (size_t i = begin; i < end; ++i) {
        const ribbon_job* j = &c->jobs[i];
        const float* P = c->sim->tiles[j->slot].blocks + (size_t)j->block * bf + SIM_OFF_P(K);
        c->bad[i] = tsk_sim_block_ribbons(K, P, j->l0, j->l1, c->widths + j->at * K,
                                          c->sides + 3 * j->at, c->out + j->at * 6 * K);
    }
}

/* The error for the first bad blade of a job that tsk_sim_block_ribbons refused: each lane's
 * knots gathered from the block and checked as tsk_blades_expand checks a blade. */
static tsk_status report_bad_ribbon(const tsk_blade_sim* sim, const ribbon_job* j,
                                    const float* widths, const float* sides) {
    const int32_t K = sim->K;
    const float* P =
        sim->tiles[j->slot].blocks + (size_t)j->block * SIM_BLOCK_FLOATS(K) + SIM_OFF_P(K);
    float knots[3 * TSK_BLADE_SIM_MAX_KNOTS];
    for (int32_t l = j->l0; l < j->l1; ++l) {
        const size_t b = (size_t)(j->at + (l - j->l0));
        for (size_t r = 0; r < 3 * (size_t)K; ++r) knots[r] = P[r * SIM_W + l];
        const tsk_status s = tsk_ribbon_report_bad(knots, widths + b * K, sides + 3 * b, K, b);
        if (s != TSK_OK) return s;
    }
    return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "a blade's ribbon could not be made");
}

/* Appends to jobs (when not NULL) the jobs of blades [first, first + count) of the active ones,
 * whose output starts at blade `at` of the caller's arrays; returns how many there are.
 * prefix[i] is the first active blade of tile slot i (prefix[tile_count] = all of them): the
 * run's first tile is found by bisection, so many runs do not each walk the tiles before them. */
static size_t range_jobs(const tsk_blade_sim* sim, const int64_t* prefix, int64_t first,
                         int64_t count, int64_t at, ribbon_job* jobs) {
    const int64_t end = first + count;
    int32_t lo = 0, hi = sim->tile_count; /* the last slot whose first blade is <= first */
    while (hi - lo > 1) {
        const int32_t mid = lo + (hi - lo) / 2;
        if (prefix[mid] <= first) lo = mid;
        else hi = mid;
    }
    size_t nj = 0;
    for (int32_t i = lo; i < sim->tile_count && prefix[i] < end; ++i) {
        const int64_t fb = prefix[i];
        const int64_t a = first > fb ? first : fb;
        const int64_t b = end < prefix[i + 1] ? end : prefix[i + 1];
        for (int64_t x = a; x < b;) { /* x: the next blade, as an index of the active ones */
            const int64_t in = x - fb, blk = in / SIM_W;
            const int64_t stop = fb + (blk + 1) * SIM_W < b ? fb + (blk + 1) * SIM_W : b;
            if (jobs)
                jobs[nj] = (ribbon_job){i, (int32_t)blk, (int32_t)(in - blk * SIM_W),
                                        (int32_t)(stop - fb - blk * SIM_W), at + (x - first)};
            ++nj;
            x = stop;
        }
    }
    return nj;
}

/* The ribbons of runs of active blades (one run for tsk_blade_sim_get_ribbons), each run's
 * range already checked: jobs per block, in parallel. */
static tsk_status ribbons_of_runs(const tsk_blade_sim* sim, const int64_t* starts,
                                  const int64_t* counts, int64_t run_count, const float* widths,
                                  const float* sides, float* positions) {
    int64_t* prefix = tsk_alloc(((size_t)sim->tile_count + 1) * sizeof *prefix, "ribbon runs");
    if (!prefix) return TSK_ERR_MEMORY;
    prefix[0] = 0;
    for (int32_t i = 0; i < sim->tile_count; ++i)
        prefix[i + 1] = prefix[i] + sim->tiles[i].blade_count;
    size_t room = 0;
    for (int64_t r = 0; r < run_count; ++r)
        room += range_jobs(sim, prefix, starts[r], counts[r], 0, NULL);
    tsk_status s = TSK_OK;
    if (room > 0 && !widths) s = tsk_error_arg(TSK_ERR_ARGUMENT, "widths", "is NULL");
    else if (room > 0 && !sides) s = tsk_error_arg(TSK_ERR_ARGUMENT, "sides", "is NULL");
    else if (room > 0 && !positions) s = tsk_error_arg(TSK_ERR_ARGUMENT, "positions", "is NULL");
    ribbon_job* jobs = NULL;
    int* bad = NULL;
    if (room > 0 && s == TSK_OK) {
        jobs = tsk_alloc(room * sizeof *jobs, "ribbon jobs");
        bad = tsk_calloc(room, sizeof *bad, "ribbon checks");
        if (!jobs || !bad) s = TSK_ERR_MEMORY;
    }
    if (room > 0 && s == TSK_OK) {
        size_t nj = 0;
        int64_t at = 0;
        for (int64_t r = 0; r < run_count; at += counts[r++])
            nj += range_jobs(sim, prefix, starts[r], counts[r], at, jobs + nj);
        ribbons_ctx c = {sim, jobs, widths, sides, positions, bad};
        tsk_parallel_for(nj, 4, ribbons_range, &c);
        for (size_t i = 0; i < nj && s == TSK_OK; ++i)
            if (bad[i]) s = report_bad_ribbon(sim, &jobs[i], widths, sides);
    }
    tsk_free(jobs);
    tsk_free(bad);
    tsk_free(prefix);
    return s;
}

static int64_t active_blades(const tsk_blade_sim* sim) {
    int64_t total = 0;
    for (int32_t i = 0; i < sim->tile_count; ++i) total += sim->tiles[i].blade_count;
    return total;
}

tsk_status tsk_blade_sim_get_ribbons(const tsk_blade_sim* sim, int64_t first, int64_t count,
                                     const float* widths, const float* sides, float* positions) {
    if (!sim) return tsk_error_arg(TSK_ERR_ARGUMENT, "sim", "is NULL");
    const int64_t total = active_blades(sim);
    if (first < 0 || count < 0 || first > total || count > total - first)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "first",
                             "%lld blades from blade %lld on are not among the %lld active ones",
                             (long long)count, (long long)first, (long long)total);
    return ribbons_of_runs(sim, &first, &count, 1, widths, sides, positions);
}

tsk_status tsk_blade_sim_get_ribbon_runs(const tsk_blade_sim* sim, const int64_t* starts,
                                         const int64_t* counts, int64_t run_count,
                                         const float* widths, const float* sides,
                                         float* positions) {
    if (!sim) return tsk_error_arg(TSK_ERR_ARGUMENT, "sim", "is NULL");
    if (run_count < 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "run_count", "must be >= 0, got %lld",
                             (long long)run_count);
    if (run_count > 0 && (!starts || !counts))
        return tsk_error_arg(TSK_ERR_ARGUMENT, starts ? "counts" : "starts", "is NULL");
    const int64_t total = active_blades(sim);
    for (int64_t r = 0; r < run_count; ++r)
        if (starts[r] < 0 || counts[r] < 0 || starts[r] > total || counts[r] > total - starts[r])
            return tsk_error_arg(TSK_ERR_ARGUMENT, "starts",
                                 "run %lld: %lld blades from blade %lld on are not among the "
                                 "%lld active ones",
                                 (long long)r, (long long)counts[r], (long long)starts[r],
                                 (long long)total);
    return ribbons_of_runs(sim, starts, counts, run_count, widths, sides, positions);
}

tsk_status tsk_blade_sim_get_tile_knots(const tsk_blade_sim* sim, int32_t tile, float* knots) {
    if (!sim) return tsk_error_arg(TSK_ERR_ARGUMENT, "sim", "is NULL");
    tsk_status s = check_tile(sim, tile);
    if (s != TSK_OK) return s;
    int32_t slot = find_tile(sim, tile);
    if (slot < 0) return tsk_error_arg(TSK_ERR_ARGUMENT, "tile", "tile %d is not active", tile);
    if (sim->tiles[slot].blade_count > 0 && !knots)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "knots", "is NULL");
    copy_tile_knots(sim, &sim->tiles[slot], knots);
    return TSK_OK;
}
