/* Whole blades from a cluster (issue 31): the partition of seed 000 §4.2 cuts each blade at
 * the crotch between it and its neighbours, and the symmetric matching of §4.3 ends there.
 * Below that cut the blade runs on through the part it shares with its neighbours, down to
 * the base where it attaches; above its last matched pair it runs out to a tip that may be
 * narrower than the contour's smoothing. These functions continue a matched skeleton both
 * ways: through the shared part by the blade's own heading and heading change (a least-
 * squares line through the tangent angle against arc length over the root-most 75 % of the
 * matched skeleton) and its own width trend, kept inside the cleaned mask, until the mask
 * ends (the base); and at the tip along its last direction to the last mask pixel. */
#include <math.h>

#include "capture_internal.h"
#include "core/tmath.h"

#define TWO_PI 6.283185307179586
#define FIT_MIN 6 /* fewest samples a fit uses */
#define FIT_MAX 512 /* most samples a fit uses */
#define MISS_MAX 2 /* consecutive steps outside the mask that end a walk */
#define TIP_GAP_MAX 6 /* half-pixel steps off the mask a tip walk crosses */
#define HEADING_SHARE 0.75f /* the root-most share of the matched skeleton the heading fits */
#define SKIP_WIDTHS 0.5 /* blade widths next to the cut the heading fit leaves out */
#define CURVE_TURN_MAX 0.6 /* radians the fitted heading change may add over the walk */

static int mask_at(const tsk_capture* cap, float x, float y) {
    const int u = (int)lroundf(x), v = (int)lroundf(y);
    if (u < 0 || v < 0 || u >= cap->width || v >= cap->height) return 0;
    return cap->mask[(size_t)v * (size_t)cap->width + (size_t)u] != 0;
}

/* least squares y = c0 + c1 x + c2 x^2 over n samples; x scaled by sc for conditioning.
 * Returns 0 if the system is singular. */
static int fit_quad(const double* x, const double* y, int n, double sc, double c[3]) {
    double m[3][4] = {{0}};
    for (int i = 0; i < n; ++i) {
        const double u = x[i] / sc, p[3] = {1.0, u, u * u};
        for (int r = 0; r < 3; ++r) {
            for (int q = 0; q < 3; ++q) m[r][q] += p[r] * p[q];
            m[r][3] += p[r] * y[i];
        }
    }
    for (int col = 0; col < 3; ++col) { /* Gauss-Jordan with partial pivoting */
        int piv = col;
        for (int r = col + 1; r < 3; ++r)
            if (fabs(m[r][col]) > fabs(m[piv][col])) piv = r;
        if (fabs(m[piv][col]) < 1e-12) return 0;
        for (int q = 0; q < 4; ++q) {
            const double tmp = m[col][q];
            m[col][q] = m[piv][q];
            m[piv][q] = tmp;
        }
        for (int r = 0; r < 3; ++r) {
            if (r == col) continue;
            const double f = m[r][col] / m[col][col];
            for (int q = col; q < 4; ++q) m[r][q] -= f * m[col][q];
        }
    }
    c[0] = m[0][3] / m[0][0];
    c[1] = m[1][3] / m[1][1] / sc;
    c[2] = m[2][3] / m[2][2] / (sc * sc);
    return 1;
}

/* least squares y = a + b x over n samples (b = 0 when x does not vary) */
static void fit_line(const double* x, const double* y, int n, double* a, double* b) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (int i = 0; i < n; ++i) {
        sx += x[i];
        sy += y[i];
        sxx += x[i] * x[i];
        sxy += x[i] * y[i];
    }
    const double den = n * sxx - sx * sx;
    *b = fabs(den) > 1e-12 ? (n * sxy - sx * sy) / den : 0.0;
    *a = (sy - *b * sx) / n;
}

