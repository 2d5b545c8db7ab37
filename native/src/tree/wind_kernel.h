/* The tree wind's block kernel (seed 001 §4.2–4.3 for a block of sibling-ordered branches),
 * written once in wind_kernel_impl.h and compiled per instruction set (core/simd.h): wind.c the
 * portable kernel, wind_avx2.c and wind_avx512.c where TSK_SIMD_X86_PATHS. */
#ifndef TSK_TREE_WIND_KERNEL_H
#define TSK_TREE_WIND_KERNEL_H

#include "core/simd.h"
#include "tree/tree_internal.h"

/* What a wind step reads besides the tree; branch k of a range is branch base + k. */
typedef struct tree_wind_ctx {
    tsk_tree* t;
    const float* force;
    const float* parent_pts; /* where parents are read */
    const sloan_frames* parent_frames;
    float strength, power, b2_scale;
    size_t base; /* first branch of the range */
} tree_wind_ctx;

/* Poses branches i .. i + lanes - 1 (lanes: 4, 8, 16) as tree_pose_branch does one at a time,
 * the same bytes, and builds the Sloan frames of those with children. Returns 0, having
 * written nothing, when a lane needs tree_pose_branch's fallbacks (a trunk, a degenerate
 * frame, a bend beyond TREE_BEND_MAX). */
int tree_wind_block_portable(const tree_wind_ctx* c, size_t i);
#if TSK_SIMD_X86_PATHS
int tree_wind_block_avx2(const tree_wind_ctx* c, size_t i);
int tree_wind_block_avx512(const tree_wind_ctx* c, size_t i);
#endif

#endif
