/* Private C interface to OpenSubdiv (bridge/opensubdiv.cpp): a Catmull–Clark refiner and
 * stencil table built once for a quad topology, applied to any number of cage poses. No
 * OpenSubdiv type crosses this header; every function catches every exception. */
#ifndef TSK_OPENSUBDIV_BRIDGE_H
#define TSK_OPENSUBDIV_BRIDGE_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct tsk_osd tsk_osd;

/// Builds Far::TopologyRefiner (uniform, `levels`) and Far::StencilTable for `face_count`
/// quads (validated by the caller) over `vertex_count` vertices.
tsk_status tsk_osd_create(const int32_t* quads, size_t face_count, size_t vertex_count, int levels,
                          tsk_osd** out);
void tsk_osd_destroy(tsk_osd* osd);
size_t tsk_osd_vertex_count(const tsk_osd* osd);
size_t tsk_osd_face_count(const tsk_osd* osd);
/// Refined quads, 4 indices each.
tsk_status tsk_osd_faces(const tsk_osd* osd, int32_t* quads);
/// refined = stencils applied to cage (xyz float32 each).
tsk_status tsk_osd_apply(const tsk_osd* osd, const float* cage, float* refined);

#ifdef __cplusplus
}
#endif
#endif
