/* The rest pose of a block: loading a tile's rest blades into the block layout (rest
 * directions in parallel-transported frames, lengths, widths, root frame) and rebuilding rest
 * positions from them, exactly as the solver rebuilds them every step. */
#include "sim/sim_internal.h"

#include <math.h>

#define W SIM_W

void tsk_sim_block_load_lane(int32_t K, float* block, int lane, const float* knots,
                             const float* widths, const float* side) {
    float* P = block + SIM_OFF_P(K);
    float* R = block + SIM_OFF_R(K);
    float* L = block + SIM_OFF_L(K);
    float* WD = block + SIM_OFF_WD(K);
    float* S0 = block + SIM_OFF_S0(K);
    const int l = lane;
    /* root frame: tangent of the first segment, side from the caller made perpendicular */
    double t[3] = {knots[3] - knots[0], knots[4] - knots[1], knots[5] - knots[2]};
    double tl = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    for (int c = 0; c < 3; ++c) t[c] /= tl;
    double s[3] = {0, 0, 0}, sl = 0;
    if (side) {
        double d = side[0] * t[0] + side[1] * t[1] + side[2] * t[2];
        for (int c = 0; c < 3; ++c) s[c] = side[c] - d * t[c];
        sl = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    }
    if (sl < 1e-6) { /* horizontal, perpendicular to the first segment; +y if it stands upright */
        s[0] = -t[1], s[1] = t[0], s[2] = 0;
        sl = sqrt(s[0] * s[0] + s[1] * s[1]);
        if (sl < 1e-6) {
            s[0] = 0, s[1] = 1, s[2] = 0;
            double d = t[1];
            for (int c = 0; c < 3; ++c) s[c] -= d * t[c];
            sl = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
        }
    }
    for (int c = 0; c < 3; ++c) s[c] /= sl;
    float gt0 = (float)t[0], gt1 = (float)t[1], gt2 = (float)t[2];
    float gs0 = (float)s[0], gs1 = (float)s[1], gs2 = (float)s[2];
    float gn0 = gt1 * gs2 - gt2 * gs1, gn1 = gt2 * gs0 - gt0 * gs2, gn2 = gt0 * gs1 - gt1 * gs0;
    R[l] = gt0, R[W + l] = gt1, R[2 * W + l] = gt2;
    S0[l] = gs0, S0[W + l] = gs1, S0[2 * W + l] = gs2;
    P[l] = knots[0], P[W + l] = knots[1], P[2 * W + l] = knots[2];
    WD[l] = widths[0];
    double total = 0;
    for (int k = 1; k < K; ++k) {
        const float* a = knots + 3 * (k - 1);
        const float* b = knots + 3 * k;
        double d[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
        double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        total += len;
        for (int c = 0; c < 3; ++c) d[c] /= len;
        /* the rest direction in the frame the solver will rebuild (not the exact one), so that
           rounding does not accumulate along the blade */
        double r[3] = {d[0] * gt0 + d[1] * gt1 + d[2] * gt2, d[0] * gs0 + d[1] * gs1 + d[2] * gs2,
                       d[0] * gn0 + d[1] * gn1 + d[2] * gn2};
        /* unit r keeps the rebuilt frames from growing or shrinking along the blade */
        const double rl = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
        const float rx = (float)(r[0] / rl), ry = (float)(r[1] / rl), rz = (float)(r[2] / rl);
        float* Rk = R + (size_t)k * 3 * W;
        Rk[l] = rx, Rk[W + l] = ry, Rk[2 * W + l] = rz;
        L[(size_t)k * W + l] = (float)len;
        WD[(size_t)k * W + l] = widths[k];
        const float c = sim_side_coef(rx, ry);
        const float lx = -ry, ly = 1.0f - c * ry, lz = -c * rz;
        const float u0 = gt0 * rx + gs0 * ry + gn0 * rz, u1 = gt1 * rx + gs1 * ry + gn1 * rz,
                    u2 = gt2 * rx + gs2 * ry + gn2 * rz;
        const float v0 = gt0 * lx + gs0 * ly + gn0 * lz, v1 = gt1 * lx + gs1 * ly + gn1 * lz,
                    v2 = gt2 * lx + gs2 * ly + gn2 * lz;
        gt0 = u0, gt1 = u1, gt2 = u2, gs0 = v0, gs1 = v1, gs2 = v2;
        gn0 = gt1 * gs2 - gt2 * gs1, gn1 = gt2 * gs0 - gt0 * gs2, gn2 = gt0 * gs1 - gt1 * gs0;
    }
    L[l] = (float)total;
}
