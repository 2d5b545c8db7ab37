/* The meadow's tile grid (seed 000 §3, §4.5): the area is cut into square tiles; each tile
 * takes a contiguous, wrapping run of patch blades starting at an offset hashed from its
 * grid coordinates, and as many blades as the density map gives it. */
#include "meadow_internal.h"

#include <math.h>
#include <string.h>

enum { TILE_GRAIN = 4096 };

tsk_meadow_def tsk_default_meadow_def(void) {
    tsk_meadow_def d;
    memset(&d, 0, sizeof d);
    d.size[0] = 10.0f;
    d.size[1] = 10.0f;
    d.tile_size = 0.5f;
    d.blades_per_tile = 64; /* seed 000 Table 1: tiles of 64 blades */
    d.patch_blades = 16384;
    d.chunk_blades = 1;
    d.seed = 1;
    d.density = TSK_DENSITY_NOISE;
    d.noise_scale = 8.0f;
    d.noise_octaves = 3;
    d.noise_persistence = 0.5f;
    d.noise_contrast = 2.5f;
    d.noise_threshold = 0.15f;
    return d;
}

void tsk_meadow_destroy(tsk_meadow* m) {
    if (m == NULL) return;
    tsk_free(m->counts);
    tsk_free(m->offsets);
    tsk_free(m->density);
    tsk_free(m->first_blade);
    tsk_free(m);
}

static tsk_status check_def(const tsk_meadow_def* d) {
    static const char* origin_names[3] = {"origin.x", "origin.y", "origin.z"};
    for (int a = 0; a < 3; ++a)
        if (!isfinite(d->origin[a]) || fabsf(d->origin[a]) > 1e7f)
            return tsk_error_arg(TSK_ERR_ARGUMENT, origin_names[a],
                                 "must be finite and within 10,000 km, got %g",
                                 (double)d->origin[a]);
    static const char* size_names[2] = {"size.x", "size.y"};
    for (int a = 0; a < 2; ++a) {
        if (!isfinite(d->size[a]) || !(d->size[a] > 0.0f))
            return tsk_error_arg(TSK_ERR_ARGUMENT, size_names[a],
                                 "must be finite and > 0 m, got %g", (double)d->size[a]);
        if (d->size[a] > 1e7f)
            return tsk_error_arg(TSK_ERR_LIMIT, size_names[a],
                                 "%g m exceeds the limit of 10,000 km", (double)d->size[a]);
    }
    if (!isfinite(d->tile_size) || !(d->tile_size > 0.0f))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "tile_size", "must be finite and > 0 m, got %g",
                             (double)d->tile_size);
    if (d->tile_size > d->size[0] || d->tile_size > d->size[1])
        return tsk_error_arg(TSK_ERR_ARGUMENT, "tile_size",
                             "a tile of %g m is larger than the meadow area %g x %g m",
                             (double)d->tile_size, (double)d->size[0], (double)d->size[1]);
    if (d->patch_blades > TSK_PATCH_MAX_BLADES)
        return tsk_error_arg(TSK_ERR_LIMIT, "patch_blades", "%d exceeds the patch limit of %d",
                             (int)d->patch_blades, TSK_PATCH_MAX_BLADES);
    if (d->patch_blades < 1)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "patch_blades", "must be at least 1, got %d",
                             (int)d->patch_blades);
    if (d->blades_per_tile > TSK_MEADOW_MAX_BLADES_PER_TILE)
        return tsk_error_arg(TSK_ERR_LIMIT, "blades_per_tile", "%d exceeds the limit of %d",
                             (int)d->blades_per_tile, TSK_MEADOW_MAX_BLADES_PER_TILE);
    if (d->blades_per_tile < 1)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "blades_per_tile", "must be at least 1, got %d",
                             (int)d->blades_per_tile);
    if (d->blades_per_tile > d->patch_blades)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "blades_per_tile",
                             "%d is more than the patch's %d blades (tiles would repeat blades)",
                             (int)d->blades_per_tile, (int)d->patch_blades);
    if (d->chunk_blades < 1 || d->patch_blades % d->chunk_blades != 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "chunk_blades",
                             "must be >= 1 and divide patch_blades (%d), got %d",
                             (int)d->patch_blades, (int)d->chunk_blades);
    if (d->chunk_blades > d->blades_per_tile)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "chunk_blades",
                             "%d is more than blades_per_tile (%d)", (int)d->chunk_blades,
                             (int)d->blades_per_tile);
    /* grid size in double first, so that absurd requests cannot overflow */
    const double nx = floor((double)d->size[0] / (double)d->tile_size);
    const double ny = floor((double)d->size[1] / (double)d->tile_size);
    if (nx * ny > (double)TSK_MEADOW_MAX_TILES)
        return tsk_error_arg(TSK_ERR_LIMIT, "tile_size",
                             "%.0f x %.0f tiles exceed the limit of %d tiles; use larger tiles", nx,
                             ny, TSK_MEADOW_MAX_TILES);
    if (nx * ny * (double)d->blades_per_tile > (double)TSK_MEADOW_MAX_BLADES)
        return tsk_error_arg(TSK_ERR_LIMIT, "blades_per_tile",
                             "%.0f tiles x %d blades = %.0f blades exceed the meadow limit of "
                             "%lld",
                             nx * ny, (int)d->blades_per_tile, nx * ny * d->blades_per_tile,
                             (long long)TSK_MEADOW_MAX_BLADES);
    return tsk_meadow_check_density(d);
}

