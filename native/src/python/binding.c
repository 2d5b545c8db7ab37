/* The binding's handles (busy guard, closed check) and field tables (def structs <-> dicts),
 * shared by every py_<part>.c. */
#include "binding.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

/* ---- handles --------------------------------------------------------------------------- */

static void handle_destructor(PyObject* cap) {
    const char* name = PyCapsule_GetName(cap);
    tsk_py_handle* h = PyCapsule_GetPointer(cap, name);
    if (h == NULL) {
        PyErr_Clear();
        return;
    }
    if (h->ptr != NULL) h->kind->destroy(h->ptr);
    PyMem_Free(h);
}

PyObject* tsk_py_handle_new(const tsk_py_kind* kind, void* ptr) {
    tsk_py_handle* h = PyMem_Malloc(sizeof *h);
    if (h == NULL) {
        kind->destroy(ptr);
        return PyErr_NoMemory();
    }
    h->ptr = ptr;
    h->kind = kind;
    h->busy = 0;
    PyObject* cap = PyCapsule_New(h, kind->capsule, handle_destructor);
    if (cap == NULL) {
        kind->destroy(ptr);
        PyMem_Free(h);
    }
    return cap;
}

static tsk_py_handle* handle_of(PyObject* obj, const tsk_py_kind* kind) {
    tsk_py_handle* h =
        PyCapsule_IsValid(obj, kind->capsule) ? PyCapsule_GetPointer(obj, kind->capsule) : NULL;
    if (h == NULL) {
        PyErr_Clear();
        tsk_py_raise_arg(kind->arg, "expected a %s handle from %s", kind->noun, kind->maker);
    }
    return h;
}

static int refuse_busy(const tsk_py_handle* h) {
    if (!h->busy) return 0;
    tsk_py_raise_arg(h->kind->arg,
                     "the %s is busy: another thread is using it (a handle serves one "
                     "thread at a time; make one per thread)",
                     h->kind->noun);
    return 1;
}

tsk_py_handle* tsk_py_handle_get(PyObject* obj, const tsk_py_kind* kind) {
    tsk_py_handle* h = handle_of(obj, kind);
    if (h == NULL) return NULL;
    if (h->ptr == NULL) {
        tsk_py_raise_arg(kind->arg, "the %s handle is closed (destroyed by %s)", kind->noun,
                         kind->closer ? kind->closer : "?");
        return NULL;
    }
    return refuse_busy(h) ? NULL : h;
}

int tsk_py_handle_close(PyObject* obj, const tsk_py_kind* kind) {
    tsk_py_handle* h = handle_of(obj, kind);
    if (h == NULL || refuse_busy(h)) return 0;
    void* ptr = h->ptr;
    if (ptr == NULL) return 1; /* closing twice is harmless */
    h->ptr = NULL;
    /* closing a device may wait for its thread: not with the GIL held */
    Py_BEGIN_ALLOW_THREADS kind->destroy(ptr);
    Py_END_ALLOW_THREADS return 1;
}

/* ---- field tables ---------------------------------------------------------------------- */

static int read_int(PyObject* value, const char* key, long long lo, long long hi, long long* out) {
    /* an integer, numpy's included; a float is refused rather than truncated */
    PyObject* i = PyNumber_Index(value);
    if (i == NULL) {
        PyErr_Clear();
        tsk_py_raise_arg(key, "must be an integer");
        return 0;
    }
    int overflow = 0;
    const long long v = PyLong_AsLongLongAndOverflow(i, &overflow);
    Py_DECREF(i);
    if (overflow != 0 || v < lo || v > hi || (v == -1 && PyErr_Occurred())) {
        PyErr_Clear();
        tsk_py_raise_arg(key, "must be an integer from %lld to %lld", lo, hi);
        return 0;
    }
    *out = v;
    return 1;
}

