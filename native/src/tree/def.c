/* Tree definitions: defaults, the built-in Weber–Penn presets, parameter validation and
 * Weber–Penn's ShapeRatio. Every default lives here. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "tree_internal.h"
#include "core/tmath.h"

static tsk_tree_level_def lvl(float length, float length_v, float taper, float seg_splits,
                              float split_angle, float split_angle_v, int curve_res, float curve,
                              float curve_back, float curve_v, float down_angle, float down_angle_v,
                              float rotate, float rotate_v, int branches) {
    tsk_tree_level_def l;
    l.length = length;
    l.length_v = length_v;
    l.taper = taper;
    l.seg_splits = seg_splits;
    l.split_angle = split_angle;
    l.split_angle_v = split_angle_v;
    l.curve_res = curve_res;
    l.curve = curve;
    l.curve_back = curve_back;
    l.curve_v = curve_v;
    l.down_angle = down_angle;
    l.down_angle_v = down_angle_v;
    l.rotate = rotate;
    l.rotate_v = rotate_v;
    l.branches = branches;
    return l;
}

tsk_tree_def tsk_default_tree_def(void) {
    tsk_tree_def d;
    memset(&d, 0, sizeof d);
    d.seed = 1;
    d.shape = TSK_TREE_TEND_FLAME;
    d.base_size = 0.4f;
    d.scale = 10.0f;
    d.scale_v = 0.0f;
    d.z_scale = 1.0f;
    d.z_scale_v = 0.0f;
    d.levels = 2;
    d.ratio = 0.02f;
    d.ratio_power = 1.2f;
    d.lobes = 0;
    d.lobe_depth = 0.0f;
    d.flare = 0.5f;
    d.scale0 = 1.0f;
    d.scale0_v = 0.0f;
    d.base_splits = 0;
    d.level[0] = lvl(1.0f, 0, 1, 0, 0, 0, 6, 0, 0, 10, 0, 0, 0, 0, 0);
    d.level[1] = lvl(0.4f, 0, 1, 0, 0, 0, 4, -20, 0, 20, 60, 10, 140, 0, 30);
    d.level[2] = lvl(0.5f, 0, 1, 0, 0, 0, 3, -10, 0, 30, 45, 10, 140, 0, 10);
    d.level[3] = lvl(0.4f, 0, 1, 0, 0, 0, 2, 0, 0, 0, 45, 10, 77, 0, 6);
    d.leaves = 20;
    d.leaf_shape = 0;
    d.leaf_scale = 0.15f;
    d.leaf_scale_x = 0.6f;
    d.attraction_up = 0.5f;
    d.prune_ratio = 0.0f;
    d.prune_width = 0.5f;
    d.prune_width_peak = 0.5f;
    d.prune_power_low = 0.5f;
    d.prune_power_high = 0.5f;
    d.taper_power = 1.0f;
    d.lobe_fade = 0.0f;
    d.bulges = 0;
    d.bulge_depth = 0.0f;
    d.max_branches = 1u << 20;
    d.max_leaves = 1u << 21;
    return d;
}

/* ---- presets: Weber & Penn 1995 tables as carried by Blender's Sapling presets; Lobes,
 * LobeDepth and Flare from the paper (Sapling lacks them). Unused level-3 rows keep the
 * paper's down/rotate values, which leaves of a 3-level tree use. */

static void preset_quaking_aspen(tsk_tree_def* d) {
    d->shape = 7, d->base_size = 0.4f, d->scale = 13, d->scale_v = 3, d->levels = 3;
    d->ratio = 0.015f, d->ratio_power = 1.2f, d->lobes = 5, d->lobe_depth = 0.07f;
    d->flare = 0.6f, d->scale0 = 1, d->scale0_v = 0.2f, d->base_splits = 0;
    d->level[0] = lvl(1, 0, 1, 0, 0, 0, 3, 0, 0, 20, 0, 0, 0, 0, 0);
    d->level[1] = lvl(0.3f, 0, 1, 0, 0, 0, 5, -40, 0, 50, 60, -50, 140, 0, 50);
    d->level[2] = lvl(0.6f, 0, 1, 0, 0, 0, 3, -40, 0, 75, 45, 10, 140, 0, 30);
    d->level[3] = lvl(0.45f, 0, 1, 0, 0, 0, 1, 0, 0, 0, 45, 10, 77, 0, 10);
    d->leaves = 25, d->leaf_shape = 0, d->leaf_scale = 0.17f, d->leaf_scale_x = 1;
    d->attraction_up = 0.5f, d->prune_ratio = 0;
}

