/* Binding of the core: version, threads, deterministic random numbers, vector lengths, mesh
 * edges. */
#include "binding.h"

static PyObject* py_version(PyObject* self, PyObject* args) {
    (void)self;
    (void)args;
    return PyUnicode_FromString(tsk_version());
}

static PyObject* py_set_threads(PyObject* self, PyObject* args) {
    (void)self;
    int n;
    if (!PyArg_ParseTuple(args, "i:set_threads", &n)) return NULL;
    tsk_status s = tsk_set_threads(n);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_get_threads(PyObject* self, PyObject* args) {
    (void)self;
    (void)args;
    return PyLong_FromLong(tsk_get_threads());
}

static PyObject* py_hash4(PyObject* self, PyObject* args) {
    (void)self;
    unsigned long long seed, a, b, c;
    if (!PyArg_ParseTuple(args, "KKKK:hash4", &seed, &a, &b, &c)) return NULL;
    return PyLong_FromUnsignedLongLong(tsk_hash4(seed, a, b, c));
}

static PyObject* py_rand_fill(PyObject* self, PyObject* args) {
    (void)self;
    unsigned long long seed, stream;
    PyObject* out_obj;
    if (!PyArg_ParseTuple(args, "KKO:rand_fill", &seed, &stream, &out_obj)) return NULL;
    Py_buffer out;
    if (!tsk_py_buffer(out_obj, "out", TSK_PY_F32, -1, 1, &out)) return NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_rand_fill(seed, stream, out.buf, (size_t)tsk_py_count(&out));
    Py_END_ALLOW_THREADS PyBuffer_Release(&out);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_vec3_lengths(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *xyz_obj, *out_obj;
    if (!PyArg_ParseTuple(args, "OO:vec3_lengths", &xyz_obj, &out_obj)) return NULL;
    Py_buffer xyz, out;
    if (!tsk_py_buffer(out_obj, "out", TSK_PY_F32, -1, 1, &out)) return NULL;
    const Py_ssize_t n = tsk_py_count(&out);
    if (!tsk_py_buffer(xyz_obj, "xyz", TSK_PY_F32, 3 * n, 0, &xyz)) {
        PyBuffer_Release(&out);
        return NULL;
    }
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_vec3_lengths(xyz.buf, (size_t)n, out.buf);
    Py_END_ALLOW_THREADS PyBuffer_Release(&xyz);
    PyBuffer_Release(&out);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_vec3_bounds(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* xyz_obj;
    if (!PyArg_ParseTuple(args, "O:vec3_bounds", &xyz_obj)) return NULL;
    Py_buffer xyz;
    if (!tsk_py_buffer(xyz_obj, "xyz", TSK_PY_F32, -1, 0, &xyz)) return NULL;
    const Py_ssize_t n = tsk_py_count(&xyz);
    if (n % 3 != 0) {
        PyBuffer_Release(&xyz);
        PyErr_Format(PyExc_ValueError, "xyz: %zd floats is not a whole number of points", n);
        return NULL;
    }
    float lo[3], hi[3];
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_vec3_bounds(xyz.buf, (size_t)(n / 3), lo, hi);
    Py_END_ALLOW_THREADS PyBuffer_Release(&xyz);
    if (s != TSK_OK) return tsk_py_raise(s);
    return Py_BuildValue("((ddd)(ddd))", (double)lo[0], (double)lo[1], (double)lo[2], (double)hi[0],
                         (double)hi[1], (double)hi[2]);
}

static PyObject* py_mesh_edges(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *corners_obj, *edges_obj, *ce_obj;
    int face_size, vertex_count;
    if (!PyArg_ParseTuple(args, "OiiOO:mesh_edges", &corners_obj, &face_size, &vertex_count,
                          &edges_obj, &ce_obj))
        return NULL;
    if (face_size < 3 || face_size > 64) {
        PyErr_Format(PyExc_ValueError, "face_size: %d is not in 3..64", face_size);
        return NULL;
    }
    Py_buffer corners, edges, ce;
    if (!tsk_py_buffer(corners_obj, "corners", TSK_PY_I32, -1, 0, &corners)) return NULL;
    const Py_ssize_t n = tsk_py_count(&corners);
    if (n % face_size != 0) {
        PyBuffer_Release(&corners);
        PyErr_Format(PyExc_ValueError, "corners: %zd is not a multiple of face_size %d", n,
                     face_size);
        return NULL;
    }
    if (!tsk_py_buffer(edges_obj, "edges", TSK_PY_I32, 2 * n, 1, &edges)) {
        PyBuffer_Release(&corners);
        return NULL;
    }
    if (!tsk_py_buffer(ce_obj, "corner_edges", TSK_PY_I32, n, 1, &ce)) {
        PyBuffer_Release(&corners);
        PyBuffer_Release(&edges);
        return NULL;
    }
    size_t count = 0;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_mesh_edges(corners.buf, (size_t)(n / face_size), face_size,
                                              vertex_count, edges.buf, ce.buf, &count);
    Py_END_ALLOW_THREADS PyBuffer_Release(&corners);
    PyBuffer_Release(&edges);
    PyBuffer_Release(&ce);
    if (s != TSK_OK) return tsk_py_raise(s);
    return PyLong_FromSize_t(count);
}

static PyObject* py_allocated_bytes(PyObject* self, PyObject* args) {
    (void)self;
    (void)args;
    return PyLong_FromSize_t(tsk_allocated_bytes());
}

static PyObject* py_set_memory_budget(PyObject* self, PyObject* args) {
    (void)self;
    unsigned long long bytes;
    if (!PyArg_ParseTuple(args, "K:set_memory_budget", &bytes)) return NULL;
    tsk_set_memory_budget((uint64_t)bytes);
    Py_RETURN_NONE;
}

static PyObject* py_memory_budget(PyObject* self, PyObject* args) {
    (void)self;
    (void)args;
    return PyLong_FromUnsignedLongLong((unsigned long long)tsk_memory_budget());
}

PyMethodDef tsk_py_core_methods[] = {
    {"set_memory_budget", py_set_memory_budget, METH_VARARGS,
     "set_memory_budget($module, bytes, /)\n--\n\n"
     "largest memory estimate one request may have; 0 = default (half of physical memory, or "
     "TSK_MEMORY_BUDGET_MB)."},
    {"memory_budget", py_memory_budget, METH_NOARGS,
     "memory_budget($module, /)\n--\n\n"
     "-> int: bytes."},
    {"version", py_version, METH_NOARGS,
     "version($module, /)\n--\n\n"
     "-> str: native library version."},
    {"set_threads", py_set_threads, METH_VARARGS,
     "set_threads($module, n, /)\n--\n\n"
     "worker threads, 0 = all cores."},
    {"get_threads", py_get_threads, METH_NOARGS,
     "get_threads($module, /)\n--\n\n"
     "-> int."},
    {"hash4", py_hash4, METH_VARARGS,
     "hash4($module, seed, a, b, c, /)\n--\n\n"
     "-> int: counter-based hash."},
    {"rand_fill", py_rand_fill, METH_VARARGS,
     "rand_fill($module, seed, stream, out, /)\n--\n\n"
     "out[i] = uniform [0,1) of (seed, stream, i); out float32."},
    {"vec3_lengths", py_vec3_lengths, METH_VARARGS,
     "vec3_lengths($module, xyz, out, /)\n--\n\n"
     "out[i] = |xyz[i]|; xyz float32 (3n), out float32 (n)."},
    {"vec3_bounds", py_vec3_bounds, METH_VARARGS,
     "vec3_bounds($module, xyz, /)\n--\n\n"
     "-> ((lo x, y, z), (hi x, y, z)): bounding box of float32 points (3n, n >= 1); non-finite"
     " points are refused."},
    {"mesh_edges", py_mesh_edges, METH_VARARGS,
     "mesh_edges($module, corners, face_size, vertex_count, edges, corner_edges, /)\n--\n\n"
     "-> int: the distinct edges of faces of face_size corners (int32), in first-use order; "
     "edges int32 (room for 2 per corner), corner_edges int32 (one per corner)."},
    {"allocated_bytes", py_allocated_bytes, METH_NOARGS,
     "allocated_bytes($module, /)\n--\n\n"
     "-> int: bytes held by the native library."},
    {NULL, NULL, 0, NULL},
};
