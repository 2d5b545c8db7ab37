/* The blade solver for one block of SIM_W blades: Verlet integration with damping, gravity
 * (with preload) and wind drag; global and local shape constraints; length constraints and
 * collisions iterated, then a follow-the-leader pass that makes lengths exact while keeping
 * knots outside colliders (Han & Harada 2012, as seed 000 §2 and §4.5 adopt it: collision a
 * hard constraint; length, bending and twisting soft constraints of an iterative solver).
 * Every value is a vector of the SIM_W lanes of a block (GCC/Clang vector extensions), so each
 * operation is one AVX-512 instruction, two AVX2 or four SSE ones. */
#include "sim/sim_internal.h"

#include <string.h>

#if defined(__GNUC__)
/* The vector helpers below are always inlined static functions: no ABI crosses them. */
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

/* 16 floats: one lane per blade of the block. */
typedef float vf __attribute__((vector_size(4 * SIM_W)));
typedef int32_t vi __attribute__((vector_size(4 * SIM_W)));
typedef uint32_t vu __attribute__((vector_size(4 * SIM_W)));

/* Wider vector units when the CPU has them. Only IEEE add/sub/mul/div, comparisons and bit
 * operations are used and -ffp-contract=off forbids fused multiply-add, so every clone computes
 * the same bits. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_ADDRESS__)
#define SIM_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define SIM_CLONES
#endif

#define INL static inline __attribute__((always_inline))

/* Metres around a block's knots (plus its longest segment) within which a collider takes part
 * in the iterations. */
#define SIM_CULL_MARGIN 0.03f

INL vf ld(const float* p) {
    vf v;
    memcpy(&v, p, sizeof v);
    return v;
}
INL void st(float* p, vf v) { memcpy(p, &v, sizeof v); }
/* All ones. 1 * x == x exactly; GCC turns this into one broadcast, where (vf){0} + x becomes
 * one scalar store per lane. */
static const vf sim_one = {1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f,
                           1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f,
                           1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f};
_Static_assert(SIM_W == 32, "sim_one and any() are written for 32 lanes");
INL vf splat(float x) { return sim_one * x; }
INL vf sel(vi m, vf a, vf b) { return (vf)(((vi)a & m) | ((vi)b & ~m)); }
/* Comparison masks (all ones where true) from the sign of a difference: for finite values
 * b - a < 0 exactly when a > b (x - x = +0). GCC lowers vector comparisons wider than the
 * machine's vectors one element at a time; a subtraction and a shift it splits cleanly. */
INL vi gt(vf a, vf b) { return (vi)(b - a) >> 31; }
INL vi lt(vf a, vf b) { return (vi)(a - b) >> 31; }
INL vi gts(vf a, float b) { return gt(a, splat(b)); }
INL vi lts(vf a, float b) { return lt(a, splat(b)); }
INL vf vmax(vf a, vf b) { return sel(gt(a, b), a, b); }
INL vf vmin(vf a, vf b) { return sel(lt(a, b), a, b); }

/* 1/sqrt(x) for x > 0 by Newton's method from a bit-level first guess; three steps reach float
 * precision (relative error ~1e-7). Only add, multiply and integer operations: it vectorises
 * (the build keeps errno semantics for sqrtf, which would stop that) and gives the same bits on
 * every instruction set. x = 0 returns a large finite number, so x * rsq(x) = 0. */
INL vf rsq(vf x) {
    vu i = (vu)x;
    i = 0x5f375a86u - (i >> 1);
    vf y = (vf)i;
    const vf h = 0.5f * x;
    y = y * (1.5f - h * y * y);
    y = y * (1.5f - h * y * y);
    y = y * (1.5f - h * y * y);
    return y;
}

/* Two Newton steps (relative error < 5e-6): enough to normalise frame vectors. */
INL vf rsq2(vf x) {
    vu i = (vu)x;
    i = 0x5f375a86u - (i >> 1);
    vf y = (vf)i;
    const vf h = 0.5f * x;
    y = y * (1.5f - h * y * y);
    y = y * (1.5f - h * y * y);
    return y;
}

