/* Tussock blade simulation: every blade of a touched meadow tile is simulated as a chain of
 * K knots with the position-based solver of Han & Harada 2012 ("Real-time hair simulation
 * with efficient hair style preservation", the basis of AMD TressFX) and tiles are activated
 * and released as colliders pass (tile management of Fan et al. 2015).
 * Specification: seed 000 (Fan & Sheng) §1, §3, §4.5, §5 and Table 1. */
#ifndef TUSSOCK_SIM_H
#define TUSSOCK_SIM_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- limits -------------------------------------------------------------------------------- */

/// Knots per blade: 2..64 (seed 000 §1: "no more than 64 vertices", 16 typical).
#define TSK_BLADE_SIM_MIN_KNOTS 2
#define TSK_BLADE_SIM_MAX_KNOTS 64
/// Most colliders per step; more returns TSK_ERR_LIMIT.
#define TSK_BLADE_SIM_MAX_COLLIDERS 4096
/// Most tiles in the grid (tiles_x * tiles_y); more returns TSK_ERR_LIMIT.
#define TSK_BLADE_SIM_MAX_TILES (1 << 24)
/// Most blades in one tile; more returns TSK_ERR_LIMIT.
#define TSK_BLADE_SIM_MAX_BLADES_PER_TILE 65536
/// Most length-constraint iterations per step.
#define TSK_BLADE_SIM_MAX_ITERATIONS 64
/// Largest |coordinate| in metres (1000 km) of the grid origin, ground height, collider ends
/// and rest knots, and the largest tile size, collider radius, collision and activation
/// margins and blade height: beyond, squared distances in the solver's float arithmetic
/// overflow (a collider of radius 3e38 made every knot NaN). TSK_ERR_ARGUMENT above.
#define TSK_BLADE_SIM_MAX_COORD 1.0e6f
/// Largest |component| of gravity (m/s^2) and of wind velocities (m/s); TSK_ERR_ARGUMENT above.
#define TSK_BLADE_SIM_MAX_ACCEL 1.0e4f
#define TSK_BLADE_SIM_MAX_WIND 1.0e4f
/// Largest wind_drag / linear_density, 1/(m s): the drag fraction per step (that times width
/// and dt) is capped at 1 far below it; beyond, it overflows. TSK_ERR_ARGUMENT above.
#define TSK_BLADE_SIM_MAX_DRAG 1.0e30

/* ---- definition ---------------------------------------------------------------------------- */