static void preset_black_tupelo(tsk_tree_def* d) {
    d->shape = 4, d->base_size = 0.2f, d->scale = 23, d->scale_v = 5, d->levels = 4;
    d->ratio = 0.015f, d->ratio_power = 1.3f, d->lobes = 3, d->lobe_depth = 0.1f;
    d->flare = 1.0f, d->scale0 = 1, d->scale0_v = 0, d->base_splits = 0;
    d->level[0] = lvl(1, 0, 1, 0, 0, 0, 10, 0, 0, 40, 0, 0, 0, 0, 0);
    d->level[1] = lvl(0.3f, 0.05f, 1, 0, 0, 0, 10, 0, 0, 90, 60, -40, 140, 0, 50);
    d->level[2] = lvl(0.6f, 0.1f, 1, 0, 0, 0, 10, -10, 0, 150, 30, 10, 140, 0, 25);
    d->level[3] = lvl(0.4f, 0, 1, 0, 0, 0, 1, 0, 0, 0, 45, 10, 140, 0, 12);
    d->leaves = 6, d->leaf_shape = 0, d->leaf_scale = 0.3f, d->leaf_scale_x = 0.5f;
    d->attraction_up = 0.5f, d->prune_ratio = 0;
}

static void preset_weeping_willow(tsk_tree_def* d) {
    d->shape = 3, d->base_size = 0.05f, d->scale = 15, d->scale_v = 5, d->levels = 4;
    d->ratio = 0.03f, d->ratio_power = 2, d->lobes = 9, d->lobe_depth = 0.03f;
    d->flare = 0.75f, d->scale0 = 1, d->scale0_v = 0, d->base_splits = 2;
    d->level[0] = lvl(0.8f, 0, 1, 0.1f, 3, 0, 8, 0, 20, 120, 0, 0, 0, 0, 0);
    d->level[1] = lvl(0.5f, 0.1f, 1, 0.2f, 30, 10, 16, 40, 80, 90, 20, 10, -120, 30, 25);
    d->level[2] = lvl(1.5f, 0, 1, 0.2f, 45, 20, 12, 0, 0, 0, 30, 10, -120, 30, 10);
    d->level[3] = lvl(0.1f, 0, 1, 0, 0, 0, 1, 0, 0, 0, 20, 10, 140, 0, 300);
    d->leaves = 15, d->leaf_shape = 0, d->leaf_scale = 0.12f, d->leaf_scale_x = 0.2f;
    d->attraction_up = -3, d->prune_ratio = 1, d->prune_width = 0.4f;
    d->prune_width_peak = 0.6f, d->prune_power_low = 0.001f, d->prune_power_high = 0.5f;
}

static void preset_ca_black_oak(tsk_tree_def* d) {
    d->shape = 2, d->base_size = 0.05f, d->scale = 10, d->scale_v = 5, d->levels = 3;
    d->ratio = 0.018f, d->ratio_power = 1.3f, d->lobes = 5, d->lobe_depth = 0.1f;
    d->flare = 1.2f, d->scale0 = 1, d->scale0_v = 0, d->base_splits = 2;
    d->level[0] = lvl(1, 0, 0.95f, 0.4f, 10, 0, 8, 0, 0, 90, 0, 0, 0, 0, 0);
    d->level[1] = lvl(0.8f, 0.1f, 1, 0.2f, 10, 10, 10, 40, -70, 150, 30, -30, 80, 0, 40);
    d->level[2] = lvl(0.2f, 0.05f, 1, 0.1f, 10, 10, 3, 0, 0, 30, 45, 10, 140, 0, 120);
    d->level[3] = lvl(0.4f, 0, 1, 0, 0, 0, 1, 0, 0, 0, 45, 10, 140, 0, 0);
    d->leaves = 25, d->leaf_shape = 6, d->leaf_scale = 0.12f, d->leaf_scale_x = 0.66f;
    d->attraction_up = 0.8f, d->prune_ratio = 0;
}

