/* Shared helpers of the CPython binding: buffer checks and status -> tussock.Error.
 * The binding holds no logic: it checks arguments and buffers and calls C. */
#ifndef TSK_BINDING_H
#define TSK_BINDING_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "tussock/core.h"

/// tussock.Error, a subclass of RuntimeError.
extern PyObject* tsk_py_error;

/// Raises tussock.Error with the C library's last message; returns NULL.
PyObject* tsk_py_raise(tsk_status status);

/// Raises tussock.Error with a message of the binding's own ("name: ..."); returns NULL.
PyObject* tsk_py_raise_arg(const char* name, const char* fmt, ...);

/// Element types a buffer may have.
typedef enum tsk_py_dtype { TSK_PY_F32, TSK_PY_I32, TSK_PY_I64, TSK_PY_U16, TSK_PY_U8 } tsk_py_dtype;

/// Gets a C-contiguous buffer of `dtype` with exactly `count` elements (count < 0: any
/// count, returned by tsk_py_count), writable when `writable`. On any mismatch raises
/// tussock.Error naming `name` and returns 0; on success returns 1 and the caller must
/// PyBuffer_Release(view).
int tsk_py_buffer(PyObject* obj, const char* name, tsk_py_dtype dtype, Py_ssize_t count,
                  int writable, Py_buffer* view);

/// Number of elements in a buffer obtained by tsk_py_buffer.
Py_ssize_t tsk_py_count(const Py_buffer* view);

/// Buffers acquired together (tsk_py_views_get) and released together (tsk_py_views_release).
/// The most a function holds is 17: picture_composite's 16 layers and its output.
enum { TSK_PY_MAX_VIEWS = 17 };
typedef struct tsk_py_views {
    Py_buffer view[TSK_PY_MAX_VIEWS];
    int n;
} tsk_py_views;

/// Acquires `obj` as tsk_py_buffer does and stores its data pointer in *ptr; when `optional`
/// and obj is None, *ptr = NULL and nothing is held. Returns 0 with tussock.Error raised on a
/// bad buffer; the caller then releases the set.
int tsk_py_views_get(tsk_py_views* v, PyObject* obj, const char* name, tsk_py_dtype dtype,
                     Py_ssize_t count, int writable, int optional, void** ptr);

/// Acquires `obj` as a read-only float32 buffer of xyz triples (one per blade, knot...) and
/// stores their number in *count. Returns 0 with tussock.Error raised on a bad buffer or a
/// length that is not a multiple of 3; the caller then releases the set.
int tsk_py_views_get_xyz(tsk_py_views* v, PyObject* obj, const char* name, float** ptr,
                         Py_ssize_t* count);

/// Releases every buffer of the set (safe to call twice).
void tsk_py_views_release(tsk_py_views* v);

#endif