/// Grid, solver and tile-management parameters. Units: metres, seconds, kilograms.
///
/// Force model, per knot k of full width w_k (m) with velocity v_k = (x_k - x_k,prev) / dt:
///   a_k = g - preload_k + (wind_drag / linear_density) * w_k * (wind_k - v_k)      [m/s^2]
/// i.e. linear air drag wind_drag * w * (relative velocity) per metre of blade on a blade of
/// linear_density kg per metre (the drag step is capped so that it never reverses the relative
/// velocity). Velocity also decays as exp(-damping t). preload_k = gravity_preload * g in the
/// rest pose; its component along the segment turns with the segment.
/// Every per-step "rate" r (1/s) turns into the fraction 1 - exp(-r dt) of the error that the
/// constraint removes in a step of dt seconds: an error left to that constraint alone decays as
/// exp(-r t), whatever the frame rate.
typedef struct tsk_blade_sim_def {
    /* tile grid (the same layout as the meadow): tile (i, j) has index j*tiles_x + i and
       covers [origin.x + i*tile_size, +tile_size) x [origin.y + j*tile_size, +tile_size). */
    float origin[3]; ///< metres (default 0, 0, 0); origin.z is not used, see ground_height
    float tile_size; ///< metres, > 0 (default 0.5)
    int32_t tiles_x, tiles_y; ///< >= 1 each, product <= TSK_BLADE_SIM_MAX_TILES (default 20 x 20)
    int32_t knot_count; ///< knots per blade, 2..64, root first (default 16)

    /* forces */
    float gravity[3]; ///< m/s^2 (default 0, 0, -9.81). The rest pose is taken to be the
        ///< shape the blade holds under gravity: see gravity_preload.
    float gravity_preload; ///< 0..1 (default 1): fraction of gravity the blade carries in its
        ///< rest pose. The carrying force turns with the blade, so a blade
        ///< pressed flat droops; 0 = the rest pose sags under gravity.
    float damping; ///< 1/s, >= 0 (default 4): velocity decays as exp(-damping t)
    float wind_drag; ///< kg/(m^2 s), >= 0 (default 0.2): linear air drag per unit blade
        ///< area per unit relative speed
    float linear_density; ///< kg/m, > 0 (default 1e-3): mass per metre of blade;
        ///< wind_drag / linear_density <= TSK_BLADE_SIM_MAX_DRAG

    /* constraints (Han & Harada 2012) */
    float global_stiffness_root; ///< 1/s, >= 0 (default 30): pull toward the rest pose at the root
    float global_stiffness_tip; ///< 1/s, >= 0 (default 1): the same at the tip; the per-step
        ///< fraction is interpolated linearly in arc length between them
    float local_stiffness; ///< 1/s, >= 0 (default 120): pull of each segment toward its rest
        ///< direction in its parent segment's frame (bending, twisting);
        ///< the per-step fraction is capped at 0.95 (beyond, the root-to-tip
        ///< sweep overshoots)
    int32_t iterations; ///< length + collision iterations per step, 1..64 (default 4)

    /* collisions */
    float ground_height; ///< metres (default 0): no knot goes below z = ground_height
    float collision_margin; ///< metres, >= 0 (default 0.002): added to every collider's radius
        ///< (half a blade's thickness, so the surface does not cut through)

    /* tile management (Fan et al. 2015) */
    float activation_margin; ///< metres, >= 0 (default 0.1): a tile activates when a collider's
        ///< bounds grown by this margin touch it
    float max_blade_height; ///< metres, > 0 (default 1): height above ground_height that a tile's
        ///< blades may reach; colliders entirely above it activate nothing
    float rest_distance; ///< metres, > 0 (default 0.002): a tile is quiet when every knot is
        ///< closer than this to its rest position ...
    float rest_speed; ///< m/s, > 0 (default 0.02): ... and slower than this
    int32_t rest_frames; ///< >= 1 (default 30): quiet steps, untouched, before blending back
    int32_t blend_frames; ///< >= 1 (default 8): steps over which a quiet tile blends linearly
        ///< back to its exact rest pose; then it is released and freed
    int32_t settle_frames; ///< >= 1 (default 120): untouched steps after which a tile blends back
        ///< even if it never gets quiet (wind keeps its blades bent or
        ///< moving, so the simulated set would otherwise only grow) ...
    int32_t settle_blend_frames; ///< >= 1 (default 48): ... over this many steps, longer than
        ///< blend_frames: the blades may be far from rest
} tsk_blade_sim_def;

/// Defaults as documented on each field.
tsk_blade_sim_def tsk_default_blade_sim_def(void);

/* ---- colliders ----------------------------------------------------------------------------- */

typedef enum tsk_collider_kind {
    TSK_COLLIDER_SPHERE = 0, ///< centre a, radius
    TSK_COLLIDER_CAPSULE = 1, ///< segment a-b swept by a sphere of radius
} tsk_collider_kind;

/// A collider for one step. Positions in metres (world space, like the rest knots).
typedef struct tsk_blade_collider {
    int32_t kind; ///< tsk_collider_kind
    float radius; ///< metres, > 0
    float a[3]; ///< sphere centre, or capsule end a
    float b[3]; ///< capsule end b (ignored for spheres)
} tsk_blade_collider;

/* ---- wind ---------------------------------------------------------------------------------- */

/// How the wind passed to tsk_blade_sim_step is laid out (velocities in m/s, xyz interleaved).
typedef enum tsk_wind_layout {
    TSK_WIND_NONE = 0, ///< no wind (the pointer may be NULL)
    TSK_WIND_UNIFORM = 1, ///< 3 floats: one velocity for every knot
    TSK_WIND_PER_BLADE = 2, ///< 3 floats per active blade, in tsk_blade_sim_get_active order
    TSK_WIND_PER_KNOT = 3, ///< 3K floats per active blade, knots root first, same order
} tsk_wind_layout;

