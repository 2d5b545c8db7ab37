/* Single-blade partition (seed 000 §4.2, Fig. 4): a blob's contour is smoothed and
 * resampled at 1 pixel, its distance to the cluster centre is measured, and blades are
 * the significant peaks of that distance (tips); the minima between neighbouring tips are
 * the splits between blades. Significance is topographic prominence, so that wiggles of
 * a noisy contour do not create false splits. */
#include <math.h>
#include <string.h>

#include "capture_internal.h"
#include "core/tmath.h"

#define EDGE_PX 1.0f /* a sample within this distance of the border lies on it */

static int ring_alloc(tsk_capture* cap, int m) {
    size_t old = cap->ring_cap;
    size_t c1 = old, c2 = old, c3 = old, c4 = old;
    if ((size_t)m <= old) return 1;
    if (!tsk_cap_grow((void**)&cap->ring.x, &c1, (size_t)m, sizeof(float), "contour") ||
        !tsk_cap_grow((void**)&cap->ring.y, &c2, (size_t)m, sizeof(float), "contour") ||
        !tsk_cap_grow((void**)&cap->ring.d, &c3, (size_t)m, sizeof(float), "contour") ||
        !tsk_cap_grow((void**)&cap->ring.edge, &c4, (size_t)m, 1, "contour"))
        return 0;
    /* all four grew with the same rule from the same old capacity */
    cap->ring_cap = c1;
    return 1;
}

tsk_status tsk_capture_make_ring(tsk_capture* cap, const tsk_capture_def* def, const int32_t* xy,
                                 int n) {
    if (!tsk_cap_grow((void**)&cap->tmp, &cap->tmp_cap, 4 * (size_t)n + 8, sizeof(float),
                      "contour"))
        return TSK_ERR_MEMORY;
    float* rx = cap->tmp;
    float* ry = rx + n;
    float* sx = ry + n;
    float* sy = sx + n;
    for (int i = 0; i < n; ++i) {
        rx[i] = (float)xy[2 * i];
        ry[i] = (float)xy[2 * i + 1];
    }
    tsk_smooth_circular(rx, sx, n, def->contour_smooth);
    tsk_smooth_circular(ry, sy, n, def->contour_smooth);
    double perimeter = 0.0;
    for (int i = 0; i < n; ++i) {
        int j = (i + 1) % n;
        perimeter += hypot((double)(sx[j] - sx[i]), (double)(sy[j] - sy[i]));
    }
    int m = (int)lround(perimeter);
    if (m < 8) m = 8;
    if (!ring_alloc(cap, m)) return TSK_ERR_MEMORY;
    /* resample the closed polyline at m equal arc steps */
    const double step = perimeter / m;
    double seg_start = 0.0;
    int seg = 0;
    double seg_len = hypot((double)(sx[1 % n] - sx[0]), (double)(sy[1 % n] - sy[0]));
    for (int i = 0; i < m; ++i) {
        double t = i * step;
        while (seg_start + seg_len < t && seg < n - 1) {
            seg_start += seg_len;
            ++seg;
            int j = (seg + 1) % n;
            seg_len = hypot((double)(sx[j] - sx[seg]), (double)(sy[j] - sy[seg]));
        }
        int j = (seg + 1) % n;
        double f = seg_len > 1e-9 ? (t - seg_start) / seg_len : 0.0;
        if (f < 0.0) f = 0.0;
        if (f > 1.0) f = 1.0;
        float x = (float)(sx[seg] + f * (sx[j] - sx[seg]));
        float y = (float)(sy[seg] + f * (sy[j] - sy[seg]));
        cap->ring.x[i] = x;
        cap->ring.y[i] = y;
        cap->ring.edge[i] =
            (uint8_t)(x <= EDGE_PX || y <= EDGE_PX || x >= (float)(cap->width - 1) - EDGE_PX ||
                      y >= (float)(cap->height - 1) - EDGE_PX);
    }
    cap->ring.n = m;
    /* the centre (seed 000 §4.2): the blob's centroid, or its base */
    float cx = 0.0f, cy = 0.0f;
    if (def->root == TSK_ROOT_CENTROID) {
        double a = 0.0, gx = 0.0, gy = 0.0;
        for (int i = 0; i < m; ++i) {
            int j = (i + 1) % m;
            double c =
                (double)cap->ring.x[i] * cap->ring.y[j] - (double)cap->ring.x[j] * cap->ring.y[i];
            a += c;
            gx += (cap->ring.x[i] + cap->ring.x[j]) * c;
            gy += (cap->ring.y[i] + cap->ring.y[j]) * c;
        }
        if (fabs(a) > 1e-9) {
            cx = (float)(gx / (3.0 * a));
            cy = (float)(gy / (3.0 * a));
        } else {
            cx = cap->ring.x[0];
            cy = cap->ring.y[0];
        }
    } else {
        /* base: mean x of the lowest 10 % of the blob, at its lowest row */
        float ymin = cap->ring.y[0], ymax = cap->ring.y[0];
        for (int i = 1; i < m; ++i) {
            if (cap->ring.y[i] < ymin) ymin = cap->ring.y[i];
            if (cap->ring.y[i] > ymax) ymax = cap->ring.y[i];
        }
        const float cut = ymax - 0.1f * (ymax - ymin) - 1.0f;
        double sum = 0.0;
        int cnt = 0;
        for (int i = 0; i < m; ++i)
            if (cap->ring.y[i] >= cut) {
                sum += cap->ring.x[i];
                ++cnt;
            }
        cx = (float)(sum / (cnt > 0 ? cnt : 1));
        cy = ymax;
    }
    cap->ring.cx = cx;
    cap->ring.cy = cy;
    float* raw = cap->tmp; /* the raw contour is no longer needed */
    if ((size_t)m > cap->tmp_cap &&
        !tsk_cap_grow((void**)&cap->tmp, &cap->tmp_cap, (size_t)m, sizeof(float), "contour"))
        return TSK_ERR_MEMORY;
    raw = cap->tmp;
    for (int i = 0; i < m; ++i) raw[i] = tsk_hypotf(cap->ring.x[i] - cx, cap->ring.y[i] - cy);
    tsk_smooth_circular(raw, cap->ring.d, m, def->split_smooth);
    return TSK_OK;
}

