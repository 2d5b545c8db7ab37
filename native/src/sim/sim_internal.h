/* Private layout of the blade simulation: per-tile blocks of SIM_W blades stored as
 * structure-of-arrays (one float per blade lane), the tile record, prepared colliders and the
 * block kernel that the tile manager runs in parallel. */
#ifndef TSK_SIM_INTERNAL_H
#define TSK_SIM_INTERNAL_H

#include "tussock/sim.h"

/* Blades per block: the lanes of every vector value. 32 floats = two AVX-512 registers (four
 * AVX2, eight SSE): two independent registers per operation hide the latency of the solver's
 * root-to-tip chains (measured: 16 lanes 201, 32 lanes 156, 64 lanes 152 ns per blade-step,
 * one thread, block in cache). A block of 32 blades x 16 knots is ~23 KB, so every pass of a
 * step runs in L1 after the block is read once. */
#define SIM_W 32

/* Block layout, in floats, for K knots (each array is [knot][component][lane]):
 *   P  [K][3][W]  current positions (knot 0 = root, never moves)
 *   Q  [K][3][W]  previous positions (Verlet)
 *   R  [K][3][W]  R[k], k >= 1: unit rest direction of segment k-1 -> k in the rest frame of the
 *                 segment before it (segment 0: the root frame); R[0] = root frame tangent T0
 *   L  [K][W]     L[k], k >= 1: rest length of segment k-1 -> k; L[0] = total rest length
 *   WD [K][W]     full width at each knot, metres
 *   S0 [3][W]     root frame side vector
 * Lanes past the tile's blade count hold copies of the tile's first blade and are never output. */
#define SIM_OFF_P(K) 0
#define SIM_OFF_Q(K) ((size_t)3 * (K) * SIM_W)
#define SIM_OFF_R(K) ((size_t)6 * (K) * SIM_W)
#define SIM_OFF_L(K) ((size_t)9 * (K) * SIM_W)
#define SIM_OFF_WD(K) ((size_t)10 * (K) * SIM_W)
#define SIM_OFF_S0(K) ((size_t)11 * (K) * SIM_W)
#define SIM_BLOCK_FLOATS(K) ((size_t)11 * (K) * SIM_W + 3 * SIM_W)

/* A collider prepared for the kernel: segment a + t*ab (t in [0,1]; ab = 0 for spheres). */
typedef struct sim_collider {
    float a[3], ab[3];
    float inv_ab2; /* 1/|ab|^2, 0 for spheres */
    float r;       /* radius + collision_margin */
    float lo[3], hi[3]; /* bounding box */
} sim_collider;

/* An active tile. */
typedef struct sim_tile {
    int32_t index;
    int32_t blade_count;
    int32_t block_count;
    int32_t quiet_frames; /* consecutive quiet, untouched steps */
    int32_t blend_left;   /* > 0: blending back to rest, steps left */
    int32_t touched;      /* touched by a collider (or activate_tile) since the last step */
    float* blocks;        /* block_count blocks (NULL when empty) */
    float* bounds;        /* 6 floats per block: reach box lo xyz, hi xyz */
    size_t bytes;         /* bytes held by blocks + bounds */
} sim_tile;

/* What the kernel needs from a step, the same for every block. */
typedef struct sim_step_params {
    int32_t K;
    int32_t iterations;
    float dt, dt2;
    float damp;           /* exp(-damping dt) */
    float gravity[3];
    float preload;        /* gravity_preload */
    float drag;           /* wind_drag / linear_density * dt, 1/m (times width -> fraction) */
    float alpha_root, alpha_tip; /* global shape fractions per step */
    float alpha_local;    /* local shape fraction per step */
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
 * its side vector is  e_y - (r_y / (1 + r_x)) (e_x + r). The same rotation carries the current
 * frames, so a segment's rest direction in its parent's frame (r) holds bending and the bend's
 * direction relative to the blade's face (twist). */
static inline float sim_side_coef(float rx, float ry) {
    float den = 1.0f + rx;
    den = den > 1e-6f ? den : 1e-6f; /* a segment folded straight back: keep finite */
    return ry / den;
}

/* Runs one step on one block. `wind` is NULL or [K][3][W] velocities (m/s) for the block's
 * lanes. `cols`/`ncol`: the colliders that may reach the block. blend: fraction (0..1] of the
 * remaining way to rest to blend after the step, 0 for none. */
void tsk_sim_block_step(const sim_step_params* p, float* block, const float* wind,
                        const sim_collider* const* cols, int ncol, float blend,
                        sim_block_stats* stats);

/* Fills P (and Q = P) of a block with the rest pose rebuilt from R, L, S0 and the root. */
void tsk_sim_block_rest(int32_t K, float* block);

/* Validates a definition (messages name the field). */
tsk_status tsk_sim_check_def(const tsk_blade_sim_def* def);

/* Loads one blade (K knots xyz, K widths, side or NULL; validated by the caller) into `lane`
 * of a block: root frame, rest directions, lengths, widths. Call tsk_sim_block_rest after
 * every lane is loaded. */
void tsk_sim_block_load_lane(int32_t K, float* block, int lane, const float* knots,
                             const float* widths, const float* side);

#endif
