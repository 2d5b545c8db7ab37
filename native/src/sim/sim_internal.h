/* Private layout of the blade simulation: per-tile blocks of SIM_W blades stored as
 * structure-of-arrays (one float per blade lane), the tile record, prepared colliders and the
 * block kernel that the tile manager runs in parallel. */
#ifndef TSK_SIM_INTERNAL_H
#define TSK_SIM_INTERNAL_H

#include "core/simd.h"
#include "tussock/sim.h"
#include "core/tmath.h"

#include <math.h>
#include <string.h>

/* Blades per block: the lanes of every stored value. The kernel works on 16 lanes at a time
 * (one AVX-512 register, two AVX2 ones), half a block per sweep. */
#define SIM_W 32

/* Block layout for K knots, W = SIM_W lanes; every array is [row][lane], rows as listed.
 * The state is kept small because a step over a million blades streams all of it through
 * memory (docs/performance.md): 543 bytes per blade at 16 knots, of which only P and V are
 * written back.
 *   P   float    [K][3]    current positions (knot 0 = root, never moves)
 *   V   half     [K-1][3]  displacement of knots 1..K-1 over the last step, metres (IEEE
 *                          binary16 bits: the Verlet velocity times dt)
 *   D   int16    [K-1][3]  rest segment k-1 -> k (row k-1) in the rest frame of the segment
 *                          before it (segment 0: the root frame), in units of DS. The rest
 *                          pose is what the solver rebuilds from these and Q: lengths, unit
 *                          directions, frames parallel-transported (sim_side_coef)
 *   Q   float    [K-1][2]  per rest segment, the two quotients of its rebuild, computed once
 *                          when the tile is provided (sim_rest_quotients): IL = 1 / |D DS|
 *                          (row 2(k-1)) and the side coefficient C (row 2(k-1)+1). The step
 *                          then rebuilds the pose with no square root or division (stored,
 *                          they cost 120 bytes per blade and save a tenth of the step)
 *   WD  uint8    [K-1]     width at knots 1..K-1 in units of WS (only wind drag uses it)
 *   lane floats  [9]       T0 xyz (root frame tangent), S0 xyz (root frame side), DS (metres
 *                          per D unit), WS (metres per WD unit), LT (total rest length)
 * Lanes past the tile's blade count hold copies of the tile's first blade and are never output. */
#define SIM_ROUND64(b) (((b) + 63) & ~(size_t)63)
#define SIM_BYTES_P(K) ((size_t)(K)*3 * SIM_W * 4)
#define SIM_BYTES_V(K) ((size_t)((K)-1) * 3 * SIM_W * 2)
#define SIM_BYTES_WD(K) SIM_ROUND64((size_t)((K)-1) * SIM_W)
#define SIM_BYTES_Q(K) ((size_t)((K)-1) * 2 * SIM_W * 4)
#define SIM_BOFF_V(K) SIM_BYTES_P(K)
#define SIM_BOFF_D(K) (SIM_BOFF_V(K) + SIM_BYTES_V(K))
#define SIM_BOFF_Q(K) (SIM_BOFF_D(K) + SIM_BYTES_V(K))
#define SIM_BOFF_WD(K) (SIM_BOFF_Q(K) + SIM_BYTES_Q(K))
#define SIM_BOFF_LANE(K) (SIM_BOFF_WD(K) + SIM_BYTES_WD(K))
#define SIM_LANE_ROWS 9
enum { SIM_LANE_T0 = 0, SIM_LANE_S0 = 3, SIM_LANE_DS = 6, SIM_LANE_WS = 7, SIM_LANE_LT = 8 };
/* Offsets and sizes in floats (blocks are float arrays, 64-byte aligned). */
#define SIM_OFF_P(K) 0
#define SIM_OFF_LANE(K) (SIM_BOFF_LANE(K) / 4)
#define SIM_OFF_LT(K) (SIM_OFF_LANE(K) + (size_t)SIM_LANE_LT * SIM_W) /* total rest length */
#define SIM_BLOCK_FLOATS(K) ((SIM_BOFF_LANE(K) + (size_t)SIM_LANE_ROWS * SIM_W * 4) / 4)