static int read_float(PyObject* value, const char* key, float* out) {
    const double v = PyFloat_AsDouble(value);
    if (v == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        tsk_py_raise_arg(key, "must be a number");
        return 0;
    }
    *out = (float)v;
    return 1;
}

static int read_choice(PyObject* value, const tsk_py_field* f, int* out) {
    const char* s = PyUnicode_Check(value) ? PyUnicode_AsUTF8AndSize(value, NULL) : NULL;
    if (s != NULL)
        for (int i = 0; f->choices[i] != NULL; ++i)
            if (strcmp(s, f->choices[i]) == 0) {
                *out = i;
                return 1;
            }
    PyErr_Clear();
    char list[256] = "";
    size_t n = 0;
    for (int i = 0; f->choices[i] != NULL && n < sizeof list; ++i)
        n += (size_t)snprintf(list + n, sizeof list - n, "%s'%s'",
                              i == 0 ? "" : (f->choices[i + 1] ? ", " : " or "), f->choices[i]);
    if (s != NULL) tsk_py_raise_arg(f->name, "must be %s, got '%s'", list, s);
    else tsk_py_raise_arg(f->name, "must be %s (a string)", list);
    return 0;
}

static int set_value(const tsk_py_field* f, char* p, PyObject* value, void* def) {
    long long v;
    switch (f->type) {
        case TSK_PY_FLOAT:
            return read_float(value, f->name, (float*)p);
        case TSK_PY_INT:
            if (!read_int(value, f->name, INT32_MIN, INT32_MAX, &v)) return 0;
            *(int32_t*)p = (int32_t)v;
            return 1;
        case TSK_PY_U32:
            if (!read_int(value, f->name, 0, UINT32_MAX, &v)) return 0;
            *(uint32_t*)p = (uint32_t)v;
            return 1;
        case TSK_PY_U64: {
            PyObject* i = PyNumber_Index(value);
            if (i == NULL) {
                PyErr_Clear();
                tsk_py_raise_arg(f->name, "must be an integer");
                return 0;
            }
            *(uint64_t*)p = (uint64_t)PyLong_AsUnsignedLongLongMask(i);
            Py_DECREF(i);
            return !PyErr_Occurred();
        }
        case TSK_PY_BOOL: {
            const int t = PyObject_IsTrue(value);
            if (t < 0) return 0;
            *(int*)p = t;
            return 1;
        }
        case TSK_PY_VEC2:
        case TSK_PY_VEC3: {
            const Py_ssize_t n = f->type == TSK_PY_VEC2 ? 2 : 3;
            float x[3];
            if (!PySequence_Check(value) || PySequence_Size(value) != n) {
                PyErr_Clear();
                tsk_py_raise_arg(f->name, "must be a sequence of %zd numbers", n);
                return 0;
            }
            for (Py_ssize_t c = 0; c < n; ++c) {
                PyObject* item = PySequence_GetItem(value, c);
                const double d = item ? PyFloat_AsDouble(item) : -1.0;
                Py_XDECREF(item);
                if (d == -1.0 && PyErr_Occurred()) {
                    PyErr_Clear();
                    tsk_py_raise_arg(f->name, "must be a sequence of %zd numbers", n);
                    return 0;
                }
                x[c] = (float)d;
            }
            memcpy(p, x, (size_t)n * sizeof x[0]);
            return 1;
        }
        case TSK_PY_CHOICE:
            return read_choice(value, f, (int*)p);
        case TSK_PY_CUSTOM:
            return f->read(value, def);
    }
    return 0;
}

int tsk_py_def_set(const tsk_py_def* table, void* def, const char* key, PyObject* value) {
    for (size_t i = 0; i < table->count; ++i) {
        const tsk_py_field* f = &table->fields[i];
        if (strcmp(f->name, key) == 0) return set_value(f, (char*)def + f->offset, value, def);
    }
    if (table->base != NULL)
        return tsk_py_def_set(table->base, (char*)def + table->base_offset, key, value);
    return -1;
}

