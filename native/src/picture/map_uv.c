/* The native warp as Blender's compositor draws it: Blender's Map UV node does not sample
 * bilinearly but with an elliptical weighted average (EWA, Greene & Heckbert 1986) whose
 * ellipse comes from differences of the UV pass between neighbouring pixels. This file
 * re-implements that sampling from the UV pass, so that a native frame equals the
 * compositor's output (within float rounding) and previews, bakes and renders agree.
 *
 * Two Blenders draw it differently, and both are kept exact:
 *  - 3.x (4.x with filter "Anisotropic"): every pixel's derivatives are one-pixel central
 *    differences of the UV pass in pixels (one-sided at the border);
 *  - 5.x (Interpolation "Anisotropic", CPU compositor): pixels go in 2x2 blocks whose four
 *    pixels share forward differences of the normalised UV pass (a pixel takes its row's
 *    horizontal and its column's vertical difference), and the result is multiplied by the
 *    UV pass's third channel (alpha).
 * The EWA itself is the same in both: weights (exp(a r) - exp(a)) / (1 - exp(a)), a = -2,
 * tabulated at 256 steps of r = Q / 256 like Blender's table, zeros read outside the
 * picture with their weights counted. */
#include "picture_internal.h"
#include "core/tmath.h"

#include <math.h>

enum { EWA_STEPS = 256 };

typedef struct map_uv_ctx {
    int width, height;
    const float* src; /* premultiplied RGBA, rows top-first */
    const float* uv; /* the UV pass, rows bottom-up (Blender's order) */
    float* dst; /* rows top-first */
    float weights[EWA_STEPS];
} map_uv_ctx;

/* Radii (a major, b minor) of the ellipse A u^2 + B u v + C v^2 = F. */
static void ellipse_axes(float A, float B, float C, float F, float* a, float* b) {
    if (F <= 1e-5f) {
        *a = sqrtf(A > C ? A : C);
        *b = 0.0f;
        return;
    }
    const float amc = A - C, apc = A + C, f2 = F * 2.0f;
    const float r = sqrtf(amc * amc + B * B);
    float d = apc - r;
    *a = (d <= 0.0f) ? sqrtf(A > C ? A : C) : sqrtf(f2 / d);
    d = apc + r;
    *b = (d <= 0.0f) ? 0.0f : sqrtf(f2 / d);
}

/* Angle of its major axis (computed only when the ellipse must be widened: atan2 is the
 * costliest step of the filter). Both branches of Blender's formula agree. */
static float ellipse_angle(float A, float B, float C) {
    return 0.5f * (tsk_atan2f(B, A - C) + 3.14159265358979323846f);
}

/* The implicit ellipse from squared radii and angle (inverse of ellipse_axes). */
static void ellipse_implicit(float a2, float b2, float th, float* A, float* B, float* C, float* F) {
    float c2 = tsk_cosf(th);
    const float s2 = 1.0f - c2 * c2;
    c2 *= c2;
    *A = a2 * s2 + b2 * c2;
    *B = (b2 - a2) * tsk_sinf(2.0f * th);
    *C = a2 * c2 + b2 * s2;
    *F = a2 * b2;
}

/* Reads pixel (x, y) of src in Blender's coordinates (y up); zero outside. */
static void read_pixel(const map_uv_ctx* c, int x, int y, float out[4]) {
    if (x < 0 || y < 0 || x >= c->width || y >= c->height) {
        out[0] = out[1] = out[2] = out[3] = 0.0f;
        return;
    }
    const float* p = c->src + ((size_t)(c->height - 1 - y) * c->width + x) * 4;
    out[0] = p[0];
    out[1] = p[1];
    out[2] = p[2];
    out[3] = p[3];
}

/* EWA around (uv0, uv1) (normalised) with derivatives du, dv (normalised); no
 * interpolation minimum (Blender's compositor passes intpol = false), alpha averaged.
 * Blender 5.x passes the jacobian's columns, du = d(uv)/dx and dv = d(uv)/dy; Blender 3.x
 * passed its rows, (dU/dx / W, dU/dy / H) and (dV/dx / W, dV/dy / H), and map_uv_rows does
 * the same to draw what 3.x draws. */
