/* The branch deformer of seed 001 §3: a (v, theta) grid per branch becomes an unbent branch
 * (taper, flare, bulges, lobes: eq. 2–6) bent along its Bézier by the generalized de
 * Casteljau deformation with Sloan frames (eq. 7–9); normals come from the Jacobian of that
 * deformation applied to the unbent surface's tangents (eq. 10). Leaves are cards. */
#include <math.h>
#include <string.h>

#include "core/simd.h"
#include "tree_internal.h"
#include "core/tmath.h"

#define TWO_PI 6.28318530717958647692f

void tree_leaf_card(const tsk_tree* t, size_t j, v3* corners, v3* normal);

tsk_tree_mesh_def tsk_default_tree_mesh_def(void) {
    tsk_tree_mesh_def m;
    const int along[TSK_TREE_MAX_LEVELS] = {16, 8, 4, 2};
    const int around[TSK_TREE_MAX_LEVELS] = {16, 8, 6, 4};
    memcpy(m.along, along, sizeof along);
    memcpy(m.around, around, sizeof around);
    m.leaves = 1;
    return m;
}

/* ---- eq. 2–5 ------------------------------------------------------------------------------ */

typedef struct radius_terms {
    float value, dv, dtheta;
} radius_terms;

/* Radius and its partial derivatives: seed 001, eq. 2 (taper), 3 (flare), 4 (bulges), 5 (lobes),
 * multiplied as in eq. 6. */
static radius_terms branch_radius_terms(const tsk_branch_shape* s, float v, float theta) {
    const float r = s->radius;
    /* seed 001, eq. 2: f_taper = r (1 - taper v^t); Weber–Penn's taper amount scales v^t */
    float vt, ft_v;
    if (s->taper_power == 1.0f) { /* Weber–Penn's linear taper: no powf */
        vt = v;
        ft_v = -r * s->taper;
    } else {
        const float vp = v > 1e-6f ? v : 1e-6f;
        vt = tsk_powf(v, s->taper_power);
        ft_v = -r * s->taper * s->taper_power * tsk_powf(vp, s->taper_power - 1.0f);
    }
    const float ft = r * (1.0f - s->taper * vt);
    /* seed 001, eq. 3: f_flare = f/100 * 100^(1-8v) + 1 */
    float ff = 1.0f, ff_v = 0.0f;
    if (s->flare != 0.0f) {
        const float e = s->flare / 100.0f * tsk_powf(100.0f, 1.0f - 8.0f * v);
        ff = e + 1.0f;
        ff_v = e * (-8.0f * 4.60517018598809f); /* d/dv 100^(1-8v) = -8 ln(100) 100^(1-8v) */
    }
    /* seed 001, eq. 4: f_bulges = 1 + b_d sin(b_n 2 pi v) */
    float fb = 1.0f, fb_v = 0.0f;
    if (s->bulge_depth != 0.0f && s->bulges != 0.0f) {
        const float w = s->bulges * TWO_PI;
        float sw, cw;
        tsk_sincosf(w * v, &sw, &cw);
        fb = 1.0f + s->bulge_depth * sw;
        fb_v = s->bulge_depth * w * cw;
    }
    /* seed 001, eq. 5: f_lobes = 1 + l_d sin(l_n theta) (1 - v l_t) */
    float fl = 1.0f, fl_v = 0.0f, fl_t = 0.0f;
    if (s->lobe_depth != 0.0f && s->lobes != 0.0f) {
        float sn, cs;
        tsk_sincosf(s->lobes * theta, &sn, &cs);
        const float fade = 1.0f - v * s->lobe_fade;
        fl = 1.0f + s->lobe_depth * sn * fade;
        fl_v = -s->lobe_depth * sn * s->lobe_fade;
        fl_t = s->lobe_depth * s->lobes * cs * fade;
    }
    radius_terms rt;
    const float fbl = fb * fl;
    rt.value = ft * ff * fbl;
    rt.dv = ft_v * ff * fbl + ft * ff_v * fbl + ft * ff * fb_v * fl + ft * ff * fb * fl_v;
    rt.dtheta = ft * ff * fb * fl_t;
    return rt;
}

