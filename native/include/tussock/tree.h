/* Tussock trees: Weber–Penn (1995) parametric trees whose stems are cubic Bézier curves,
 * the branch deformer of seed 001 §3 (taper, flare, bulges, lobes, generalized de Casteljau
 * bending with Sloan frames, normals through the Jacobian), leaves as cards, Catmull–Clark
 * smoothing through OpenSubdiv, and the per-branch wind step of seed 001 §4 (eq. 15–17).
 *
 * Coordinates: metres, Z up, the trunk grows from the origin along +Z. Angles in the
 * definition are in degrees (as in Weber & Penn's tables); attachment angles read back
 * from a tree are in radians. */
#ifndef TUSSOCK_TREE_H
#define TUSSOCK_TREE_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/// Most recursion levels (Weber–Penn: trunk = level 0 ... level 3).
#define TSK_TREE_MAX_LEVELS 4
/// Most children (Branches) or leaves (Leaves) one stem may carry.
#define TSK_TREE_MAX_CHILDREN 10000
/// Hard upper bound of tsk_tree_def.max_branches and .max_leaves.
#define TSK_TREE_HARD_LIMIT (1u << 22)

/// Per-level Weber–Penn parameters ("nLength", "nTaper", ... for n = 0..3). DownAngle,
/// Rotate and Branches of level n describe how stems of level n sit on (and how many grow
/// from) their level n-1 parent; those of level 0 are unused.
typedef struct tsk_tree_level_def {
    float length; ///< nLength: length as a fraction of the parent's (level 0: of Scale)
    float length_v; ///< nLengthV: ± variation of length
    float taper; ///< nTaper: 0 = cylinder ... 1 = cone to a point (seed eq. 2 amount)
    float seg_splits; ///< nSegSplits: clones per segment (error-diffused), 0 = none
    float split_angle; ///< nSplitAngle: degrees between a clone and its stem
    float split_angle_v; ///< nSplitAngleV: ± degrees
    int curve_res; ///< nCurveRes: segments along the stem (1..64)
    float curve; ///< nCurve: total bend of the stem, degrees
    float curve_back; ///< nCurveBack: bend of the second half (S-curve), degrees; 0 = none
    float curve_v; ///< nCurveV: ± random bend per stem, degrees
    float down_angle; ///< nDownAngle: degrees between a child and its parent
    float down_angle_v; ///< nDownAngleV: ± degrees; negative = varies with position on parent
    float rotate; ///< nRotate: degrees around the parent between successive children
    float rotate_v; ///< nRotateV: ± degrees
    int branches; ///< nBranches: most children of a parent of level n-1 (0..10000)
} tsk_tree_level_def;

/// Weber–Penn tree shapes (ShapeRatio of the paper).
typedef enum tsk_tree_shape {
    TSK_TREE_CONICAL = 0,
    TSK_TREE_SPHERICAL = 1,
    TSK_TREE_HEMISPHERICAL = 2,
    TSK_TREE_CYLINDRICAL = 3,
    TSK_TREE_TAPERED_CYLINDRICAL = 4,
    TSK_TREE_FLAME = 5,
    TSK_TREE_INVERSE_CONICAL = 6,
    TSK_TREE_TEND_FLAME = 7,
} tsk_tree_shape;

