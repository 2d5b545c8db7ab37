/* The blade solver for one block of SIM_W blades: Verlet integration with damping, gravity
 * (with preload) and wind drag; global and local shape constraints; length constraints and
 * collisions iterated (Han & Harada 2012, as seed 000 §2 and §4.5 adopt it: collision a hard
 * constraint, length, bending and twisting soft constraints of an iterative solver).
 * Every inner loop runs over the SIM_W lanes of a block, so the compiler vectorises it. */
#if defined(__GNUC__) && !defined(__clang__)
/* sqrtf without errno so that it vectorises; results are the same correctly rounded roots. */
#pragma GCC optimize("no-math-errno")
#endif

#include "sim/sim_internal.h"

#include <math.h>

#define W SIM_W
#define LANES for (int l = 0; l < W; ++l)

/* Wider vector units when the CPU has them. Only IEEE add/mul/div/sqrt/min/max are used and
 * -ffp-contract=off forbids fused multiply-add, so every clone computes the same bits. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_ADDRESS__)
#define SIM_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define SIM_CLONES
#endif

/* Moves the current frame (t, s, n) of segment k-1 to segment k: the predicted frame is the
 * parent frame turned by the rest rotation (r, side (lx, ly, lz)); it is then turned by the
 * smallest rotation taking its tangent to the actual direction d (not normalised). */
#define FRAME_ADVANCE(t, s, n, rx, ry, rz, lx, ly, lz, d0, d1, d2)                              \
    do {                                                                                    \
        const float pt0 = t##0 * rx + s##0 * ry + n##0 * rz;                                \
        const float pt1 = t##1 * rx + s##1 * ry + n##1 * rz;                                \
        const float pt2 = t##2 * rx + s##2 * ry + n##2 * rz;                                \
        const float ps0 = t##0 * lx + s##0 * ly + n##0 * lz;                                \
        const float ps1 = t##1 * lx + s##1 * ly + n##1 * lz;                                \
        const float ps2 = t##2 * lx + s##2 * ly + n##2 * lz;                                \
        const float dd = d0 * d0 + d1 * d1 + d2 * d2;                                       \
        const float ok = dd > 1e-30f ? 1.0f : 0.0f;                                         \
        const float inv = ok / sqrtf(dd > 1e-30f ? dd : 1.0f);                              \
        const float a0 = ok * d0 * inv + (1.0f - ok) * pt0;                                 \
        const float a1 = ok * d1 * inv + (1.0f - ok) * pt1;                                 \
        const float a2 = ok * d2 * inv + (1.0f - ok) * pt2;                                 \
        float den = 1.0f + (pt0 * a0 + pt1 * a1 + pt2 * a2);                                \
        const float q = den > 1e-6f ? (a0 * ps0 + a1 * ps1 + a2 * ps2) / den : 0.0f;        \
        t##0 = a0, t##1 = a1, t##2 = a2;                                                    \
        s##0 = ps0 - q * (pt0 + a0), s##1 = ps1 - q * (pt1 + a1), s##2 = ps2 - q * (pt2 + a2); \
        n##0 = t##1 * s##2 - t##2 * s##1;                                                   \
        n##1 = t##2 * s##0 - t##0 * s##2;                                                   \
        n##2 = t##0 * s##1 - t##1 * s##0;                                                   \
    } while (0)