typedef struct tiles_ctx {
    tsk_meadow* m;
    tsk_noise noise;
    int64_t* chunk_sums; /* blades per chunk of tiles */
    int64_t* chunk_nonempty;
} tiles_ctx;

static void compute_tiles(size_t begin, size_t end, size_t chunk, void* vctx) {
    tiles_ctx* c = vctx;
    tsk_meadow* m = c->m;
    const tsk_meadow_def* d = &m->def;
    const int32_t C = d->chunk_blades;
    const uint64_t runs = (uint64_t)(d->patch_blades / C);
    const int32_t cap = C * (d->blades_per_tile / C);
    const double ts = d->tile_size;
    int64_t sum = 0, nonempty = 0;
    for (size_t t = begin; t < end; ++t) {
        const int32_t i = (int32_t)(t % (size_t)m->tiles_x), j = (int32_t)(t / (size_t)m->tiles_x);
        const double cx = (double)d->origin[0] + ((double)i + 0.5) * ts;
        const double cy = (double)d->origin[1] + ((double)j + 0.5) * ts;
        const double dens = tsk_meadow_density_at(d, &c->noise, cx, cy);
        int32_t count = C * (int32_t)floor((double)d->blades_per_tile * dens / C + 0.5);
        if (count > cap) count = cap;
        m->density[t] = (float)dens;
        m->counts[t] = count;
        /* seed 000 §4.5: the tile's offset in the patch from its position in the scene */
        m->offsets[t] =
            C * (int32_t)(tsk_hash4(d->seed, TSK_TILE_STREAM, (uint64_t)i, (uint64_t)j) % runs);
        sum += count;
        nonempty += count > 0;
    }
    c->chunk_sums[chunk] = sum;
    c->chunk_nonempty[chunk] = nonempty;
}

static void prefix_tiles(size_t begin, size_t end, size_t chunk, void* vctx) {
    tiles_ctx* c = vctx;
    int64_t acc = c->chunk_sums[chunk]; /* holds the exclusive prefix of this chunk here */
    for (size_t t = begin; t < end; ++t) {
        c->m->first_blade[t] = acc;
        acc += c->m->counts[t];
    }
}