/* A collider prepared for the kernel: segment a + t*ab (t in [0,1]; ab = 0 for spheres). */
typedef struct sim_collider {
    float a[3], ab[3];
    float inv_ab2; /* 1/|ab|^2, 0 for spheres */
    float r; /* radius + collision_margin */
    float lo[3], hi[3]; /* bounding box */
} sim_collider;

/* An active tile. */
typedef struct sim_tile {
    int32_t index;
    int32_t blade_count;
    int32_t block_count;
    int32_t quiet_frames; /* consecutive quiet, untouched steps */
    int32_t untouched; /* consecutive untouched steps, quiet or not */
    int32_t blend_left; /* > 0: blending back to rest, steps left */
    int32_t blend_total; /* steps of the blend under way */
    int32_t touched; /* touched by a collider (or activate_tile) since the last step */
    float* blocks; /* block_count blocks (NULL when empty) */
    float* bounds; /* 6 floats per block: reach box lo xyz, hi xyz */
    size_t bytes; /* bytes held by blocks + bounds */
} sim_tile;

/* The simulation (tiles.c). Its four tile lists ascend strictly, and pending is
 * (touched U forced) minus the active tiles (tsk_sim_lists_problem checks them). */
struct tsk_blade_sim {
    tsk_blade_sim_def def;
    int32_t K;
    sim_tile* tiles; /* active tiles, ascending index; tile_cap allocated */
    int32_t tile_count, tile_cap;
    int32_t* pending; /* ascending */
    int32_t pending_count;
    int32_t* forced; /* activate_tile requests not yet provided, ascending */
    int32_t forced_count;
    int32_t* touched; /* tiles touched by the current colliders, ascending */
    int32_t touched_count;
    sim_collider* cols;
    int32_t collider_count;
    float bin_pad; /* how far any active tile's reach box extends beyond its square, metres */
};

/* NULL when the tile lists and the active tiles' records are consistent, else what is wrong
 * (for TSK_ASSERT and the tests): every list ascends strictly within [0, tiles_x tiles_y), a
 * list with entries is allocated, no tile is both active and pending or forced, every pending
 * tile is touched or forced, and each active tile's blocks match its blade count. After an
 * allocation failure pending may lack tiles, so that direction is not checked. */
const char* tsk_sim_lists_problem(const tsk_blade_sim* sim);

/* TSK_OK, or TSK_ERR_INTERNAL with tsk_sim_lists_problem's answer as the message. */
tsk_status tsk_sim_validate(const tsk_blade_sim* sim);

/* What the kernel needs from a step, the same for every block. */
typedef struct sim_step_params {
    int32_t K;
    int32_t iterations;
    float dt, dt2;
    float damp; /* exp(-damping dt) */
    float gravity[3];
    float preload; /* gravity_preload */
    float drag; /* wind_drag / linear_density * dt, 1/m (times width -> fraction) */
    float alpha_root, alpha_tip; /* global shape fractions per step */
    float alpha_local; /* local shape fraction per step */
    float ground;
} sim_step_params;

/* Statistics of one block after a step: squared max displacement from rest and squared max
 * displacement over the step (speed * dt). */
typedef struct sim_block_stats {
    float max_disp2;
    float max_step2;
} sim_block_stats;

/* Rest-frame rotation. The rest frames are parallel-transported (Bishop) frames: the frame of
 * segment k is the frame of segment k-1 turned by the smallest rotation that takes its tangent
 * to segment k's direction. In the parent's coordinates that rotation takes e_x to r (unit), and
 * its side vector is  e_y - c (e_x + r), c = r_y / (1 + r_x); in world coordinates the side
 * turns into  s - c (t + u)  (t the parent's tangent, u the segment's). The same rotation carries the current
 * frames, so a segment's rest direction in its parent's frame (r) holds bending and the bend's
 * direction relative to the blade's face (twist). */
