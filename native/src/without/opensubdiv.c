/* Stand-in for the OpenSubdiv bridge (bridge/opensubdiv.cpp) in a build without OpenSubdiv
 * (CMake option TSK_WITH_OPENSUBDIV=OFF): a smooth tree mesh fails with a message that says so. */
#include "bridge/opensubdiv_bridge.h"

static tsk_status without_opensubdiv(void) {
    return tsk_error(TSK_ERR_INTERNAL,
                     "smoothing (Catmull-Clark): this Tussock was built without OpenSubdiv");
}

tsk_status tsk_osd_create(const int32_t* quads, size_t face_count, size_t vertex_count, int levels,
                          tsk_osd** out) {
    (void)quads, (void)face_count, (void)vertex_count, (void)levels;
    *out = NULL;
    return without_opensubdiv();
}

void tsk_osd_destroy(tsk_osd* osd) { (void)osd; }
size_t tsk_osd_vertex_count(const tsk_osd* osd) {
    (void)osd;
    return 0;
}
size_t tsk_osd_face_count(const tsk_osd* osd) {
    (void)osd;
    return 0;
}

tsk_status tsk_osd_faces(const tsk_osd* osd, int32_t* quads) {
    (void)osd, (void)quads;
    return without_opensubdiv();
}

tsk_status tsk_osd_apply(const tsk_osd* osd, const float* cage, float* refined) {
    (void)osd, (void)cage, (void)refined;
    return without_opensubdiv();
}