float tsk_branch_radius(const tsk_branch_shape* shape, float v, float theta) {
    if (shape == NULL) return 0.0f;
    return branch_radius_terms(shape, v, theta).value;
}

/* ---- eq. 6–10 at one (v, theta) ------------------------------------------------------------ */

typedef struct ring_eval {
    v3 B, dB; /* curve point and derivative at u = v */
    v3 S, T; /* blended handles (eq. 9) */
    v3 dS, dT; /* their derivatives in u */
} ring_eval;

static void ring_setup(const v3* P, const sloan_frames* f, float u, ring_eval* r) {
    r->B = bez_point(P, u);
    r->dB = bez_deriv(P, u);
    float q[3], dq[3];
    bern2(u, q);
    bern2_deriv(u, dq);
    r->S =
        v3_add(v3_add(v3_scale(f->S[0], q[0]), v3_scale(f->S[1], q[1])), v3_scale(f->S[2], q[2]));
    r->T =
        v3_add(v3_add(v3_scale(f->T[0], q[0]), v3_scale(f->T[1], q[1])), v3_scale(f->T[2], q[2]));
    r->dS = v3_add(v3_add(v3_scale(f->S[0], dq[0]), v3_scale(f->S[1], dq[1])),
                   v3_scale(f->S[2], dq[2]));
    r->dT = v3_add(v3_add(v3_scale(f->T[0], dq[0]), v3_scale(f->T[1], dq[1])),
                   v3_scale(f->T[2], dq[2]));
}

/* Position and normal for the unbent surface point (eq. 6) u = v, a = sin(theta) rho,
 * b = cos(theta) rho, mapped by eq. 9: X = B(u) + S(u) a + T(u) b. The tangents of the
 * unbent surface, d/dv and d/dtheta of (u, a, b), are multiplied by the Jacobian
 * [dX/du dX/da dX/db] = [B' + S' a + T' b, S, T] (eq. 10). */
static inline void surface_point(const ring_eval* r, float st, float ct, radius_terms rho, v3* pos,
                                 v3* nrm) {
    const float a = st * rho.value, b = ct * rho.value;
    *pos = v3_make(r->B.x + r->S.x * a + r->T.x * b, r->B.y + r->S.y * a + r->T.y * b,
                   r->B.z + r->S.z * a + r->T.z * b);
    if (nrm == NULL) return;
    const v3 Ju = v3_make(r->dB.x + r->dS.x * a + r->dT.x * b, r->dB.y + r->dS.y * a + r->dT.y * b,
                          r->dB.z + r->dS.z * a + r->dT.z * b);
    /* unbent tangents: d/dv (1, st rho_v, ct rho_v); d/dtheta (0, ct rho + st rho_t, -st rho + ct rho_t) */
    const float av = st * rho.dv, bv = ct * rho.dv;
    const float at = ct * rho.value + st * rho.dtheta, bt = -st * rho.value + ct * rho.dtheta;
    const v3 tv = v3_make(Ju.x + r->S.x * av + r->T.x * bv, Ju.y + r->S.y * av + r->T.y * bv,
                          Ju.z + r->S.z * av + r->T.z * bv);
    const v3 tt =
        v3_make(r->S.x * at + r->T.x * bt, r->S.y * at + r->T.y * bt, r->S.z * at + r->T.z * bt);
    const v3 n = v3_cross(tt, tv);
    const float l2 = v3_dot(n, n), tl2 = v3_dot(tv, tv);
    if (l2 > 1e-24f * (tl2 * tl2 + 1e-30f)) {
        *nrm = v3_scale(n, 1.0f / sqrtf(l2));
    } else {
        /* a point where the radius is zero (a tip): the normal is along the branch */
        *nrm = v3_norm_or(tv, v3_make(0, 0, 1));
    }
}

void tsk_branch_surface(const float* Pf, const float* Of, const tsk_branch_shape* shape, float v,
                        float theta, float* position, float* normal) {
    if (Pf == NULL || Of == NULL || shape == NULL || position == NULL) return;
    v3 P[4];
    tree_load_points(Pf, 0, P);
    sloan_frames f;
    sloan_build(P, v3_make(Of[0], Of[1], Of[2]), &f);
    ring_eval r;
    ring_setup(P, &f, v, &r);
    radius_terms rho = branch_radius_terms(shape, v, theta);
    v3 pos, nrm;
    float st, ct;
    tsk_sincosf(theta, &st, &ct);
    surface_point(&r, st, ct, rho, &pos, normal ? &nrm : NULL);
    position[0] = pos.x, position[1] = pos.y, position[2] = pos.z;
    if (normal) normal[0] = nrm.x, normal[1] = nrm.y, normal[2] = nrm.z;
}

