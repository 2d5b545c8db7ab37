/* Tussock wind: one wind that blades, branches and pictures all sample. It sums a
 * steady breeze, up to 8 travelling sine waves (seed 001, eq. 11-14) with gusts, and a
 * 2D stable-fluids grid on the ground plane (seed 004, eq. 1-2) pushed by sources; a
 * wave-equation continuum (seed 004, eq. 3-4) driven by the fluid gives vegetation sway.
 *
 * Coordinates: the ground plane is world (x, y); z is up and ignored by the wind. The
 * fluid/continuum grid covers [origin_x, origin_x + nx*cell_size] x [origin_y, origin_y +
 * ny*cell_size]; outside it the fluid contributes its boundary value (zero-gradient).
 * Units: metres, seconds, m/s unless stated. All buffers are owned by the caller.
 * Threads: a handle may be sampled from several threads at once, but not while another
 * thread steps it, changes it or destroys it (the library itself runs in parallel inside
 * each call). */
#ifndef TUSSOCK_WIND_H
#define TUSSOCK_WIND_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

enum {
    TSK_WIND_MAX_WAVES = 8, ///< sine waves per parameter set
    TSK_WIND_MAX_SOURCES = 64, ///< fluid sources per handle
    TSK_WIND_MAX_GRID = 1024, ///< cells per side of the fluid grid (TSK_ERR_LIMIT above)
    TSK_WIND_MIN_GRID = 4, ///< cells per side of the fluid grid (TSK_ERR_ARGUMENT below)
    TSK_WIND_BLEND_HISTORY = 4, ///< parameter sets kept for cross-fading (oldest dropped)
    TSK_WIND_MAX_ITERATIONS = 10000, ///< pressure solver iterations per step
};

/// One travelling sine wave (seed 001, eq. 11 and 14). Its contribution to the wind is
///   W = A * ((sin(theta) + 1) / 2)^k * D,  theta = (2 pi / L) * (D . (x, y) - s t) + phase
/// so the wave pushes along D with a speed between 0 and A (never against D), crests move
/// downwind along D at speed s, and k > 1 sharpens the peaks and widens the calm troughs.
/// Departures from the printed eq. 14, on purpose: its (sin/2)^k is undefined for
/// non-integer k where sin < 0, so we use the ((sin + 1) / 2)^k of [Fer04] that the seed
/// cites for k; its 1/l (branch segment length) is applied by the tree module; and the time
/// term has the sign that moves crests downwind (a negative s gives the seed's +t phi).
/// Evaluated in float: points more than ~1e5 wavelengths from the origin lose phase detail
/// (the result stays bounded).
typedef struct tsk_wind_wave {
    float amplitude; ///< A, peak wind speed of this wave, m/s, 0..100
    float dir_x; ///< D, direction on the ground plane (normalised internally, not 0)
    float dir_y;
    float wavelength; ///< L, distance between crests, m, > 0 (0.01..1e5)
    float speed; ///< s, crest speed along D, m/s (negative: crests move upwind), |s| <= 1000
    float phase; ///< phase offset, radians, |phase| <= 1e4
    float power; ///< k, peak sharpness (seed 001 eq. 14), 0.1..64; 1 = plain sine
} tsk_wind_wave;

/// Gusts: short, smooth speed boosts along a direction, at deterministic random times.
/// Time is cut into slots of `interval` seconds; slot j holds one gust that starts at a
/// random time inside the slot (so it ends inside it), lasts `duration` and has a random
/// peak between strength/2 and strength; its shape in time is a raised cosine
/// (0.5 - 0.5 cos), so speed and its derivative are continuous. The gust front travels
/// across the ground along D at `front_speed`: a point p feels the gust of local time
/// t - (D . p) / front_speed. Randomness: tsk_rand01(seed, slot, ...).
typedef struct tsk_wind_gust_def {
    float strength; ///< peak extra speed, m/s, 0..100 (0 = no gusts)
    float interval; ///< slot length, the mean time between gusts, s, > 0
    float duration; ///< s, 0 < duration <= interval
    float dir_x; ///< D (normalised internally, not 0)
    float dir_y;
    float front_speed; ///< m/s, 0 or 0.001..1e4; 0 = the whole scene feels the gust at once
    uint64_t seed;
} tsk_wind_gust_def;

/// The analytic part of the wind: a steady breeze, sine waves and gusts.
typedef struct tsk_wind_sines_def {
    float base_x; ///< steady wind, m/s (|base| <= 100)
    float base_y;
    int wave_count; ///< 0..TSK_WIND_MAX_WAVES
    tsk_wind_wave waves[TSK_WIND_MAX_WAVES];
    tsk_wind_gust_def gust;
} tsk_wind_sines_def;

