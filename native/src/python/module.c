/* The _tussock extension module: creates tussock.Error and gathers the method tables of
 * every py_<part>.c (listed by CMake in py_parts.h). */
#include "binding.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

PyObject* tsk_py_error = NULL;

PyObject* tsk_py_raise(tsk_status status) {
    const char* msg = tsk_last_error();
    if (msg == NULL || msg[0] == '\0') msg = tsk_status_name(status);
    PyErr_SetString(tsk_py_error, msg);
    return NULL;
}

PyObject* tsk_py_raise_arg(const char* name, const char* fmt, ...) {
    char buf[512];
    int n = snprintf(buf, sizeof buf, "%s: ", name);
    if (n < 0 || (size_t)n >= sizeof buf) n = 0;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf + n, sizeof buf - (size_t)n, fmt, ap);
    va_end(ap);
    PyErr_SetString(tsk_py_error, buf);
    return NULL;
}

static const char* dtype_name(tsk_py_dtype dtype) {
    switch (dtype) {
        case TSK_PY_F32:
            return "float32";
        case TSK_PY_I32:
            return "int32";
        case TSK_PY_I64:
            return "int64";
        case TSK_PY_U16:
            return "uint16";
        case TSK_PY_U8:
            return "uint8";
    }
    return "?";
}

/* Accepts struct-module codes with an optional native/little-endian prefix. */
static int format_matches(const char* format, tsk_py_dtype dtype, Py_ssize_t itemsize) {
    if (format == NULL) format = "B";
    if (format[0] == '<' || format[0] == '=' || format[0] == '@') ++format;
    if (format[0] == '\0' || format[1] != '\0') return 0;
    switch (dtype) {
        case TSK_PY_F32:
            return format[0] == 'f' && itemsize == 4;
        case TSK_PY_I32:
            return (format[0] == 'i' || format[0] == 'l') && itemsize == 4;
        case TSK_PY_I64:
            return (format[0] == 'q' || format[0] == 'l') && itemsize == 8;
        case TSK_PY_U16:
            return format[0] == 'H' && itemsize == 2;
        case TSK_PY_U8:
            return (format[0] == 'B' || format[0] == 'c') && itemsize == 1;
    }
    return 0;
}

int tsk_py_buffer(PyObject* obj, const char* name, tsk_py_dtype dtype, Py_ssize_t count,
                  int writable, Py_buffer* view) {
    if (PyObject_GetBuffer(obj, view, PyBUF_RECORDS_RO) != 0) {
        PyErr_Clear();
        tsk_py_raise_arg(name, "expected a %s array (numpy or any buffer), got %s",
                         dtype_name(dtype), Py_TYPE(obj) ? "an object without a buffer" : "?");
        return 0;
    }
    const char* problem = NULL;
    char detail[160] = "";
    if (!format_matches(view->format, dtype, view->itemsize)) {
        snprintf(detail, sizeof detail, "must have dtype %s, got format '%s' of %zd bytes",
                 dtype_name(dtype), view->format ? view->format : "B", view->itemsize);
        problem = detail;
    } else if (!PyBuffer_IsContiguous(view, 'C')) {
        problem = "must be C-contiguous (use numpy.ascontiguousarray)";
    } else if (writable && view->readonly) {
        problem = "must be writable (the result is written into it)";
    } else if (count >= 0 && view->len / view->itemsize != count) {
        snprintf(detail, sizeof detail, "must have exactly %zd elements, got %zd", count,
                 view->len / view->itemsize);
        problem = detail;
    }
    if (problem != NULL) {
        PyBuffer_Release(view);
        tsk_py_raise_arg(name, "%s", problem);
        return 0;
    }
    return 1;
}

Py_ssize_t tsk_py_count(const Py_buffer* view) {
    return view->itemsize > 0 ? view->len / view->itemsize : 0;
}

void tsk_py_views_release(tsk_py_views* v) {
    for (int i = 0; i < v->n; ++i) PyBuffer_Release(&v->view[i]);
    v->n = 0;
}

int tsk_py_views_get(tsk_py_views* v, PyObject* obj, const char* name, tsk_py_dtype dtype,
                     Py_ssize_t count, int writable, int optional, void** ptr) {
    *ptr = NULL;
    if (obj == Py_None && optional) return 1;
    if (v->n >= TSK_PY_MAX_VIEWS) {
        PyErr_SetString(PyExc_SystemError, "too many buffers");
        return 0;
    }
    if (!tsk_py_buffer(obj, name, dtype, count, writable, &v->view[v->n])) return 0;
    *ptr = v->view[v->n].buf;
    v->n++;
    return 1;
}

int tsk_py_views_get_xyz(tsk_py_views* v, PyObject* obj, const char* name, float** ptr,
                         Py_ssize_t* count) {
    if (!tsk_py_views_get(v, obj, name, TSK_PY_F32, -1, 0, 0, (void**)ptr)) return 0;
    const Py_ssize_t n3 = tsk_py_count(&v->view[v->n - 1]);
    if (n3 % 3 != 0) {
        tsk_py_raise_arg(name, "length %zd is not a multiple of 3", n3);
        return 0;
    }
    *count = n3 / 3;
    return 1;
}

/* Every part's method table, declared and listed from py_parts.h. */
#define TSK_PY_PART(part) extern PyMethodDef tsk_py_##part##_methods[];
#include "py_parts.h"
#undef TSK_PY_PART

static struct PyModuleDef g_module = {
    PyModuleDef_HEAD_INIT,
    "_tussock",
    "Tussock's native library: capture, meadows, wind, trees and pictures.",
    -1,
    NULL,
    NULL,
    NULL,
    NULL,
    NULL,
};

PyMODINIT_FUNC PyInit__tussock(void);
PyMODINIT_FUNC PyInit__tussock(void) {
    PyObject* m = PyModule_Create(&g_module);
    if (m == NULL) return NULL;
    if (tsk_py_error == NULL) {
        tsk_py_error = PyErr_NewExceptionWithDoc("tussock.Error",
                                                 "An error reported by Tussock's native library.",
                                                 PyExc_RuntimeError, NULL);
        if (tsk_py_error == NULL) goto fail;
    }
    Py_INCREF(tsk_py_error);
    if (PyModule_AddObject(m, "Error", tsk_py_error) != 0) {
        Py_DECREF(tsk_py_error);
        goto fail;
    }
    if (PyModule_AddStringConstant(m, "__version__", tsk_version()) != 0) goto fail;
#define TSK_PY_PART(part) \
    if (PyModule_AddFunctions(m, tsk_py_##part##_methods) != 0) goto fail;
#include "py_parts.h"
#undef TSK_PY_PART
    return m;
fail:
    Py_DECREF(m);
    return NULL;
}
