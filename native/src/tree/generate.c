/* The Weber–Penn generator (Weber & Penn 1995): grows stems level by level, each stem one
 * cubic Bézier (seed 001 §2.1: "as if generating a branch with only 3 segments"), with its
 * attachment (v, theta, alpha) on the parent, clones from splits, leaves and pruning.
 *
 * Simplifications, stated: a stem's CurveRes segments (curve, curve-back, CurveV,
 * AttractionUp, ZScale) are walked as a polyline and fitted by one cubic Bézier that keeps
 * the end points and the start and end directions; clones are stems of the same level that
 * start on their stem at the split point (the stem itself does not deflect) and do not
 * split again; leaves sit on the stems of the last level (on the trunk for Levels = 1). */
#include <math.h>
#include <string.h>

#include "tree_internal.h"
#include "core/tmath.h"

#define DEG (3.14159265358979f / 180.0f)

enum rand_purpose {
    R_SCALE = 1,
    R_ZSCALE,
    R_SCALE0,
    R_LEN,
    R_DOWN,
    R_ROT0,
    R_ROT,
    R_CURVEV,
    R_SPLIT_ANGLE,
    R_SPLIT_ROT,
    R_LEAF_DOWN,
    R_LEAF_ROT0,
    R_LEAF_ROT,
};

/* One stem while growing (array of structs; turned into the tree's SoA at the end). */
typedef struct gstem {
    int32_t parent, level, depth, is_clone;
    float v, theta, alpha; /* attachment, radians */
    float length, radius;
    float len_max; /* the nLength(+V) factor drawn for this stem */
    float wp_parent_len; /* length of the level-(n-1) stem it grows from */
    float wp_offset; /* distance from that stem's base */
    float base_frac; /* fraction of the stem without children (BaseSize on the trunk) */
    float taper;
    float child_factor; /* 1/(1 + clones): a split stem shares its children with its clones */
    float Q[9];
    float P[12];
    float O[3];
    float root[3];
} gstem;

typedef struct gleaf {
    int32_t parent;
    float v, theta, alpha, length, width;
} gleaf;

typedef struct gen {
    const tsk_tree_def* d;
    gstem* s;
    size_t n, cap;
    gleaf* l;
    size_t ln, lcap;
    float scale_tree, z_scale;
    float split_error[TSK_TREE_MAX_LEVELS];
} gen;

/* What one thread needs to place stems: a tsk_tree shell to pose them with the shared pose
 * function, and the Sloan frames of the last parent it placed a stem on with the points and
 * end orientation they were built from (siblings are placed one after another). */
typedef struct placer {
    struct tsk_tree pose_shell;
    float frames_src[15];
    sloan_frames frames;
    int has_frames;
} placer;

static float rnd(const gen* g, int level, size_t idx, int purpose, size_t j) {
    return tsk_rand01(g->d->seed, ((uint64_t)(uint32_t)level << 40) ^ (uint64_t)idx,
                      (uint64_t)purpose, (uint64_t)j);
}
/* uniform in [-1, 1) */
static float rnd_sym(const gen* g, int level, size_t idx, int purpose, size_t j) {
    return 2.0f * rnd(g, level, idx, purpose, j) - 1.0f;
}

static tsk_status push_stem(gen* g, gstem** out) {
    if (g->n >= g->d->max_branches)
        return tsk_error_arg(TSK_ERR_LIMIT, "max_branches",
                             "these parameters grow more than %u branches; lower "
                             "level[n].branches or raise max_branches (at most %u)",
                             g->d->max_branches, TSK_TREE_HARD_LIMIT);
    if (g->n == g->cap) {
        size_t cap = g->cap ? g->cap * 2 : 256;
        if (cap > g->d->max_branches) cap = g->d->max_branches;
        /* the handle keeps ~30 floats per branch beside the generator's stems */
        if (tsk_memory_check((double)cap * (sizeof(gstem) + 128.0), "max_branches") != TSK_OK)
            return TSK_ERR_LIMIT;
        gstem* s = tsk_alloc(cap * sizeof(gstem), "tree stems");
        if (s == NULL) return TSK_ERR_MEMORY;
        if (g->n) memcpy(s, g->s, g->n * sizeof(gstem));
        tsk_free(g->s);
        g->s = s;
        g->cap = cap;
    }
    *out = &g->s[g->n++];
    memset(*out, 0, sizeof(gstem));
    (*out)->child_factor = 1.0f;
    return TSK_OK;
}

