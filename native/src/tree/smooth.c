/* The smooth option of the tree mesh: argument checks around the OpenSubdiv bridge
 * (Catmull–Clark stencils built once per topology, applied per frame) and vertex normals
 * of the refined quads. */
#include <math.h>

#include "bridge/opensubdiv_bridge.h"
#include "tree_internal.h"

struct tsk_subdiv {
    tsk_osd* osd;
    size_t cage_vertices;
};

tsk_status tsk_subdiv_create(const int32_t* quads, size_t face_count, size_t vertex_count,
                             int levels, tsk_subdiv** out) {
    if (out == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    *out = NULL;
    if (levels < 1 || levels > 4)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "levels", "must be 1..4, got %d", levels);
    if (quads == NULL || face_count == 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "quads", "no faces given");
    if (vertex_count == 0 || vertex_count > (size_t)(INT32_MAX / 64) ||
        face_count > (size_t)(INT32_MAX / 64))
        return tsk_error_arg(TSK_ERR_LIMIT, "vertex_count",
                             "%zu vertices / %zu faces: must be 1..%d", vertex_count, face_count,
                             INT32_MAX / 64);
    /* refined size grows 4x per level */
    const double refined = (double)face_count * pow(4.0, levels);
    if (refined > (double)(INT32_MAX / 8))
        return tsk_error_arg(TSK_ERR_LIMIT, "levels", "%d levels of %zu faces make %.0f faces",
                             levels, face_count, refined);
    for (size_t i = 0; i < 4 * face_count; ++i)
        if (quads[i] < 0 || (size_t)quads[i] >= vertex_count)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "quads",
                                 "index %d of face %zu is outside 0..%zu", quads[i], i / 4,
                                 vertex_count - 1);
    tsk_subdiv* sd = tsk_calloc(1, sizeof(tsk_subdiv), "subdivision");
    if (sd == NULL) return TSK_ERR_MEMORY;
    tsk_status s = tsk_osd_create(quads, face_count, vertex_count, levels, &sd->osd);
    if (s != TSK_OK) {
        tsk_free(sd);
        return s;
    }
    sd->cage_vertices = vertex_count;
    *out = sd;
    return TSK_OK;
}

void tsk_subdiv_destroy(tsk_subdiv* sd) {
    if (sd == NULL) return;
    tsk_osd_destroy(sd->osd);
    tsk_free(sd);
}

size_t tsk_subdiv_cage_vertex_count(const tsk_subdiv* sd) { return sd ? sd->cage_vertices : 0; }
size_t tsk_subdiv_vertex_count(const tsk_subdiv* sd) {
    return sd ? tsk_osd_vertex_count(sd->osd) : 0;
}
size_t tsk_subdiv_face_count(const tsk_subdiv* sd) { return sd ? tsk_osd_face_count(sd->osd) : 0; }

tsk_status tsk_subdiv_faces(const tsk_subdiv* sd, int32_t* quads) {
    if (sd == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "subdiv", "is NULL");
    if (quads == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "quads", "is NULL");
    return tsk_osd_faces(sd->osd, quads);
}

tsk_status tsk_subdiv_apply(const tsk_subdiv* sd, const float* cage, float* refined) {
    if (sd == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "subdiv", "is NULL");
    if (cage == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "cage", "is NULL");
    if (refined == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "refined", "is NULL");
    for (size_t i = 0; i < 3 * sd->cage_vertices; ++i)
        if (!isfinite(cage[i]))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "cage", "vertex %zu is not finite", i / 3);
    return tsk_osd_apply(sd->osd, cage, refined);
}

tsk_status tsk_quad_normals(const float* p, size_t vertex_count, const int32_t* quads,
                            size_t face_count, float* normals) {
    if ((p == NULL || normals == NULL) && vertex_count > 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, p == NULL ? "positions" : "normals", "is NULL");
    if (quads == NULL && face_count > 0) return tsk_error_arg(TSK_ERR_ARGUMENT, "quads", "is NULL");
    for (size_t i = 0; i < 4 * face_count; ++i)
        if (quads[i] < 0 || (size_t)quads[i] >= vertex_count)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "quads", "index %d of face %zu is out of range",
                                 quads[i], i / 4);
    for (size_t i = 0; i < 3 * vertex_count; ++i) normals[i] = 0.0f;
    for (size_t f = 0; f < face_count; ++f) {
        const int32_t* q = quads + 4 * f;
        const v3 a = tree_load3(p, (size_t)q[0]), b = tree_load3(p, (size_t)q[1]);
        const v3 c = tree_load3(p, (size_t)q[2]), d = tree_load3(p, (size_t)q[3]);
        /* cross of the diagonals: twice the (planar) quad's area times its normal */
        const v3 n = v3_scale(v3_cross(v3_sub(c, a), v3_sub(d, b)), 0.5f);
        for (int k = 0; k < 4; ++k) {
            float* o = normals + 3 * (size_t)q[k];
            o[0] += n.x, o[1] += n.y, o[2] += n.z;
        }
    }
    for (size_t i = 0; i < vertex_count; ++i) {
        const v3 n = v3_norm_or(tree_load3(normals, i), v3_make(0, 0, 1));
        tree_store3(normals, i, n);
    }
    return TSK_OK;
}