static void preset_lombardy_poplar(tsk_tree_def* d) {
    d->shape = 2, d->base_size = 0.1f, d->scale = 25, d->scale_v = 5, d->levels = 3;
    d->ratio = 0.015f, d->ratio_power = 1.2f, d->lobes = 0, d->lobe_depth = 0;
    d->flare = 0.8f, d->scale0 = 1, d->scale0_v = 0, d->base_splits = 0;
    d->level[0] = lvl(1, 0, 1, 0, 0, 0, 4, 0, 0, 0, 0, 0, 0, 0, 0);
    d->level[1] = lvl(0.3f, 0, 1, 0, 0, 0, 3, -20, 0, 0, 30, 0, 77, 15, 60);
    d->level[2] = lvl(0.4f, 0.1f, 1, 0, 0, 0, 3, -20, 0, 40, 30, 10, 77, 15, 35);
    d->level[3] = lvl(0.3f, 0, 1, 0, 0, 0, 1, 0, 0, 0, 30, 10, 77, 15, 10);
    d->leaves = 30, d->leaf_shape = 8, d->leaf_scale = 0.3f, d->leaf_scale_x = 1;
    d->attraction_up = 0.5f, d->prune_ratio = 0;
}

static void preset_european_larch(tsk_tree_def* d) {
    d->shape = 0, d->base_size = 0.25f, d->scale = 15, d->scale_v = 7, d->levels = 3;
    d->ratio = 0.015f, d->ratio_power = 1.3f, d->lobes = 0, d->lobe_depth = 0;
    d->flare = 0.3f, d->scale0 = 1, d->scale0_v = 0, d->base_splits = 0;
    d->level[0] = lvl(1, 0, 1, 0, 0, 0, 20, 0, 0, 60, 0, 0, 0, 0, 0);
    d->level[1] = lvl(0.25f, 0, 1, 0, 0, 0, 17, 20, -100, 120, 60, -50, 70, 30, 60);
    d->level[2] = lvl(0.3f, 0.1f, 1, 0.15f, 40, 10, 7, 0, 0, 0, 70, 30, 70, 30, 50);
    d->level[3] = lvl(0.3f, 0, 1, 0, 0, 0, 1, 0, 0, 0, 30, 15, 120, 30, 0);
    d->leaves = 200, d->leaf_shape = 2, d->leaf_scale = 0.07f, d->leaf_scale_x = 0.5f;
    d->attraction_up = -2, d->prune_ratio = 0;
}

typedef struct preset_entry {
    const char* name;
    void (*fill)(tsk_tree_def*);
} preset_entry;

static const preset_entry g_presets[] = {
    {"quaking_aspen", preset_quaking_aspen},     {"black_tupelo", preset_black_tupelo},
    {"weeping_willow", preset_weeping_willow},   {"ca_black_oak", preset_ca_black_oak},
    {"lombardy_poplar", preset_lombardy_poplar}, {"european_larch", preset_european_larch},
};
enum { PRESET_COUNT = (int)(sizeof g_presets / sizeof g_presets[0]) };

int tsk_tree_preset_count(void) { return PRESET_COUNT; }

const char* tsk_tree_preset_name(int index) {
    return index >= 0 && index < PRESET_COUNT ? g_presets[index].name : NULL;
}

tsk_status tsk_tree_preset(const char* name, tsk_tree_def* out) {
    if (name == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "name", "is NULL");
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    for (int i = 0; i < PRESET_COUNT; ++i) {
        if (strcmp(name, g_presets[i].name) == 0) {
            *out = tsk_default_tree_def();
            g_presets[i].fill(out);
            return TSK_OK;
        }
    }
    return tsk_error_arg(TSK_ERR_ARGUMENT, "name",
                         "unknown tree preset '%.64s' (quaking_aspen, black_tupelo, "
                         "weeping_willow, ca_black_oak, lombardy_poplar, european_larch)",
                         name);
}

/* ---- validation -------------------------------------------------------------------------- */

static tsk_status check_range(const char* name, double v, double lo, double hi) {
    if (!isfinite(v)) return tsk_error_arg(TSK_ERR_ARGUMENT, name, "is not finite (%g)", v);
    if (v < lo || v > hi)
        return tsk_error_arg(TSK_ERR_ARGUMENT, name, "must be in [%g, %g], got %g", lo, hi, v);
    return TSK_OK;
}

#define CHECK_FIELD(expr, name, lo, hi)                            \
    do {                                                           \
        tsk_status s_ = check_range(name, (double)(expr), lo, hi); \
        if (s_ != TSK_OK) return s_;                               \
    } while (0)