static tsk_status push_leaf(gen* g, gleaf** out) {
    if (g->ln >= g->d->max_leaves)
        return tsk_error_arg(TSK_ERR_LIMIT, "max_leaves",
                             "these parameters grow more than %u leaves; lower leaves or raise "
                             "max_leaves (at most %u)",
                             g->d->max_leaves, TSK_TREE_HARD_LIMIT);
    if (g->ln == g->lcap) {
        size_t cap = g->lcap ? g->lcap * 2 : 256;
        if (cap > g->d->max_leaves) cap = g->d->max_leaves;
        if (tsk_memory_check((double)cap * (sizeof(gleaf) + 64.0), "max_leaves") != TSK_OK)
            return TSK_ERR_LIMIT;
        gleaf* l = tsk_alloc(cap * sizeof(gleaf), "tree leaves");
        if (l == NULL) return TSK_ERR_MEMORY;
        if (g->ln) memcpy(l, g->l, g->ln * sizeof(gleaf));
        tsk_free(g->l);
        g->l = l;
        g->lcap = cap;
    }
    *out = &g->l[g->ln++];
    return TSK_OK;
}

/* Radius of stem s at v before flare/lobes: seed 001, eq. 2 with the Weber–Penn taper amount. */
static float stem_radius_at(const tsk_tree_def* d, const gstem* s, float v) {
    return s->radius * (1.0f - s->taper * tsk_powf(v, d->taper_power));
}

/* Rotates unit d toward +Z by `angle` radians (negative: toward -Z), clamped at the poles. */
static v3 toward_up(v3 d, float angle) {
    float decl = tsk_acosf(fmaxf(-1.0f, fminf(1.0f, d.z)));
    float nd = fmaxf(0.0f, fminf(3.14159265f, decl - angle));
    v3 h = v3_norm_or(v3_make(d.x, d.y, 0), v3_make(1, 0, 0));
    float sn, cn;
    tsk_sincosf(nd, &sn, &cn);
    return v3_make(h.x * sn, h.y * sn, cn);
}

/* Pruning envelope of Weber & Penn (ShapeRatio 8) around the trunk axis. */
static int inside_envelope(const gen* g, v3 p) {
    const tsk_tree_def* d = g->d;
    const float S = g->scale_tree;
    const float ratio = (S - p.z) / (S * (1.0f - d->base_size));
    if (!(ratio >= 0.0f && ratio <= 1.0f)) return 0;
    const float peak = d->prune_width_peak;
    float env;
    if (ratio < 1.0f - peak) env = tsk_powf(ratio / (1.0f - peak), d->prune_power_high);
    else env = peak > 0.0f ? tsk_powf((1.0f - ratio) / peak, d->prune_power_low) : 1.0f;
    return sqrtf(p.x * p.x + p.y * p.y) / S < d->prune_width * env;
}

/* Walks stem s (already attached: origin, axis, side, W) as a CurveRes polyline of total
 * length L and fits the cubic Bézier. Returns 1 if every polyline point is inside the
 * pruning envelope. idx keys the random numbers of the stem. */