int tsk_capture_extend_root(const tsk_capture* cap, const tsk_capture_def* def, const float* x,
                            const float* y, const float* w, int count, int max_out, float* ox,
                            float* oy, float* ow) {
    if (count < FIT_MIN || max_out <= 0) return 0;
    /* the walk is at most twice as long as the matched part (a blade two thirds hidden) */
    double matched_len = 0.0;
    for (int i = 1; i < count; ++i)
        matched_len += hypot((double)(x[i] - x[i - 1]), (double)(y[i] - y[i - 1]));
    if ((double)max_out > 2.0 * matched_len) max_out = (int)(2.0 * matched_len);
    const int e = count - 1;
    /* arc from the root end back towards the tip */
    double arc_back[FIT_MAX], ang[FIT_MAX], wid[FIT_MAX];
    /* heading window: the root-most 75 % of the matched skeleton (FIT_MIN .. FIT_MAX
     * samples) without the half blade width next to the cut, where a neighbour still pulls
     * the pairs' midpoints aside; a longer window steadies the fitted heading change */
    int m = (int)(HEADING_SHARE * (float)count);
    if (m < FIT_MIN) m = FIT_MIN;
    if (m > FIT_MAX) m = FIT_MAX;
    const int lag = 3; /* tangent over +-3 samples of the smoothed skeleton */
    float hx = x[e] - x[e - lag > 0 ? e - lag : 0], hy = y[e] - y[e - lag > 0 ? e - lag : 0];
    const double ref = tsk_atan2((double)hy, (double)hx);
    double acc = 0.0;
    int n = 0;
    double wmean = 0.0;
    for (int k = 0; k < m; ++k) wmean += w[e - k];
    wmean /= m;
    const int skip = (int)(SKIP_WIDTHS * wmean);
    for (int k = 0; k < m; ++k) {
        const int i = e - k;
        if (k > 0) acc += hypot((double)(x[i + 1] - x[i]), (double)(y[i + 1] - y[i]));
        const int i0 = i - lag < 0 ? 0 : i - lag, i1 = i + lag > e ? e : i + lag;
        if (i1 - i0 < 2 || (k < skip && m - skip >= FIT_MIN)) continue;
        double a = tsk_atan2((double)(y[i1] - y[i0]), (double)(x[i1] - x[i0])) - ref;
        a -= TWO_PI * floor((a + 0.5 * TWO_PI) / TWO_PI); /* relative to ref, in [-pi, pi) */
        arc_back[n] = -acc;
        ang[n] = a;
        wid[n] = w[i];
        ++n;
    }
    if (n < FIT_MIN) return 0;
    double a0, kappa, w0, wslope;
    fit_line(arc_back, ang, n, &a0, &kappa);
    fit_line(arc_back, wid, n, &w0, &wslope);
    /* Width: a blade's width changes slowly but not linearly (a lanceolate blade narrows
     * again towards its base), so its trend is a parabola in arc length over the matched
     * skeleton without its tip-most 30 %, at most FIT_MAX samples of it. */
    double wc[3] = {w0, wslope, 0.0};
    {
        int mw = (int)(0.7f * (float)count);
        if (mw < FIT_MIN) mw = FIT_MIN;
        const int stride = (mw + FIT_MAX - 1) / FIT_MAX;
        double wacc = 0.0;
        int nw = 0;
        for (int k = 0; k < mw; ++k) {
            const int i = e - k;
            if (k > 0) wacc += hypot((double)(x[i + 1] - x[i]), (double)(y[i + 1] - y[i]));
            if (k % stride) continue;
            arc_back[nw] = -wacc;
            wid[nw] = w[i];
            ++nw;
        }
        double q[3];
        if (nw >= 2 * FIT_MIN && wacc > 1.0 && fit_quad(arc_back, wid, nw, wacc, q)) {
            wc[0] = q[0];
            wc[1] = q[1];
            wc[2] = q[2];
            w0 = q[0];
        }
    }
    /* the walk: heading a0 + kappa * s from the root end, the path kept inside the mask by
     * at most one pixel of sideways shift per step and half a width in all */
    const float wend = (float)w0 > 1.0f ? (float)w0 : 1.0f;
    float px = x[e], py = y[e];
    float drift = 0.0f;
    int out = 0, miss = 0, last_in = 0;
    float last_dx = 0.0f, last_dy = 0.0f;
    const int to_centre = def->root == TSK_ROOT_CENTROID;
    float centre_best = tsk_hypotf(px - cap->ring.cx, py - cap->ring.cy);
    for (int step = 1; step <= max_out; ++step) {
        const double s = (double)step;
        double turn = kappa * s;
        if (turn > CURVE_TURN_MAX) turn = CURVE_TURN_MAX;
        if (turn < -CURVE_TURN_MAX) turn = -CURVE_TURN_MAX;
        const double h = ref + a0 + turn;
        const float dx = (float)tsk_cos(h), dy = (float)tsk_sin(h);
        px += dx;
        py += dy;
        int moved = 0;
        if (!mask_at(cap, px, py)) {
            /* slide sideways into the mask, within the drift budget */
            for (int side = -1; side <= 1 && !moved; side += 2) {
                const float nx = px - (float)side * dy, ny = py + (float)side * dx;
                if (fabsf(drift + (float)side) <= 0.5f * wend && mask_at(cap, nx, ny)) {
                    px = nx;
                    py = ny;
                    drift += (float)side;
                    moved = 1;
                }
            }
            if (!moved) {
                if (++miss > MISS_MAX) break;
            } else {
                miss = 0;
            }
        } else {
            miss = 0;
        }
        float wk = (float)(wc[0] + (wc[1] + wc[2] * s) * s);
        if (wk < 0.3f * wend) wk = 0.3f * wend;
        if (wk > 1.5f * wend) wk = 1.5f * wend;
        if (wk < 1.0f) wk = 1.0f;
        if (to_centre) { /* blades radiate from the centroid: stop once past it */
            const float dc = tsk_hypotf(px - cap->ring.cx, py - cap->ring.cy);
            if (dc > centre_best + 1.0f) break;
            if (dc < centre_best) centre_best = dc;
        }
        ox[out] = px;
        oy[out] = py;
        ow[out] = wk;
        ++out;
        /* the walk ends at the last step that met the mask straight ahead: steps that only
         * slid along the mask's edge at the end are the base's edge, not the blade */
        if (miss == 0 && !moved) {
            last_in = out;
            last_dx = dx;
            last_dy = dy;
        }
    }
    /* end half a pixel past the last pixel centre in the mask: at the mask's edge */
    out = last_in;
    if (out > 0 && out < max_out) {
        ox[out] = ox[out - 1] + 0.5f * last_dx;
        oy[out] = oy[out - 1] + 0.5f * last_dy;
        ow[out] = ow[out - 1];
        ++out;
    }
    return out;
}