int tsk_capture_partition(tsk_capture* cap, const tsk_capture_def* def) {
    const int n = cap->ring.n;
    const float* d = cap->ring.d;
    int kept = 0;
    for (int i = 0; i < n; ++i) {
        const float di = d[i];
        if (!(di > d[(i + n - 1) % n] && di >= d[(i + 1) % n])) continue;
        /* topographic prominence on the closed contour */
        float min_l = di, min_r = di;
        int steps = 1;
        for (int j = (i + n - 1) % n; steps < n; j = (j + n - 1) % n, ++steps) {
            if (d[j] > di) break;
            if (d[j] < min_l) min_l = d[j];
        }
        steps = 1;
        for (int j = (i + 1) % n; steps < n; j = (j + 1) % n, ++steps) {
            if (d[j] > di) break;
            if (d[j] < min_r) min_r = d[j];
        }
        const float prominence = di - (min_l > min_r ? min_l : min_r);
        if (prominence < def->split_prominence) continue;
        if (!tsk_cap_grow((void**)&cap->peaks, &cap->peaks_cap, (size_t)kept + 1, sizeof(int),
                          "peaks"))
            return -1;
        cap->peaks[kept++] = i;
    }
    if (kept == 0) {
        int best = 0;
        for (int i = 1; i < n; ++i)
            if (d[i] > d[best]) best = i;
        if (!tsk_cap_grow((void**)&cap->peaks, &cap->peaks_cap, 1, sizeof(int), "peaks")) return -1;
        cap->peaks[kept++] = best;
    }
    if (!tsk_cap_grow((void**)&cap->spans, &cap->spans_cap, (size_t)kept, sizeof(tsk_blade_span),
                      "blades"))
        return -1;
    /* split after peak a: the minimum of d strictly between peak a and the next peak */
    for (int a = 0; a < kept; ++a) {
        const int p = cap->peaks[a];
        const int q = cap->peaks[(a + 1) % kept];
        int len = (q - p + n) % n;
        if (len == 0) len = n;
        int best = (p + 1) % n;
        for (int s = 1; s < len; ++s) {
            int j = (p + s) % n;
            if (d[j] < d[best]) best = j;
        }
        cap->spans[a].tip = p;
        cap->spans[a].hi = best;
        cap->spans[(a + 1) % kept].lo = best;
    }
    return kept;
}