static int shape_stem(const gen* g, const gstem* s, size_t idx, float L, v3 origin, v3 axis,
                      v3 side, v3* P) {
    const tsk_tree_def* d = g->d;
    const tsk_tree_level_def* lv = &d->level[s->level];
    const int R = lv->curve_res;
    const int half = R / 2;
    v3 x = origin;
    float beta = 0.0f, acc_up = 0.0f;
    v3 dir = axis;
    int inside = 1;
    for (int k = 0; k < R; ++k) {
        float inc;
        if (lv->curve_back == 0.0f || R < 2) inc = lv->curve / (float)R;
        else inc = k < half ? lv->curve / (float)half : lv->curve_back / (float)(R - half);
        inc += rnd_sym(g, s->level, idx, R_CURVEV, (size_t)k) * fabsf(lv->curve_v) / (float)R;
        inc *= DEG;
        const float b_mid = beta + 0.5f * inc; /* midpoint rule along the segment */
        beta += inc;
        float sb, cb;
        tsk_sincosf(b_mid, &sb, &cb);
        dir = v3_comb(axis, cb, side, sb);
        if (s->level >= 2 && d->attraction_up != 0.0f) {
            dir = toward_up(dir, acc_up);
            const float decl = tsk_acosf(fmaxf(-1.0f, fminf(1.0f, dir.z)));
            const float step = d->attraction_up * decl / (float)R;
            dir = toward_up(dir, step);
            acc_up += step;
        }
        v3 seg = v3_scale(dir, L / (float)R);
        if (s->level == 0) seg.z *= g->z_scale;
        x = v3_add(x, seg);
        if (d->prune_ratio > 0.0f && s->level >= 1 && !inside_envelope(g, x)) inside = 0;
    }
    /* end direction: the last segment's (with the second half of its bend) */
    v3 t_end = dir;
    if (s->level < 2 || d->attraction_up == 0.0f) {
        float sb, cb;
        tsk_sincosf(beta, &sb, &cb);
        t_end = v3_comb(axis, cb, side, sb);
    }
    v3 t0 = axis;
    if (s->level == 0) {
        t0 = v3_norm_or(v3_make(t0.x, t0.y, t0.z * g->z_scale), t0);
        t_end = v3_norm_or(v3_make(t_end.x, t_end.y, t_end.z * g->z_scale), t_end);
    }
    const float h = v3_len(v3_sub(x, origin)) / 3.0f;
    P[0] = origin;
    P[1] = v3_add(origin, v3_scale(t0, h));
    P[3] = x;
    P[2] = v3_sub(x, v3_scale(t_end, h));
    return inside;
}

/* The rest points of stem p and their Sloan frames, built once for a run of siblings: the
 * cache is keyed by the points themselves, so it can never be stale. */
static const sloan_frames* stem_frames(placer* pl, const gstem* p, v3* Pp) {
    tree_load_points(p->P, 0, Pp);
    if (!pl->has_frames || memcmp(pl->frames_src, p->P, 12 * sizeof(float)) != 0 ||
        memcmp(pl->frames_src + 12, p->O, 3 * sizeof(float)) != 0) {
        sloan_build(Pp, v3_make(p->O[0], p->O[1], p->O[2]), &pl->frames);
        memcpy(pl->frames_src, p->P, 12 * sizeof(float));
        memcpy(pl->frames_src + 12, p->O, 3 * sizeof(float));
        pl->has_frames = 1;
    }
    return &pl->frames;
}

/* Attaches stem s (index idx) to its parent, shapes it, prunes it, stores its local points
 * and poses it with the shared pose function. Reads only stem idx and its parent, already
 * placed, and writes only stem idx: stems of one generation are placed in parallel. */
static void place_stem(const gen* g, placer* pl, size_t idx) {
    gstem* s = &g->s[idx];
    v3 origin, U, V;
    if (s->parent < 0) {
        origin = v3_make(s->root[0], s->root[1], s->root[2]);
        U = v3_make(0, 0, 1);
        V = v3_make(1, 0, 0);
    } else {
        v3 Pp[4];
        const sloan_frames f = *stem_frames(pl, &g->s[s->parent], Pp);
        float st, ct;
        tsk_sincosf(s->theta, &st, &ct);
        tree_attach_frame(Pp, &f, s->v, ct, st, &origin, &U, &V);
    }
    float ca, sa; /* the same bits as the tree's trig */
    tsk_sincosf(s->alpha, &sa, &ca);
    const v3 axis = v3_comb(U, ca, V, sa), side = v3_comb(U, -sa, V, ca), W = v3_cross(U, V);
    v3 P[4];
    float L = s->length;
    if (!shape_stem(g, s, idx, L, origin, axis, side, P) && g->d->prune_ratio > 0.0f) {
        /* Weber–Penn pruning: shorten until inside the envelope, then blend by PruneRatio */
        float Lp = L;
        for (int it = 0; it < 24; ++it) {
            Lp *= 0.85f;
            if (shape_stem(g, s, idx, Lp, origin, axis, side, P)) break;
        }
        L = L * (1.0f - g->d->prune_ratio) + Lp * g->d->prune_ratio;
        s->radius *= tsk_powf(L / s->length, g->d->ratio_power);
        s->length = L;
        shape_stem(g, s, idx, L, origin, axis, side, P);
    }
    for (int k = 1; k < 4; ++k) {
        v3 q = v3_sub(P[k], origin);
        s->Q[3 * (k - 1)] = v3_dot(q, axis);
        s->Q[3 * (k - 1) + 1] = v3_dot(q, side);
        s->Q[3 * (k - 1) + 2] = v3_dot(q, W);
    }
    /* pose through the shared function (zero force) so rest == wind step at zero force */
    struct tsk_tree* t = &pl->pose_shell;
    int32_t parent = s->parent, level = s->level;
    float av = s->v, at = s->theta, aa = s->alpha;
    float seg = 1.0f;
    float trig[4];
    tsk_sincosf(s->theta, &trig[1], &trig[0]);
    tsk_sincosf(s->alpha, &trig[3], &trig[2]);
    t->trig = trig;
    t->parent = &parent;
    t->level = &level;
    t->attach_v = &av;
    t->attach_theta = &at;
    t->attach_alpha = &aa;
    t->local = s->Q;
    t->root = s->root;
    t->rest_seg = &seg;
    t->seg12 = &seg;
    t->inv_l = &seg;
    v3 Pp[4] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    sloan_frames fp;
    memset(&fp, 0, sizeof fp);
    if (s->parent >= 0) fp = *stem_frames(pl, &g->s[s->parent], Pp);
    v3 Pout[4], Oout;
    tree_pose_branch(t, 0, Pp, &fp, v3_make(0, 0, 0), 1.8f, 0.0f, Pout, &Oout);
    tree_store_points(s->P, 0, Pout);
    s->O[0] = Oout.x, s->O[1] = Oout.y, s->O[2] = Oout.z;
}