static tsk_status check_level(const tsk_tree_level_def* l, int n, int used, int placed) {
    char name[48];
#define LNAME(field) (snprintf(name, sizeof name, "level[%d]." field, n), name)
    /* every field must be finite, used or not */
    const float fields[] = {l->length,      l->length_v,      l->taper,        l->seg_splits,
                            l->split_angle, l->split_angle_v, l->curve,        l->curve_back,
                            l->curve_v,     l->down_angle,    l->down_angle_v, l->rotate,
                            l->rotate_v};
    static const char* names[] = {"length",      "length_v",      "taper",        "seg_splits",
                                  "split_angle", "split_angle_v", "curve",        "curve_back",
                                  "curve_v",     "down_angle",    "down_angle_v", "rotate",
                                  "rotate_v"};
    for (size_t i = 0; i < sizeof fields / sizeof fields[0]; ++i) {
        if (!isfinite(fields[i])) {
            snprintf(name, sizeof name, "level[%d].%s", n, names[i]);
            return tsk_error_arg(TSK_ERR_ARGUMENT, name, "is not finite (%g)", (double)fields[i]);
        }
    }
    if (used) {
        CHECK_FIELD(l->length, LNAME("length"), 0.0, 10.0);
        CHECK_FIELD(l->length_v, LNAME("length_v"), 0.0, 10.0);
        CHECK_FIELD(l->taper, LNAME("taper"), 0.0, 1.0);
        CHECK_FIELD(l->seg_splits, LNAME("seg_splits"), 0.0, 4.0);
        CHECK_FIELD(l->split_angle, LNAME("split_angle"), -180.0, 180.0);
        CHECK_FIELD(l->split_angle_v, LNAME("split_angle_v"), -180.0, 180.0);
        CHECK_FIELD(l->curve_res, LNAME("curve_res"), 1.0, 64.0);
        CHECK_FIELD(l->curve, LNAME("curve"), -3600.0, 3600.0);
        CHECK_FIELD(l->curve_back, LNAME("curve_back"), -3600.0, 3600.0);
        CHECK_FIELD(l->curve_v, LNAME("curve_v"), -3600.0, 3600.0);
    }
    if (placed) {
        CHECK_FIELD(l->down_angle, LNAME("down_angle"), -180.0, 180.0);
        CHECK_FIELD(l->down_angle_v, LNAME("down_angle_v"), -180.0, 180.0);
        CHECK_FIELD(l->rotate, LNAME("rotate"), -360.0, 360.0);
        CHECK_FIELD(l->rotate_v, LNAME("rotate_v"), -360.0, 360.0);
    }
    if (used && n > 0) {
        if (l->branches < 0)
            return tsk_error_arg(TSK_ERR_ARGUMENT, LNAME("branches"), "must be >= 0, got %d",
                                 l->branches);
        if (l->branches > TSK_TREE_MAX_CHILDREN)
            return tsk_error_arg(TSK_ERR_LIMIT, LNAME("branches"),
                                 "%d children per stem exceeds the limit of %d", l->branches,
                                 TSK_TREE_MAX_CHILDREN);
    }
#undef LNAME
    return TSK_OK;
}