/* ---- whole-tree mesh ---------------------------------------------------------------------- */

static tsk_status check_mesh_args(const tsk_tree* t, const tsk_tree_mesh_def* m) {
    if (t == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "tree", "is NULL");
    if (m == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "mesh", "is NULL");
    for (int l = 0; l < TSK_TREE_MAX_LEVELS; ++l) {
        if (m->along[l] < 1 || m->along[l] > 256)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "mesh.along", "level %d: must be 1..256, got %d",
                                 l, m->along[l]);
        if (m->around[l] < 3 || m->around[l] > 256)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "mesh.around",
                                 "level %d: must be 3..256, got %d", l, m->around[l]);
    }
    return TSK_OK;
}

/* Where each branch's part of the mesh starts: its first vertex, face and edge (n + 1 of
 * each; the last are where the leaves start). The tree's parts are written in parallel. */
typedef struct branch_offsets {
    size_t *v, *f, *e;
} branch_offsets;

static tsk_status offsets_make(const tsk_tree* t, const tsk_tree_mesh_def* m, branch_offsets* o) {
    o->v = tsk_alloc(3 * (t->n + 1) * sizeof(size_t), "mesh offsets");
    if (o->v == NULL) return TSK_ERR_MEMORY;
    o->f = o->v + t->n + 1;
    o->e = o->f + t->n + 1;
    size_t v = 0, f = 0, e = 0;
    for (size_t i = 0; i < t->n; ++i) {
        o->v[i] = v, o->f[i] = f, o->e[i] = e;
        const int l = t->level[i];
        const size_t A = (size_t)m->along[l], C = (size_t)m->around[l];
        v += (A + 1) * C, f += A * C, e += (2 * A + 1) * C;
    }
    o->v[t->n] = v, o->f[t->n] = f, o->e[t->n] = e;
    return TSK_OK;
}

/* Total sizes; also fails with TSK_ERR_LIMIT past 2^31 vertices (int32 indices). */
static tsk_status mesh_sizes(const tsk_tree* t, const tsk_tree_mesh_def* m, size_t* nv,
                             size_t* nf) {
    size_t v = 0, f = 0;
    for (int l = 0; l < TSK_TREE_MAX_LEVELS; ++l) {
        v += t->level_count[l] * (size_t)(m->along[l] + 1) * (size_t)m->around[l];
        f += t->level_count[l] * (size_t)m->along[l] * (size_t)m->around[l];
    }
    if (m->leaves) {
        v += 4 * t->leaf_n;
        f += t->leaf_n;
    }
    if (v > (size_t)INT32_MAX)
        return tsk_error_arg(TSK_ERR_LIMIT, "mesh",
                             "%zu vertices exceed the 2^31 limit of int32 indices; lower "
                             "mesh.along/around",
                             v);
    *nv = v;
    *nf = f;
    return TSK_OK;
}

tsk_status tsk_tree_mesh_count(const tsk_tree* t, const tsk_tree_mesh_def* m, size_t* vertex_count,
                               size_t* face_count) {
    tsk_status s = check_mesh_args(t, m);
    if (s != TSK_OK) return s;
    if (vertex_count == NULL || face_count == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, vertex_count ? "face_count" : "vertex_count",
                             "is NULL");
    s = mesh_sizes(t, m, vertex_count, face_count);
    if (s != TSK_OK) return s;
    /* memory budget: the buffers a caller fills (positions, normals; quads, corner uvs) */
    return tsk_memory_check((double)*vertex_count * 24.0 + (double)*face_count * 48.0, "mesh");
}

typedef struct topo_ctx {
    const tsk_tree* t;
    const tsk_tree_mesh_def* m;
    branch_offsets o;
    int32_t* faces;
    float* uvs;
    int32_t* edges;
    int32_t* corner_edges;
} topo_ctx;