typedef struct place_ctx {
    const gen* g;
    size_t first;
} place_ctx;

static void place_range(size_t begin, size_t end, size_t chunk, void* ctx) {
    (void)chunk;
    const place_ctx* c = ctx;
    placer pl; /* each chunk its own frames cache: the same frames whoever builds them */
    memset(&pl, 0, sizeof pl);
    for (size_t i = begin; i < end; ++i) place_stem(c->g, &pl, c->first + i);
}

/* Places stems [first, end), made from stems already placed, on all threads. */
static void place_generation(const gen* g, size_t first, size_t end) {
    if (end <= first) return;
    place_ctx c = {g, first};
    tsk_parallel_for(end - first, 32, place_range, &c);
}

/* Clones of stem idx at its segment ends (0BaseSplits, nSegSplits). */
static tsk_status grow_clones(gen* g, size_t idx) {
    const tsk_tree_def* d = g->d;
    const gstem base = g->s[idx];
    if (base.is_clone) return TSK_OK;
    const tsk_tree_level_def* lv = &d->level[base.level];
    const int R = lv->curve_res;
    const size_t first_clone = g->n;
    for (int k = 0; k + 1 < R; ++k) {
        int splits = 0;
        if (base.level == 0 && k == 0 && d->base_splits > 0) {
            splits = d->base_splits;
        } else if (lv->seg_splits > 0.0f) {
            float want = lv->seg_splits + g->split_error[base.level];
            splits = (int)want;
            g->split_error[base.level] = want - (float)splits;
        }
        if (splits <= 0) continue;
        const float vs = (float)(k + 1) / (float)R;
        const float theta0 = 360.0f * rnd(g, base.level, idx, R_SPLIT_ROT, (size_t)k);
        for (int j = 0; j < splits; ++j) {
            gstem* c = NULL;
            tsk_status st = push_stem(g, &c);
            if (st != TSK_OK) return st;
            const gstem* b = &g->s[idx];
            c->parent = (int32_t)idx;
            c->level = b->level;
            c->depth = b->depth + 1;
            c->is_clone = 1;
            c->v = vs;
            c->theta = (theta0 + 360.0f * (float)(j + 1) / (float)(splits + 1)) * DEG;
            const float sa =
                lv->split_angle + rnd_sym(g, b->level, idx, R_SPLIT_ANGLE, (size_t)(k * 64 + j)) *
                                      fabsf(lv->split_angle_v);
            c->alpha = sa * DEG;
            c->length = (1.0f - vs) * b->length;
            c->radius = stem_radius_at(d, b, vs);
            c->taper = b->taper;
            c->len_max = b->len_max;
            c->wp_parent_len = b->wp_parent_len;
            c->wp_offset = b->wp_offset;
            c->base_frac = 0.0f; /* placed with its generation (place_generation) */
        }
    }
    const float share = 1.0f / (float)(1 + g->n - first_clone);
    g->s[idx].child_factor = share;
    for (size_t c = first_clone; c < g->n; ++c) g->s[c].child_factor = share;
    return TSK_OK;
}