int tsk_capture_extend_tip(const tsk_capture* cap, const float* x, const float* y, const float* w,
                           int count, int max_out, float* ox, float* oy, float* ow) {
    if (count < 4 || max_out <= 0) return 0;
    const int back = count > 6 ? 6 : count - 1;
    float dx = x[0] - x[back], dy = y[0] - y[back];
    const float dl = tsk_hypotf(dx, dy);
    if (dl < 1e-6f) return 0;
    dx /= dl;
    dy /= dl;
    float px = x[0], py = y[0];
    int out = 0, last_in = 0, miss = 0;
    const float step = 0.5f;
    for (int k = 1; k <= max_out - 1; ++k) {
        float nx = px + step * dx, ny = py + step * dy;
        int found = mask_at(cap, nx, ny);
        for (int side = -1; side <= 1 && !found; side += 2) {
            /* a bending tip: one pixel sideways */
            const float sx = nx - (float)side * dy, sy = ny + (float)side * dx;
            if (mask_at(cap, sx, sy)) {
                nx = 0.5f * (nx + sx); /* half way: the tip turns, not jumps */
                ny = 0.5f * (ny + sy);
                found = 1;
            }
        }
        /* a tip narrower than a pixel covers only some pixel centres: gaps of up to
         * TIP_GAP_MAX steps are crossed if the mask goes on after them */
        if (!found && ++miss > TIP_GAP_MAX) break;
        if (found) miss = 0;
        px = nx;
        py = ny;
        ox[out] = px;
        oy[out] = py;
        ow[out] = w[0];
        ++out;
        if (found) last_in = out;
    }
    out = last_in;
    if (out < max_out) { /* the last sample lies on average a quarter pixel past the last
                          * pixel centre: a quarter more reaches that pixel's edge */
        const float bx = out > 0 ? ox[out - 1] : x[0], by = out > 0 ? oy[out - 1] : y[0];
        ox[out] = bx + 0.25f * dx;
        oy[out] = by + 0.25f * dy;
        ow[out] = 0.0f;
        ++out;
    }
    /* widths taper to zero over the extension */
    for (int k = 0; k < out; ++k) ow[k] = w[0] * (float)(out - 1 - k) / (float)(out > 1 ? out : 1);
    return out;
}
