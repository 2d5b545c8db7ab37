/* Binding of bake caches: frame files and .pc2 assembly. */
#include "binding.h"

#include "tussock/bake.h"

static PyObject* py_bake_write_frame(PyObject* self, PyObject* args) {
    (void)self;
    const char* path;
    int frame;
    PyObject* xyz_obj;
    if (!PyArg_ParseTuple(args, "siO:bake_write_frame", &path, &frame, &xyz_obj)) return NULL;
    Py_buffer xyz;
    if (!tsk_py_buffer(xyz_obj, "xyz", TSK_PY_F32, -1, 0, &xyz)) return NULL;
    Py_ssize_t n = tsk_py_count(&xyz);
    if (n % 3 != 0) {
        PyBuffer_Release(&xyz);
        return tsk_py_raise_arg("xyz", "must hold 3 floats per point, got %zd floats", n);
    }
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_bake_write_frame(path, frame, xyz.buf, (uint32_t)(n / 3));
    Py_END_ALLOW_THREADS PyBuffer_Release(&xyz);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_bake_frame_info(PyObject* self, PyObject* args) {
    (void)self;
    const char* path;
    if (!PyArg_ParseTuple(args, "s:bake_frame_info", &path)) return NULL;
    int32_t frame = 0;
    uint32_t count = 0;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_bake_frame_info(path, &frame, &count);
    Py_END_ALLOW_THREADS if (s != TSK_OK) return tsk_py_raise(s);
    return Py_BuildValue("(iI)", frame, count);
}

static PyObject* py_bake_read_frame(PyObject* self, PyObject* args) {
    (void)self;
    const char* path;
    PyObject* out_obj;
    if (!PyArg_ParseTuple(args, "sO:bake_read_frame", &path, &out_obj)) return NULL;
    Py_buffer out;
    if (!tsk_py_buffer(out_obj, "out", TSK_PY_F32, -1, 1, &out)) return NULL;
    Py_ssize_t n = tsk_py_count(&out);
    tsk_status s = TSK_OK;
    if (n % 3 != 0) {
        PyBuffer_Release(&out);
        return tsk_py_raise_arg("out", "must hold 3 floats per point, got %zd floats", n);
    }
    Py_BEGIN_ALLOW_THREADS s = tsk_bake_read_frame(path, out.buf, (uint32_t)(n / 3));
    Py_END_ALLOW_THREADS PyBuffer_Release(&out);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_bake_assemble_pc2(PyObject* self, PyObject* args) {
    (void)self;
    const char* path;
    PyObject* list;
    float start, rate;
    if (!PyArg_ParseTuple(args, "sOff:bake_assemble_pc2", &path, &list, &start, &rate)) return NULL;
    if (!PyList_Check(list)) return tsk_py_raise_arg("frame_paths", "must be a list of paths");
    Py_ssize_t n = PyList_Size(list);
    if (n <= 0 || n > TSK_BAKE_MAX_FRAMES)
        return tsk_py_raise_arg("frame_paths", "must hold 1 to %d paths, got %zd",
                                TSK_BAKE_MAX_FRAMES, n);
    const char** paths = PyMem_Malloc((size_t)n * sizeof(char*));
    if (paths == NULL) return PyErr_NoMemory();
    for (Py_ssize_t i = 0; i < n; ++i) {
        PyObject* item = PyList_GetItem(list, i);
        paths[i] = item && PyUnicode_Check(item) ? PyUnicode_AsUTF8AndSize(item, NULL) : NULL;
        if (paths[i] == NULL) {
            PyMem_Free(paths);
            PyErr_Clear();
            return tsk_py_raise_arg("frame_paths", "item %zd is not a path string", i);
        }
    }
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_bake_assemble_pc2(path, paths, (int32_t)n, start, rate);
    Py_END_ALLOW_THREADS PyMem_Free(paths);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_pc2_info(PyObject* self, PyObject* args) {
    (void)self;
    const char* path;
    if (!PyArg_ParseTuple(args, "s:pc2_info", &path)) return NULL;
    uint32_t points = 0, samples = 0;
    float start = 0, rate = 0;
    tsk_status s = tsk_pc2_info(path, &points, &start, &rate, &samples);
    if (s != TSK_OK) return tsk_py_raise(s);
    return Py_BuildValue("{sIsfsfsI}", "points", points, "start_frame", start, "sample_rate", rate,
                         "samples", samples);
}

static PyObject* py_pc2_read_sample(PyObject* self, PyObject* args) {
    (void)self;
    const char* path;
    unsigned int index;
    PyObject* out_obj;
    if (!PyArg_ParseTuple(args, "sIO:pc2_read_sample", &path, &index, &out_obj)) return NULL;
    Py_buffer out;
    if (!tsk_py_buffer(out_obj, "out", TSK_PY_F32, -1, 1, &out)) return NULL;
    Py_ssize_t n = tsk_py_count(&out);
    tsk_status s = tsk_pc2_read_sample(path, index, out.buf, (uint32_t)(n / 3));
    PyBuffer_Release(&out);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

PyMethodDef tsk_py_bake_methods[] = {
    {"bake_write_frame", py_bake_write_frame, METH_VARARGS,
     "bake_write_frame($module, path, frame, xyz, /)\n--\n\n"
     "one frame file, atomically; xyz float32 (3n)."},
    {"bake_frame_info", py_bake_frame_info, METH_VARARGS,
     "bake_frame_info($module, path, /)\n--\n\n"
     "-> (frame, points): verifies header and checksum."},
    {"bake_read_frame", py_bake_read_frame, METH_VARARGS,
     "bake_read_frame($module, path, out, /)\n--\n\n"
     "a verified frame into out float32 (3n)."},
    {"bake_assemble_pc2", py_bake_assemble_pc2, METH_VARARGS,
     "bake_assemble_pc2($module, path, frame_paths, start_frame, sample_rate, /)\n--\n\n"
     "verified frames -> .pc2."},
    {"pc2_info", py_pc2_info, METH_VARARGS,
     "pc2_info($module, path, /)\n--\n\n"
     "-> dict(points, start_frame, sample_rate, samples)."},
    {"pc2_read_sample", py_pc2_read_sample, METH_VARARGS,
     "pc2_read_sample($module, path, index, out, /)\n--\n\n"
     "one sample of a .pc2 into out float32 (3n)."},
    {NULL, NULL, 0, NULL},
};