/* Number of children of level c on stem s (Weber & Penn 1995, "stems"). */
static int child_count(const gen* g, const gstem* s, int c) {
    const tsk_tree_def* d = g->d;
    const float stems_max = (float)d->level[c].branches;
    float n;
    if (s->level == 0) n = stems_max;
    else if (s->level == 1)
        n = stems_max * (0.2f + 0.8f * (s->length / s->wp_parent_len) / s->len_max);
    else n = stems_max * (1.0f - 0.5f * s->wp_offset / s->wp_parent_len);
    n *= s->child_factor;
    if (!(n > 0.0f)) return 0;
    return (int)floorf(n + 0.5f);
}

static int leaf_count(const gen* g, const gstem* s) {
    const float leaves = (float)g->d->leaves;
    float n = s->level == 0 ? leaves
                            : leaves * tree_shape_ratio(TSK_TREE_TAPERED_CYLINDRICAL,
                                                        s->wp_offset / s->wp_parent_len);
    n *= s->child_factor;
    if (!(n > 0.0f)) return 0;
    return (int)floorf(n + 0.5f);
}

/* Next rotation angle (degrees) around the parent: nRotate >= 0 turns by Rotate ±
 * RotateV each time; a negative Rotate alternates sides, 180 ± (180 + Rotate). */
static float next_rotation(float prev, float rotate, float var, int j) {
    if (rotate >= 0.0f) return prev + rotate + var;
    return prev + 180.0f + ((j & 1) ? 1.0f : -1.0f) * (180.0f + rotate) + var;
}

static tsk_status grow_children(gen* g, size_t idx) {
    const tsk_tree_def* d = g->d;
    const gstem s = g->s[idx];
    const int c = s.level + 1;
    if (c >= d->levels) return TSK_OK;
    const tsk_tree_level_def* lc = &d->level[c];
    const int n = child_count(g, &s, c);
    const float base_len = s.base_frac * s.length;
    float rot = 360.0f * rnd(g, c, idx, R_ROT0, 0);
    for (int j = 0; j < n; ++j) {
        const float v = s.base_frac + (1.0f - s.base_frac) * ((float)j + 0.5f) / (float)n;
        const float offset = v * s.length;
        const float len_max =
            fmaxf(0.0f, lc->length + rnd_sym(g, c, idx, R_LEN, (size_t)j) * lc->length_v);
        float L;
        const float ratio = (s.length - offset) / fmaxf(s.length - base_len, 1e-12f);
        if (c == 1) L = s.length * len_max * tree_shape_ratio(d->shape, ratio);
        else L = len_max * (s.length - 0.6f * offset);
        if (!(L > 1e-6f)) continue; /* Weber–Penn: stems of no length are not grown */
        float alpha;
        if (lc->down_angle_v >= 0.0f)
            alpha = lc->down_angle + rnd_sym(g, c, idx, R_DOWN, (size_t)j) * lc->down_angle_v;
        else
            alpha = lc->down_angle +
                    lc->down_angle_v * (1.0f - 2.0f * tree_shape_ratio(TSK_TREE_CONICAL, ratio));
        rot = next_rotation(rot, lc->rotate,
                            rnd_sym(g, c, idx, R_ROT, (size_t)j) * fabsf(lc->rotate_v), j);
        gstem* ch = NULL;
        tsk_status st = push_stem(g, &ch);
        if (st != TSK_OK) return st;
        const gstem* p = &g->s[idx];
        ch->parent = (int32_t)idx;
        ch->level = c;
        ch->depth = p->depth + 1;
        ch->is_clone = 0;
        ch->v = v;
        ch->theta = rot * DEG;
        ch->alpha = alpha * DEG;
        ch->length = L;
        float r = p->radius * tsk_powf(L / p->length, d->ratio_power);
        ch->radius = fminf(r, stem_radius_at(d, p, v));
        ch->taper = lc->taper;
        ch->len_max = len_max;
        ch->wp_parent_len = p->length;
        ch->wp_offset = offset;
        ch->base_frac = 0.0f; /* placed with its generation (place_generation) */
    }
    return TSK_OK;
}

