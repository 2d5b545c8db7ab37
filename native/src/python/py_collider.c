/* Binding of the collider fits (tussock/collider.h): float32 points, matrices (16 floats, row
 * by row) and rows (8 floats each), int32 triangles and parents, uint8 deform flags; results
 * into caller buffers. Argument and buffer checks only. */
#include "binding.h"

#include "tussock/collider.h"

static PyObject* py_fit_bones(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *pts_o, *to_o, *heads_o, *tails_o, *rest_o, *parent_o, *deforms_o, *out_o, *group_o;
    float min_size;
    if (!PyArg_ParseTuple(args, "OOOOOOOfOO:collider_fit_bones", &pts_o, &to_o, &heads_o, &tails_o,
                          &rest_o, &parent_o, &deforms_o, &min_size, &out_o, &group_o))
        return NULL;
    tsk_py_views v = {.n = 0};
    float *pts, *to, *heads, *tails, *rest, *out;
    int32_t *parent, *group;
    uint8_t* deforms;
    Py_ssize_t n = 0;
    if (!tsk_py_views_get_xyz(&v, pts_o, "points", &pts, &n) ||
        !tsk_py_views_get(&v, to_o, "to_armature", TSK_PY_F32, 16, 0, 0, (void**)&to) ||
        !tsk_py_views_get(&v, parent_o, "parent", TSK_PY_I32, -1, 0, 0, (void**)&parent)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    const Py_ssize_t b = tsk_py_count(&v.view[v.n - 1]);
    if (b > TSK_COLLIDER_FIT_MAX_SHAPES || n > TSK_COLLIDER_FIT_MAX_POINTS) {
        tsk_py_views_release(&v);
        return tsk_py_raise_arg(b > TSK_COLLIDER_FIT_MAX_SHAPES ? "parent" : "points",
                                "%zd bones and %zd points exceed the limits of %d and %d", b, n,
                                TSK_COLLIDER_FIT_MAX_SHAPES, TSK_COLLIDER_FIT_MAX_POINTS);
    }
    if (!tsk_py_views_get(&v, heads_o, "heads", TSK_PY_F32, 3 * b, 0, 0, (void**)&heads) ||
        !tsk_py_views_get(&v, tails_o, "tails", TSK_PY_F32, 3 * b, 0, 0, (void**)&tails) ||
        !tsk_py_views_get(&v, rest_o, "rest", TSK_PY_F32, 16 * b, 0, 0, (void**)&rest) ||
        !tsk_py_views_get(&v, deforms_o, "deforms", TSK_PY_U8, b, 0, 0, (void**)&deforms) ||
        !tsk_py_views_get(&v, out_o, "out", TSK_PY_F32, 8 * b, 1, 0, (void**)&out) ||
        !tsk_py_views_get(&v, group_o, "group", TSK_PY_I32, n, 1, 0, (void**)&group)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_collider_fit_bones(
        pts, (int32_t)n, to, heads, tails, rest, parent, deforms, (int32_t)b, min_size, out, group);
    Py_END_ALLOW_THREADS tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static int mesh_views(tsk_py_views* v, PyObject* pts_o, PyObject* tris_o, float** pts,
                      Py_ssize_t* n, int32_t** tris, Py_ssize_t* t);

static PyObject* py_fit_groups(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *pts_o, *tris_o, *group_o, *to_o, *aw_o, *pose_o, *rows_o;
    if (!PyArg_ParseTuple(args, "OOOOOOO:collider_fit_groups", &pts_o, &tris_o, &group_o, &to_o,
                          &aw_o, &pose_o, &rows_o))
        return NULL;
    tsk_py_views v = {.n = 0};
    float *pts, *to, *aw, *pose, *rows;
    int32_t *group, *tris;
    Py_ssize_t n = 0, t = 0;
    if (!mesh_views(&v, pts_o, tris_o, &pts, &n, &tris, &t) ||
        !tsk_py_views_get(&v, pose_o, "pose", TSK_PY_F32, -1, 0, 0, (void**)&pose)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    const Py_ssize_t p16 = tsk_py_count(&v.view[v.n - 1]);
    if (p16 % 16 != 0 || p16 / 16 > TSK_COLLIDER_FIT_MAX_SHAPES ||
        n > TSK_COLLIDER_FIT_MAX_POINTS) {
        tsk_py_views_release(&v);
        return tsk_py_raise_arg("pose",
                                "must hold 16 floats per bone, at most %d bones (got %zd "
                                "floats), and at most %d points (got %zd)",
                                TSK_COLLIDER_FIT_MAX_SHAPES, p16, TSK_COLLIDER_FIT_MAX_POINTS, n);
    }
    const Py_ssize_t b = p16 / 16;
    if (!tsk_py_views_get(&v, group_o, "group", TSK_PY_I32, n, 0, 0, (void**)&group) ||
        !tsk_py_views_get(&v, to_o, "to_world", TSK_PY_F32, 16, 0, 0, (void**)&to) ||
        !tsk_py_views_get(&v, aw_o, "armature_world", TSK_PY_F32, 16, 0, 0, (void**)&aw) ||
        !tsk_py_views_get(&v, rows_o, "rows", TSK_PY_F32, 8 * b, 1, 0, (void**)&rows)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_collider_fit_groups(pts, (int32_t)n, tris, (int32_t)t, group, to,
                                                       aw, pose, (int32_t)b, rows);
    Py_END_ALLOW_THREADS tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

/* points, triangles (int32 triples or None) as buffers of the set `v`; *tris NULL for None */
static int mesh_views(tsk_py_views* v, PyObject* pts_o, PyObject* tris_o, float** pts,
                      Py_ssize_t* n, int32_t** tris, Py_ssize_t* t) {
    *tris = NULL;
    *t = 0;
    if (!tsk_py_views_get_xyz(v, pts_o, "points", pts, n) ||
        !tsk_py_views_get(v, tris_o, "triangles", TSK_PY_I32, -1, 0, 1, (void**)tris))
        return 0;
    if (*tris != NULL) {
        const Py_ssize_t k = tsk_py_count(&v->view[v->n - 1]);
        if (k % 3 != 0) {
            tsk_py_raise_arg("triangles", "length %zd is not a multiple of 3", k);
            return 0;
        }
        *t = k / 3;
    }
    if (*n > TSK_COLLIDER_FIT_MAX_POINTS || *t > TSK_COLLIDER_FIT_MAX_POINTS) {
        tsk_py_raise_arg("points", "%zd points and %zd triangles exceed the limit of %d", *n, *t,
                         TSK_COLLIDER_FIT_MAX_POINTS);
        return 0;
    }
    return 1;
}

static PyObject* py_fit_spheres(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *pts_o, *tris_o, *world_o, *rows_o;
    int max_spheres;
    if (!PyArg_ParseTuple(args, "OOOiO:collider_fit_spheres", &pts_o, &tris_o, &world_o,
                          &max_spheres, &rows_o))
        return NULL;
    if (max_spheres < 1 || max_spheres > TSK_COLLIDER_FIT_MAX_SHAPES)
        return tsk_py_raise_arg("max_spheres", "must be 1..%d, got %d", TSK_COLLIDER_FIT_MAX_SHAPES,
                                max_spheres);
    tsk_py_views v = {.n = 0};
    float *pts, *world, *rows;
    int32_t* tris;
    Py_ssize_t n, t;
    if (!mesh_views(&v, pts_o, tris_o, &pts, &n, &tris, &t) ||
        !tsk_py_views_get(&v, world_o, "world", TSK_PY_F32, 16, 0, 0, (void**)&world) ||
        !tsk_py_views_get(&v, rows_o, "rows", TSK_PY_F32, 8 * (Py_ssize_t)max_spheres, 1, 0,
                          (void**)&rows)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    int32_t count = 0;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_collider_fit_spheres(pts, (int32_t)n, tris, (int32_t)t, world,
                                                        max_spheres, rows, &count);
    Py_END_ALLOW_THREADS tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    return PyLong_FromLong(count);
}

static PyObject* py_mesh_volume(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *pts_o, *tris_o;
    if (!PyArg_ParseTuple(args, "OO:collider_mesh_volume", &pts_o, &tris_o)) return NULL;
    tsk_py_views v = {.n = 0};
    float* pts;
    int32_t* tris;
    Py_ssize_t n, t;
    if (!mesh_views(&v, pts_o, tris_o, &pts, &n, &tris, &t)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    double volume = 0.0;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_collider_mesh_volume(pts, (int32_t)n, tris, (int32_t)t, &volume);
    Py_END_ALLOW_THREADS tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    return PyFloat_FromDouble(volume);
}

PyMethodDef tsk_py_collider_methods[] = {
    {"collider_fit_bones", py_fit_bones, METH_VARARGS,
     "collider_fit_bones($module, points, to_armature, heads, tails, rest, parent, deforms, "
     "min_size, out, group, /)\n--\n\n"
     "Which vertices make each deforming bone's limb, at rest: the bone of each point into "
     "group (int32, -1 none), and each bone's capsule in bone space into out (float32, 8 per "
     "bone; kind -1 for a bone with no points). points: float32 xyz of the mesh at rest; "
     "to_armature: 16 floats, mesh -> armature space; heads, tails: xyz per bone; rest: 16 "
     "floats per bone (Bone.matrix_local); parent: int32 (-1 none); deforms: uint8; min_size: "
     "bones spanning less give their points to their parent."},
    {"collider_fit_groups", py_fit_groups, METH_VARARGS,
     "collider_fit_groups($module, points, triangles, group, to_world, armature_world, pose, "
     "rows, /)\n--\n\n"
     "Each bone's capsule fitted to its points where they are now (float32 xyz, object space; "
     "group from collider_fit_bones) and the triangles (int32 triples or None) they are "
     "corners of, in its frame armature_world @ pose[i] (16 floats per bone, "
     "PoseBone.matrix), into rows (float32, 8 per bone, world space; kind -1: none)."},
    {"collider_fit_spheres", py_fit_spheres, METH_VARARGS,
     "collider_fit_spheres($module, points, triangles, world, max_spheres, rows, /)\n--\n\n"
     "-> count. At most max_spheres spheres holding every triangle (int32 triples, or None: "
     "the points) placed by world (16 floats), into rows (float32, 8 * max_spheres)."},
    {"collider_mesh_volume", py_mesh_volume, METH_VARARGS,
     "collider_mesh_volume($module, points, triangles, /)\n--\n\n"
     "-> float. The volume a closed triangle mesh encloses (m^3)."},
    {NULL, NULL, 0, NULL},
};
