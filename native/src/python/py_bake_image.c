/* Binding of picture bake frames: OpenEXR image frames with a verifying sidecar. */
#include "binding.h"

#include "tussock/bake_image.h"

static PyObject* py_bake_write_image(PyObject* self, PyObject* args) {
    (void)self;
    const char* path;
    int frame, width, height;
    unsigned long long key;
    PyObject* rgba_obj;
    if (!PyArg_ParseTuple(args, "siKOii:bake_write_image", &path, &frame, &key, &rgba_obj, &width,
                          &height))
        return NULL;
    if (width < 1 || height < 1)
        return tsk_py_raise_arg("width, height", "must be positive, got %dx%d", width, height);
    Py_buffer rgba;
    if (!tsk_py_buffer(rgba_obj, "rgba", TSK_PY_F32, (Py_ssize_t)width * height * 4, 0, &rgba))
        return NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_bake_write_image(path, frame, (uint64_t)key, rgba.buf,
                                                    (size_t)tsk_py_count(&rgba), width, height);
    Py_END_ALLOW_THREADS PyBuffer_Release(&rgba);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_bake_image_info(PyObject* self, PyObject* args) {
    (void)self;
    const char* path;
    if (!PyArg_ParseTuple(args, "s:bake_image_info", &path)) return NULL;
    int32_t frame = 0;
    uint64_t key = 0;
    int w = 0, h = 0;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_bake_image_info(path, &frame, &key, &w, &h);
    Py_END_ALLOW_THREADS if (s != TSK_OK) return tsk_py_raise(s);
    return Py_BuildValue("{sisKsisi}", "frame", (int)frame, "key", (unsigned long long)key, "width",
                         w, "height", h);
}

PyMethodDef tsk_py_bake_image_methods[] = {
    {"bake_write_image", py_bake_write_image, METH_VARARGS,
     "bake_write_image($module, path, frame, key, rgba, width, height, /)\n--\n\n"
     "an OpenEXR frame (float32 RGBA 4*W*H, rows top-first) and its sidecar path + '.tski', "
     "atomically; key: a 64-bit int the caller derives from the frame's inputs."},
    {"bake_image_info", py_bake_image_info, METH_VARARGS,
     "bake_image_info($module, path, /)\n--\n\n"
     "-> dict(frame, key, width, height): verifies the sidecar (format version) and the EXR's "
     "size and checksum."},
    {NULL, NULL, 0, NULL},
};