static tsk_status grow_leaves(gen* g, size_t idx) {
    const tsk_tree_def* d = g->d;
    const gstem s = g->s[idx];
    if (d->leaves <= 0 || s.level != d->levels - 1) return TSK_OK;
    const int c = d->levels < TSK_TREE_MAX_LEVELS ? d->levels : TSK_TREE_MAX_LEVELS - 1;
    const tsk_tree_level_def* lc = &d->level[c];
    const int n = leaf_count(g, &s);
    float rot = 360.0f * rnd(g, 9, idx, R_LEAF_ROT0, 0);
    for (int j = 0; j < n; ++j) {
        gleaf* l = NULL;
        tsk_status st = push_leaf(g, &l);
        if (st != TSK_OK) return st;
        l->parent = (int32_t)idx;
        l->v = s.base_frac + (1.0f - s.base_frac) * ((float)j + 0.5f) / (float)n;
        rot = next_rotation(rot, lc->rotate,
                            rnd_sym(g, 9, idx, R_LEAF_ROT, (size_t)j) * fabsf(lc->rotate_v), j);
        l->theta = rot * DEG;
        l->alpha = (lc->down_angle +
                    rnd_sym(g, 9, idx, R_LEAF_DOWN, (size_t)j) * fabsf(lc->down_angle_v)) *
                   DEG;
        l->length = d->leaf_scale;
        l->width = d->leaf_scale * d->leaf_scale_x;
    }
    return TSK_OK;
}

static void free_tree_arrays(tsk_tree* t) {
    void* arrays[] = {
        t->seg12,        t->inv_l,        t->parent,   t->level,    t->depth,  t->attach_v,
        t->attach_theta, t->attach_alpha, t->trig,     t->has_kids, t->frames, t->prev_frames,
        t->length,       t->rest_seg,     t->shape,    t->local,    t->root,   t->rest,
        t->rest_O,       t->cur,          t->cur_O,    t->prev,     t->prev_O, t->leaf_parent,
        t->leaf_attach,  t->leaf_size,    t->leaf_trig};
    for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; ++i) tsk_free(arrays[i]);
}

void tsk_tree_destroy(tsk_tree* tree) {
    if (tree == NULL) return;
    free_tree_arrays(tree);
    tsk_free(tree);
}

static void rest_frames_range(size_t begin, size_t end, size_t chunk, void* ctx) {
    (void)chunk;
    tsk_tree* t = ctx;
    for (size_t i = begin; i < end; ++i) {
        if (!t->has_kids[i]) continue;
        v3 P[4];
        tree_load_points(t->rest, i, P);
        sloan_build(P, tree_load3(t->rest_O, i), &t->frames[i]);
    }
}

/* The rest pose as the current one, with the Sloan frames of every branch that carries
 * children or leaves (has_kids set). */
void tree_pose_rest(tsk_tree* t) {
    memcpy(t->cur, t->rest, 12 * t->n * sizeof(float));
    memcpy(t->cur_O, t->rest_O, 3 * t->n * sizeof(float));
    tsk_parallel_for(t->n, 256, rest_frames_range, t);
    t->at_rest = 1;
}

typedef struct build_ctx {
    const gen* g;
    tsk_tree* t;
} build_ctx;

/* The tree's arrays from the generator's stems [begin, end). */
static void build_branches(size_t begin, size_t end, size_t chunk, void* ctx) {
    (void)chunk;
    const build_ctx* c = ctx;
    const gen* g = c->g;
    const tsk_tree_def* d = g->d;
    tsk_tree* t = c->t;
    for (size_t i = begin; i < end; ++i) {
        const gstem* s = &g->s[i];
        t->parent[i] = s->parent;
        t->level[i] = s->level;
        t->depth[i] = s->depth;
        t->attach_v[i] = s->v;
        t->attach_theta[i] = s->theta;
        t->attach_alpha[i] = s->alpha;
        tsk_sincosf(s->theta, &t->trig[4 * i + 1], &t->trig[4 * i]);
        tsk_sincosf(s->alpha, &t->trig[4 * i + 3], &t->trig[4 * i + 2]);
        t->length[i] = s->length;
        memcpy(t->local + 9 * i, s->Q, sizeof s->Q);
        memcpy(t->root + 3 * i, s->root, sizeof s->root);
        memcpy(t->rest + 12 * i, s->P, sizeof s->P);
        memcpy(t->rest_O + 3 * i, s->O, sizeof s->O);
        const float dq[3] = {s->Q[6] - s->Q[3], s->Q[7] - s->Q[4], s->Q[8] - s->Q[5]};
        t->rest_seg[i] = sqrtf(dq[0] * dq[0] + dq[1] * dq[1] + dq[2] * dq[2]);
        const float dp[3] = {s->Q[3] - s->Q[0], s->Q[4] - s->Q[1], s->Q[5] - s->Q[2]};
        t->seg12[i] = sqrtf(dp[0] * dp[0] + dp[1] * dp[1] + dp[2] * dp[2]);
        tsk_branch_shape* sh = &t->shape[i];
        sh->radius = s->radius;
        sh->taper = s->taper;
        sh->taper_power = d->taper_power;
        sh->flare = s->level == 0 ? d->flare : 0.0f;
        sh->bulges = (float)d->bulges;
        sh->bulge_depth = d->bulge_depth;
        sh->lobes = s->level == 0 ? (float)d->lobes : 0.0f;
        sh->lobe_depth = s->level == 0 ? d->lobe_depth : 0.0f;
        sh->lobe_fade = d->lobe_fade;
    }
}

