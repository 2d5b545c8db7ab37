/* Skeleton and expansion width of one blade (seed 000 §4.3, Fig. 5): the two sides of the
 * blade's contour are walked from the tip towards the root and matched as symmetric pairs;
 * each pair gives a skeleton point (its midpoint) and the full width (its distance). The
 * skeleton is smoothed, resampled to even knots ordered root -> tip, each knot takes the
 * median depth around it and is back-projected to the camera frame in metres. */
#include <math.h>
#include <string.h>

#include "capture_internal.h"
#include "core/tmath.h"

#define MATCH_WINDOW 4 /* the matched point may advance up to this many samples per step */
#define DEPTH_MAX_WINDOW 5
#define TIP_EXT_MAX 64 /* half-pixel steps the tip may run on beyond the contour's tip */

static float median_depth(const tsk_capture* cap, float u, float v, int r) {
    const int w = cap->width, h = cap->height;
    const int cu = (int)lroundf(u), cv = (int)lroundf(v);
    float vals[(2 * DEPTH_MAX_WINDOW + 1) * (2 * DEPTH_MAX_WINDOW + 1)];
    int n = 0;
    for (int y = cv - r; y <= cv + r; ++y) {
        if (y < 0 || y >= h) continue;
        for (int x = cu - r; x <= cu + r; ++x) {
            if (x < 0 || x >= w) continue;
            float d = cap->depth[(size_t)y * (size_t)w + (size_t)x];
            if (d > 0.0f && d >= cap->near_m && d <= cap->far_m) {
                /* insertion sort: windows are small */
                int k = n++;
                while (k > 0 && vals[k - 1] > d) {
                    vals[k] = vals[k - 1];
                    --k;
                }
                vals[k] = d;
            }
        }
    }
    if (n == 0) return NAN;
    return n % 2 ? vals[n / 2] : 0.5f * (vals[n / 2 - 1] + vals[n / 2]);
}

static float interp(const float* a, int n, float t) {
    if (t <= 0.0f) return a[0];
    if (t >= (float)(n - 1)) return a[n - 1];
    int i = (int)t;
    float f = t - (float)i;
    return a[i] + f * (a[i + 1] - a[i]);
}

