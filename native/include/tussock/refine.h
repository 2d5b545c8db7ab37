/* Tussock refine: reduces a captured blade skeleton (100+ knots) to the 2..64 knots the
 * meadow uses by greedily merging the adjacent knots that move most alike (seed 000 §4.4,
 * eq. 1-3, Algorithm 1), and makes the movement data the merging needs: knots tracked
 * through a captured sequence, or a physically based bending simulation of a still capture
 * under a standard gusting wind. All buffers are owned by the caller. */
#ifndef TUSSOCK_REFINE_H
#define TUSSOCK_REFINE_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ==== skeleton refining (Algorithm 1) ================================================= */

#define TSK_REFINE_MIN_TARGET 2 ///< fewest knots a refined blade may have
#define TSK_REFINE_MAX_TARGET 64 ///< most knots a refined blade may have
#define TSK_REFINE_MAX_KNOTS 65536 ///< most knots of an input blade (else TSK_ERR_LIMIT)
#define TSK_REFINE_MAX_FRAMES 65536 ///< most frames of movement data (else TSK_ERR_LIMIT)
/// Most knots x frames of one blade (else TSK_ERR_LIMIT): 2^26 samples = 768 MiB of xyz.
#define TSK_REFINE_MAX_SAMPLES ((size_t)1 << 26)

/// How a blade is refined.
typedef struct tsk_refine_def {
    /// m: knots of the refined blade, 2..64 (default 16). Must not exceed the input's count.
    int target_knots;
    /// μ of seed 000 eq. 1, in [0, 1] (default 0.5): weight of the mean distance of two
    /// knots; 1 - μ weights the variance of that distance over the frames. μ = 1 is the pure
    /// distance criterion. Distances are measured in units of the blade's rest length, so
    /// the same μ means the same thing for a 5 cm and a 50 cm blade, in any unit.
    float mu;
} tsk_refine_def;

/// Defaults: target_knots 16, mu 0.5.
tsk_refine_def tsk_default_refine_def(void);

/// One input blade. Knots run from the root (index 0) to the tip (index knot_count - 1).
typedef struct tsk_refine_input {
    const float* knots; ///< [knot_count][3] rest positions, metres (any unit works)
    const float* widths; ///< [knot_count] full blade width at each knot, >= 0
    const float* trajectories; ///< [frame_count][knot_count][3] knot positions per frame
    size_t knot_count; ///< >= 2, <= TSK_REFINE_MAX_KNOTS
    size_t frame_count; ///< >= 1, <= TSK_REFINE_MAX_FRAMES
} tsk_refine_input;

/// Where one refined blade is written (m = target_knots). Caller-owned buffers.
typedef struct tsk_refine_output {
    float* knots; ///< [m][3] rest positions of the refined knots
    float* widths; ///< [m] widths of the refined knots
    /// [m][2] int32: for refined knot k, {first source knot, number of source knots}. The
    /// ranges are contiguous, in order, and partition 0..knot_count-1: knot k stands for
    /// source knots first..first+count-1 ("which knots merged", seed Fig. 6).
    int32_t* ranges;
    /// Optional (NULL to skip): [frame_count][m][3] the refined knots' trajectories, the
    /// same combination of source trajectories as the rest positions.
    float* trajectories;
} tsk_refine_output;

/// Refines one blade by seed 000 Algorithm 1: while more than m knots remain, the adjacent
/// pair with the smallest movement difference D (eq. 1-3, over all frames) is merged.
///
/// Merging rules (exact, so that results can be checked):
/// - A pair merges into its midpoint: position and each frame's position are 0.5f*(a + b).
///   A pair that contains the root (the first knot) merges into the root, and a pair that
///   contains the tip into the tip, so root and tip never move.
/// - Width is carried by segment length: source knot j owns the arc length
///   l_j = (|p_j - p_{j-1}| + |p_{j+1} - p_j|) / 2 of the rest skeleton (a segment missing
///   at the root or tip counts 0, so the l_j add up to the blade length); a refined knot's
///   width is sum(l_j * w_j) / sum(l_j) over the source knots it
///   stands for (the mean width of the stretch of blade it represents).
/// - Ties in D go to the pair nearer the root.
/// - Distances in D are divided by the rest length L = sum of |p_{j+1} - p_j| (double).
/// Cost O(K log K + K * F) for K knots and F frames (a binary heap with lazily invalidated
/// entries). Errors name the argument: target_knots, mu, knot_count, frame_count, knots
/// (non-finite, or two consecutive knots at the same place), widths, trajectories, out.
tsk_status tsk_refine_blade(const tsk_refine_def* def, const tsk_refine_input* blade,
                            const tsk_refine_output* out);