/// A whole tree: Weber & Penn 1995, Table 1, plus the extra deformer controls of seed 001
/// (bulges, lobe fade, taper power) and limits.
typedef struct tsk_tree_def {
    uint64_t seed; ///< random seed; the same def gives the same tree, byte for byte
    int shape; ///< tsk_tree_shape (0..7)
    float base_size; ///< BaseSize: fraction of the trunk without branches (0..1)
    float scale, scale_v; ///< Scale, ScaleV: tree size and ± variation (m)
    float z_scale, z_scale_v; ///< ZScale, ZScaleV: vertical stretch of the trunk and ± variation
    int levels; ///< Levels: 1..4
    float ratio; ///< Ratio: trunk radius / trunk length
    float ratio_power; ///< RatioPower: child radius = parent radius * (Lc/Lp)^RatioPower
    int lobes; ///< Lobes: lobes around the trunk (seed eq. 5, l_n)
    float lobe_depth; ///< LobeDepth: lobe amplitude (l_d)
    float flare; ///< Flare: extra trunk radius at the ground (seed eq. 3, f)
    float scale0, scale0_v; ///< 0Scale, 0ScaleV: trunk radius multiplier and ± variation
    int base_splits; ///< 0BaseSplits: clones of the trunk at the top of its first segment
    tsk_tree_level_def level[TSK_TREE_MAX_LEVELS];
    int leaves; ///< Leaves: leaves per stem of the last level (0 = none)
    int leaf_shape; ///< LeafShape: 0..9, carried for the material (cards are quads)
    float leaf_scale; ///< LeafScale: leaf length (m)
    float leaf_scale_x; ///< LeafScaleX: leaf width / leaf length
    float attraction_up; ///< AttractionUp: bend of level >= 2 stems toward (+) or away from up
    float prune_ratio; ///< PruneRatio: 0 = no pruning ... 1 = full pruning to the envelope
    float prune_width; ///< PruneWidth: envelope half width / Scale
    float prune_width_peak; ///< PruneWidthPeak: height fraction of the widest envelope point
    float prune_power_low; ///< PrunePowerLow: envelope curvature below the peak
    float prune_power_high; ///< PrunePowerHigh: envelope curvature above the peak
    /* seed 001 deformer extras (not in Weber–Penn) */
    float taper_power; ///< exponent t of seed eq. 2, r(1 - taper v^t); 1 = Weber–Penn
    float lobe_fade; ///< l_t of seed eq. 5: 0 = lobes up the whole trunk, 1 = fade to tip
    int bulges; ///< b_n of seed eq. 4 (bulges along every stem), 0 = none
    float bulge_depth; ///< b_d of seed eq. 4
    /* limits */
    uint32_t max_branches; ///< refuse (TSK_ERR_LIMIT) trees with more stems (<= 2^22)
    uint32_t max_leaves; ///< refuse trees with more leaves (<= 2^22)
} tsk_tree_def;

/// Defaults: a small two-level tree (every field set; change what you need).
tsk_tree_def tsk_default_tree_def(void);

/// Number of built-in presets.
int tsk_tree_preset_count(void);
/// Name of preset i ("quaking_aspen", ...), NULL when out of range.
const char* tsk_tree_preset_name(int index);
/// Fills *out with the named preset (Weber & Penn's tables, via Blender's Sapling presets).
tsk_status tsk_tree_preset(const char* name, tsk_tree_def* out);

/// Checks every field; the message names the first bad one (e.g. "level[2].branches: ...").
tsk_status tsk_tree_validate(const tsk_tree_def* def);

/// A generated tree: branches (one cubic Bézier each, stored parent-before-child and grouped
/// by depth), leaves, and the current wind pose. Opaque.
typedef struct tsk_tree tsk_tree;

/// Grows a tree. Returns TSK_ERR_LIMIT (naming max_branches/max_leaves) when the parameters
/// imply more stems or leaves than allowed, before allocating for them.
tsk_status tsk_tree_create(const tsk_tree_def* def, tsk_tree** out);
/// Frees a tree (NULL is ignored).
void tsk_tree_destroy(tsk_tree* tree);

/// Number of branches (stems, clones included) / leaves.
size_t tsk_tree_branch_count(const tsk_tree* tree);
size_t tsk_tree_leaf_count(const tsk_tree* tree);
/// Number of branches of Weber–Penn level `level` (0 = trunk and its clones).
size_t tsk_tree_level_branch_count(const tsk_tree* tree, int level);

/// Caller-owned arrays that tsk_tree_get_branches fills; any pointer may be NULL (skipped).
/// n = tsk_tree_branch_count.
typedef struct tsk_tree_branches {
    int32_t* parent; ///< n: index of the parent branch, -1 for the trunk (parent < index)
    int32_t* level; ///< n: Weber–Penn level (clones keep their stem's level)
    int32_t* depth; ///< n: steps from the trunk (non-decreasing with the index)
    float* points; ///< 12n: P0 P1 P2 P3 (xyz) of the current pose, metres
    float* rest; ///< 12n: P0..P3 of the rest pose
    float* attach; ///< 3n: v on the parent (0..1), theta around it, alpha down (radians)
    float* radius; ///< 2n: radius at the base and at the tip (m, before flare/lobes)
    float* length; ///< n: stem length (m)
    float* orient; ///< 3n: the orientation vector O of seed eq. 8 (unit), current pose
} tsk_tree_branches;

