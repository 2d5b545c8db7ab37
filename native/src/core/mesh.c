/* Edges of a polygon mesh given by its corners, for handing a mesh to Blender complete:
 * without edges, Blender 3.4's Mesh.update() derives them itself with a hash of every corner,
 * the largest single cost of building a tree mesh (docs/performance.md). */
#include <string.h>

#include "tussock/core.h"

/* The vertex after corner c in its face. */
static int32_t next_vertex(const int32_t* corners, size_t c, int face_size) {
    const size_t f = c / (size_t)face_size, k = c % (size_t)face_size;
    return corners[f * (size_t)face_size + (k + 1) % (size_t)face_size];
}

tsk_status tsk_mesh_edges(const int32_t* corners, size_t face_count, int face_size,
                          int32_t vertex_count, int32_t* edges, int32_t* corner_edges,
                          size_t* edge_count) {
    if (edge_count == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "edge_count", "is NULL");
    *edge_count = 0;
    if (face_size < 3 || face_size > 64)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "face_size", "%d is not in 3..64", face_size);
    if (vertex_count < 0)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "vertex_count", "%d is negative", (int)vertex_count);
    if (face_count > (size_t)INT32_MAX / (size_t)face_size)
        return tsk_error_arg(TSK_ERR_LIMIT, "face_count", "%zu faces of %d corners are too many",
                             face_count, face_size);
    const size_t n = face_count * (size_t)face_size;
    if (n == 0) return TSK_OK;
    if (corners == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "corners", "is NULL");
    if (edges == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "edges", "is NULL");
    if (corner_edges == NULL) return tsk_error_arg(TSK_ERR_ARGUMENT, "corner_edges", "is NULL");
    for (size_t c = 0; c < n; ++c) {
        const int32_t a = corners[c];
        if (a < 0 || a >= vertex_count)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "corners",
                                 "vertex %d at corner %zu is not in 0..%d", (int)a, c,
                                 (int)vertex_count - 1);
    }
    for (size_t c = 0; c < n; ++c)
        if (corners[c] == next_vertex(corners, c, face_size))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "corners",
                                 "face %zu repeats vertex %d in a row (a zero-length edge)",
                                 c / (size_t)face_size, (int)corners[c]);
    /* corners bucketed by the smaller vertex of their edge, in corner order (counting sort);
     * within a bucket, `seen` maps the larger vertex to the bucket's first corner with it */
    const size_t nv = (size_t)vertex_count;
    int32_t* start = tsk_calloc(nv + 1, sizeof *start, "edge buckets");
    int32_t* seen = tsk_alloc(nv * sizeof *seen, "edge buckets");
    int32_t* hi = tsk_alloc(n * sizeof *hi, "edge buckets");
    int32_t* slot = tsk_alloc(n * sizeof *slot, "edge buckets");
    int32_t* first = tsk_alloc(n * sizeof *first, "edge buckets");
    tsk_status s = TSK_OK;
    if (start == NULL || seen == NULL || hi == NULL || slot == NULL || first == NULL) {
        s = TSK_ERR_MEMORY;
        goto done;
    }
    /* lo of each corner's edge kept in `first` for now, hi in `hi` */
    for (size_t f = 0, c = 0; f < face_count; ++f)
        for (int k = 0; k < face_size; ++k, ++c) {
            const int32_t a = corners[c];
            const int32_t b = corners[k + 1 < face_size ? c + 1 : c + 1 - (size_t)face_size];
            first[c] = a < b ? a : b;
            hi[c] = a < b ? b : a;
            start[first[c] + 1]++;
        }
    for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
    for (size_t c = 0; c < n; ++c) slot[start[first[c]]++] = (int32_t)c; /* start: bucket ends */
    for (size_t v = nv; v > 0; --v) start[v] = start[v - 1]; /* back to starts */
    start[0] = 0;
    for (size_t v = 0; v < nv; ++v) seen[v] = -1;
    for (size_t v = 0; v < nv; ++v) {
        const int32_t b0 = start[v], b1 = start[v + 1];
        for (int32_t i = b0; i < b1; ++i) {
            const int32_t c = slot[i];
            if (seen[hi[c]] < 0) seen[hi[c]] = c; /* slots are in corner order: first wins */
            first[c] = seen[hi[c]];
        }
        for (int32_t i = b0; i < b1; ++i) seen[hi[slot[i]]] = -1;
    }
    /* edges numbered in the order their first corner appears, drawn from that corner */
    size_t ne = 0;
    for (size_t f = 0, c = 0; f < face_count; ++f)
        for (int k = 0; k < face_size; ++k, ++c) {
            if (first[c] == (int32_t)c) {
                edges[2 * ne] = corners[c];
                edges[2 * ne + 1] = corners[k + 1 < face_size ? c + 1 : c + 1 - (size_t)face_size];
                corner_edges[c] = (int32_t)ne++;
            } else {
                corner_edges[c] = corner_edges[first[c]];
            }
        }
    *edge_count = ne;
done:
    tsk_free(start);
    tsk_free(seen);
    tsk_free(hi);
    tsk_free(slot);
    tsk_free(first);
    return s;
}