static void ewa(const map_uv_ctx* c, float uv0, float uv1, const float du[2], const float dv[2],
                float out[4]) {
    const int W = c->width, H = c->height;
    const float ff2 = (float)W, ff = sqrtf(ff2), q = (float)H / ff;
    const float ux = du[0] * ff, vx = du[1] * q, uy = dv[0] * ff, vy = dv[1] * q;
    float A = vx * vx + vy * vy;
    float B = -2.0f * (ux * vx + uy * vy);
    float C = ux * ux + uy * uy;
    float F = A * C - B * B * 0.25f;
    const float rmin = 0.765625f / ff2;
    float a, b;
    ellipse_axes(A, B, C, F, &a, &b);
    float b2 = b * b;
    if (b2 < rmin) {
        const float a2 = a * a;
        if (a2 < rmin) {
            B = 0.0f;
            A = C = rmin;
            F = A * C;
        } else {
            b2 = rmin;
            ellipse_implicit(a2, b2, ellipse_angle(A, B, C), &A, &B, &C, &F);
        }
    }
    const float ue = ff * sqrtf(C), ve = ff * sqrtf(A);
    float d = (float)EWA_STEPS / (F * ff2);
    A *= d;
    B *= d;
    C *= d;
    float U0 = uv0 * (float)W, V0 = uv1 * (float)H;
    int u1 = (int)floorf(U0 - ue), u2 = (int)ceilf(U0 + ue);
    int v1 = (int)floorf(V0 - ve), v2 = (int)ceilf(V0 + ve);
    const int lim = EWA_STEPS - 1;
    if (U0 - (float)u1 > (float)lim) u1 = (int)U0 - lim;
    if ((float)u2 - U0 > (float)lim) u2 = (int)U0 + lim;
    if (V0 - (float)v1 > (float)lim) v1 = (int)V0 - lim;
    if ((float)v2 - V0 > (float)lim) v2 = (int)V0 + lim;
    out[0] = out[1] = out[2] = out[3] = 0.0f;
    if (u2 < 0 || u1 >= W || v2 < 0 || v1 >= H) return;
    U0 -= 0.5f;
    V0 -= 0.5f;
    const float ddq = 2.0f * A;
    const float U = (float)u1 - U0;
    const float ac1 = A * (2.0f * U + 1.0f), ac2 = A * U * U, bu = B * U;
    d = 0.0f;
    for (int v = v1; v <= v2; ++v) {
        const float V = (float)v - V0;
        float dq = ac1 + B * V;
        float Q = (C * V + bu) * V + ac2;
        for (int u = u1; u <= u2; ++u) {
            if (Q < (float)EWA_STEPS) {
                float px[4];
                const float wt = c->weights[Q < 0.0f ? 0 : (unsigned)Q];
                read_pixel(c, u, v, px);
                out[0] += px[0] * wt;
                out[1] += px[1] * wt;
                out[2] += px[2] * wt;
                out[3] += px[3] * wt;
                d += wt;
            }
            Q += dq;
            dq += ddq;
        }
    }
    d = 1.0f / d;
    out[0] *= d;
    out[1] *= d;
    out[2] *= d;
    out[3] *= d;
}

/* The UV pass at (x, y) (Blender coordinates) in pixels of the image; 0 outside. */
static int read_uv(const map_uv_ctx* c, int x, int y, float* u, float* v) {
    if (x < 0 || y < 0 || x >= c->width || y >= c->height) return 0;
    const float* p = c->uv + ((size_t)y * c->width + x) * 4;
    *u = p[0] * (float)c->width;
    *v = p[1] * (float)c->height;
    return 1;
}

static void map_uv_rows(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const map_uv_ctx* c = vctx;
    const int W = c->width, H = c->height;
    const float inv_w = 1.0f / (float)W, inv_h = 1.0f / (float)H;
    for (size_t yr = b; yr < e; ++yr) {
        const int y = (int)yr; /* Blender row, bottom-up */
        float* out = c->dst + (size_t)(H - 1 - y) * W * 4;
        for (int x = 0; x < W; ++x) {
            float ru = 0.0f, rv = 0.0f, u = 0.0f, v = 0.0f;
            read_uv(c, x, y, &ru, &rv);
            /* partial derivatives from one-pixel central (or one-sided) differences:
             * dx = (dU/dx, dU/dy), dy = (dV/dx, dV/dy) */
            float dx[2] = {0.0f, 0.0f}, dy[2] = {0.0f, 0.0f};
            int n = 0;
            if (read_uv(c, x + 1, y, &u, &v)) {
                dx[0] += u - ru;
                dy[0] += v - rv;
                ++n;
            }
            if (read_uv(c, x - 1, y, &u, &v)) {
                dx[0] += ru - u;
                dy[0] += rv - v;
                ++n;
            }
            if (n > 0) {
                const float inv = 1.0f / (float)n;
                dx[0] *= inv;
                dy[0] *= inv;
            }
            n = 0;
            if (read_uv(c, x, y + 1, &u, &v)) {
                dx[1] += u - ru;
                dy[1] += v - rv;
                ++n;
            }
            if (read_uv(c, x, y - 1, &u, &v)) {
                dx[1] += ru - u;
                dy[1] += rv - v;
                ++n;
            }
            if (n > 0) {
                const float inv = 1.0f / (float)n;
                dx[1] *= inv;
                dy[1] *= inv;
            }
            const float du[2] = {dx[0] * inv_w, dx[1] * inv_h};
            const float dv[2] = {dy[0] * inv_w, dy[1] * inv_h};
            ewa(c, ru * inv_w, rv * inv_h, du, dv, out + 4 * x);
        }
    }
}