/* Branch i's quads: (j, k) -> (j, k+1) -> (j+1, k+1) -> (j+1, k) of its (A + 1) x C grid. */
static void topology_range(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const topo_ctx* c = vctx;
    for (size_t i = b; i < e; ++i) {
        const int l = c->t->level[i];
        const int A = c->m->along[l], C = c->m->around[l];
        const float r0 = c->t->shape[i].radius;
        const float vscale = r0 > 0.0f ? c->t->length[i] / (TWO_PI * r0) : 1.0f;
        const size_t vbase = c->o.v[i];
        size_t f = c->o.f[i];
        for (int j = 0; j < A; ++j) {
            for (int k = 0; k < C; ++k, ++f) {
                const int k1 = k + 1 < C ? k + 1 : 0;
                int32_t* q = c->faces + 4 * f;
                q[0] = (int32_t)(vbase + (size_t)j * C + k);
                q[1] = (int32_t)(vbase + (size_t)j * C + k1);
                q[2] = (int32_t)(vbase + (size_t)(j + 1) * C + k1);
                q[3] = (int32_t)(vbase + (size_t)(j + 1) * C + k);
                if (c->uvs) {
                    float* uv = c->uvs + 8 * f;
                    const float u0 = (float)k / C, u1 = (float)(k + 1) / C;
                    const float v0 = (float)j / A * vscale, v1 = (float)(j + 1) / A * vscale;
                    uv[0] = u0, uv[1] = v0, uv[2] = u1, uv[3] = v0;
                    uv[4] = u1, uv[5] = v1, uv[6] = u0, uv[7] = v1;
                }
            }
        }
    }
}

/* Leaf cards: corners base-left, base-right, tip-right, tip-left; this order faces the card
 * normal. */
static void leaf_topology_range(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const topo_ctx* c = vctx;
    const size_t n = c->t->n;
    for (size_t j = b; j < e; ++j) {
        const size_t f = c->o.f[n] + j;
        int32_t* q = c->faces + 4 * f;
        const int32_t v = (int32_t)(c->o.v[n] + 4 * j);
        q[0] = v, q[1] = v + 3, q[2] = v + 2, q[3] = v + 1;
        if (c->uvs) {
            float* uv = c->uvs + 8 * f;
            uv[0] = 0, uv[1] = 0, uv[2] = 0, uv[3] = 1, uv[4] = 1, uv[5] = 1, uv[6] = 1, uv[7] = 0;
        }
    }
}

tsk_status tsk_tree_mesh_topology(const tsk_tree* t, const tsk_tree_mesh_def* m, int32_t* faces,
                                  float* uvs) {
    tsk_status s = check_mesh_args(t, m);
    if (s != TSK_OK) return s;
    size_t nv = 0, nf = 0;
    s = mesh_sizes(t, m, &nv, &nf);
    if (s != TSK_OK) return s;
    if (nf > 0 && faces == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "faces", "is NULL");
    topo_ctx c = {t, m, {NULL, NULL, NULL}, faces, uvs, NULL, NULL};
    s = offsets_make(t, m, &c.o);
    if (s != TSK_OK) return s;
    tsk_parallel_for(t->n, 64, topology_range, &c);
    if (m->leaves) tsk_parallel_for(t->leaf_n, 4096, leaf_topology_range, &c);
    tsk_free(c.o.v);
    return TSK_OK;
}

/* Branch i's edges. Ring edge (j, k): ring j's vertex k to k + 1, index e0 + j C + k
 * (j = 0..A); edge along (j, k): ring j's vertex k to ring j + 1's, after the (A + 1) C ring
 * edges. Each corner's edge leaves it toward the next corner of its quad, in the order
 * topology_range writes them: (j, k) -> (j, k+1) -> (j+1, k+1) -> (j+1, k). */