static inline float sim_side_coef(float rx, float ry) {
    float den = 1.0f + rx;
    den = den > 1e-6f ? den : 1e-6f; /* a segment folded straight back: keep finite */
    return ry / den;
}

/* One lane of the kernel's dot3 and cross3: products summed with fused multiply-adds
 * (tsk_fmaf rounds once, as the kernels' vfmadd and vfmsub). */
static inline float sim_dot3(const float a[3], const float b[3]) {
    return tsk_fmaf(a[2], b[2], tsk_fmaf(a[1], b[1], a[0] * b[0]));
}
static inline void sim_cross3(const float a[3], const float b[3], float out[3]) {
    out[0] = tsk_fmaf(a[1], b[2], -(a[2] * b[1]));
    out[1] = tsk_fmaf(a[2], b[0], -(a[0] * b[2]));
    out[2] = tsk_fmaf(a[0], b[1], -(a[1] * b[0]));
}

/* The two quotients of a rest segment d (metres), stored in the block's Q rows: 1 / |d| and
 * the side coefficient of its unit direction. */
static inline void sim_rest_quotients(const float d[3], float* il, float* c) {
    *il = 1.0f / sqrtf(sim_dot3(d, d));
    *c = sim_side_coef(*il * d[0], *il * d[1]);
}

/* One lane of the kernel's rest_segment, the same operations in the same order: the stored
 * segment d (metres, in the frame (t, s, n) of the segment before) and its quotients il and c
 * (sim_rest_quotients) turn the frame into the segment's own; returns the segment's length,
 * |d|^2 il. */
static inline float sim_rest_segment(const float d[3], float il, float c, float t[3], float s[3],
                                     float n[3]) {
    const float len = sim_dot3(d, d) * il;
    const float rx = il * d[0], ry = il * d[1], rz = il * d[2];
    float u[3], w[3];
    for (int i = 0; i < 3; ++i) u[i] = tsk_fmaf(n[i], rz, tsk_fmaf(s[i], ry, t[i] * rx));
    for (int i = 0; i < 3; ++i) w[i] = tsk_fmaf(-c, t[i] + u[i], s[i]);
    for (int i = 0; i < 3; ++i) t[i] = u[i], s[i] = w[i];
    sim_cross3(u, w, n);
    return len;
}

/* IEEE binary16 <-> binary32, round to nearest even: the bits that F16C's vcvtps2ph/vcvtph2ps
 * give, for the portable path. */
static inline uint16_t sim_float_to_half(float f) {
    uint32_t x;
    memcpy(&x, &f, 4);
    const uint32_t sign = (x >> 16) & 0x8000u;
    x &= 0x7fffffffu;
    if (x >= 0x7f800000u) return (uint16_t)(sign | 0x7c00u | (x > 0x7f800000u ? 0x200u : 0u));
    if (x >= 0x477ff000u) return (uint16_t)(sign | 0x7c00u); /* rounds past 65504 */
    const uint32_t e = x >> 23;
    if (e >= 113u) { /* a normal half */
        const uint32_t m = x - (112u << 23);
        return (uint16_t)(sign | ((m + 0xfffu + ((m >> 13) & 1u)) >> 13));
    }
    if (e < 102u) return (uint16_t)sign; /* below 2^-25 */
    const uint32_t m = (x & 0x7fffffu) | 0x800000u, sh = 126u - e;
    uint32_t q = m >> sh;
    const uint32_t rem = m & ((1u << sh) - 1u), half = 1u << (sh - 1u);
    if (rem > half || (rem == half && (q & 1u))) ++q;
    return (uint16_t)(sign | q);
}
static inline float sim_half_to_float(uint16_t h) {
    const uint32_t sign = (uint32_t)(h & 0x8000u) << 16, e = (h >> 10) & 0x1fu, m = h & 0x3ffu;
    uint32_t x;
    if (e == 0) {
        const float f = (float)m * 0x1p-24f; /* zero or subnormal: exact */
        memcpy(&x, &f, 4);
        x |= sign;
    } else if (e == 31) {
        x = sign | 0x7f800000u | (m << 13);
    } else {
        x = sign | ((e + 112u) << 23) | (m << 13);
    }
    float f;
    memcpy(&f, &x, 4);
    return f;
}