SIM_CLONES
void tsk_sim_block_step(const sim_step_params* p, float* restrict block, const float* wind,
                        const sim_collider* const* cols, int ncol, float blend,
                        sim_block_stats* stats) {
    const int K = p->K;
    float* restrict P = block + SIM_OFF_P(K);
    float* restrict Q = block + SIM_OFF_Q(K);
    const float* restrict R = block + SIM_OFF_R(K);
    const float* restrict L = block + SIM_OFF_L(K);
    const float* restrict WD = block + SIM_OFF_WD(K);
    const float* restrict S0 = block + SIM_OFF_S0(K);

    float rest[TSK_BLADE_SIM_MAX_KNOTS * 3 * W]; /* rest positions, [k][c][l] */
    float T0n[3 * W]; /* root frame normal */
    LANES {
        T0n[l] = R[W + l] * S0[2 * W + l] - R[2 * W + l] * S0[W + l];
        T0n[W + l] = R[2 * W + l] * S0[l] - R[l] * S0[2 * W + l];
        T0n[2 * W + l] = R[l] * S0[W + l] - R[W + l] * S0[l];
        rest[l] = P[l], rest[W + l] = P[W + l], rest[2 * W + l] = P[2 * W + l];
    }

    const float g0 = p->gravity[0], g1 = p->gravity[1], g2 = p->gravity[2];
    const float dt = p->dt, dt2 = p->dt2, damp = p->damp, pre = p->preload, drag = p->drag;
    const float ar = p->alpha_root, atip = p->alpha_tip;

    /* ---- pass 1: rest frames and rest positions; current frames of the old positions;
            Verlet with damping, gravity (minus the preload the rest pose carries) and wind
            drag; global shape constraint toward the rest pose. */
    {
        float gt0[W], gt1[W], gt2[W], gs0[W], gs1[W], gs2[W], gn0[W], gn1[W], gn2[W];
        float ft0[W], ft1[W], ft2[W], fs0[W], fs1[W], fs2[W], fn0[W], fn1[W], fn2[W];
        float rp0[W], rp1[W], rp2[W], xo0[W], xo1[W], xo2[W], arc[W];
        LANES {
            gt0[l] = ft0[l] = R[l], gt1[l] = ft1[l] = R[W + l], gt2[l] = ft2[l] = R[2 * W + l];
            gs0[l] = fs0[l] = S0[l], gs1[l] = fs1[l] = S0[W + l], gs2[l] = fs2[l] = S0[2 * W + l];
            gn0[l] = fn0[l] = T0n[l], gn1[l] = fn1[l] = T0n[W + l], gn2[l] = fn2[l] = T0n[2 * W + l];
            rp0[l] = xo0[l] = P[l], rp1[l] = xo1[l] = P[W + l], rp2[l] = xo2[l] = P[2 * W + l];
            arc[l] = 0.0f;
        }
        for (int k = 1; k < K; ++k) {
            const float* Rk = R + (size_t)k * 3 * W;
            const float* Lk = L + (size_t)k * W;
            const float* Wk = WD + (size_t)k * W;
            const float* wk = wind ? wind + (size_t)k * 3 * W : NULL;
            float* Pk = P + (size_t)k * 3 * W;
            float* Qk = Q + (size_t)k * 3 * W;
            float* RSk = rest + (size_t)k * 3 * W;
            LANES {
                const float rx = Rk[l], ry = Rk[W + l], rz = Rk[2 * W + l], len = Lk[l];
                const float c = sim_side_coef(rx, ry);
                const float lx = -ry, ly = 1.0f - c * ry, lz = -c * rz;
                /* rest frame and rest position */
                const float u0 = gt0[l] * rx + gs0[l] * ry + gn0[l] * rz;
                const float u1 = gt1[l] * rx + gs1[l] * ry + gn1[l] * rz;
                const float u2 = gt2[l] * rx + gs2[l] * ry + gn2[l] * rz;
                const float v0s = gt0[l] * lx + gs0[l] * ly + gn0[l] * lz;
                const float v1s = gt1[l] * lx + gs1[l] * ly + gn1[l] * lz;
                const float v2s = gt2[l] * lx + gs2[l] * ly + gn2[l] * lz;
                gt0[l] = u0, gt1[l] = u1, gt2[l] = u2, gs0[l] = v0s, gs1[l] = v1s, gs2[l] = v2s;
                gn0[l] = u1 * v2s - u2 * v1s, gn1[l] = u2 * v0s - u0 * v2s, gn2[l] = u0 * v1s - u1 * v0s;
                rp0[l] = rp0[l] + len * u0, rp1[l] = rp1[l] + len * u1, rp2[l] = rp2[l] + len * u2;
                RSk[l] = rp0[l], RSk[W + l] = rp1[l], RSk[2 * W + l] = rp2[l];
                /* current frame of the old positions */
                const float x0 = Pk[l], x1 = Pk[W + l], x2 = Pk[2 * W + l];
                const float d0 = x0 - xo0[l], d1 = x1 - xo1[l], d2 = x2 - xo2[l];
                float t0 = ft0[l], t1 = ft1[l], t2 = ft2[l], s0 = fs0[l], s1 = fs1[l], s2 = fs2[l];
                float n0 = fn0[l], n1 = fn1[l], n2 = fn2[l];
                FRAME_ADVANCE(t, s, n, rx, ry, rz, lx, ly, lz, d0, d1, d2);
                ft0[l] = t0, ft1[l] = t1, ft2[l] = t2, fs0[l] = s0, fs1[l] = s1, fs2[l] = s2;
                fn0[l] = n0, fn1[l] = n1, fn2[l] = n2;
                /* gravity preload: the rest pose carries gravity; the carrying force is fixed in
                   the segment's frame, so it turns with the segment. */
                const float gl0 = gt0[l] * g0 + gt1[l] * g1 + gt2[l] * g2;
                const float gl1 = gs0[l] * g0 + gs1[l] * g1 + gs2[l] * g2;
                const float gl2 = gn0[l] * g0 + gn1[l] * g1 + gn2[l] * g2;
                const float a0 = g0 - pre * (t0 * gl0 + s0 * gl1 + n0 * gl2);
                const float a1 = g1 - pre * (t1 * gl0 + s1 * gl1 + n1 * gl2);
                const float a2 = g2 - pre * (t2 * gl0 + s2 * gl1 + n2 * gl2);
                /* Verlet: x' = x + damp (x - q) + a dt^2 + drag (wind dt - (x - q)), where the
                   drag fraction kd = wind_drag / linear_density * width * dt (capped at 1). */
                const float q0 = Qk[l], q1 = Qk[W + l], q2 = Qk[2 * W + l];
                const float v0 = x0 - q0, v1 = x1 - q1, v2 = x2 - q2;
                float kd = drag * Wk[l];
                kd = kd < 1.0f ? kd : 1.0f;
                const float w0 = wk ? wk[l] * dt : 0.0f, w1 = wk ? wk[W + l] * dt : 0.0f,
                            w2 = wk ? wk[2 * W + l] * dt : 0.0f;
                float n0x = x0 + damp * v0 + a0 * dt2 + kd * (w0 - v0);
                float n1x = x1 + damp * v1 + a1 * dt2 + kd * (w1 - v1);
                float n2x = x2 + damp * v2 + a2 * dt2 + kd * (w2 - v2);
                /* global shape constraint, per-step fraction linear in arc length */
                arc[l] = arc[l] + len;
                const float f = arc[l] / L[l];
                const float al = ar + (atip - ar) * f;
                n0x = n0x + al * (rp0[l] - n0x);
                n1x = n1x + al * (rp1[l] - n1x);
                n2x = n2x + al * (rp2[l] - n2x);
                Qk[l] = x0, Qk[W + l] = x1, Qk[2 * W + l] = x2;
                Pk[l] = n0x, Pk[W + l] = n1x, Pk[2 * W + l] = n2x;
                xo0[l] = x0, xo1[l] = x1, xo2[l] = x2;
            }
        }
    }

    /* ---- pass 2: local shape constraints, root to tip: segment k-1 -> k is pulled toward its
            rest direction expressed in the current frame of the segment before it. */
    {
        const float al = p->alpha_local;
        float ft0[W], ft1[W], ft2[W], fs0[W], fs1[W], fs2[W], fn0[W], fn1[W], fn2[W];
        LANES {
            ft0[l] = R[l], ft1[l] = R[W + l], ft2[l] = R[2 * W + l];
            fs0[l] = S0[l], fs1[l] = S0[W + l], fs2[l] = S0[2 * W + l];
            fn0[l] = T0n[l], fn1[l] = T0n[W + l], fn2[l] = T0n[2 * W + l];
        }
        for (int k = 1; k < K; ++k) {
            const float* Rk = R + (size_t)k * 3 * W;
            const float* Lk = L + (size_t)k * W;
            float* Pk = P + (size_t)k * 3 * W;
            float* Pp = P + (size_t)(k - 1) * 3 * W;
            const float wc = k == 1 ? al : 0.5f * al; /* the root does not move */
            const float wp = k == 1 ? 0.0f : 0.5f * al;
            LANES {
                const float rx = Rk[l], ry = Rk[W + l], rz = Rk[2 * W + l], len = Lk[l];
                const float c = sim_side_coef(rx, ry);
                const float lx = -ry, ly = 1.0f - c * ry, lz = -c * rz;
                const float tg0 = ft0[l] * rx + fs0[l] * ry + fn0[l] * rz;
                const float tg1 = ft1[l] * rx + fs1[l] * ry + fn1[l] * rz;
                const float tg2 = ft2[l] * rx + fs2[l] * ry + fn2[l] * rz;
                float xp0 = Pp[l], xp1 = Pp[W + l], xp2 = Pp[2 * W + l];
                float x0 = Pk[l], x1 = Pk[W + l], x2 = Pk[2 * W + l];
                const float e0 = xp0 + len * tg0 - x0, e1 = xp1 + len * tg1 - x1,
                            e2 = xp2 + len * tg2 - x2;
                x0 = x0 + wc * e0, x1 = x1 + wc * e1, x2 = x2 + wc * e2;
                xp0 = xp0 - wp * e0, xp1 = xp1 - wp * e1, xp2 = xp2 - wp * e2;
                Pk[l] = x0, Pk[W + l] = x1, Pk[2 * W + l] = x2;
                Pp[l] = xp0, Pp[W + l] = xp1, Pp[2 * W + l] = xp2;
                const float d0 = x0 - xp0, d1 = x1 - xp1, d2 = x2 - xp2;
                float t0 = ft0[l], t1 = ft1[l], t2 = ft2[l], s0 = fs0[l], s1 = fs1[l], s2 = fs2[l];
                float n0 = fn0[l], n1 = fn1[l], n2 = fn2[l];
                FRAME_ADVANCE(t, s, n, rx, ry, rz, lx, ly, lz, d0, d1, d2);
                ft0[l] = t0, ft1[l] = t1, ft2[l] = t2, fs0[l] = s0, fs1[l] = s1, fs2[l] = s2;
                fn0[l] = n0, fn1[l] = n1, fn2[l] = n2;
            }
        }
    }

    /* ---- pass 3: length constraints and collisions, iterated; collisions and ground last. */
    const float ground = p->ground;
    for (int it = 0; it < p->iterations; ++it) {
        for (int k = 1; k < K; ++k) {
            const float* Lk = L + (size_t)k * W;
            float* Pk = P + (size_t)k * 3 * W;
            float* Pp = P + (size_t)(k - 1) * 3 * W;
            const float wc = k == 1 ? 1.0f : 0.5f, wp = k == 1 ? 0.0f : 0.5f;
            LANES {
                const float d0 = Pk[l] - Pp[l], d1 = Pk[W + l] - Pp[W + l],
                            d2 = Pk[2 * W + l] - Pp[2 * W + l];
                const float dd = d0 * d0 + d1 * d1 + d2 * d2;
                const float len = sqrtf(dd);
                const float f = dd > 1e-30f ? (len - Lk[l]) / (len > 1e-15f ? len : 1e-15f) : 0.0f;
                Pk[l] = Pk[l] - wc * f * d0, Pk[W + l] = Pk[W + l] - wc * f * d1,
                Pk[2 * W + l] = Pk[2 * W + l] - wc * f * d2;
                Pp[l] = Pp[l] + wp * f * d0, Pp[W + l] = Pp[W + l] + wp * f * d1,
                Pp[2 * W + l] = Pp[2 * W + l] + wp * f * d2;
            }
        }
        for (int ci = 0; ci < ncol; ++ci) {
            const sim_collider* col = cols[ci];
            const float a0 = col->a[0], a1 = col->a[1], a2 = col->a[2];
            const float b0 = col->ab[0], b1 = col->ab[1], b2 = col->ab[2];
            const float ia = col->inv_ab2, r = col->r, r2 = col->r * col->r;
            for (int k = 1; k < K; ++k) {
                float* Pk = P + (size_t)k * 3 * W;
                LANES {
                    const float x0 = Pk[l], x1 = Pk[W + l], x2 = Pk[2 * W + l];
                    float t = ((x0 - a0) * b0 + (x1 - a1) * b1 + (x2 - a2) * b2) * ia;
                    t = t < 0.0f ? 0.0f : (t > 1.0f ? 1.0f : t);
                    const float c0 = a0 + t * b0, c1 = a1 + t * b1, c2 = a2 + t * b2;
                    const float d0 = x0 - c0, d1 = x1 - c1, d2 = x2 - c2;
                    const float dd = d0 * d0 + d1 * d1 + d2 * d2;
                    const float d = sqrtf(dd);
                    const int inside = dd < r2;
                    const int centred = d < 1e-12f; /* on the core: push straight up */
                    const float s = r / (d > 1e-12f ? d : 1e-12f);
                    const float y0 = centred ? c0 : c0 + d0 * s;
                    const float y1 = centred ? c1 : c1 + d1 * s;
                    const float y2 = centred ? c2 + r : c2 + d2 * s;
                    Pk[l] = inside ? y0 : x0;
                    Pk[W + l] = inside ? y1 : x1;
                    Pk[2 * W + l] = inside ? y2 : x2;
                }
            }
        }
        for (int k = 1; k < K; ++k) {
            float* Pz = P + (size_t)k * 3 * W + 2 * W;
            LANES Pz[l] = Pz[l] > ground ? Pz[l] : ground;
        }
    }

    /* ---- pass 4: follow the leader, root to tip (Mueller et al. 2012): each segment is set to its
            rest length exactly; a knot that this puts inside a collider (or under the ground) goes
            to the nearest point that is both at the segment's length from the knot before it and
            on the collider's surface (the circle where the two spheres meet). The iterations above
            leave only small residuals, so this pass moves knots little. */
    for (int k = 1; k < K; ++k) {
        const float* Lk = L + (size_t)k * W;
        float* Pk = P + (size_t)k * 3 * W;
        const float* Pp = P + (size_t)(k - 1) * 3 * W;
        LANES {
            const float d0 = Pk[l] - Pp[l], d1 = Pk[W + l] - Pp[W + l], d2 = Pk[2 * W + l] - Pp[2 * W + l];
            const float dd = d0 * d0 + d1 * d1 + d2 * d2;
            const float s = dd > 1e-30f ? Lk[l] / sqrtf(dd > 1e-30f ? dd : 1.0f) : 1.0f;
            Pk[l] = Pp[l] + s * d0, Pk[W + l] = Pp[W + l] + s * d1, Pk[2 * W + l] = Pp[2 * W + l] + s * d2;
        }
        for (int ci = 0; ci < ncol; ++ci) {
            const sim_collider* col = cols[ci];
            const float a0 = col->a[0], a1 = col->a[1], a2 = col->a[2];
            const float b0 = col->ab[0], b1 = col->ab[1], b2 = col->ab[2];
            const float ia = col->inv_ab2, r = col->r, r2 = col->r * col->r;
            /* a capsule's nearest core point moves with the knot: a second round refines it */
            const int rounds = ia > 0.0f ? 3 : 1;
            for (int round = 0; round < rounds; ++round) LANES {
                const float x0 = Pk[l], x1 = Pk[W + l], x2 = Pk[2 * W + l];
                const float p0 = Pp[l], p1 = Pp[W + l], p2 = Pp[2 * W + l];
                float t = ((x0 - a0) * b0 + (x1 - a1) * b1 + (x2 - a2) * b2) * ia;
                t = t < 0.0f ? 0.0f : (t > 1.0f ? 1.0f : t);
                const float c0 = a0 + t * b0, c1 = a1 + t * b1, c2 = a2 + t * b2;
                const float xd0 = x0 - c0, xd1 = x1 - c1, xd2 = x2 - c2;
                const int inside = xd0 * xd0 + xd1 * xd1 + xd2 * xd2 < r2;
                /* circle of sphere(p, len) and sphere(c, r): centre p + a e, radius h */
                const float len = Lk[l];
                const float e0 = c0 - p0, e1 = c1 - p1, e2 = c2 - p2;
                const float D2 = e0 * e0 + e1 * e1 + e2 * e2;
                const float D = sqrtf(D2);
                const float iD = 1.0f / (D > 1e-12f ? D : 1e-12f);
                const float u0 = e0 * iD, u1 = e1 * iD, u2 = e2 * iD;
                const float a = (D2 + len * len - r2) * 0.5f * iD;
                float h2 = len * len - a * a;
                h2 = h2 > 0.0f ? h2 : 0.0f;
                const float h = sqrtf(h2);
                const float q0 = x0 - p0, q1 = x1 - p1, q2 = x2 - p2;
                const float qu = q0 * u0 + q1 * u1 + q2 * u2;
                const float w0 = q0 - qu * u0, w1 = q1 - qu * u1, w2 = q2 - qu * u2;
                const float ww = w0 * w0 + w1 * w1 + w2 * w2;
                const float iw = ww > 1e-30f ? h / sqrtf(ww > 1e-30f ? ww : 1.0f) : 0.0f;
                /* the circle exists when the previous knot is outside and within len + r */
                const int ok = inside && D > r && D < len + r && ww > 1e-30f;
                const float y0 = p0 + a * u0 + iw * w0, y1 = p1 + a * u1 + iw * w1,
                            y2 = p2 + a * u2 + iw * w2;
                /* otherwise: plain projection onto the surface */
                const float xd = sqrtf(xd0 * xd0 + xd1 * xd1 + xd2 * xd2);
                const float sc = r / (xd > 1e-12f ? xd : 1e-12f);
                const float z0 = c0 + xd0 * sc, z1 = c1 + xd1 * sc, z2 = c2 + xd2 * sc;
                float o0 = ok ? y0 : (inside ? z0 : x0);
                float o1 = ok ? y1 : (inside ? z1 : x1);
                float o2 = ok ? y2 : (inside ? z2 : x2);
                /* what is left inside (a capsule's core point moved): project (tiny move) */
                float t2 = ((o0 - a0) * b0 + (o1 - a1) * b1 + (o2 - a2) * b2) * ia;
                t2 = t2 < 0.0f ? 0.0f : (t2 > 1.0f ? 1.0f : t2);
                const float k0 = a0 + t2 * b0, k1 = a1 + t2 * b1, k2 = a2 + t2 * b2;
                const float f0 = o0 - k0, f1 = o1 - k1, f2 = o2 - k2;
                const float ff = f0 * f0 + f1 * f1 + f2 * f2;
                const float fd = sqrtf(ff);
                const float fs = r / (fd > 1e-12f ? fd : 1e-12f);
                const int in2 = ff < r2 && fd > 1e-12f && round == rounds - 1;
                Pk[l] = in2 ? k0 + f0 * fs : o0;
                Pk[W + l] = in2 ? k1 + f1 * fs : o1;
                Pk[2 * W + l] = in2 ? k2 + f2 * fs : o2;
            }
        }
        LANES {
            /* under the ground: the point of the circle where sphere(p, len) meets the ground
               plane nearest to the knot */
            const float x0 = Pk[l], x1 = Pk[W + l], x2 = Pk[2 * W + l];
            const float p0 = Pp[l], p1 = Pp[W + l], p2 = Pp[2 * W + l];
            const float len = Lk[l];
            const float hz = p2 - ground;
            float h2 = len * len - hz * hz;
            h2 = h2 > 0.0f ? h2 : 0.0f;
            const float q0 = x0 - p0, q1 = x1 - p1;
            const float qq = q0 * q0 + q1 * q1;
            const float s = qq > 1e-30f ? sqrtf(h2) / sqrtf(qq > 1e-30f ? qq : 1.0f) : 0.0f;
            const int below = x2 < ground;
            Pk[l] = below ? p0 + s * q0 : x0;
            Pk[W + l] = below ? p1 + s * q1 : x1;
            Pk[2 * W + l] = below ? ground : x2;
        }
    }

    /* ---- pass 5: blend back toward rest (tile released soon) and statistics. */
    float md[W], ms[W];
    LANES md[l] = 0.0f, ms[l] = 0.0f;
    const int snap = blend >= 1.0f;
    for (int k = 1; k < K; ++k) {
        float* Pk = P + (size_t)k * 3 * W;
        float* Qk = Q + (size_t)k * 3 * W;
        const float* RSk = rest + (size_t)k * 3 * W;
        if (blend > 0.0f) {
            for (int c = 0; c < 3; ++c) {
                float* x = Pk + c * W;
                float* q = Qk + c * W;
                const float* rs = RSk + c * W;
                LANES {
                    x[l] = snap ? rs[l] : x[l] + blend * (rs[l] - x[l]);
                    q[l] = snap ? rs[l] : q[l] + blend * (rs[l] - q[l]);
                }
            }
        }
        LANES {
            const float e0 = Pk[l] - RSk[l], e1 = Pk[W + l] - RSk[W + l],
                        e2 = Pk[2 * W + l] - RSk[2 * W + l];
            const float v0 = Pk[l] - Qk[l], v1 = Pk[W + l] - Qk[W + l],
                        v2 = Pk[2 * W + l] - Qk[2 * W + l];
            const float de = e0 * e0 + e1 * e1 + e2 * e2, dv = v0 * v0 + v1 * v1 + v2 * v2;
            md[l] = md[l] > de ? md[l] : de;
            ms[l] = ms[l] > dv ? ms[l] : dv;
        }
    }
    float m1 = 0.0f, m2 = 0.0f;
    for (int l = 0; l < W; ++l) {
        m1 = m1 > md[l] ? m1 : md[l];
        m2 = m2 > ms[l] ? m2 : ms[l];
    }
    stats->max_disp2 = m1;
    stats->max_step2 = m2;
}