static void edges_range(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const topo_ctx* c = vctx;
    for (size_t i = b; i < e; ++i) {
        const int l = c->t->level[i];
        const size_t A = (size_t)c->m->along[l], C = (size_t)c->m->around[l];
        const size_t vbase = c->o.v[i], ebase = c->o.e[i];
        const size_t along0 = ebase + (A + 1) * C;
        for (size_t j = 0; j <= A; ++j)
            for (size_t k = 0; k < C; ++k) {
                int32_t* ed = c->edges + 2 * (ebase + j * C + k);
                ed[0] = (int32_t)(vbase + j * C + k);
                ed[1] = (int32_t)(vbase + j * C + (k + 1 < C ? k + 1 : 0));
            }
        for (size_t j = 0; j < A; ++j)
            for (size_t k = 0; k < C; ++k) {
                int32_t* ed = c->edges + 2 * (along0 + j * C + k);
                ed[0] = (int32_t)(vbase + j * C + k);
                ed[1] = (int32_t)(vbase + (j + 1) * C + k);
            }
        size_t f = c->o.f[i];
        for (size_t j = 0; j < A; ++j)
            for (size_t k = 0; k < C; ++k, ++f) {
                const size_t k1 = k + 1 < C ? k + 1 : 0;
                int32_t* ce = c->corner_edges + 4 * f;
                ce[0] = (int32_t)(ebase + j * C + k);
                ce[1] = (int32_t)(along0 + j * C + k1);
                ce[2] = (int32_t)(ebase + (j + 1) * C + k);
                ce[3] = (int32_t)(along0 + j * C + k);
            }
    }
}

/* A leaf card's four sides, corners b, b+3, b+2, b+1 (leaf_topology_range). */
static void leaf_edges_range(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const topo_ctx* c = vctx;
    const size_t n = c->t->n;
    for (size_t j = b; j < e; ++j) {
        const int32_t v = (int32_t)(c->o.v[n] + 4 * j);
        const int32_t q[4] = {v, v + 3, v + 2, v + 1};
        const size_t ebase = c->o.e[n] + 4 * j, f = c->o.f[n] + j;
        for (size_t k = 0; k < 4; ++k) {
            c->edges[2 * (ebase + k)] = q[k];
            c->edges[2 * (ebase + k) + 1] = q[(k + 1) % 4];
            c->corner_edges[4 * f + k] = (int32_t)(ebase + k);
        }
    }
}

tsk_status tsk_tree_mesh_edges(const tsk_tree* t, const tsk_tree_mesh_def* m, int32_t* edges,
                               int32_t* corner_edges, size_t* edge_count) {
    if (edge_count == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "edge_count", "is NULL");
    *edge_count = 0;
    tsk_status s = check_mesh_args(t, m);
    if (s != TSK_OK) return s;
    size_t nv = 0, nf = 0;
    s = mesh_sizes(t, m, &nv, &nf);
    if (s != TSK_OK) return s;
    if (nf == 0) return TSK_OK;
    if (nf > (size_t)INT32_MAX / 4) /* edge and corner indices are int32 */
        return tsk_error_arg(TSK_ERR_LIMIT, "mesh",
                             "%zu quads have more corners than int32 "
                             "indices reach; lower mesh.along/around",
                             nf);
    if (edges == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "edges", "is NULL");
    if (corner_edges == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "corner_edges", "is NULL");
    topo_ctx c = {t, m, {NULL, NULL, NULL}, NULL, NULL, edges, corner_edges};
    s = offsets_make(t, m, &c.o);
    if (s != TSK_OK) return s;
    tsk_parallel_for(t->n, 64, edges_range, &c);
    size_t ne = c.o.e[t->n];
    if (m->leaves) {
        tsk_parallel_for(t->leaf_n, 4096, leaf_edges_range, &c);
        ne += 4 * t->leaf_n;
    }
    tsk_free(c.o.v);
    *edge_count = ne;
    return TSK_OK;
}

typedef struct deform_ctx {
    const tsk_tree* t;
    const tsk_tree_mesh_def* m;
    const float* sincos[TSK_TREE_MAX_LEVELS]; /* per level: sin, cos of 2 pi k / around */
    const size_t* vstart; /* first vertex of each branch */
    float* pos;
    float* nrm;
} deform_ctx;

#if TSK_SIMD_SSE2
#include <emmintrin.h>
/* surface_point for four consecutive vertices of one ring (same v, same radius terms),
 * lane for lane the same operations as the scalar function; writes 4 xyz positions and
 * normals. Returns 0 (writing nothing) if a lane needs the zero-radius fallback. */