tsk_status tsk_capture_skeleton(tsk_capture* cap, const tsk_capture_def* def,
                                const tsk_blade_span* span) {
    const tsk_ring* ring = &cap->ring;
    const int n = ring->n;
    const int tip = span->tip;
    const int nl = (tip - span->lo + n) % n;
    const int nr = (span->hi - tip + n) % n;
    if (nl < 2 || nr < 2) return TSK_OK;
    const int pairs_max = nl + 1;
    /* the skeleton continues beyond its matched pairs: at most the image's width + height
     * (1 px steps) below them and TIP_EXT_MAX half-pixel steps above them */
    const int root_max = cap->width + cap->height;
    const int slots = pairs_max + root_max + TIP_EXT_MAX;
    /* scratch: 3 arrays of pairs (x, y, w) + 3 smoothed + arc */
    if (!tsk_cap_grow((void**)&cap->skel, &cap->skel_cap, 7 * (size_t)slots + 8, sizeof(float),
                      "skeleton"))
        return TSK_ERR_MEMORY;
    float* px = cap->skel;
    float* py = px + slots;
    float* pw = py + slots;
    float* qx = pw + slots;
    float* qy = qx + slots;
    float* qw = qy + slots;
    float* arc = qw + slots;

    /* symmetric matching (seed 000 Fig. 5b): left side i walks back from the tip, the
     * right side follows with the point nearest to it, never going back */
    int count = 0, j = 0;
    if (!tsk_cap_grow((void**)&cap->pair_j, &cap->pair_j_cap, (size_t)pairs_max, sizeof(int),
                      "skeleton"))
        return TSK_ERR_MEMORY;
    int* pj = cap->pair_j;
    for (int i = 0; i <= nl; ++i) {
        const int li = (tip - i + n) % n;
        const float lx = ring->x[li], ly = ring->y[li];
        int best = j;
        float bd = 0.0f;
        for (int jj = j; jj <= j + MATCH_WINDOW && jj <= nr; ++jj) {
            const int rj = (tip + jj) % n;
            const float dx = ring->x[rj] - lx, dy = ring->y[rj] - ly;
            const float dd = dx * dx + dy * dy;
            if (jj == j || dd < bd) {
                bd = dd;
                best = jj;
            }
        }
        j = best;
        const int rj = (tip + j) % n;
        px[count] = 0.5f * (lx + ring->x[rj]);
        py[count] = 0.5f * (ly + ring->y[rj]);
        /* boundary samples lie on pixel centres, half a pixel inside each true edge */
        pw[count] = sqrtf(bd) + 1.0f;
        pj[count] = j;
        ++count;
        if (j >= nr) break; /* the other side ends here: the blade merges below */
    }
    /* Near a split the side that ends there turns onto the neighbouring blade and the
     * pairs widen: drop pairs within about one blade width (median) of either side's end. */
    if (count >= 8) {
        for (int i = 0; i < count; ++i) qw[i] = pw[i];
        /* median by partial selection sort of a copy (pairs are few hundred at most) */
        float* cw = qx;
        memcpy(cw, pw, (size_t)count * sizeof(float));
        const int half = count / 2;
        for (int a = 0; a <= half; ++a) {
            int m = a;
            for (int b = a + 1; b < count; ++b)
                if (cw[b] < cw[m]) m = b;
            const float t = cw[a];
            cw[a] = cw[m];
            cw[m] = t;
        }
        const int trim = (int)lroundf(def->root_trim * cw[half]);
        int keep = count;
        while (keep > 2 && (keep - 1 > nl - trim || pj[keep - 1] > nr - trim)) --keep;
        count = keep;
    }
    if (count < 2) return TSK_OK;
    tsk_smooth_open(px, qx, count, 2.0f);
    tsk_smooth_open(py, qy, count, 2.0f);
    memcpy(qw, pw, (size_t)count * sizeof(float));
    /* the blade beyond its matched pairs (issue 31): through the part it shares with its
     * neighbours down to the base, and out to the last pixel of its tip. The raw pairs are
     * no longer needed: px, py, pw hold the root part. */
    const int matched = count;
    const int rn = tsk_capture_extend_root(cap, def, qx, qy, qw, count, root_max, px, py, pw);
    float tx[TIP_EXT_MAX], ty[TIP_EXT_MAX], tw[TIP_EXT_MAX];
    const int tn = tsk_capture_extend_tip(cap, qx, qy, qw, count, TIP_EXT_MAX, tx, ty, tw);
    memmove(qx + tn, qx, (size_t)count * sizeof(float));
    memmove(qy + tn, qy, (size_t)count * sizeof(float));
    memmove(qw + tn, qw, (size_t)count * sizeof(float));
    for (int k = 0; k < tn; ++k) {
        qx[tn - 1 - k] = tx[k];
        qy[tn - 1 - k] = ty[k];
        qw[tn - 1 - k] = tw[k];
    }
    memcpy(qx + tn + count, px, (size_t)rn * sizeof(float));
    memcpy(qy + tn + count, py, (size_t)rn * sizeof(float));
    memcpy(qw + tn + count, pw, (size_t)rn * sizeof(float));
    count = tn + count + rn;
    arc[0] = 0.0f;
    for (int i = 1; i < count; ++i)
        arc[i] = arc[i - 1] + tsk_hypotf(qx[i] - qx[i - 1], qy[i] - qy[i - 1]);
    const float total = arc[count - 1];
    /* arc from the tip where the matched pairs end and the shared part begins */
    const float matched_end = arc[tn + matched - 1];
    const float matched_start = arc[tn];
    int knots = (int)lroundf(total / def->knot_spacing) + 1;
    if (knots < 2) knots = 2;
    if (knots < def->min_knots) return TSK_OK;

    /* resample at even arc length, root (far end from the tip) first */
    if (!tsk_cap_grow((void**)&cap->knots, &cap->knots_cap, 6 * (size_t)knots, sizeof(float),
                      "knots"))
        return TSK_ERR_MEMORY;
    float* ku = cap->knots;
    float* kv = ku + knots;
    float* kw = kv + knots;
    float* kz = kw + knots;
    float* ta = kz + knots;
    float* tb = ta + knots;
    int seg = 0;
    for (int k = 0; k < knots; ++k) {
        const float s = total * (1.0f - (float)k / (float)(knots - 1)); /* arc from tip */
        while (seg > 0 && arc[seg] > s) --seg;
        while (seg < count - 2 && arc[seg + 1] < s) ++seg;
        float t = (float)seg;
        const float len = arc[seg + 1 < count ? seg + 1 : seg] - arc[seg];
        if (len > 1e-6f) t += (s - arc[seg]) / len;
        ku[k] = interp(qx, count, t);
        kv[k] = interp(qy, count, t);
        kw[k] = interp(qw, count, t);
    }
    /* widths smoothed along the skeleton (seed 000 §3: "expansion widths are smoothed") */
    memcpy(ta, kw, (size_t)knots * sizeof(float));
    tsk_smooth_open(ta, kw, knots, def->width_smooth);

    /* depth of each knot: median of in-band depths around it; gaps filled from the
     * nearest knot that has one */
    int have = 0;
    for (int k = 0; k < knots; ++k) {
        float z = median_depth(cap, ku[k], kv[k], def->depth_window);
        if (isnan(z)) z = median_depth(cap, ku[k], kv[k], DEPTH_MAX_WINDOW);
        kz[k] = z;
        if (!isnan(z)) ++have;
    }
    if (have == 0) return TSK_OK;
    for (int k = 0; k < knots; ++k) {
        if (!isnan(kz[k])) continue;
        for (int o = 1; o < knots; ++o) {
            if (k - o >= 0 && !isnan(kz[k - o])) {
                tb[k] = kz[k - o];
                break;
            }
            if (k + o < knots && !isnan(kz[k + o])) {
                tb[k] = kz[k + o];
                break;
            }
        }
    }
    for (int k = 0; k < knots; ++k)
        if (isnan(kz[k])) kz[k] = tb[k];
    /* Below the matched pairs the pixels belong to whichever blade is in front: the blade
     * keeps its own depth, the line through its matched knots' depths against arc length
     * over the lower half of them, continued. */
    if (rn > 0) {
        double sx = 0, sy = 0, sxx = 0, sxy = 0;
        int nfit = 0;
        const float lo = 0.5f * (matched_start + matched_end);
        for (int k = 0; k < knots; ++k) {
            const float s = total * (1.0f - (float)k / (float)(knots - 1));
            if (s < lo || s > matched_end) continue;
            sx += s;
            sy += kz[k];
            sxx += (double)s * s;
            sxy += (double)s * kz[k];
            ++nfit;
        }
        if (nfit >= 3) {
            const double den = nfit * sxx - sx * sx;
            const double slope = fabs(den) > 1e-9 ? (nfit * sxy - sx * sy) / den : 0.0;
            const double icpt = (sy - slope * sx) / nfit;
            for (int k = 0; k < knots; ++k) {
                const float s = total * (1.0f - (float)k / (float)(knots - 1));
                if (s <= matched_end) break;
                float z = (float)(icpt + slope * s);
                if (z < cap->near_m) z = cap->near_m;
                if (z > cap->far_m) z = cap->far_m;
                kz[k] = z;
            }
        }
    }
    memcpy(ta, kz, (size_t)knots * sizeof(float));
    tsk_smooth_open(ta, kz, knots, def->width_smooth);

    /* append the blade */
    const int b = cap->blade_count;
    if (b >= TSK_CAPTURE_MAX_BLADES) return TSK_OK;
    const int k0 = cap->knot_start[b];
    const size_t need = (size_t)k0 + (size_t)knots;
    if (!tsk_cap_grow((void**)&cap->knot_start, &cap->knot_start_cap, (size_t)b + 2, sizeof(int),
                      "blades") ||
        !tsk_cap_grow((void**)&cap->flags, &cap->flags_cap, (size_t)b + 1, sizeof(uint32_t),
                      "blades") ||
        !tsk_cap_grow((void**)&cap->poly_start, &cap->poly_start_cap, (size_t)b + 2, sizeof(int),
                      "blades") ||
        !tsk_cap_grow((void**)&cap->xyz, &cap->xyz_cap, 3 * need, sizeof(float), "knots") ||
        !tsk_cap_grow((void**)&cap->uv, &cap->uv_cap, 2 * need, sizeof(float), "knots") ||
        !tsk_cap_grow((void**)&cap->width_m, &cap->width_cap, need, sizeof(float), "knots"))
        return TSK_ERR_MEMORY;
    const tsk_intrinsics K = cap->K;
    const float fmean = sqrtf(K.fx * K.fy);
    for (int k = 0; k < knots; ++k) {
        const size_t o = (size_t)k0 + (size_t)k;
        const float z = kz[k];
        cap->xyz[3 * o] = (ku[k] - K.cx) * z / K.fx;
        cap->xyz[3 * o + 1] = (kv[k] - K.cy) * z / K.fy;
        cap->xyz[3 * o + 2] = z;
        cap->uv[2 * o] = ku[k];
        cap->uv[2 * o + 1] = kv[k];
        cap->width_m[o] = kw[k] * z / fmean;
    }
    /* flags */
    uint32_t flags = 0;
    for (int s = 0; s <= nl + nr; ++s) {
        const int r = (span->lo + s) % n;
        if (ring->edge[r]) flags |= TSK_BLADE_CUT_BY_BORDER;
    }
    for (int s = -3; s <= 3; ++s)
        if (ring->edge[(tip + s + n) % n]) flags |= TSK_BLADE_TIP_AT_BORDER;
    const int lmin = nl < nr ? nl : nr, lmax = nl < nr ? nr : nl;
    if (lmax > 2 * lmin + 20) flags |= TSK_BLADE_ASYMMETRIC;
    cap->flags[b] = flags;
    /* region polygon: the span's contour from lo through the tip to hi */
    const int p0 = cap->poly_start[b];
    const int pn = nl + nr + 1;
    if (!tsk_cap_grow((void**)&cap->poly_xy, &cap->poly_cap, 2 * ((size_t)p0 + (size_t)pn),
                      sizeof(float), "blade regions"))
        return TSK_ERR_MEMORY;
    for (int s = 0; s < pn; ++s) {
        const int r = (span->lo + s) % n;
        cap->poly_xy[2 * ((size_t)p0 + (size_t)s)] = ring->x[r];
        cap->poly_xy[2 * ((size_t)p0 + (size_t)s) + 1] = ring->y[r];
    }
    cap->poly_start[b + 1] = p0 + pn;
    cap->knot_start[b + 1] = k0 + knots;
    cap->blade_count = b + 1;
    return TSK_OK;
}