/// Refines `count` blades in parallel (tsk_parallel_for, fixed grain), each exactly as
/// tsk_refine_blade would; results do not depend on the thread count. On error returns
/// the status of the lowest-indexed failing blade with a message "blades[i]: ...".
/// Blades may share input buffers; outputs must not overlap.
tsk_status tsk_refine_blades(const tsk_refine_def* def, const tsk_refine_input* blades,
                             const tsk_refine_output* outs, size_t count);

/// Movement difference D of seed 000 eq. 1-3 between two knot trajectories `a` and `b`
/// (each `frame_count` xyz triples, contiguous), with distances multiplied by `inv_length`:
///   d_i = |a_i - b_i| * inv_length,  dis = sum(d_i)/n,  var = sum(d_i^2)/n - dis^2,
///   D = mu * dis + (1 - mu) * var.
/// The seed prints eq. 3's second term as (sum d)^2 / n; that is not a variance (it grows
/// with n), so the true variance is used. Computed in double. Returns NaN for bad input.
double tsk_refine_difference(float mu, const float* a, const float* b, size_t frame_count,
                             double inv_length);

/* ==== movement data (a): knots tracked through a captured sequence ==================== */

/// Turns a sequence of captured skeletons of one blade into trajectories of the reference
/// skeleton's knots. Method: each frame's skeleton (any knot count >= 2) is oriented root to
/// tip (reversed when its first knot lies nearer the reference tip than the reference root,
/// by the sum of end-to-end distances), then resampled by normalised arc length: reference
/// knot j, at fraction u_j = s_j / L of the reference's arc length, is matched to the point
/// at the same fraction u_j of the frame skeleton's arc length (linear along its segments).
/// Zero-length segments of a frame are allowed; a frame of zero total length is not.
/// frame_offsets has frame_count + 1 entries: frame f's knots are
/// frame_knots[3*offsets[f] .. 3*offsets[f+1]) (offsets[0] = 0, non-decreasing).
/// out_trajectories: [frame_count][ref_count][3].
tsk_status tsk_refine_track(const float* ref_knots, size_t ref_count, const float* frame_knots,
                            const int32_t* frame_offsets, size_t frame_count,
                            float* out_trajectories);

/// Uniform arc-length resampling (the simple alternative to Algorithm 1): out_count knots
/// at equal arc-length steps from root to tip of the rest skeleton, widths linearly
/// interpolated. out_knots [out_count][3], out_widths [out_count] (may be NULL).
tsk_status tsk_refine_resample(const float* knots, const float* widths, size_t knot_count,
                               size_t out_count, float* out_knots, float* out_widths);

/* ==== movement data (b): bending simulation of a still capture ======================== */

