/* Shared helpers of the CPython binding: buffer checks, status -> tussock.Error, handles with
 * a busy guard, and def structs <-> dicts through field tables.
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
typedef enum tsk_py_dtype {
    TSK_PY_F32,
    TSK_PY_I32,
    TSK_PY_I64,
    TSK_PY_U16,
    TSK_PY_U8
} tsk_py_dtype;

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

/* ---- handles ------------------------------------------------------------------------
 * Every stateful object (simulation, capture, wind, tree...) reaches Python as a PyCapsule
 * holding a tsk_py_handle. The C objects are not thread-safe, and a call that releases the
 * GIL lets another Python thread in: the handle is marked busy for that time, and any use
 * of it from another thread meanwhile raises tussock.Error instead of racing. Every check
 * and mark happens with the GIL held, so a plain int is enough. */

/// One kind of handle: its capsule name, the argument name used in messages, what it is, the
/// functions that make it (for "expected a ... from ...") and close it early (NULL: none, it
/// is freed with its last reference), and how to free it.
typedef struct tsk_py_kind {
    const char* capsule; ///< "tussock.blade_sim"
    const char* arg; ///< "sim"
    const char* noun; ///< "blade simulation"
    const char* maker; ///< "blade_sim_create"
    const char* closer; ///< "wind_destroy"
    void (*destroy)(void* ptr);
} tsk_py_kind;

typedef struct tsk_py_handle {
    void* ptr; ///< NULL once closed
    const tsk_py_kind* kind;
    int busy; ///< a call is using ptr without the GIL
} tsk_py_handle;

/// Wraps `ptr` in a new handle of `kind`; on failure destroys ptr and returns NULL.
PyObject* tsk_py_handle_new(const tsk_py_kind* kind, void* ptr);

/// The handle in `obj` when it is one of `kind`, open and not busy; else NULL with
/// tussock.Error raised naming kind->arg.
tsk_py_handle* tsk_py_handle_get(PyObject* obj, const tsk_py_kind* kind);

/// Frees the object of a handle now (later calls raise "closed"; closing again does nothing);
/// refused while busy. Returns 0 with tussock.Error raised on a bad or busy handle.
int tsk_py_handle_close(PyObject* obj, const tsk_py_kind* kind);

/// Runs `stmt` without the GIL, with handle `h` marked busy meanwhile.
#define TSK_PY_UNLOCKED(h, stmt)           \
    do {                                   \
        (h)->busy = 1;                     \
        Py_BEGIN_ALLOW_THREADS stmt;       \
        Py_END_ALLOW_THREADS(h)->busy = 0; \
    } while (0)

/* ---- def structs <-> dicts -----------------------------------------------------------
 * A def struct's Python face is a table of its fields: keyword arguments or a dict are read
 * into the struct (starting from the C defaults, unknown keys refused by name) and the
 * struct is written back as a dict. */

typedef enum tsk_py_ftype {
    TSK_PY_FLOAT, ///< float, from any number
    TSK_PY_INT, ///< int32, from an integer (not a float) in int32 range
    TSK_PY_U32, ///< uint32, from an integer 0..2^32-1
    TSK_PY_U64, ///< uint64, from any integer taken modulo 2^64 (seeds)
    TSK_PY_BOOL, ///< int 0/1, from any truth value
    TSK_PY_VEC2, ///< float[2], from a sequence of 2 numbers
    TSK_PY_VEC3, ///< float[3], from a sequence of 3 numbers
    TSK_PY_CHOICE, ///< an int-sized enum, from one of the names in `choices` (index = value)
    TSK_PY_CUSTOM, ///< converted by `read` / `write` (buffers, nested lists)
} tsk_py_ftype;

typedef struct tsk_py_field {
    const char* name;
    tsk_py_ftype type;
    size_t offset;
    /// TSK_PY_CHOICE: the names of values 0, 1, ... (NULL-terminated).
    const char* const* choices;
    /// TSK_PY_CUSTOM: sets the field of `def` from `value` (1, or 0 with an error set) and
    /// returns its Python value (NULL: none; the field is then left out of dicts).
    int (*read)(PyObject* value, void* def);
    PyObject* (*write)(const void* def);
} tsk_py_field;

typedef struct tsk_py_def {
    const char* noun; ///< "blade simulation setting": "name: unknown <noun>"
    const tsk_py_field* fields;
    size_t count;
    /// Fields of an embedded struct also taken by name (NULL: none), at `base_offset`.
    const struct tsk_py_def* base;
    size_t base_offset;
} tsk_py_def;

#define TSK_PY_FIELDS(arr) (arr), (sizeof(arr) / sizeof((arr)[0]))

/// Sets the field called `key` of `def`. Returns 1, 0 with tussock.Error raised (a bad
/// value, naming the key), or -1 with nothing raised when no field has that name.
int tsk_py_def_set(const tsk_py_def* table, void* def, const char* key, PyObject* value);

/// Reads every item of dict `d` (NULL: none) into `def`. An unknown key raises
/// "key: unknown <noun>", or "where: unknown <noun> 'key'" when `where` is given; except the
/// keys named in `pass` (NULL-terminated, may be NULL), which go into a new dict *rest (NULL
/// when none) for PyArg_ParseTupleAndKeywords. Returns 0 with an exception set on failure.
int tsk_py_def_read(const tsk_py_def* table, PyObject* d, void* def, const char* where,
                    char* const* pass, PyObject** rest);

/// The fields of `def` as a new dict (the base's first), or NULL with an exception set.
PyObject* tsk_py_def_dict(const tsk_py_def* table, const void* def);

#endif
