/* Improved Perlin noise in 2D (K. Perlin, "Improving noise", SIGGRAPH 2002; the seed's
 * density map uses Perlin noise [33], seed 000 §4.5) with a seed-derived permutation, and
 * its fractal (octave) sum. Used to vary blades per tile across the meadow. */
#include "meadow_internal.h"

#include <math.h>

void tsk_noise_init(tsk_noise* noise, uint64_t seed) {
    if (noise == NULL) return;
    uint8_t p[256];
    for (int i = 0; i < 256; ++i) p[i] = (uint8_t)i;
    for (int i = 255; i > 0; --i) { /* Fisher-Yates, keyed by (seed, i) */
        const int j = (int)(tsk_hash4(seed, TSK_NOISE_STREAM, (uint64_t)i, 0) % (uint64_t)(i + 1));
        const uint8_t t = p[i];
        p[i] = p[j];
        p[j] = t;
    }
    for (int i = 0; i < 512; ++i) noise->perm[i] = p[i & 255];
}

/* quintic fade 6t^5 - 15t^4 + 10t^3 (Perlin 2002) */
static inline double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

static inline double lerp(double t, double a, double b) { return a + t * (b - a); }

/* dot of gradient h (8 directions at multiples of 45 degrees, length sqrt(2)) with (x, y) */
static inline double grad(int h, double x, double y) {
    static const double R2 = 1.4142135623730950488;
    switch (h & 7) {
        case 0:
            return R2 * x;
        case 1:
            return x + y;
        case 2:
            return R2 * y;
        case 3:
            return -x + y;
        case 4:
            return -R2 * x;
        case 5:
            return -x - y;
        case 6:
            return -R2 * y;
        default:
            return x - y;
    }
}

double tsk_noise_perlin2(const tsk_noise* noise, double x, double y) {
    if (noise == NULL || !isfinite(x) || !isfinite(y)) return 0.0;
    const double fx = floor(x), fy = floor(y);
    /* lattice coordinates mod 256 (two's complement & works for negatives) */
    const int X = (int)((int64_t)fmod(fx, 256.0) & 255), Y = (int)((int64_t)fmod(fy, 256.0) & 255);
    const double xf = x - fx, yf = y - fy;
    const double u = fade(xf), v = fade(yf);
    const uint8_t* p = noise->perm;
    const int aa = p[p[X] + Y], ab = p[p[X] + Y + 1];
    const int ba = p[p[X + 1] + Y], bb = p[p[X + 1] + Y + 1];
    const double x1 = lerp(u, grad(aa, xf, yf), grad(ba, xf - 1.0, yf));
    const double x2 = lerp(u, grad(ab, xf, yf - 1.0), grad(bb, xf - 1.0, yf - 1.0));
    return lerp(v, x1, x2);
}

double tsk_noise_fbm2(const tsk_noise* noise, double x, double y, int32_t octaves,
                      double persistence) {
    if (octaves < 1) octaves = 1;
    double sum = 0.0, norm = 0.0, amp = 1.0, freq = 1.0;
    for (int32_t o = 0; o < octaves; ++o) {
        sum += amp * tsk_noise_perlin2(noise, x * freq, y * freq);
        norm += amp;
        amp *= persistence;
        freq *= 2.0;
    }
    return norm > 0.0 ? sum / norm : 0.0;
}