static int surface_point4(const ring_eval* r, const float* st, const float* ct, radius_terms rho,
                          float* pos, float* nrm) {
    typedef __m128 f4;
#define A_ _mm_add_ps
#define S_ _mm_sub_ps
#define M_ _mm_mul_ps
#define B1(x) _mm_set1_ps(x)
    const f4 s4 = _mm_loadu_ps(st), c4 = _mm_loadu_ps(ct);
    const f4 rv = B1(rho.value), rdv = B1(rho.dv), rdt = B1(rho.dtheta);
    const f4 a = M_(s4, rv), b = M_(c4, rv);
    const f4 px = A_(A_(B1(r->B.x), M_(B1(r->S.x), a)), M_(B1(r->T.x), b));
    const f4 py = A_(A_(B1(r->B.y), M_(B1(r->S.y), a)), M_(B1(r->T.y), b));
    const f4 pz = A_(A_(B1(r->B.z), M_(B1(r->S.z), a)), M_(B1(r->T.z), b));
    f4 nx = px, ny = py, nz = pz;
    if (nrm != NULL) {
        const f4 jx = A_(A_(B1(r->dB.x), M_(B1(r->dS.x), a)), M_(B1(r->dT.x), b));
        const f4 jy = A_(A_(B1(r->dB.y), M_(B1(r->dS.y), a)), M_(B1(r->dT.y), b));
        const f4 jz = A_(A_(B1(r->dB.z), M_(B1(r->dS.z), a)), M_(B1(r->dT.z), b));
        const f4 av = M_(s4, rdv), bv = M_(c4, rdv);
        const f4 ns4 = M_(s4, B1(-1.0f));
        const f4 at = A_(M_(c4, rv), M_(s4, rdt)), bt = A_(M_(ns4, rv), M_(c4, rdt));
        const f4 tvx = A_(A_(jx, M_(B1(r->S.x), av)), M_(B1(r->T.x), bv));
        const f4 tvy = A_(A_(jy, M_(B1(r->S.y), av)), M_(B1(r->T.y), bv));
        const f4 tvz = A_(A_(jz, M_(B1(r->S.z), av)), M_(B1(r->T.z), bv));
        const f4 ttx = A_(M_(B1(r->S.x), at), M_(B1(r->T.x), bt));
        const f4 tty = A_(M_(B1(r->S.y), at), M_(B1(r->T.y), bt));
        const f4 ttz = A_(M_(B1(r->S.z), at), M_(B1(r->T.z), bt));
        const f4 cx = S_(M_(tty, tvz), M_(ttz, tvy));
        const f4 cy = S_(M_(ttz, tvx), M_(ttx, tvz));
        const f4 cz = S_(M_(ttx, tvy), M_(tty, tvx));
        const f4 l2 = A_(A_(M_(cx, cx), M_(cy, cy)), M_(cz, cz));
        const f4 tl2 = A_(A_(M_(tvx, tvx), M_(tvy, tvy)), M_(tvz, tvz));
        const f4 ok = _mm_cmpgt_ps(l2, M_(B1(1e-24f), A_(M_(tl2, tl2), B1(1e-30f))));
        if (_mm_movemask_ps(ok) != 15) return 0;
        const f4 inv = _mm_div_ps(B1(1.0f), _mm_sqrt_ps(l2));
        nx = M_(cx, inv), ny = M_(cy, inv), nz = M_(cz, inv);
    }
    /* 4 lanes of x, y, z -> 12 interleaved floats */
    float X[4], Y[4], Z[4];
    _mm_storeu_ps(X, px), _mm_storeu_ps(Y, py), _mm_storeu_ps(Z, pz);
    for (int l = 0; l < 4; ++l) pos[3 * l] = X[l], pos[3 * l + 1] = Y[l], pos[3 * l + 2] = Z[l];
    if (nrm != NULL) {
        _mm_storeu_ps(X, nx), _mm_storeu_ps(Y, ny), _mm_storeu_ps(Z, nz);
        for (int l = 0; l < 4; ++l) nrm[3 * l] = X[l], nrm[3 * l + 1] = Y[l], nrm[3 * l + 2] = Z[l];
    }
#undef A_
#undef S_
#undef M_
#undef B1
    return 1;
}
#endif

int tree_mesh_force_scalar = 0;

