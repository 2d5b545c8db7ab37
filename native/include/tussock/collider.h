/* Collider shapes fitted to the true shape of objects (issue 43), in the row layout that the
 * blade simulation takes (tsk_blade_sim_set_colliders through the binding): 8 floats per
 * shape, kind (0 sphere, 1 capsule; -1 in a fit: no shape), radius, a xyz, b xyz.
 *
 * - An armature-deformed mesh gets one capsule per deforming bone: which vertices make each
 *   bone's limb is found once at rest (tsk_collider_fit_bones), and every frame each bone's
 *   capsule is fitted in its posed frame to where those vertices are now
 *   (tsk_collider_fit_groups). Bones whose vertices span less
 *   than a size limit (fingers, toes, face bones) give their vertices to their parent.
 * - Any other mesh gets a set of spheres that covers its surface: the leaves of a median
 *   split of its triangles, each the smallest sphere about its triangles' box centre that
 *   holds them (tsk_collider_fit_spheres).
 * Matrices are 4x4, row-major, mapping column vectors (Blender's Matrix as it is read row by
 * row). All arithmetic is IEEE double without contraction, in a fixed order: the same bytes
 * on every machine, as bakes split over a farm need. */
#ifndef TUSSOCK_COLLIDER_H
#define TUSSOCK_COLLIDER_H

#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/// Most points (vertices) and triangles a fit takes; more returns TSK_ERR_LIMIT.
#define TSK_COLLIDER_FIT_MAX_POINTS (1 << 24)
/// Most bones of a fit, and most spheres of a sphere fit (the simulation's collider limit).
#define TSK_COLLIDER_FIT_MAX_SHAPES 4096
/// Largest |coordinate| of a point or matrix translation, in metres (as tussock/sim.h).
#define TSK_COLLIDER_FIT_MAX_COORD 1.0e6f

/// Fits one capsule (or sphere) per bone to a mesh at rest.
/// points       point_count xyz: the mesh's rest vertices, in the mesh object's space
/// to_armature  4x4: mesh object space -> armature space (inverse(armature world) @ mesh
///              world at rest)
/// heads, tails bone_count xyz each: the bones' rest ends in armature space
/// rest         bone_count 4x4: each bone's rest matrix (bone space -> armature space;
///              Blender's Bone.matrix_local)
/// parent       bone_count: index of each bone's parent, or -1; a parent is any other bone
/// deforms      bone_count: non-zero for bones that deform the mesh (the only ones points
///              are given to)
/// min_size     metres, >= 0: a bone whose points (its own and those its children gave it)
///              span less than this along every axis of its space gives them to its parent
/// out          bone_count rows (8 floats) in each bone's space: kind 1 capsule or 0 sphere,
///              or kind -1 (radius 0) for a bone that holds no points
/// group        point_count (or NULL): the bone whose capsule holds each point, or -1
/// Each point goes to the deforming bone whose limb it lies on: the one whose segment
/// (head-tail) it is deepest inside or nearest outside of, by that bone's thickness (the median
/// distance from its segment of the points nearest it); ties to the lower index. The
/// capsule's axis is the bone's y axis or the points' principal axis, whichever gives the
/// smaller capsule; every point of the bone lies inside it.
tsk_status tsk_collider_fit_bones(const float* points, int32_t point_count,
                                  const float* to_armature, const float* heads, const float* tails,
                                  const float* rest, const int32_t* parent, const uint8_t* deforms,
                                  int32_t bone_count, float min_size, float* out, int32_t* group);

/// The bones' capsules now: each bone's points (points: the mesh's vertices now, in object
/// space, in the order of the rest mesh; group: the bone of each, from tsk_collider_fit_bones)
/// fitted in the bone's frame now (armature_world @ pose[i], pose: Blender's PoseBone.matrix)
/// as at rest, and placed in world space (to_world: the mesh object's world matrix). Fitting
/// the points where the mesh has them, rather than moving the rest fit, holds whatever
/// moves them: the blend of several bones at a joint, shape keys, corrective modifiers.
/// tris (tri_count index triples, may be 0): a bone's capsule also holds every triangle that
/// has one of its points as a corner, so the mesh's whole surface is held.
/// rows: bone_count rows (8 floats), kind -1 for a bone without points.
tsk_status tsk_collider_fit_groups(const float* points, int32_t point_count, const int32_t* tris,
                                   int32_t tri_count, const int32_t* group, const float* to_world,
                                   const float* armature_world, const float* pose,
                                   int32_t bone_count, float* rows);

/// A set of at most max_spheres spheres (1..TSK_COLLIDER_FIT_MAX_SHAPES) that holds every
/// triangle of a mesh: points xyz (point_count) in object space, tris index triples
/// (tri_count; 0 triangles: the points alone are covered), placed by `world` (4x4). The
/// triangle set is split at the median of its centres along its widest axis, the widest
/// sphere first, until there are max_spheres leaves or no leaf can be split. Rows (kind 0)
/// into `rows` (max_spheres rows of 8 floats), their number into *count.
tsk_status tsk_collider_fit_spheres(const float* points, int32_t point_count, const int32_t* tris,
                                    int32_t tri_count, const float* world, int32_t max_spheres,
                                    float* rows, int32_t* count);

/// The volume a closed triangle mesh encloses (object space, m^3): the absolute value of the
/// sum of its signed tetrahedra. Callers compare it with the volume of the one shape fitted to
/// its bounds, to choose between that shape and a sphere set.
tsk_status tsk_collider_mesh_volume(const float* points, int32_t point_count, const int32_t* tris,
                                    int32_t tri_count, double* volume);

#ifdef __cplusplus
}
#endif

#endif