/* Blender 5.x: one output pixel (x, y) (Blender coordinates, y up) sampled at its own UV
 * with the differences its block gave it. */
static void map_uv5_pixel(const map_uv_ctx* c, int x, int y, const float uv[2],
                          const float x_grad[2], const float y_grad[2]) {
    float* out = c->dst + ((size_t)(c->height - 1 - y) * c->width + x) * 4;
    ewa(c, uv[0], uv[1], x_grad, y_grad, out);
    /* the UV pass's third channel is an alpha that Map UV multiplies in (1 in our passes,
     * which leaves the sample's bits as they are) */
    const float alpha = c->uv[((size_t)y * c->width + x) * 4 + 2];
    out[0] *= alpha;
    out[1] *= alpha;
    out[2] *= alpha;
    out[3] *= alpha;
}

/* The normalised UV of pixel (x, y), clamped to the picture (Blender reads the block's
 * right and upper neighbours "extended" when they lie outside). */
static void uv_extended(const map_uv_ctx* c, int x, int y, float uv[2]) {
    if (x > c->width - 1) x = c->width - 1;
    if (y > c->height - 1) y = c->height - 1;
    const float* p = c->uv + ((size_t)y * c->width + x) * 4;
    uv[0] = p[0];
    uv[1] = p[1];
}

/* Blender 5.x: the 2x2 pixels of the block whose lower-left pixel is (2 bx, 2 by) share the
 * four differences between their UVs: a pixel takes its row's horizontal difference and its
 * column's vertical one, so derivatives are forward differences for the even pixels and
 * backward ones for the odd. A last half block (odd width or height) differences its
 * pixels against themselves: zero, as in Blender. */
static void map_uv5_block_rows(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const map_uv_ctx* c = vctx;
    const int W = c->width, H = c->height;
    for (size_t by = b; by < e; ++by) {
        const int y = 2 * (int)by;
        for (int x = 0; x < W; x += 2) {
            float ll[2], lr[2], ul[2], ur[2];
            uv_extended(c, x, y, ll);
            uv_extended(c, x + 1, y, lr);
            uv_extended(c, x, y + 1, ul);
            uv_extended(c, x + 1, y + 1, ur);
            /* forward differences in normalised UV, as floats (the same bits as Blender's) */
            const float lower_x[2] = {lr[0] - ll[0], lr[1] - ll[1]};
            const float upper_x[2] = {ur[0] - ul[0], ur[1] - ul[1]};
            const float left_y[2] = {ul[0] - ll[0], ul[1] - ll[1]};
            const float right_y[2] = {ur[0] - lr[0], ur[1] - lr[1]};
            map_uv5_pixel(c, x, y, ll, lower_x, left_y);
            if (x + 1 < W) map_uv5_pixel(c, x + 1, y, lr, lower_x, right_y);
            if (y + 1 < H) {
                map_uv5_pixel(c, x, y + 1, ul, upper_x, left_y);
                if (x + 1 < W) map_uv5_pixel(c, x + 1, y + 1, ur, upper_x, right_y);
            }
        }
    }
}

static void init_ctx(map_uv_ctx* c, int width, int height, const float* src,
                     const float* uv_bottom_up, float* dst) {
    c->width = width;
    c->height = height;
    c->src = src;
    c->uv = uv_bottom_up;
    c->dst = dst;
    /* Blender's table holds the weights as decimal literals of 6 significant digits; the
     * same rounding here gives the same floats (all 256 checked against the tables in the
     * 3.4 and 5.2.2 binaries), where the unrounded weights left up to 4e-7 between a native
     * frame and the render. */
    const double e_a = exp(-2.0);
    for (int i = 0; i < EWA_STEPS; ++i) {
        const double r = (double)i / (double)(EWA_STEPS - 1);
        const double wt = (exp(-2.0 * r) - e_a) / (1.0 - e_a);
        double rounded = 0.0;
        if (wt > 0.0) {
            const double scale = pow(10.0, 5.0 - floor(log10(wt)));
            rounded = nearbyint(wt * scale) / scale;
        }
        c->weights[i] = (float)rounded;
    }
}

void tsk_picture_map_uv(int width, int height, const float* src, const float* uv_bottom_up,
                        float* dst) {
    map_uv_ctx c;
    init_ctx(&c, width, height, src, uv_bottom_up, dst);
    tsk_parallel_for((size_t)height, 8, map_uv_rows, &c);
}

void tsk_picture_map_uv_5(int width, int height, const float* src, const float* uv_bottom_up,
                          float* dst) {
    map_uv_ctx c;
    init_ctx(&c, width, height, src, uv_bottom_up, dst);
    /* a block row writes its two pixel rows and no other: chunks never share a pixel */
    tsk_parallel_for(((size_t)height + 1) / 2, 4, map_uv5_block_rows, &c);
}