tsk_status tsk_tree_validate(const tsk_tree_def* d) {
    if (d == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "def", "is NULL");
    if (d->levels < 1 || d->levels > TSK_TREE_MAX_LEVELS)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "levels", "must be 1..%d, got %d",
                             TSK_TREE_MAX_LEVELS, d->levels);
    if (d->shape < 0 || d->shape > 7)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "shape", "must be 0..7, got %d", d->shape);
    CHECK_FIELD(d->base_size, "base_size", 0.0, 0.999);
    CHECK_FIELD(d->scale, "scale", 1e-3, 1000.0);
    CHECK_FIELD(d->scale_v, "scale_v", 0.0, 1000.0);
    if (d->scale_v >= d->scale)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "scale_v", "must be below scale (%g), got %g",
                             (double)d->scale, (double)d->scale_v);
    CHECK_FIELD(d->z_scale, "z_scale", 1e-3, 100.0);
    CHECK_FIELD(d->z_scale_v, "z_scale_v", 0.0, 100.0);
    if (d->z_scale_v >= d->z_scale)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "z_scale_v", "must be below z_scale (%g), got %g",
                             (double)d->z_scale, (double)d->z_scale_v);
    CHECK_FIELD(d->ratio, "ratio", 1e-6, 1.0);
    CHECK_FIELD(d->ratio_power, "ratio_power", 0.0, 10.0);
    CHECK_FIELD(d->lobes, "lobes", 0.0, 64.0);
    CHECK_FIELD(d->lobe_depth, "lobe_depth", 0.0, 0.9);
    CHECK_FIELD(d->flare, "flare", 0.0, 10.0);
    CHECK_FIELD(d->scale0, "scale0", 1e-6, 100.0);
    CHECK_FIELD(d->scale0_v, "scale0_v", 0.0, 100.0);
    if (d->scale0_v >= d->scale0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "scale0_v", "must be below scale0 (%g), got %g",
                             (double)d->scale0, (double)d->scale0_v);
    CHECK_FIELD(d->base_splits, "base_splits", 0.0, 32.0);
    for (int n = 0; n < TSK_TREE_MAX_LEVELS; ++n) {
        int used = n < d->levels;
        int placed =
            (n >= 1 && n < d->levels) || (n == d->levels && d->leaves > 0) ||
            (n == TSK_TREE_MAX_LEVELS - 1 && d->levels == TSK_TREE_MAX_LEVELS && d->leaves > 0);
        tsk_status s = check_level(&d->level[n], n, used, placed);
        if (s != TSK_OK) return s;
    }
    if (d->leaves < 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "leaves",
                             "must be >= 0, got %d (Weber-Penn leaf fans are not supported)",
                             d->leaves);
    if (d->leaves > TSK_TREE_MAX_CHILDREN)
        return tsk_error_arg(TSK_ERR_LIMIT, "leaves", "%d leaves per stem exceeds the limit of %d",
                             d->leaves, TSK_TREE_MAX_CHILDREN);
    CHECK_FIELD(d->leaf_shape, "leaf_shape", 0.0, 9.0);
    CHECK_FIELD(d->leaf_scale, "leaf_scale", 0.0, 100.0);
    CHECK_FIELD(d->leaf_scale_x, "leaf_scale_x", 0.0, 10.0);
    CHECK_FIELD(d->attraction_up, "attraction_up", -10.0, 10.0);
    CHECK_FIELD(d->prune_ratio, "prune_ratio", 0.0, 1.0);
    CHECK_FIELD(d->prune_width, "prune_width", 0.0, 10.0);
    CHECK_FIELD(d->prune_width_peak, "prune_width_peak", 0.0, 1.0);
    CHECK_FIELD(d->prune_power_low, "prune_power_low", 0.0, 10.0);
    CHECK_FIELD(d->prune_power_high, "prune_power_high", 0.0, 10.0);
    if (d->prune_ratio > 0 && !(d->prune_width > 0))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "prune_width", "must be > 0 when pruning");
    CHECK_FIELD(d->taper_power, "taper_power", 1e-3, 100.0);
    CHECK_FIELD(d->lobe_fade, "lobe_fade", 0.0, 1.0);
    CHECK_FIELD(d->bulges, "bulges", 0.0, 1000.0);
    CHECK_FIELD(d->bulge_depth, "bulge_depth", 0.0, 0.9);
    if (d->max_branches < 1 || d->max_branches > TSK_TREE_HARD_LIMIT)
        return tsk_error_arg(TSK_ERR_LIMIT, "max_branches", "must be 1..%u, got %u",
                             TSK_TREE_HARD_LIMIT, d->max_branches);
    if (d->max_leaves > TSK_TREE_HARD_LIMIT)
        return tsk_error_arg(TSK_ERR_LIMIT, "max_leaves", "must be 0..%u, got %u",
                             TSK_TREE_HARD_LIMIT, d->max_leaves);
    return TSK_OK;
}

/* Weber & Penn 1995, ShapeRatio(shape, ratio). */
float tree_shape_ratio(int shape, float r) {
    const float pi = 3.14159265358979f;
    switch (shape) {
        case TSK_TREE_CONICAL:
            return 0.2f + 0.8f * r;
        case TSK_TREE_SPHERICAL:
            return 0.2f + 0.8f * tsk_sinf(pi * r);
        case TSK_TREE_HEMISPHERICAL:
            return 0.2f + 0.8f * tsk_sinf(0.5f * pi * r);
        case TSK_TREE_CYLINDRICAL:
            return 1.0f;
        case TSK_TREE_TAPERED_CYLINDRICAL:
            return 0.5f + 0.5f * r;
        case TSK_TREE_FLAME:
            return r <= 0.7f ? r / 0.7f : (1.0f - r) / 0.3f;
        case TSK_TREE_INVERSE_CONICAL:
            return 1.0f - 0.8f * r;
        case TSK_TREE_TEND_FLAME:
            return r <= 0.7f ? 0.5f + 0.5f * r / 0.7f : 0.5f + 0.5f * (1.0f - r) / 0.3f;
        default:
            return 1.0f;
    }
}