/* The kernel units (core/simd.h): blade_kernel.c the portable one, blade_kernel_avx2.c and
 * blade_kernel_avx512.c where TSK_SIMD_X86_PATHS; tsk_simd_isa() picks one per call and
 * tsk_simd_force() forces one (tests). All give the same bytes (only IEEE add, sub, mul, div,
 * sqrt, fused multiply-adds written out, comparisons and exact conversions); test_sim checks
 * it. */

/* The compiler of the AVX-512 step ("clang ..." or "gcc ...") when that is the kernel
 * tsk_sim_block_step runs, else "none"; for the benchmarks. */
const char* tsk_sim_avx512_step_running(void);

/* Runs one step on one block. `wind` is NULL or velocities (m/s) for the block's lanes, [3][W]
 * for each knot, `wind_stride` floats from one knot's rows to the next (0: the same wind at every
 * knot). `cols`/`ncol`: the colliders that may reach the block. blend: fraction (0..1] of the
 * remaining way to rest to blend after the step, 0 for none. `next`: the block stepped next, or
 * NULL; it is prefetched. */
void tsk_sim_block_step(const sim_step_params* p, float* block, const float* wind,
                        size_t wind_stride, const sim_collider* const* cols, int ncol, float blend,
                        const float* next, sim_block_stats* stats);

/* Fills P of a block with the rest pose rebuilt from D, the root frame and the root (exactly as
 * the solver rebuilds it every step) and sets V to zero. */
void tsk_sim_block_rest(int32_t K, float* block);

/* Ribbon vertices of lanes [l0, l1) of a block's knots P, as tsk_blades_expand makes them from
 * the same knots (the same bytes); widths, sides and out start at lane l0's blade. 1 (nothing
 * written) when a knot, width or side is not good input. */
int tsk_sim_block_ribbons(int32_t K, const float* P, int l0, int l1, const float* widths,
                          const float* sides, float* out);

/* Validates a definition (messages name the field). */
tsk_status tsk_sim_check_def(const tsk_blade_sim_def* def);

/* What the kernel needs for a step of dt seconds under a (valid) definition: the rates turned
 * into per-step fractions, the damping factor, the drag per unit width. */
sim_step_params tsk_sim_step_params(const tsk_blade_sim_def* def, float dt);

/* Loads one blade (K knots xyz, K widths, side or NULL; validated by the caller) into `lane`
 * of a block: root, root frame, rest segments (quantised; see blade_rest.c), widths. Call tsk_sim_block_rest after
 * every lane is loaded. */
void tsk_sim_block_load_lane(int32_t K, float* block, int lane, const float* knots,
                             const float* widths, const float* side);

/* The kernels per instruction set, behind tsk_sim_block_step, tsk_sim_block_rest and
 * tsk_sim_block_ribbons. */
#define SIM_KERNEL_DECL(sfx)                                                                     \
    void tsk_sim_block_step_##sfx(const sim_step_params* p, float* block, const float* wind,     \
                                  size_t wind_stride, const sim_collider* const* cols, int ncol, \
                                  float blend, const float* next, sim_block_stats* stats);       \
    void tsk_sim_block_rest_##sfx(int32_t K, float* block);                                      \
    int tsk_sim_block_ribbons_##sfx(int32_t K, const float* P, int l0, int l1,                   \
                                    const float* widths, const float* sides, float* out);
SIM_KERNEL_DECL(generic)
#if TSK_SIMD_X86_PATHS
SIM_KERNEL_DECL(avx2)
SIM_KERNEL_DECL(avx512)
/* Which compiler built the AVX-512 step ("clang ..." or "gcc ..."). */
const char* tsk_sim_avx512_step_compiler(void);
#endif

#endif