static void build_leaves(size_t begin, size_t end, size_t chunk, void* ctx) {
    (void)chunk;
    const build_ctx* c = ctx;
    tsk_tree* t = c->t;
    for (size_t j = begin; j < end; ++j) {
        const gleaf* l = &c->g->l[j];
        t->leaf_parent[j] = l->parent;
        t->leaf_attach[3 * j] = l->v;
        t->leaf_attach[3 * j + 1] = l->theta;
        t->leaf_attach[3 * j + 2] = l->alpha;
        t->leaf_size[2 * j] = l->length;
        t->leaf_size[2 * j + 1] = l->width;
        tsk_sincosf(l->theta, &t->leaf_trig[4 * j + 1], &t->leaf_trig[4 * j]);
        tsk_sincosf(l->alpha, &t->leaf_trig[4 * j + 3], &t->leaf_trig[4 * j + 2]);
    }
}

static tsk_status build_tree(gen* g, tsk_tree** out) {
    tsk_tree* t = tsk_calloc(1, sizeof(tsk_tree), "tree");
    if (t == NULL) return TSK_ERR_MEMORY;
    const size_t n = g->n, m = g->ln;
    t->n = n;
    t->leaf_n = m;
    t->parent = tsk_alloc(n * sizeof(int32_t), "tree parents");
    t->level = tsk_alloc(n * sizeof(int32_t), "tree levels");
    t->depth = tsk_alloc(n * sizeof(int32_t), "tree depths");
    t->attach_v = tsk_alloc(n * sizeof(float), "tree attachments");
    t->attach_theta = tsk_alloc(n * sizeof(float), "tree attachments");
    t->attach_alpha = tsk_alloc(n * sizeof(float), "tree attachments");
    t->trig = tsk_alloc(4 * n * sizeof(float), "tree attachments");
    t->has_kids = tsk_calloc(n, 1, "tree attachments");
    t->frames = tsk_alloc(n * sizeof(sloan_frames), "tree frames");
    t->prev_frames = tsk_alloc(n * sizeof(sloan_frames), "tree frames");
    t->length = tsk_alloc(n * sizeof(float), "tree lengths");
    t->rest_seg = tsk_alloc(n * sizeof(float), "tree lengths");
    t->seg12 = tsk_alloc(n * sizeof(float), "tree lengths");
    t->inv_l = tsk_alloc(n * sizeof(float), "tree lengths");
    t->shape = tsk_alloc(n * sizeof(tsk_branch_shape), "tree shapes");
    t->local = tsk_alloc(9 * n * sizeof(float), "tree local points");
    t->root = tsk_alloc(3 * n * sizeof(float), "tree roots");
    t->rest = tsk_alloc(12 * n * sizeof(float), "tree rest pose");
    t->rest_O = tsk_alloc(3 * n * sizeof(float), "tree rest pose");
    t->cur = tsk_alloc(12 * n * sizeof(float), "tree pose");
    t->cur_O = tsk_alloc(3 * n * sizeof(float), "tree pose");
    t->prev = tsk_alloc(12 * n * sizeof(float), "tree pose");
    t->prev_O = tsk_alloc(3 * n * sizeof(float), "tree pose");
    t->leaf_parent = tsk_alloc(m * sizeof(int32_t), "tree leaves");
    t->leaf_attach = tsk_alloc(3 * m * sizeof(float), "tree leaves");
    t->leaf_size = tsk_alloc(2 * m * sizeof(float), "tree leaves");
    t->leaf_trig = tsk_alloc(4 * m * sizeof(float), "tree leaves");
    if (!t->parent || !t->level || !t->depth || !t->attach_v || !t->attach_theta ||
        !t->attach_alpha || !t->trig || !t->has_kids || !t->frames || !t->prev_frames ||
        !t->length || !t->rest_seg || !t->seg12 || !t->inv_l || !t->shape || !t->local ||
        !t->root || !t->rest || !t->rest_O || !t->cur || !t->cur_O || !t->prev || !t->prev_O ||
        !t->leaf_parent || !t->leaf_attach || !t->leaf_size || !t->leaf_trig) {
        tsk_tree_destroy(t);
        return TSK_ERR_MEMORY;
    }
    int depth = -1;
    for (size_t i = 0; i < n; ++i) {
        const gstem* s = &g->s[i];
        while (depth < s->depth) {
            ++depth;
            if (depth < 65) t->depth_start[depth] = i;
        }
        t->level_count[s->level]++;
    }
    t->depth_count = depth + 1;
    t->depth_start[t->depth_count] = n;
    build_ctx c = {g, t};
    tsk_parallel_for(n, 256, build_branches, &c);
    tsk_parallel_for(m, 4096, build_leaves, &c);
    for (size_t i = 0; i < n; ++i)
        if (t->parent[i] >= 0) t->has_kids[t->parent[i]] = 1;
    for (size_t j = 0; j < m; ++j) t->has_kids[t->leaf_parent[j]] = 1;
    tree_pose_rest(t);
    tree_set_length_power(t, 1.0f);
    *out = t;
    return TSK_OK;
}