/* ---- the simulation ------------------------------------------------------------------------ */

/// A tile grid with its active tiles. Not thread-safe: one caller at a time (the work inside
/// tsk_blade_sim_step runs in parallel).
typedef struct tsk_blade_sim tsk_blade_sim;

/// Validates `def` (messages name the field; TSK_ERR_LIMIT for knot_count > 64, too many tiles
/// or iterations; TSK_ERR_ARGUMENT for lengths beyond TSK_BLADE_SIM_MAX_COORD and gravity beyond
/// TSK_BLADE_SIM_MAX_ACCEL) and creates an empty simulation (no tile active, no per-tile memory).
tsk_status tsk_blade_sim_create(const tsk_blade_sim_def* def, tsk_blade_sim** out);
/// Frees the simulation and every tile it holds. NULL is ignored.
void tsk_blade_sim_destroy(tsk_blade_sim* sim);

/// A deep copy of the whole state: definition, active tiles with their blades, pending and
/// touched tiles, colliders, rest counters. The copy and the original are independent; stepping
/// both the same way gives the same bytes. This is how callers keep snapshots of a simulation
/// (to go back in time without starting again from rest): keep a clone, and clone it again to
/// resume from it. Memory: about info.state_bytes plus a few hundred bytes. On failure *out is
/// NULL and nothing is leaked.
tsk_status tsk_blade_sim_clone(const tsk_blade_sim* sim, tsk_blade_sim** out);

/// Sets the colliders for the next step (copied; count 0..TSK_BLADE_SIM_MAX_COLLIDERS, more
/// returns TSK_ERR_LIMIT; a radius or end beyond TSK_BLADE_SIM_MAX_COORD is refused) and updates tile activation: every tile whose square, between
/// ground_height and ground_height + max_blade_height, meets a collider's bounding box grown by
/// activation_margin is "touched". A touched tile that is not active becomes pending: it needs
/// its rest blades (tsk_blade_sim_get_pending, tsk_blade_sim_provide_tile). A pending tile that
/// is no longer touched stops being pending. Touched active tiles never start to rest.
tsk_status tsk_blade_sim_set_colliders(tsk_blade_sim* sim, const tsk_blade_collider* colliders,
                                       int32_t count);

/// Makes a tile pending (or keeps it active) as if touched, without a collider: for scripted
/// disturbances and benchmarks. It rests and is released like any other tile.
tsk_status tsk_blade_sim_activate_tile(tsk_blade_sim* sim, int32_t tile);

/// Number of pending tiles, and their indices in ascending order into `tiles` (caller-owned,
/// at least tsk_blade_sim_pending_count entries).
int32_t tsk_blade_sim_pending_count(const tsk_blade_sim* sim);
tsk_status tsk_blade_sim_get_pending(const tsk_blade_sim* sim, int32_t* tiles);

/// Gives a pending (or any inactive) tile its rest blades and activates it. The state is
/// allocated here (tsk_alloc) and starts from the rest pose, so nothing pops.
///  - knots: blade_count * K * 3 floats, world metres, each blade root first; the root is pinned
///  - widths: blade_count * K floats, full blade width at each knot, metres, >= 0 (wind drag)
///  - sides: blade_count * 3 floats, the blade's side direction (width direction) at rest, or
///    NULL (then a horizontal direction perpendicular to the first segment is used); it fixes the
///    blade's material frame, so bending keeps its direction relative to the blade's face.
/// These are what tsk_meadow_realise_knots writes for one tile. blade_count 0 marks the tile as
/// empty (active, no memory, nothing to simulate). Errors: tile out of range, non-finite values,
/// a knot coordinate beyond TSK_BLADE_SIM_MAX_COORD, negative widths, a zero-length segment,
/// blade_count > TSK_BLADE_SIM_MAX_BLADES_PER_TILE; TSK_ERR_LIMIT when the state of every
/// active tile with this one would exceed the memory budget (tsk_memory_check).
tsk_status tsk_blade_sim_provide_tile(tsk_blade_sim* sim, int32_t tile, int32_t blade_count,
                                      const float* knots, const float* widths, const float* sides);