/// The stable-fluids grid (seed 004, eq. 1-2 after Stam 1999) on the ground plane.
/// Velocities inside the solver are normalised: |v| <= 1 (seed 004), and 1 means `speed`
/// m/s in the world. Boundaries are open: pressure 0 outside the grid (Dirichlet), so flow
/// leaves and enters freely, and values beyond the edge repeat the edge (zero gradient).
typedef struct tsk_wind_fluid_def {
    int nx, ny; ///< cells; 0 and 0 = no fluid grid; else 4..1024 each
    float origin_x, origin_y; ///< world position of the grid's corner, m
    float cell_size; ///< m, > 0
    float dt; ///< s per step, 1e-4..1 (fixed so that steps are reproducible)
    float speed; ///< m/s that a normalised velocity of 1 means, 0..100
    float viscosity; ///< m^2/s, >= 0 (0 skips the diffusion solve)
    float decay; ///< 1/s, >= 0: velocity falls by exp(-decay dt) per step
    int pressure_iterations; ///< Jacobi iterations per step, 1..TSK_WIND_MAX_ITERATIONS
    float pressure_tolerance; ///< 0 = always run all iterations; > 0 = stop early when
        ///< max |divergence| (normalised velocity per cell) < this
    int diffusion_iterations; ///< Jacobi iterations of the viscosity solve, 1..1000
} tsk_wind_fluid_def;

/// The vegetation continuum (seed 004, eq. 3-4): a 2D wave on the fluid grid (same cells),
///   a = c^2 lap(Vp) + drive (Vf - Vp),   Vp+ = (1 + gamma) Vp - gamma Vp- + a dt^2
/// where Vf is the fluid velocity sampled bilinearly at the cell centre. Stability of this
/// scheme needs dt^2 (8 c^2 / cell^2 + drive) < 2 (1 + gamma); otherwise creation fails.
/// Edges absorb outgoing waves (Mur's first-order condition).
typedef struct tsk_wind_continuum_def {
    int enabled; ///< 0 = no continuum (requires a fluid grid when 1)
    float c; ///< wave speed, m/s, >= 0 (seed 004 used 1..10 grid units)
    float gamma; ///< seed 004 eq. 4 gamma, 0..1: share of the last step's change kept
        ///< (1 = undamped; amplitudes fall by sqrt(gamma) per step)
    float drive; ///< 1/s^2, >= 0: spring pulling Vp to the wind; (2 pi f)^2 sways at f Hz
} tsk_wind_continuum_def;

/// Everything a wind handle needs.
typedef struct tsk_wind_def {
    tsk_wind_sines_def sines;
    tsk_wind_fluid_def fluid;
    tsk_wind_continuum_def continuum;
} tsk_wind_def;

/// A fluid source (seed 004, III-C): at each push it sets the fluid velocity inside its
/// radius towards strength * D, weighted by the smooth falloff (1 - (r/R)^2)^2.
typedef struct tsk_wind_source {
    float x, y; ///< world position on the ground plane, m
    float dir_x, dir_y; ///< push direction (normalised internally, not 0)
    float strength; ///< 0..1, normalised speed set at the centre
    float radius; ///< m, > 0
    float interval; ///< s between pushes, >= 0 (0 = every step); the "frequency" of
        ///< seed 004. A push happens in the step [t, t + dt) that
        ///< contains a time start + n * interval (n = 0, 1, ...).
    float start; ///< s, time of the first push
} tsk_wind_source;

typedef struct tsk_wind tsk_wind;

/// Defaults: 2 m/s breeze along +x, 2 gentle waves, weak gusts, a 64x64 grid of 0.5 m
/// cells at 1/60 s per step, continuum c = 4 m/s, gamma = 0.98, sway 0.5 Hz.
tsk_wind_sines_def tsk_default_wind_sines_def(void);
tsk_wind_gust_def tsk_default_wind_gust_def(void);
tsk_wind_wave tsk_default_wind_wave(void);
tsk_wind_fluid_def tsk_default_wind_fluid_def(void);
tsk_wind_continuum_def tsk_default_wind_continuum_def(void);
tsk_wind_def tsk_default_wind_def(void);
tsk_wind_source tsk_default_wind_source(void);

