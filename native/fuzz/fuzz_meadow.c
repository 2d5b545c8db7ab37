/* Fuzz target: blade models, patch and meadow definitions. The bytes give up to 3 blade
 * models (knot counts and coordinates, edge values included), a tsk_patch_def (weights,
 * knot count, scales), a tsk_meadow_def (sizes, tiles, density kind, noise, a small density
 * image), then the patch mesh, the tile data, chunk instances and the realised blades and
 * knots of the first tiles, and blade expansion of fuzzed skeletons. The harness keeps
 * patches at most 4096 blades (larger valid counts are cut down: cost only); the memory
 * budget (256 MiB, fz_init) refuses larger meadows through the library's own check. */
#include "fuzz.h"
#include "tussock/meadow.h"

int LLVMFuzzerInitialize(int* argc, char*** argv) {
    (void)argc;
    (void)argv;
    fz_init();
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fz r = {data, size};
    tsk_blade_model models[3];
    int nm = fz_u8(&r) % 4;
    for (int m = 0; m < nm; ++m) {
        int k = fz_int(&r, 8);
        float xyz[3 * 70], wid[70];
        const int kk = (k >= 2 && k <= 70) ? k : 8;
        for (int i = 0; i < kk; ++i) {
            xyz[3 * i] = fz_float(&r, 0.01f * i);
            xyz[3 * i + 1] = fz_float(&r, 0.0f);
            xyz[3 * i + 2] = fz_float(&r, 0.05f * i);
            wid[i] = fz_float(&r, 0.01f);
        }
        if (tsk_blade_model_set(&models[m], xyz, wid, (k >= 2 && k <= 70) ? k : kk) != TSK_OK)
            (void)tsk_blade_model_default(&models[m], 2 + (fz_u8(&r) % 63));
        tsk_blade_model res;
        (void)tsk_blade_model_resample(&models[m], fz_int(&r, 5), &res);
        float side[3];
        tsk_blade_model_side(&models[m], side);
        if (!isfinite(side[0]) || !isfinite(side[1])) abort();
    }
    tsk_patch_def pd = tsk_default_patch_def();
    pd.blade_count = fz_int(&r, 64);
    if (pd.blade_count > 4096 && pd.blade_count <= TSK_PATCH_MAX_BLADES)
        pd.blade_count = 1 + pd.blade_count % 4096;
    pd.scale_min = fz_float(&r, pd.scale_min);
    pd.scale_max = fz_float(&r, pd.scale_max);
    pd.seed = fz_u64(&r);
    pd.knot_count = fz_int(&r, 0);
    float weights[3] = {fz_float(&r, 1.0f), fz_float(&r, 1.0f), fz_float(&r, 1.0f)};
    pd.models = nm ? models : NULL;
    pd.model_count = nm;
    if (fz_u8(&r) % 8 == 0) pd.model_count = fz_int(&r, nm) % 4; /* mismatched */
    if (pd.model_count > nm) pd.model_count = nm;
    pd.model_weights = (fz_u8(&r) & 1) ? weights : NULL;
    tsk_patch* patch = NULL;
    if (tsk_patch_create(&pd, &patch) == TSK_OK) {
        const int32_t nb = tsk_patch_blade_count(patch), kn = tsk_patch_knot_count(patch);
        if (nb != pd.blade_count || kn < 2 || kn > TSK_BLADE_MAX_KNOTS) {
            fprintf(stderr, "patch: %d blades (asked %d), %d knots (asked %d)\n", nb,
                    pd.blade_count, kn, pd.knot_count);
            abort();
        }
        size_t nv = 0, nt = 0;
        if (tsk_patch_mesh_counts(patch, &nv, &nt) != TSK_OK) abort();
        float* pos = malloc(nv * 3 * sizeof *pos);
        float* nor = malloc(nv * 3 * sizeof *nor);
        float* uvs = malloc(nv * 2 * sizeof *uvs);
        int32_t* tris = malloc(nt * 3 * sizeof *tris);
        int32_t* bi = malloc(nv * sizeof *bi);
        if (tsk_patch_expand(patch, fz_float(&r, 0.5f), pos, nor, uvs, tris, bi) == TSK_OK)
            for (size_t i = 0; i < nt * 3; ++i)
                if (tris[i] < 0 || (size_t)tris[i] >= nv) abort();
        free(pos);
        free(nor);
        free(uvs);
        free(tris);
        free(bi);
        tsk_blade_model bm;
        (void)tsk_patch_get_model(patch, fz_int(&r, 0), &bm);
    }
    tsk_meadow_def md = tsk_default_meadow_def();
    md.origin[0] = fz_float(&r, 0.0f);
    md.size[0] = fz_float(&r, 2.0f);
    md.size[1] = fz_float(&r, 2.0f);
    md.tile_size = fz_float(&r, 0.5f);
    md.blades_per_tile = fz_int(&r, 16);
    md.patch_blades = patch ? tsk_patch_blade_count(patch) : fz_int(&r, 64);
    md.chunk_blades = fz_int(&r, 1);
    md.seed = fz_u64(&r);
    md.density = (tsk_density_kind)(fz_u8(&r) % 4);
    md.noise_scale = fz_float(&r, md.noise_scale);
    md.noise_octaves = fz_int(&r, md.noise_octaves);
    md.noise_persistence = fz_float(&r, md.noise_persistence);
    md.noise_contrast = fz_float(&r, md.noise_contrast);
    md.noise_threshold = fz_float(&r, md.noise_threshold);
    float image[64];
    for (int i = 0; i < 64; ++i) image[i] = fz_float(&r, 0.5f);
    md.image = (fz_u8(&r) % 4) ? image : NULL;
    md.image_width = fz_int(&r, 8);
    md.image_height = fz_int(&r, 8);
    if ((int64_t)md.image_width * md.image_height > 64) md.image_width = md.image_height = 8;
    tsk_meadow* meadow = NULL;
    if (tsk_meadow_create(&md, &meadow) == TSK_OK) {
        tsk_meadow_info info;
        if (tsk_meadow_get_info(meadow, &info) != TSK_OK) abort();
        if (info.tile_count != (int64_t)info.tiles_x * info.tiles_y) abort();
        if (info.tile_count <= 4096 && info.chunk_instances <= 65536) {
            const size_t nt = (size_t)info.tile_count, ni = (size_t)info.chunk_instances;
            int32_t* counts = malloc((nt + 1) * sizeof *counts);
            int32_t* offs = malloc((nt + 1) * sizeof *offs);
            float* dens = malloc((nt + 1) * sizeof *dens);
            float* org = malloc((nt + ni + 1) * 3 * sizeof *org);
            int32_t* ch = malloc((ni + 1) * sizeof *ch);
            int32_t* tl = malloc((ni + 1) * sizeof *tl);
            if (tsk_meadow_get_tiles(meadow, counts, offs, dens) != TSK_OK) abort();
            int64_t sum = 0;
            for (size_t t = 0; t < nt; ++t) {
                if (counts[t] < 0 || counts[t] > md.blades_per_tile) abort();
                if (offs[t] < 0 || offs[t] >= md.patch_blades) abort();
                if (!(dens[t] >= 0.0f && dens[t] <= 1.0f)) abort();
                sum += counts[t];
            }
            if (sum != info.blade_count) abort();
            if (tsk_meadow_instances(meadow, org, offs, counts) != TSK_OK) abort();
            if (tsk_meadow_chunk_instances(meadow, org, ch, tl) != TSK_OK) abort();
            for (size_t i = 0; i < ni; ++i)
                if (tl[i] < 0 || (size_t)tl[i] >= nt || ch[i] < 0 ||
                    ch[i] >= md.patch_blades / md.chunk_blades)
                    abort();
            free(counts);
            free(offs);
            free(dens);
            free(org);
            free(ch);
            free(tl);
        }
        int64_t te = info.tile_count < 4 ? info.tile_count : 4, bc = 0;
        const int64_t tb = fz_u8(&r) % 2;
        if (fz_u8(&r) % 8 == 0) te = (int64_t)fz_int(&r, 3);
        if (tsk_meadow_blade_count(meadow, tb, te, &bc) == TSK_OK && patch != NULL &&
            bc <= 4 * 65536) {
            const int kn = tsk_patch_knot_count(patch);
            float* xyz = malloc((size_t)(bc + 1) * 3 * sizeof *xyz);
            float* turn = malloc((size_t)(bc + 1) * sizeof *turn);
            float* sc = malloc((size_t)(bc + 1) * sizeof *sc);
            int32_t* pi = malloc((size_t)(bc + 1) * sizeof *pi);
            float* knots = malloc((size_t)(bc + 1) * 3 * kn * sizeof *knots);
            float* widths = malloc((size_t)(bc + 1) * kn * sizeof *widths);
            float* sides = malloc((size_t)(bc + 1) * 3 * sizeof *sides);
            (void)tsk_meadow_realise(meadow, patch, tb, te, xyz, turn, sc, pi);
            (void)tsk_meadow_realise_knots(meadow, patch, tb, te, knots, widths, sides);
            free(xyz);
            free(turn);
            free(sc);
            free(pi);
            free(knots);
            free(widths);
            free(sides);
        }
        tsk_meadow_destroy(meadow);
    }
    /* expansion of a fuzzed skeleton */
    {
        const int k = 2 + fz_u8(&r) % 7;
        /* buffers for the most knots, since the count handed over may be fuzzed */
        float knots[3 * TSK_BLADE_MAX_KNOTS] = {0}, widths[TSK_BLADE_MAX_KNOTS] = {0}, side[3];
        float pos[3 * 2 * TSK_BLADE_MAX_KNOTS], nor[3 * 2 * TSK_BLADE_MAX_KNOTS];
        float uvs[2 * 2 * TSK_BLADE_MAX_KNOTS];
        int32_t tris[3 * 2 * TSK_BLADE_MAX_KNOTS];
        for (int i = 0; i < k; ++i) {
            knots[3 * i] = fz_float(&r, 0.0f);
            knots[3 * i + 1] = fz_float(&r, 0.0f);
            knots[3 * i + 2] = fz_float(&r, 0.1f * i);
            widths[i] = fz_float(&r, 0.01f);
        }
        side[0] = fz_float(&r, 0.0f);
        side[1] = fz_float(&r, 1.0f);
        side[2] = fz_float(&r, 0.0f);
        (void)tsk_blade_expand(knots, widths, fz_u8(&r) % 16 ? k : fz_int(&r, k), side, pos, nor,
                               uvs);
        (void)tsk_blade_indices(fz_u8(&r) % 16 ? k : fz_int(&r, k), fz_int(&r, 0), tris);
        (void)tsk_blades_expand(knots, widths, side, 1, k, pos, nor, uvs);
    }
    tsk_noise noise;
    tsk_noise_init(&noise, fz_u64(&r));
    const double v = tsk_noise_fbm2(&noise, fz_float(&r, 1.5f), fz_float(&r, 2.5f),
                                    fz_int(&r, 3) % 13, fz_float(&r, 0.5f));
    (void)v;
    tsk_patch_destroy(patch);
    fz_check_leaks("meadow");
    return 0;
}