/// Copies branch data into the caller's arrays.
tsk_status tsk_tree_get_branches(const tsk_tree* tree, const tsk_tree_branches* out);

/// Leaves of the current pose, caller-owned arrays of m = tsk_tree_leaf_count entries, any
/// may be NULL: position (3m, base of the leaf on its stem), direction (3m, unit, along the
/// leaf), normal (3m, unit, card normal), size (2m: length, width in m), parent (m).
tsk_status tsk_tree_get_leaves(const tsk_tree* tree, float* position, float* direction,
                               float* normal, float* size, int32_t* parent);

/// Tip (P3) of every branch in the current pose, 3n floats, for sampling a wind field.
tsk_status tsk_tree_tip_positions(const tsk_tree* tree, float* xyz);

/* ---- wind (seed 001 §4.2–4.3) --------------------------------------------------------- */

typedef enum tsk_tree_wind_mode {
    /// seed 001: every branch attaches to its parent's pose of the previous step, all in
    /// parallel; children lag one step per level.
    TSK_TREE_WIND_LAGGED = 0,
    /// walks the depths in order inside one step: children sit exactly on the moved parent.
    TSK_TREE_WIND_EXACT = 1,
} tsk_tree_wind_mode;

typedef struct tsk_tree_wind_def {
    int mode; ///< tsk_tree_wind_mode
    float strength; ///< multiplies every force (default 1)
    float bend_power; ///< exponent of the bend factor, seed eq. 16 (default 1.8)
    float length_power; ///< the force is divided by l^length_power, l = |P3 - P2| at rest;
        ///< 1 = seed eq. 14 (short twigs bend most), 0 = all alike (0..3)
} tsk_tree_wind_def;

tsk_tree_wind_def tsk_default_tree_wind_def(void);

/// One wind step. `force` holds 3n floats: the wind force at each branch's tip (sampled by
/// the caller, e.g. from the shared wind module at tsk_tree_tip_positions). Following seed
/// eq. 14 the tree divides it by the branch's P2–P3 distance (to the power
/// wind.length_power); eq. 16 turns it into bend
/// vectors b3 = F|F|^(p-1), b2 = (1/3)^p b3, and eq. 17 moves P2 and P3 keeping the segment
/// lengths. A force of exactly zero everywhere gives the rest pose exactly.
tsk_status tsk_tree_wind_step(tsk_tree* tree, const float* force, const tsk_tree_wind_def* wind);

/// Puts the tree back into its rest pose.
void tsk_tree_reset_pose(tsk_tree* tree);

/// The lag error of seed §5 (0 in exact mode): the largest distance between a child's P0 and
/// the point at its v on its parent's current curve, in metres (max_metres) and divided by
/// the parent's radius there, that radius taken at least 10 % of the parent's base radius so
/// that tapered tips do not divide by zero (max_relative_gap). Either pointer may be NULL.
tsk_status tsk_tree_attachment_gap(const tsk_tree* tree, double* max_relative_gap,
                                   double* max_metres);

/* ---- mesh (seed 001 §3) ----------------------------------------------------------------- */

/// How finely branches are meshed. Per level: rings along the stem and vertices around.
typedef struct tsk_tree_mesh_def {
    int along[TSK_TREE_MAX_LEVELS]; ///< quads along a stem of each level (1..256)
    int around[TSK_TREE_MAX_LEVELS]; ///< vertices around a stem of each level (3..256)
    int leaves; ///< 1: add leaf cards (one quad each, after all branches)
} tsk_tree_mesh_def;

/* Smooth option: build a tsk_subdiv (below) once from the cage topology and apply it to
 * every deformed cage; leaves are better left out of a smoothed cage (mesh.leaves = 0). */

tsk_tree_mesh_def tsk_default_tree_mesh_def(void);