/* Whether any lane of a mask is set: OR the halves together down to 4 lanes. */
typedef int32_t vi16 __attribute__((vector_size(64)));
typedef int32_t vi8 __attribute__((vector_size(32)));
typedef int32_t vi4 __attribute__((vector_size(16)));
INL int any(vi m) {
    vi16 a, b;
    memcpy(&a, &m, sizeof a);
    memcpy(&b, (const char*)&m + sizeof a, sizeof b);
    a |= b;
    vi8 c, d;
    memcpy(&c, &a, sizeof c);
    memcpy(&d, (const char*)&a + sizeof c, sizeof d);
    c |= d;
    vi4 e, f;
    memcpy(&e, &c, sizeof e);
    memcpy(&f, (const char*)&c + sizeof e, sizeof f);
    e |= f;
    return (e[0] | e[1] | e[2] | e[3]) != 0;
}

typedef struct v3 {
    vf x, y, z;
} v3;

INL v3 ld3(const float* p) { return (v3){ld(p), ld(p + SIM_W), ld(p + 2 * SIM_W)}; }
INL void st3(float* p, v3 v) {
    st(p, v.x);
    st(p + SIM_W, v.y);
    st(p + 2 * SIM_W, v.z);
}
INL v3 add3(v3 a, v3 b) { return (v3){a.x + b.x, a.y + b.y, a.z + b.z}; }
INL v3 sub3(v3 a, v3 b) { return (v3){a.x - b.x, a.y - b.y, a.z - b.z}; }
INL v3 mul3(vf s, v3 a) { return (v3){s * a.x, s * a.y, s * a.z}; }
INL vf dot3(v3 a, v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
INL v3 cross3(v3 a, v3 b) {
    return (v3){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
INL v3 sel3(vi m, v3 a, v3 b) { return (v3){sel(m, a.x, b.x), sel(m, a.y, b.y), sel(m, a.z, b.z)}; }
/* frame (t, s, n) applied to local coordinates (a, b, c) */
INL v3 apply3(v3 t, v3 s, v3 n, vf a, vf b, vf c) {
    return (v3){t.x * a + s.x * b + n.x * c, t.y * a + s.y * b + n.y * c,
                t.z * a + s.z * b + n.z * c};
}

/* Wind of a block without wind. */
static const float sim_no_wind[TSK_BLADE_SIM_MAX_KNOTS * 3 * SIM_W];

/* Rest rotation of segment k in its parent's frame: the smallest rotation taking e_x to the
 * unit rest direction r turns e_y into (-r_y, 1 - c r_y, -c r_z), c = r_y / (1 + r_x)
 * (see sim_side_coef). */
INL void rest_side(v3 r, vf* lx, vf* ly, vf* lz) {
    const vf c = r.y / vmax(1.0f + r.x, splat(1e-6f));
    *lx = -r.y;
    *ly = 1.0f - c * r.y;
    *lz = -c * r.z;
}

/* Moves the current frame (t, s, n) of the parent segment to the child segment whose rest
 * direction in the parent frame is r (rest side l) and whose actual direction is d: the
 * predicted frame is the parent turned by the rest rotation; it is then turned by the smallest
 * rotation taking its tangent onto d. A zero d keeps the prediction. */
INL void frame_advance(v3* t, v3* s, v3* n, v3 r, vf lx, vf ly, vf lz, v3 d) {
    const v3 pt = apply3(*t, *s, *n, r.x, r.y, r.z);
    const v3 ps = apply3(*t, *s, *n, lx, ly, lz);
    const vf dd = dot3(d, d);
    const vi ok = gts(dd, 1e-30f);
    const v3 a = sel3(ok, mul3(rsq2(sel(ok, dd, splat(1.0f))), d), pt);
    const vf den = 1.0f + dot3(pt, a);
    const vi okd = gts(den, 1e-6f);
    const vf q = sel(okd, dot3(a, ps) / sel(okd, den, splat(1.0f)), splat(0.0f));
    *t = a;
    *s = sub3(ps, mul3(q, add3(pt, a)));
    *n = cross3(*t, *s);
}

/* Pushes x out of a collider (capsule core a + t ab, t in [0, 1]; ab = 0 for a sphere) along
 * the surface normal. A knot exactly on the core goes straight up. */
INL v3 push_out(v3 x, const sim_collider* col) {
    const v3 a = {splat(col->a[0]), splat(col->a[1]), splat(col->a[2])};
    const v3 ab = {splat(col->ab[0]), splat(col->ab[1]), splat(col->ab[2])};
    const vf r = splat(col->r);
    const vf t = vmin(vmax(dot3(sub3(x, a), ab) * col->inv_ab2, splat(0.0f)), splat(1.0f));
    const v3 c = add3(a, mul3(t, ab));
    const v3 d = sub3(x, c);
    const vf dd = dot3(d, d);
    const vi inside = lt(dd, r * r);
    if (!any(inside)) return x; /* most knots of most blocks: no work */
    const vi centred = lts(dd, 1e-24f);
    const vf s = r * rsq(vmax(dd, splat(1e-24f)));
    v3 y = add3(c, mul3(s, d));
    y = sel3(centred, (v3){c.x, c.y, c.z + r}, y);
    return sel3(inside, y, x);
}

void tsk_sim_block_rest(int32_t K, float* block) {
    float* P = block + SIM_OFF_P(K);
    float* Q = block + SIM_OFF_Q(K);
    const float* R = block + SIM_OFF_R(K);
    const float* L = block + SIM_OFF_L(K);
    v3 gt = ld3(R), gs = ld3(block + SIM_OFF_S0(K));
    v3 gn = cross3(gt, gs);
    v3 p = ld3(P);
    st3(Q, p);
    for (int k = 1; k < K; ++k) {
        const v3 r = ld3(R + (size_t)k * 3 * SIM_W);
        vf lx, ly, lz;
        rest_side(r, &lx, &ly, &lz);
        const v3 u = apply3(gt, gs, gn, r.x, r.y, r.z);
        const v3 sw = apply3(gt, gs, gn, lx, ly, lz);
        p = add3(p, mul3(ld(L + (size_t)k * SIM_W), u));
        gt = u, gs = sw, gn = cross3(u, sw);
        st3(P + (size_t)k * 3 * SIM_W, p);
        st3(Q + (size_t)k * 3 * SIM_W, p);
    }
}

SIM_CLONES
void tsk_sim_block_step(const sim_step_params* p, float* block, const float* wind,
                        const sim_collider* const* cols, int ncol, float blend,
                        sim_block_stats* stats) {
    const int K = p->K;
    float* P = block + SIM_OFF_P(K);
    float* Q = block + SIM_OFF_Q(K);
    const float* R = block + SIM_OFF_R(K);
    const float* L = block + SIM_OFF_L(K);
    const float* WD = block + SIM_OFF_WD(K);
    const v3 T0 = ld3(R), S0 = ld3(block + SIM_OFF_S0(K));
    const v3 N0 = cross3(T0, S0);
    if (!wind) wind = sim_no_wind;

    /* rest positions, [k][c][lane] */
    float rest[TSK_BLADE_SIM_MAX_KNOTS * 3 * SIM_W] __attribute__((aligned(64)));
    st3(rest, ld3(P));

    const v3 g = {splat(p->gravity[0]), splat(p->gravity[1]), splat(p->gravity[2])};
    const vf dt = splat(p->dt), dt2 = splat(p->dt2), damp = splat(p->damp);
    const vf pre = splat(p->preload), drag = splat(p->drag);
    const vf ar = splat(p->alpha_root), atip = splat(p->alpha_tip);

    vf max_len = splat(0.0f); /* longest segment of the block */
    /* 1 / L^2 of every segment, for pass 2 */
    float il2[TSK_BLADE_SIM_MAX_KNOTS * SIM_W] __attribute__((aligned(64)));

    /* ---- pass 1, one sweep root to tip. For knot k: the rest frame and rest position (rebuilt
            from the rest directions); Verlet with damping, gravity (minus the preload the rest
            pose carries) and wind drag; the global shape constraint toward the rest pose. Then
            the local shape constraint of segment k-1 -> k: it is pulled toward its rest
            direction expressed in the current frame of the segment before it.
            The preload is -g at rest. Its part along the segment turns with the segment (a blade
            pressed flat no longer carries its weight along itself); the small part across the
            segment stays fixed in the world. */
    {
        const float alc = p->alpha_local;
        v3 gt = T0, gs = S0, gn = N0; /* rest frame */
        v3 ft = T0, fs = S0, fn = N0; /* current frame (local shape) */
        v3 rp = ld3(P), xo = rp, xp = rp;
        vf arc = splat(0.0f);
        const vf inv_total = 1.0f / ld(L);
        for (int k = 1; k < K; ++k) {
            const size_t o3 = (size_t)k * 3 * SIM_W, o1 = (size_t)k * SIM_W;
            const v3 r = ld3(R + o3);
            const vf len = ld(L + o1);
            max_len = vmax(max_len, len);
            vf lx, ly, lz;
            rest_side(r, &lx, &ly, &lz);
            const vf il = 1.0f / len;
            st(il2 + o1, il * il);
            /* rest frame and rest position of this segment */
            const v3 u = apply3(gt, gs, gn, r.x, r.y, r.z);
            const v3 sw = apply3(gt, gs, gn, lx, ly, lz);
            gt = u, gs = sw, gn = cross3(u, sw);
            rp = add3(rp, mul3(len, u));
            st3(rest + o3, rp);
            /* current direction of the segment (old positions): the last step ended with every
               segment at its rest length (follow-the-leader pass), so d / L is a unit vector */
            const v3 x = ld3(P + o3);
            const v3 tc = mul3(il, sub3(x, xo));
            const vf ga = dot3(u, g); /* gravity along the rest segment */
            const v3 acc = sub3(g, mul3(pre, add3(mul3(ga, tc), sub3(g, mul3(ga, u)))));
            /* Verlet: x' = x + damp (x - q) + a dt^2 + kd (wind dt - (x - q)), with the drag
               fraction kd = wind_drag / linear_density * width * dt, at most 1 */
            const v3 q = ld3(Q + o3);
            const v3 v = sub3(x, q);
            const vf kd = vmin(drag * ld(WD + o1), splat(1.0f));
            const v3 w = mul3(dt, ld3(wind + o3));
            v3 xn = add3(add3(x, mul3(damp, v)), add3(mul3(dt2, acc), mul3(kd, sub3(w, v))));
            /* global shape constraint, per-step fraction linear in arc length */
            arc = arc + len;
            const vf al = ar + (atip - ar) * (arc * inv_total);
            xn = add3(xn, mul3(al, sub3(rp, xn)));
            st3(Q + o3, x);
            xo = x;
            /* local shape constraint of segment k-1 -> k */
            const v3 target = add3(xp, mul3(len, apply3(ft, fs, fn, r.x, r.y, r.z)));
            const v3 e = sub3(target, xn);
            const float wc = k == 1 ? alc : 0.5f * alc; /* the root does not move */
            const float wp = k == 1 ? 0.0f : 0.5f * alc;
            xn = add3(xn, mul3(splat(wc), e));
            xp = sub3(xp, mul3(splat(wp), e));
            st3(P + o3 - 3 * SIM_W, xp);
            frame_advance(&ft, &fs, &fn, r, lx, ly, lz, sub3(xn, xp));
            xp = xn;
        }
        st3(P + (size_t)(K - 1) * 3 * SIM_W, xp);
    }

    /* ---- colliders near the block now: its knots' box grown by SIM_CULL_MARGIN. The iterations
            and the follow-the-leader pass use these; a last pass below checks every collider
            that can reach the block, so no knot ends inside any of them. */
    const sim_collider* near[TSK_BLADE_SIM_MAX_COLLIDERS];
    int nnear = 0;
    if (ncol > 0) {
        v3 lo = ld3(P), hi = lo;
        for (int k = 1; k < K; ++k) {
            const v3 x = ld3(P + (size_t)k * 3 * SIM_W);
            lo = (v3){vmin(lo.x, x.x), vmin(lo.y, x.y), vmin(lo.z, x.z)};
            hi = (v3){vmax(hi.x, x.x), vmax(hi.y, x.y), vmax(hi.z, x.z)};
        }
        float bl[3] = {lo.x[0], lo.y[0], lo.z[0]}, bh[3] = {hi.x[0], hi.y[0], hi.z[0]};
        for (int l = 1; l < SIM_W; ++l) {
            bl[0] = bl[0] < lo.x[l] ? bl[0] : lo.x[l], bh[0] = bh[0] > hi.x[l] ? bh[0] : hi.x[l];
            bl[1] = bl[1] < lo.y[l] ? bl[1] : lo.y[l], bh[1] = bh[1] > hi.y[l] ? bh[1] : hi.y[l];
            bl[2] = bl[2] < lo.z[l] ? bl[2] : lo.z[l], bh[2] = bh[2] > hi.z[l] ? bh[2] : hi.z[l];
        }
        /* knots move in the passes below by about a segment length at most */
        float m = 0.0f;
        for (int l = 0; l < SIM_W; ++l) m = m > max_len[l] ? m : max_len[l];
        m += SIM_CULL_MARGIN;
        for (int ci = 0; ci < ncol; ++ci) {
            const sim_collider* c = cols[ci];
            int overlap = 1;
            for (int a = 0; a < 3; ++a) overlap &= c->lo[a] <= bh[a] + m && c->hi[a] >= bl[a] - m;
            if (overlap) near[nnear++] = c;
        }
    }

    /* ---- pass 2: length constraints (each segment's two knots move half way; the root never)
            and collisions, iterated. Segments are relaxed odd then even: segments of one parity
            share no knot, so their updates are independent (same convergence as a sweep, and no
            chain of dependent operations along the blade). */
    const vf ground = splat(p->ground);
    for (int it = 0; it < p->iterations; ++it) {
        for (int parity = 1; parity <= 2; ++parity)
            for (int k = parity; k < K; k += 2) {
                const size_t o3 = (size_t)k * 3 * SIM_W;
                v3 xp = ld3(P + o3 - 3 * SIM_W);
                v3 x = ld3(P + o3);
                const v3 d = sub3(x, xp);
                /* the exact correction (len - L) / len, to first order in len/L - 1:
                   (len^2 / L^2 - 1) / 2, no square root; bounded for large errors. The
                   follow-the-leader pass below makes lengths exact. */
                const vf f = vmin(vmax(0.5f * (dot3(d, d) * ld(il2 + (size_t)k * SIM_W) - 1.0f),
                                       splat(-0.5f)), splat(0.5f));
                const float wc = k == 1 ? 1.0f : 0.5f, wp = k == 1 ? 0.0f : 0.5f;
                x = sub3(x, mul3(wc * f, d));
                xp = add3(xp, mul3(wp * f, d));
                st3(P + o3 - 3 * SIM_W, xp);
                st3(P + o3, x);
            }
        for (int ci = 0; ci < nnear; ++ci)
            for (int k = 1; k < K; ++k) {
                float* pk = P + (size_t)k * 3 * SIM_W;
                st3(pk, push_out(ld3(pk), near[ci]));
            }
        for (int k = 1; k < K; ++k) {
            float* pz = P + (size_t)k * 3 * SIM_W + 2 * SIM_W;
            st(pz, vmax(ld(pz), ground));
        }
    }

    /* ---- pass 3: follow the leader, root to tip (Mueller et al. 2012): each segment is set to
            its rest length exactly; a knot this puts inside a collider goes to the nearest point
            that is both at the segment's length from the knot before it and on the collider's
            surface (the circle where the two spheres meet); under the ground, to the nearest
            point of the circle where that sphere meets the ground plane. The iterations above
            leave small residuals, so this pass moves knots little. */
    {
        v3 xp = ld3(P);
        for (int k = 1; k < K; ++k) {
            const size_t o3 = (size_t)k * 3 * SIM_W;
            const vf len = ld(L + (size_t)k * SIM_W);
            v3 x = ld3(P + o3);
            {
                const v3 d = sub3(x, xp);
                const vf dd = dot3(d, d);
                const vi ok = gts(dd, 1e-30f);
                x = sel3(ok, add3(xp, mul3(len * rsq2(sel(ok, dd, splat(1.0f))), d)), x);
            }
            for (int ci = 0; ci < nnear; ++ci) {
                const sim_collider* col = near[ci];
                const v3 a = {splat(col->a[0]), splat(col->a[1]), splat(col->a[2])};
                const v3 ab = {splat(col->ab[0]), splat(col->ab[1]), splat(col->ab[2])};
                const vf r = splat(col->r), r2 = r * r;
                /* a capsule's nearest core point moves with the knot: more rounds refine it */
                const int rounds = col->inv_ab2 > 0.0f ? 3 : 1;
                for (int round = 0; round < rounds; ++round) {
                    const vf t = vmin(vmax(dot3(sub3(x, a), ab) * col->inv_ab2, splat(0.0f)), splat(1.0f));
                    const v3 c = add3(a, mul3(t, ab));
                    const v3 xd = sub3(x, c);
                    const vi inside = lt(dot3(xd, xd), r2);
                    if (!any(inside)) break; /* no lane inside: nothing to project */
                    /* circle of sphere(xp, len) and sphere(c, r): centre xp + h0 u, radius h */
                    const v3 e = sub3(c, xp);
                    const vf D2 = dot3(e, e);
                    const vf iD = rsq(vmax(D2, splat(1e-24f)));
                    const vf D = D2 * iD;
                    const v3 u = mul3(iD, e);
                    const vf h0 = (D2 + len * len - r2) * 0.5f * iD;
                    const vf h2 = vmax(len * len - h0 * h0, splat(0.0f));
                    const vf h = h2 * rsq(sel(gts(h2, 1e-30f), h2, splat(1.0f)));
                    const v3 q = sub3(x, xp);
                    const v3 w = sub3(q, mul3(dot3(q, u), u));
                    const vf ww = dot3(w, w);
                    const vi wok = gts(ww, 1e-30f);
                    const vf iw = sel(wok, h * rsq(sel(wok, ww, splat(1.0f))), splat(0.0f));
                    /* the circle exists when the previous knot is outside (it may lie on the
                       surface, up to rounding), within len + r */
                    const vi ok = inside & gt(D, r * 0.999f) & lt(D, len + r) & wok;
                    const v3 y = add3(add3(xp, mul3(h0, u)), mul3(iw, w));
                    x = sel3(ok, y, x);
                    if (round == rounds - 1) x = push_out(x, col); /* what is left: tiny */
                }
            }
            if (any(lt(x.z, ground))) {
                const vf hz = xp.z - ground;
                const vf h2 = vmax(len * len - hz * hz, splat(0.0f));
                const vf qx = x.x - xp.x, qy = x.y - xp.y;
                const vf qq = qx * qx + qy * qy;
                const vi ok = gts(qq, 1e-30f);
                const vf s = sel(ok, h2 * rsq(sel(gts(h2, 1e-30f), h2, splat(1.0f))) *
                                         rsq(sel(ok, qq, splat(1.0f))),
                                 splat(0.0f));
                const vi below = lt(x.z, ground);
                x = sel3(below, (v3){xp.x + s * qx, xp.y + s * qy, ground}, x);
            }
            st3(P + o3, x);
            xp = x;
        }
    }

    /* ---- last check against every collider that can reach the block (a knot the passes above
            moved into one they did not consider goes to its surface), then the ground. */
    if (ncol > nnear) {
        for (int ci = 0; ci < ncol; ++ci) {
            const sim_collider* col = cols[ci];
            const v3 a = {splat(col->a[0]), splat(col->a[1]), splat(col->a[2])};
            const v3 ab = {splat(col->ab[0]), splat(col->ab[1]), splat(col->ab[2])};
            const vf r2 = splat(col->r * col->r);
            vi hit = (vi){0};
            for (int k = 1; k < K; ++k) {
                const v3 x = ld3(P + (size_t)k * 3 * SIM_W);
                const vf t = vmin(vmax(dot3(sub3(x, a), ab) * col->inv_ab2, splat(0.0f)), splat(1.0f));
                const v3 d = sub3(x, add3(a, mul3(t, ab)));
                hit |= lt(dot3(d, d), r2);
            }
            if (!any(hit)) continue;
            for (int k = 1; k < K; ++k) {
                float* pk = P + (size_t)k * 3 * SIM_W;
                st3(pk, push_out(ld3(pk), col));
            }
            for (int k = 1; k < K; ++k) {
                float* pz = P + (size_t)k * 3 * SIM_W + 2 * SIM_W;
                st(pz, vmax(ld(pz), ground));
            }
        }
    }

    /* ---- pass 4: blend back toward rest (the tile is released soon) and statistics. */
    vf md = splat(0.0f), ms = splat(0.0f);
    const vi snap = (vi){0} + (blend >= 1.0f ? -1 : 0);
    const vf bl = splat(blend);
    for (int k = 1; k < K; ++k) {
        const size_t o3 = (size_t)k * 3 * SIM_W;
        v3 x = ld3(P + o3), q = ld3(Q + o3);
        const v3 rs = ld3(rest + o3);
        if (blend > 0.0f) {
            x = sel3(snap, rs, add3(x, mul3(bl, sub3(rs, x))));
            q = sel3(snap, rs, add3(q, mul3(bl, sub3(rs, q))));
            st3(P + o3, x);
            st3(Q + o3, q);
        }
        const v3 e = sub3(x, rs), v = sub3(x, q);
        md = vmax(md, dot3(e, e));
        ms = vmax(ms, dot3(v, v));
    }
    float m1 = 0.0f, m2 = 0.0f;
    for (int l = 0; l < SIM_W; ++l) {
        m1 = m1 > md[l] ? m1 : md[l];
        m2 = m2 > ms[l] ? m2 : ms[l];
    }
    stats->max_disp2 = m1;
    stats->max_step2 = m2;
}