static int passes(char* const* pass, const char* key) {
    for (; pass != NULL && *pass != NULL; ++pass)
        if (strcmp(*pass, key) == 0) return 1;
    return 0;
}

int tsk_py_def_read(const tsk_py_def* table, PyObject* d, void* def, const char* where,
                    char* const* pass, PyObject** rest) {
    if (rest != NULL) *rest = NULL;
    if (d == NULL) return 1;
    if (!PyDict_Check(d)) {
        tsk_py_raise_arg(where ? where : "def", "must be a dict");
        return 0;
    }
    PyObject *key, *value;
    Py_ssize_t pos = 0;
    while (PyDict_Next(d, &pos, &key, &value)) {
        const char* k = PyUnicode_Check(key) ? PyUnicode_AsUTF8AndSize(key, NULL) : NULL;
        if (k == NULL) {
            PyErr_Clear();
            tsk_py_raise_arg(where ? where : "def", "keys must be strings");
            goto fail;
        }
        const int r = tsk_py_def_set(table, def, k, value);
        if (r == 0) goto fail;
        if (r > 0) continue;
        if (rest != NULL && passes(pass, k)) {
            if (*rest == NULL && (*rest = PyDict_New()) == NULL) goto fail;
            if (PyDict_SetItem(*rest, key, value) != 0) goto fail;
            continue;
        }
        if (where != NULL) tsk_py_raise_arg(where, "unknown %s '%s'", table->noun, k);
        else tsk_py_raise_arg(k, "unknown %s", table->noun);
        goto fail;
    }
    return 1;
fail:
    if (rest != NULL) Py_CLEAR(*rest);
    return 0;
}

static PyObject* field_value(const tsk_py_field* f, const void* def) {
    const char* p = (const char*)def + f->offset;
    switch (f->type) {
        case TSK_PY_FLOAT:
            return PyFloat_FromDouble(*(const float*)p);
        case TSK_PY_INT:
            return PyLong_FromLong(*(const int32_t*)p);
        case TSK_PY_U32:
            return PyLong_FromUnsignedLong(*(const uint32_t*)p);
        case TSK_PY_U64:
            return PyLong_FromUnsignedLongLong(*(const uint64_t*)p);
        case TSK_PY_BOOL:
            return PyBool_FromLong(*(const int*)p);
        case TSK_PY_VEC2: {
            const float* x = (const float*)p;
            return Py_BuildValue("(dd)", (double)x[0], (double)x[1]);
        }
        case TSK_PY_VEC3: {
            const float* x = (const float*)p;
            return Py_BuildValue("(ddd)", (double)x[0], (double)x[1], (double)x[2]);
        }
        case TSK_PY_CHOICE: {
            const int v = *(const int*)p;
            int n = 0;
            while (f->choices[n] != NULL) ++n;
            if (v < 0 || v >= n) return PyLong_FromLong(v);
            return PyUnicode_FromString(f->choices[v]);
        }
        case TSK_PY_CUSTOM:
            return f->write ? f->write(def) : (Py_INCREF(Py_None), Py_None);
    }
    Py_RETURN_NONE;
}

static int fill_dict(PyObject* d, const tsk_py_def* table, const void* def) {
    if (table->base != NULL && !fill_dict(d, table->base, (const char*)def + table->base_offset))
        return 0;
    for (size_t i = 0; i < table->count; ++i) {
        const tsk_py_field* f = &table->fields[i];
        if (f->type == TSK_PY_CUSTOM && f->write == NULL) continue;
        PyObject* v = field_value(f, def);
        if (v == NULL || PyDict_SetItemString(d, f->name, v) != 0) {
            Py_XDECREF(v);
            return 0;
        }
        Py_DECREF(v);
    }
    return 1;
}

PyObject* tsk_py_def_dict(const tsk_py_def* table, const void* def) {
    PyObject* d = PyDict_New();
    if (d != NULL && !fill_dict(d, table, def)) Py_CLEAR(d);
    return d;
}