tsk_status tsk_tree_create(const tsk_tree_def* def, tsk_tree** out) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    tsk_status st = tsk_tree_validate(def);
    if (st != TSK_OK) return st;
    gen g;
    memset(&g, 0, sizeof g);
    g.d = def;
    g.scale_tree = def->scale + rnd_sym(&g, 0, 0, R_SCALE, 0) * def->scale_v;
    g.z_scale = def->z_scale + rnd_sym(&g, 0, 0, R_ZSCALE, 0) * def->z_scale_v;
    /* the trunk */
    gstem* trunk = NULL;
    st = push_stem(&g, &trunk);
    if (st != TSK_OK) goto done;
    trunk->parent = -1;
    trunk->level = 0;
    trunk->depth = 0;
    trunk->length = (def->level[0].length + rnd_sym(&g, 0, 0, R_LEN, 0) * def->level[0].length_v) *
                    g.scale_tree;
    if (!(trunk->length > 1e-6f)) {
        st = tsk_error_arg(TSK_ERR_ARGUMENT, "level[0].length", "the trunk has no length (%g m)",
                           (double)trunk->length);
        goto done;
    }
    trunk->radius =
        trunk->length * def->ratio * (def->scale0 + rnd_sym(&g, 0, 0, R_SCALE0, 0) * def->scale0_v);
    trunk->taper = def->level[0].taper;
    trunk->len_max = def->level[0].length;
    trunk->wp_parent_len = trunk->length;
    trunk->base_frac = def->base_size;
    place_generation(&g, 0, 1);
    /* breadth first, a generation at a time: parents before children, depths
     * non-decreasing. Creating a stem needs only its parent, placed with the generation
     * before, so the stems are numbered and drawn in the same order as if each were
     * placed as soon as it was made, and a generation is placed in parallel after. */
    for (size_t first = 0, end = g.n; first < end; first = end, end = g.n) {
        for (size_t i = first; i < end; ++i) {
            if (g.s[i].depth >= 64) continue; /* not with <= 4 levels and 1 clone step */
            st = grow_clones(&g, i);
            if (st != TSK_OK) goto done;
            st = grow_children(&g, i);
            if (st != TSK_OK) goto done;
            st = grow_leaves(&g, i);
            if (st != TSK_OK) goto done;
        }
        place_generation(&g, end, g.n);
    }
    st = build_tree(&g, out);
done:
    tsk_free(g.s);
    tsk_free(g.l);
    return st;
}

size_t tsk_tree_branch_count(const tsk_tree* tree) { return tree ? tree->n : 0; }
size_t tsk_tree_leaf_count(const tsk_tree* tree) { return tree ? tree->leaf_n : 0; }
size_t tsk_tree_level_branch_count(const tsk_tree* tree, int level) {
    if (tree == NULL || level < 0 || level >= TSK_TREE_MAX_LEVELS) return 0;
    return tree->level_count[level];
}