/// Sizes of the cage mesh (before smoothing): vertices, quads. Faces are always quads.
tsk_status tsk_tree_mesh_count(const tsk_tree* tree, const tsk_tree_mesh_def* mesh,
                               size_t* vertex_count, size_t* face_count);

/// Writes the cage topology: faces (4 int32 per quad, vertex indices, counter-clockwise seen
/// from outside) and per-corner UVs (8 floats per quad: u,v of each corner; u = θ/2π, v
/// = length along the stem / circumference at its base). Topology depends only on the tree
/// and `mesh`, never on the pose.
tsk_status tsk_tree_mesh_topology(const tsk_tree* tree, const tsk_tree_mesh_def* mesh,
                                  int32_t* faces, float* corner_uvs);

/// The edges of the cage topology, for handing the mesh to Blender complete: for each branch
/// its rings' edges then the edges along it, then four per leaf card. Writes 2 vertex indices
/// per edge (edges: room for 2 * 4 * quads), the edge of every corner of the faces of
/// tsk_tree_mesh_topology (corner_edges: 4 * quads; the edge from that corner to the next)
/// and *edge_count. The same edges as tsk_mesh_edges derives from the faces, in closed form
/// (a tube of A quads along and C around has (2A + 1) C edges), so no hashing.
tsk_status tsk_tree_mesh_edges(const tsk_tree* tree, const tsk_tree_mesh_def* mesh, int32_t* edges,
                               int32_t* corner_edges, size_t* edge_count);

/// Deforms the cage for the current pose: positions and unit normals (3 floats per vertex
/// each; normals may be NULL). Seed eq. 1–10.
tsk_status tsk_tree_mesh_deform(const tsk_tree* tree, const tsk_tree_mesh_def* mesh,
                                float* positions, float* normals);

/* ---- deformer pieces, exposed for tests and tools ------------------------------------ */

/// Radius of the unbent branch (seed eq. 2–6): r (1 - taper v^t) f_flare f_bulges f_lobes.
typedef struct tsk_branch_shape {
    float radius, taper, taper_power, flare;
    float bulges, bulge_depth;
    float lobes, lobe_depth, lobe_fade;
} tsk_branch_shape;

float tsk_branch_radius(const tsk_branch_shape* shape, float v, float theta);

/// Surface point and unit normal of a branch given by Bézier points P (12 floats) and
/// orientation O (3 floats) at (v, theta) (seed eq. 7–10). normal may be NULL.
void tsk_branch_surface(const float* P, const float* O, const tsk_branch_shape* shape, float v,
                        float theta, float* position, float* normal);

/* ---- Catmull–Clark smoothing (OpenSubdiv) ---------------------------------------------- */

/// A refiner for one quad topology: built once (OpenSubdiv Far::TopologyRefiner and
/// Far::StencilTable), applied to any number of cage poses. Opaque.
typedef struct tsk_subdiv tsk_subdiv;

/// Builds the refiner for `face_count` quads over `vertex_count` vertices, `levels` uniform
/// Catmull–Clark levels (1..4).
tsk_status tsk_subdiv_create(const int32_t* quads, size_t face_count, size_t vertex_count,
                             int levels, tsk_subdiv** out);
void tsk_subdiv_destroy(tsk_subdiv* sd);
/// Vertices of the cage it was built for.
size_t tsk_subdiv_cage_vertex_count(const tsk_subdiv* sd);
/// Refined vertex and quad counts.
size_t tsk_subdiv_vertex_count(const tsk_subdiv* sd);
size_t tsk_subdiv_face_count(const tsk_subdiv* sd);
/// Refined quads (4 int32 per face).
tsk_status tsk_subdiv_faces(const tsk_subdiv* sd, int32_t* quads);
/// Applies the stencils to a cage pose: cage 3*vertex_count floats -> refined 3*refined.
tsk_status tsk_subdiv_apply(const tsk_subdiv* sd, const float* cage, float* refined);
/// Area-weighted unit vertex normals of a quad mesh (3 floats per vertex).
tsk_status tsk_quad_normals(const float* positions, size_t vertex_count, const int32_t* quads,
                            size_t face_count, float* normals);

#ifdef __cplusplus
}
#endif
#endif