/// Checks a definition without creating anything (the same checks as tsk_wind_create).
/// Errors name the field, e.g. "fluid.nx", "sines.waves[2].wavelength", "continuum.c".
tsk_status tsk_wind_def_validate(const tsk_wind_def* def);
tsk_status tsk_wind_sines_def_validate(const tsk_wind_sines_def* def);

/// Creates a wind at time 0 with still air in the grid. *out is NULL on failure.
tsk_status tsk_wind_create(const tsk_wind_def* def, tsk_wind** out);
/// Frees a wind. NULL is ignored.
void tsk_wind_destroy(tsk_wind* wind);

/// Replaces the sines, gusts and breeze, cross-fading from what blew before over
/// [start_time, start_time + blend_time] with a smoothstep weight, so that nothing jumps
/// (changing a wave in place would, as seed 001 warns). blend_time 0 switches at
/// start_time. Sampling before start_time still gives the old wind. Up to
/// TSK_WIND_BLEND_HISTORY sets are kept; when full, the oldest is dropped.
tsk_status tsk_wind_set_sines(tsk_wind* wind, const tsk_wind_sines_def* def, double start_time,
                              double blend_time);

/// Replaces the fluid sources (count 0..TSK_WIND_MAX_SOURCES; `sources` may be NULL if 0).
tsk_status tsk_wind_set_sources(tsk_wind* wind, const tsk_wind_source* sources, size_t count);

/// Advances fluid and continuum by `steps` fixed steps (0..1e6) of fluid.dt. The time
/// advances even without a grid. Deterministic and independent of the thread count.
tsk_status tsk_wind_step(tsk_wind* wind, int steps);

/// Current simulation time, s (steps * dt).
double tsk_wind_time(const tsk_wind* wind);

/// Saved states, so that a timeline can go back without stepping again from time 0: a state
/// holds everything later steps and samples read (the clock, the sines history, the
/// sources, the fluid velocities and the pressure warm start, the continuum's two time
/// levels). Loading a state into a wind made from the same fluid and continuum definition
/// makes it step and sample bit for bit as the saving wind did from then on.
/// Size of a state of this wind, bytes (0 for NULL); about 28 bytes per grid cell.
size_t tsk_wind_state_size(const tsk_wind* wind);
/// Writes the state into buf of exactly tsk_wind_state_size(wind) bytes.
tsk_status tsk_wind_save_state(const tsk_wind* wind, void* buf, size_t size);
/// Replaces the wind's state with a saved one. Refused with TSK_ERR_ARGUMENT, the wind left
/// unchanged, when the size is not the wind's state size, the bytes are not a state of
/// this format, were saved by a wind of another fluid or continuum definition, or hold
/// values a wind cannot reach (non-finite; a fluid speed beyond 1, a pressure beyond 1e9, a
/// continuum value beyond 1e4; bad sources or sines).
tsk_status tsk_wind_load_state(tsk_wind* wind, const void* buf, size_t size);

/// Samples the wind at `count` ground points (x[i], y[i]) at time t (s): the breeze,
/// waves and gusts are evaluated at t exactly; the fluid and continuum give their current
/// state (the caller steps them to t). vx, vy receive m/s. sway_x, sway_y (both NULL or
/// both given) receive the continuum value Vp (normalised, about -1..1; 0 without
/// continuum). Any output may alias no input. Non-finite x, y or t -> TSK_ERR_ARGUMENT.
tsk_status tsk_wind_sample(const tsk_wind* wind, double t, size_t count, const float* x,
                           const float* y, float* vx, float* vy, float* sway_x, float* sway_y);

/// As tsk_wind_sample with interleaved xyz points (3*count floats, z ignored) and xyz
/// velocities out (z = 0); sway_xyz may be NULL (else 3*count floats, z = 0).
tsk_status tsk_wind_sample_xyz(const tsk_wind* wind, double t, size_t count, const float* xyz,
                               float* vel_xyz, float* sway_xyz);

/// Grid size (0, 0 without fluid).
void tsk_wind_grid_size(const tsk_wind* wind, int* nx, int* ny);

/// Copies the fluid velocity at cell centres (normalised, |v| <= 1), row-major, y rows of
/// nx cells, into vx, vy of exactly `count` = nx*ny floats each (for a debug image).
tsk_status tsk_wind_read_fluid(const tsk_wind* wind, float* vx, float* vy, size_t count);

/// Copies the continuum Vp at cell centres into px, py (count = nx*ny each).
tsk_status tsk_wind_read_continuum(const tsk_wind* wind, float* px, float* py, size_t count);

#ifdef __cplusplus
}
#endif
#endif