/// A physically based bending model of a blade, used until the blade solver of the
/// simulation issue exists. The blade is an inextensible elastic rod clamped at the root:
/// - knots carry lumped mass m_i = density * thickness * (the blade area of the half
///   segments around knot i, segment width = mean of its knots' widths);
/// - bending stiffness EI_i = youngs_modulus * width_i * thickness^3 / 12 (a flat ribbon);
///   knot i resists the change of the angle between its segments as a rotational spring
///   k_i = EI_i / l_i, l_i the mean length of its two segments (root: half the first
///   segment, the root tangent being clamped). The rest direction of each segment is kept
///   in a frame parallel-transported from the clamped root (Bishop frame, no twist);
///   the discrete curvature is 2 tan(theta/2) (discrete elastic rods);
/// - gravity acts on the knot masses; wind drag per length 0.5 * air_density *
///   drag_coefficient * width * |v_n| v_n, v_n the part of (wind - knot velocity) normal
///   to the blade; a mass-proportional damping `damping` (1/s) stands for internal losses;
/// - Verlet integration; after every step the segment lengths are restored by fast
///   projection (Goldenthal et al. 2007: Newton steps on the tridiagonal system of segment
///   tensions, weighted by inverse mass, so the corrections are true constraint forces),
///   then an exact root-to-tip pass removes the tiny remainder.
/// The step is explicit: its length is 0.4 * l_min^2 * sqrt(mass per length / EI) (stable
/// below 0.5), so the cost grows as knots^3: on one core of the 2-core test machine a
/// 20 cm blade costs ~0.5 s per simulated second at 64 knots, ~4 s at 128 and ~30 s at 256
/// (about 50-150 ns per knot and step).
typedef struct tsk_refine_bend_def {
    float youngs_modulus; ///< effective Young's modulus, Pa (default 3e9, a grass leaf
        ///< whose fold and midrib stiffen it)
    float thickness; ///< blade thickness, m (default 4e-4)
    float density; ///< kg/m^3 (default 900)
    float min_width_ratio; ///< widths below this fraction of the widest are raised to it
        ///< for mass and stiffness, so a pointed tip stays defined (0.05)
    float gravity[3]; ///< m/s^2 (default 0, 0, -9.81: Blender's Z up)
    /// 1 (default): the rest (captured) shape is already the equilibrium under gravity, so
    /// gravity does not sag it further (rest curvature is offset by the gravity moment;
    /// exact when that moment has no twist part, e.g. a blade curving in a vertical plane,
    /// since the model has no twist stiffness); 0: the rest shape is stress-free and sags.
    int gravity_prestress;
    float air_density; ///< kg/m^3 (default 1.2)
    float drag_coefficient; ///< dimensionless (default 1.2, a flat plate across the flow)
    float damping; ///< mass-proportional damping, 1/s (default 2)
    float wind_speed; ///< mean speed of the standard wind, m/s (default 3)
    float wind_direction[3]; ///< direction of the standard wind (normalised; default +x)
    float gust; ///< relative gust amplitude in [0, 1] (default 0.5)
    float fps; ///< frames per second of the output (default 24)
    float warmup; ///< seconds simulated before the first output frame (default 1)
    float time_step; ///< seconds; 0 (default) = automatic, stable step
} tsk_refine_bend_def;

/// Defaults as documented in tsk_refine_bend_def.
tsk_refine_bend_def tsk_default_refine_bend_def(void);

/// The standard wind at time t (seconds), m/s: a gusting wind, uniform in space, a sum of
/// sines so that it is deterministic:
///   along = speed * (1 + gust * (0.6 sin(2pi 0.31 t) + 0.3 sin(2pi 0.87 t + 1.1)
///                                + 0.1 sin(2pi 2.3 t + 2.3)))           (>= 0)
///   across = speed * gust * 0.25 * sin(2pi 0.53 t + 0.4)
/// `along` follows wind_direction, `across` the horizontal (z-up) perpendicular of it.
void tsk_refine_wind_at(const tsk_refine_bend_def* def, double t, float out[3]);

/// Simulates the blade (rest knots [knot_count][3], widths [knot_count]) under the
/// standard wind, starting at rest, and writes out_trajectories [frame_count][knot_count][3]
/// at t = warmup + f / fps. knot_count 2..TSK_REFINE_MAX_KNOTS; the total work
/// knots * steps is limited to 4e9 (TSK_ERR_LIMIT). Returns TSK_ERR_INTERNAL if the state
/// becomes non-finite (a time step forced too long).
tsk_status tsk_refine_simulate(const tsk_refine_bend_def* def, const float* knots,
                               const float* widths, size_t knot_count, size_t frame_count,
                               float* out_trajectories);

#ifdef __cplusplus
}
#endif
#endif