tsk_status tsk_meadow_create(const tsk_meadow_def* def, tsk_meadow** out) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    if (def == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "def", "is NULL");
    tsk_status s = check_def(def);
    if (s != TSK_OK) return s;
    {
        /* memory budget: the tile arrays, plus the chunk instances the caller builds from
         * them (origin, chunk, tile: 20 bytes each) when every tile is full */
        const double tiles = floor((double)def->size[0] / (double)def->tile_size) *
                             floor((double)def->size[1] / (double)def->tile_size);
        const double instances = tiles * (double)def->blades_per_tile / (double)def->chunk_blades;
        s = tsk_memory_check(tiles * 20.0 + instances * 20.0, "meadow");
        if (s != TSK_OK) return s;
    }

    tsk_meadow* m = tsk_calloc(1, sizeof *m, "meadow");
    if (m == NULL) return TSK_ERR_MEMORY;
    m->def = *def;
    m->tiles_x = (int32_t)floor((double)def->size[0] / (double)def->tile_size);
    m->tiles_y = (int32_t)floor((double)def->size[1] / (double)def->tile_size);
    m->tile_count = (int64_t)m->tiles_x * m->tiles_y;
    const size_t n = (size_t)m->tile_count;
    m->counts = tsk_alloc(n * sizeof(int32_t), "tile counts");
    m->offsets = tsk_alloc(n * sizeof(int32_t), "tile offsets");
    m->density = tsk_alloc(n * sizeof(float), "tile density");
    m->first_blade = tsk_alloc((n + 1) * sizeof(int64_t), "tile prefix sums");
    const size_t chunks = tsk_chunk_count(n, TILE_GRAIN);
    tiles_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.m = m;
    ctx.chunk_sums = tsk_alloc(chunks * sizeof(int64_t), "tile chunk sums");
    ctx.chunk_nonempty = tsk_alloc(chunks * sizeof(int64_t), "tile chunk sums");
    if (!m->counts || !m->offsets || !m->density || !m->first_blade || !ctx.chunk_sums ||
        !ctx.chunk_nonempty) {
        tsk_free(ctx.chunk_sums);
        tsk_free(ctx.chunk_nonempty);
        tsk_meadow_destroy(m);
        return TSK_ERR_MEMORY;
    }
    tsk_noise_init(&ctx.noise, def->seed);
    tsk_parallel_for(n, TILE_GRAIN, compute_tiles, &ctx);
    /* chunk sums -> exclusive prefixes, in chunk order (thread-count independent) */
    int64_t acc = 0, nonempty = 0;
    for (size_t c = 0; c < chunks; ++c) {
        const int64_t v = ctx.chunk_sums[c];
        ctx.chunk_sums[c] = acc;
        acc += v;
        nonempty += ctx.chunk_nonempty[c];
    }
    tsk_parallel_for(n, TILE_GRAIN, prefix_tiles, &ctx);
    m->first_blade[n] = acc;
    m->nonempty = nonempty;
    m->def.image = NULL; /* not kept */
    tsk_free(ctx.chunk_sums);
    tsk_free(ctx.chunk_nonempty);
    *out = m;
    return TSK_OK;
}

tsk_status tsk_meadow_get_info(const tsk_meadow* m, tsk_meadow_info* info) {
    if (m == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "meadow", "is NULL");
    if (info == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "info", "is NULL");
    memset(info, 0, sizeof *info);
    info->tiles_x = m->tiles_x;
    info->tiles_y = m->tiles_y;
    info->tile_count = m->tile_count;
    info->blade_count = m->first_blade[m->tile_count];
    info->nonempty_tiles = m->nonempty;
    info->chunk_instances = info->blade_count / m->def.chunk_blades;
    info->patch_blades = m->def.patch_blades;
    info->chunk_blades = m->def.chunk_blades;
    info->tile_size = m->def.tile_size;
    for (int a = 0; a < 3; ++a) info->origin[a] = m->def.origin[a];
    return TSK_OK;
}

tsk_status tsk_meadow_get_tiles(const tsk_meadow* m, int32_t* counts, int32_t* offsets,
                                float* density) {
    if (m == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "meadow", "is NULL");
    const size_t n = (size_t)m->tile_count;
    if (counts) memcpy(counts, m->counts, n * sizeof(int32_t));
    if (offsets) memcpy(offsets, m->offsets, n * sizeof(int32_t));
    if (density) memcpy(density, m->density, n * sizeof(float));
    return TSK_OK;
}

tsk_status tsk_meadow_blade_count(const tsk_meadow* m, int64_t tile_begin, int64_t tile_end,
                                  int64_t* count) {
    if (m == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "meadow", "is NULL");
    if (count == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "count", "is NULL");
    if (tile_begin < 0 || tile_end < tile_begin || tile_end > m->tile_count)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "tile_begin",
                             "tile range [%lld, %lld) is not inside [0, %lld)",
                             (long long)tile_begin, (long long)tile_end, (long long)m->tile_count);
    *count = m->first_blade[tile_end] - m->first_blade[tile_begin];
    return TSK_OK;
}
