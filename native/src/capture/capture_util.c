/* Small helpers of the capture module: growable arrays on tsk_alloc and 1-D Gaussian
 * smoothing of contour and skeleton signals (circular for closed contours, renormalised
 * at the ends for open polylines). */
#include <math.h>
#include <string.h>

#include "capture_internal.h"
#include "core/tmath.h"

int tsk_cap_grow(void** p, size_t* cap, size_t need, size_t elem, const char* what) {
    if (need <= *cap) return 1;
    size_t n = *cap * 2 > need ? *cap * 2 : need;
    if (n < 16) n = 16;
    void* q = tsk_calloc(n, elem, what);
    if (q == NULL) return 0;
    if (*p != NULL && *cap > 0) memcpy(q, *p, *cap * elem);
    tsk_free(*p);
    *p = q;
    *cap = n;
    return 1;
}

#define SMOOTH_MAX_RADIUS 64

static int make_kernel(float sigma, float* k) {
    int r = (int)ceilf(3.0f * sigma);
    if (r > SMOOTH_MAX_RADIUS) r = SMOOTH_MAX_RADIUS;
    double sum = 0.0;
    for (int i = -r; i <= r; ++i) {
        k[i + r] = tsk_expf(-0.5f * (float)(i * i) / (sigma * sigma));
        sum += k[i + r];
    }
    for (int i = 0; i <= 2 * r; ++i) k[i] = (float)(k[i] / sum);
    return r;
}

void tsk_smooth_circular(const float* in, float* out, int n, float sigma) {
    if (n <= 0) return;
    /* below 1e-3 px the kernel is the identity (neighbour weights exp(-5e5) = 0), and
     * sigma*sigma would underflow to 0 and make 0/0 = NaN weights */
    if (!(sigma >= 1e-3f)) {
        memcpy(out, in, (size_t)n * sizeof(float));
        return;
    }
    float k[2 * SMOOTH_MAX_RADIUS + 1];
    const int r = make_kernel(sigma, k);
    for (int i = 0; i < n; ++i) {
        float acc = 0.0f;
        for (int j = -r; j <= r; ++j) {
            int t = (i + j) % n;
            if (t < 0) t += n;
            acc += k[j + r] * in[t];
        }
        out[i] = acc;
    }
}

void tsk_smooth_open(const float* in, float* out, int n, float sigma) {
    if (n <= 0) return;
    /* below 1e-3 px the kernel is the identity (neighbour weights exp(-5e5) = 0), and
     * sigma*sigma would underflow to 0 and make 0/0 = NaN weights */
    if (!(sigma >= 1e-3f)) {
        memcpy(out, in, (size_t)n * sizeof(float));
        return;
    }
    float k[2 * SMOOTH_MAX_RADIUS + 1];
    const int r = make_kernel(sigma, k);
    for (int i = 0; i < n; ++i) {
        float acc = 0.0f, wsum = 0.0f;
        for (int j = -r; j <= r; ++j) {
            int t = i + j;
            if (t < 0 || t >= n) continue;
            acc += k[j + r] * in[t];
            wsum += k[j + r];
        }
        out[i] = acc / wsum;
    }
}
