/* The rest pose of a block: loading a tile's rest blades into the block layout (root frame,
 * rest segments in parallel-transported frames with their two quotients, widths). The segments
 * are stored as 16-bit integers in units of the blade's longest segment / 32000, each one aimed
 * from the knot the solver rebuilds before it, so rounding does not accumulate along the blade:
 * the rebuilt rest pose stays within about a 20,000th of the longest segment of the given knots
 * (1 µm for 2 cm segments, measured with float coordinates up to 10 m from the origin). */
#include "sim/sim_internal.h"
#include "core/tmath.h"

#include <math.h>

#define W SIM_W

/* Segment vectors are stored in units of (longest segment) / SIM_D_UNITS. */
#define SIM_D_UNITS 32000.0

void tsk_sim_block_load_lane(int32_t K, float* block, int lane, const float* knots,
                             const float* widths, const float* side) {
    char* base = (char*)block;
    float* P = block + SIM_OFF_P(K);
    int16_t* D = (int16_t*)(base + SIM_BOFF_D(K));
    float* Q = (float*)(base + SIM_BOFF_Q(K));
    uint8_t* WD = (uint8_t*)(base + SIM_BOFF_WD(K));
    float* LF = (float*)(base + SIM_BOFF_LANE(K));
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
    float gt[3] = {(float)t[0], (float)t[1], (float)t[2]};
    float gs[3] = {(float)s[0], (float)s[1], (float)s[2]};
    float gn[3];
    sim_cross3(gt, gs, gn); /* as the kernel's cross3 */
    for (int c = 0; c < 3; ++c) {
        LF[(SIM_LANE_T0 + c) * W + l] = gt[c];
        LF[(SIM_LANE_S0 + c) * W + l] = gs[c];
        P[c * W + l] = knots[c];
    }
    /* the unit of the stored segments */
    double longest = 0;
    for (int k = 1; k < K; ++k) {
        const float* a = knots + 3 * (k - 1);
        const float* b = knots + 3 * k;
        double d[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
        double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        longest = longest > len ? longest : len;
    }
    const float ds = (float)(longest / SIM_D_UNITS);
    /* each segment aimed from the knot the solver rebuilds, in the frame it rebuilds */
    float rp[3] = {knots[0], knots[1], knots[2]};
    float total = 0.0f;
    for (int k = 1; k < K; ++k) {
        const float* x = knots + 3 * k;
        const double aim[3] = {(double)x[0] - rp[0], (double)x[1] - rp[1], (double)x[2] - rp[2]};
        const double loc[3] = {aim[0] * gt[0] + aim[1] * gt[1] + aim[2] * gt[2],
                               aim[0] * gs[0] + aim[1] * gs[1] + aim[2] * gs[2],
                               aim[0] * gn[0] + aim[1] * gn[1] + aim[2] * gn[2]};
        int q[3], big = 0;
        for (int c = 0; c < 3; ++c) {
            double v = nearbyint(loc[c] / ds);
            v = v > 32767 ? 32767 : v < -32767 ? -32767 : v;
            q[c] = (int)v;
            if (fabs(loc[c]) > fabs(loc[big])) big = c;
        }
        if (q[0] == 0 && q[1] == 0 && q[2] == 0) q[big] = loc[big] < 0 ? -1 : 1; /* never zero */
        float d[3];
        for (int c = 0; c < 3; ++c) {
            D[((size_t)(k - 1) * 3 + c) * W + l] = (int16_t)q[c];
            d[c] = (float)q[c] * ds;
        }
        float il, side_c;
        sim_rest_quotients(d, &il, &side_c);
        Q[(size_t)(k - 1) * 2 * W + l] = il;
        Q[((size_t)(k - 1) * 2 + 1) * W + l] = side_c;
        const float len = sim_rest_segment(d, il, side_c, gt, gs, gn);
        for (int c = 0; c < 3; ++c) rp[c] = tsk_fmaf(len, gt[c], rp[c]); /* as the kernel's madd3 */
        total += len;
    }
    /* widths (for wind drag only) in 255ths of the widest knot */
    float wmax = 0.0f;
    for (int k = 1; k < K; ++k) wmax = wmax > widths[k] ? wmax : widths[k];
    const float ws = wmax / 255.0f;
    for (int k = 1; k < K; ++k) {
        double u = ws > 0.0f ? nearbyint(widths[k] / ws) : 0.0;
        WD[(size_t)(k - 1) * W + l] = (uint8_t)(u > 255 ? 255 : u < 0 ? 0 : u);
    }
    LF[SIM_LANE_DS * W + l] = ds;
    LF[SIM_LANE_WS * W + l] = ws;
    LF[SIM_LANE_LT * W + l] = total;
}