/// Advances every active tile by dt seconds (0 < dt <= 1): Verlet integration with damping,
/// gravity and wind drag; global and local shape constraints; `iterations` rounds of length
/// constraints and collisions; collisions and ground last, so after the step no knot lies inside
/// a collider (grown by collision_margin) or below the ground (roots are pinned where they were
/// provided, wherever that is) (for colliders that do not
/// overlap each other). Then tiles that have been quiet and untouched for rest_frames steps blend
/// back to rest over blend_frames steps and are released (memory freed). `wind` as `layout`
/// says; non-finite wind or a component beyond TSK_BLADE_SIM_MAX_WIND returns TSK_ERR_ARGUMENT
/// and leaves the state unchanged.
/// Deterministic and independent of the thread count.
tsk_status tsk_blade_sim_step(tsk_blade_sim* sim, float dt, const float* wind,
                              tsk_wind_layout layout);

/// Summary of the current state.
typedef struct tsk_blade_sim_info {
    int32_t knot_count;
    int32_t active_tiles; ///< tiles with rest data (including empty ones)
    int64_t active_blades; ///< blades in active tiles
    int32_t pending_tiles; ///< touched tiles waiting for rest data
    int32_t blending_tiles; ///< active tiles blending back to rest
    int32_t collider_count;
    size_t state_bytes; ///< bytes of per-tile state held (0 when no tile is active)
} tsk_blade_sim_info;

tsk_status tsk_blade_sim_get_info(const tsk_blade_sim* sim, tsk_blade_sim_info* info);

/// Active tiles in ascending index order: tile index and blade count (caller arrays of
/// info.active_tiles entries; either may be NULL). This is the order of wind input and knots.
tsk_status tsk_blade_sim_get_active(const tsk_blade_sim* sim, int32_t* tiles,
                                    int32_t* blade_counts);

/// Current knots of every active blade, active tiles in order, blades in the order provided,
/// K knots root first, xyz interleaved: info.active_blades * K * 3 floats (caller-owned).
tsk_status tsk_blade_sim_get_knots(const tsk_blade_sim* sim, float* knots);

/// Ribbon vertices (seed 000 §4.5) of `count` active blades from active blade `first` on, in
/// the order of tsk_blade_sim_get_knots: the bytes tsk_blades_expand(knots, widths, sides,
/// count, K, positions, NULL, NULL) gives on those blades' knots, made without copying the
/// knots out of the solver. widths: count * K floats (finite, >= 0), sides: count * 3 (finite,
/// non-zero), positions: count * 2K * 3 floats (caller-owned). A bad width or side, or a
/// non-finite knot, is reported for the first such blade (its index in widths and sides);
/// positions are then partly written.
tsk_status tsk_blade_sim_get_ribbons(const tsk_blade_sim* sim, int64_t first, int64_t count,
                                     const float* widths, const float* sides, float* positions);

/// Ribbon vertices, as tsk_blade_sim_get_ribbons makes them, of the active blades in
/// `run_count` runs: run r is the counts[r] blades from active blade starts[r] on. The runs'
/// blades follow each other, run by run, in widths (K floats per blade), sides (3) and
/// positions (2K * 3, caller-owned). Runs may overlap or come in any order; each must lie
/// within the active blades (TSK_ERR_ARGUMENT names the first that does not). A bad width,
/// side or knot is reported as tsk_blade_sim_get_ribbons does, the blade named by its index
/// in widths and sides.
tsk_status tsk_blade_sim_get_ribbon_runs(const tsk_blade_sim* sim, const int64_t* starts,
                                         const int64_t* counts, int64_t run_count,
                                         const float* widths, const float* sides, float* positions);

/// Current knots of one active tile: its blade_count * K * 3 floats. TSK_ERR_ARGUMENT if the
/// tile is not active.
tsk_status tsk_blade_sim_get_tile_knots(const tsk_blade_sim* sim, int32_t tile, float* knots);

/// Whether a tile is active (1), pending (2) or neither (0); -1 for an index out of range.
int32_t tsk_blade_sim_tile_state(const tsk_blade_sim* sim, int32_t tile);

#ifdef __cplusplus
}
#endif
#endif