static void deform_branch(const deform_ctx* c, size_t i) {
    const tsk_tree* t = c->t;
    const int l = t->level[i];
    const int A = c->m->along[l], C = c->m->around[l];
    v3 P[4];
    tree_load_points(t->cur, i, P);
    sloan_frames f;
    sloan_build(P, tree_load3(t->cur_O, i), &f);
    const tsk_branch_shape* sh = &t->shape[i];
    const int lobed = sh->lobe_depth != 0.0f && sh->lobes != 0.0f;
    const float* st = c->sincos[l];
    const float* ct = c->sincos[l] + C;
    size_t vi = c->vstart[i];
    for (int j = 0; j <= A; ++j) {
        const float v = (float)j / (float)A;
        ring_eval r;
        ring_setup(P, &f, v, &r);
        radius_terms rho = branch_radius_terms(sh, v, 0.0f);
        int k = 0;
#if TSK_SIMD_SSE2
        if (!lobed && !tree_mesh_force_scalar) {
            for (; k + 4 <= C; k += 4, vi += 4) {
                if (!surface_point4(&r, st + k, ct + k, rho, c->pos + 3 * vi,
                                    c->nrm ? c->nrm + 3 * vi : NULL))
                    break; /* this group and the rest of the ring go one by one */
            }
        }
#endif
        for (; k < C; ++k, ++vi) {
            if (lobed) rho = branch_radius_terms(sh, v, TWO_PI * (float)k / (float)C);
            v3 p, n;
            surface_point(&r, st[k], ct[k], rho, &p, c->nrm ? &n : NULL);
            tree_store3(c->pos, vi, p);
            if (c->nrm) tree_store3(c->nrm, vi, n);
        }
    }
}

static void deform_range(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const deform_ctx* c = vctx;
    for (size_t i = b; i < e; ++i) deform_branch(c, i);
}

typedef struct leaf_ctx {
    const tsk_tree* t;
    size_t vbase;
    float* pos;
    float* nrm;
} leaf_ctx;

static void leaf_range(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const leaf_ctx* c = vctx;
    for (size_t j = b; j < e; ++j) {
        v3 corners[4], n;
        tree_leaf_card(c->t, j, corners, &n);
        for (int k = 0; k < 4; ++k) {
            tree_store3(c->pos, c->vbase + 4 * j + (size_t)k, corners[k]);
            if (c->nrm) tree_store3(c->nrm, c->vbase + 4 * j + (size_t)k, n);
        }
    }
}

tsk_status tsk_tree_mesh_deform(const tsk_tree* t, const tsk_tree_mesh_def* m, float* positions,
                                float* normals) {
    tsk_status s = check_mesh_args(t, m);
    if (s != TSK_OK) return s;
    size_t nv = 0, nf = 0;
    s = mesh_sizes(t, m, &nv, &nf);
    if (s != TSK_OK) return s;
    if (nv > 0 && positions == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "positions", "is NULL");
    branch_offsets o;
    s = offsets_make(t, m, &o);
    if (s != TSK_OK) return s;
    const size_t* vstart = o.v;
    const size_t acc = o.v[t->n];
    float* tables = tsk_alloc(2 * 256 * TSK_TREE_MAX_LEVELS * sizeof(float), "mesh tables");
    if (tables == NULL) {
        tsk_free(o.v);
        return TSK_ERR_MEMORY;
    }
    deform_ctx c = {t, m, {NULL, NULL, NULL, NULL}, vstart, positions, normals};
    for (int l = 0; l < TSK_TREE_MAX_LEVELS; ++l) {
        float* tab = tables + 2 * 256 * l;
        const int C = m->around[l];
        for (int k = 0; k < C; ++k) {
            const float th = TWO_PI * (float)k / (float)C;
            tsk_sincosf(th, &tab[k], &tab[C + k]);
        }
        c.sincos[l] = tab;
    }
    tsk_parallel_for(t->n, 64, deform_range, &c);
    tsk_free(tables);
    if (m->leaves) {
        leaf_ctx lc = {t, acc, positions, normals};
        tsk_parallel_for(t->leaf_n, 1024, leaf_range, &lc);
    }
    tsk_free(o.v);
    return TSK_OK;
}
