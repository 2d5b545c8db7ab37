/* Binding of the tree module: definitions as dicts, a tree as a capsule handle, counts,
 * filling caller-owned numpy buffers (branches, leaves, tips, mesh), the wind step and the
 * OpenSubdiv smoothing handle. Argument and buffer checks only. */
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "binding.h"
#include "tussock/tree.h"

/* ---- definition <-> dict ---------------------------------------------------------------- */

#define FD(n, t) \
    { #n, t, offsetof(tsk_tree_def, n), NULL, NULL, NULL }
#define LD(n, t) \
    { #n, t, offsetof(tsk_tree_level_def, n), NULL, NULL, NULL }
static const tsk_py_field k_level_fields[] = {
    LD(length, TSK_PY_FLOAT),     LD(length_v, TSK_PY_FLOAT),    LD(taper, TSK_PY_FLOAT),
    LD(seg_splits, TSK_PY_FLOAT), LD(split_angle, TSK_PY_FLOAT), LD(split_angle_v, TSK_PY_FLOAT),
    LD(curve_res, TSK_PY_INT),    LD(curve, TSK_PY_FLOAT),       LD(curve_back, TSK_PY_FLOAT),
    LD(curve_v, TSK_PY_FLOAT),    LD(down_angle, TSK_PY_FLOAT),  LD(down_angle_v, TSK_PY_FLOAT),
    LD(rotate, TSK_PY_FLOAT),     LD(rotate_v, TSK_PY_FLOAT),    LD(branches, TSK_PY_INT),
};
static const tsk_py_def k_level_def = {"parameter", TSK_PY_FIELDS(k_level_fields), NULL, 0};

/* 'level': a list of at most TSK_TREE_MAX_LEVELS dicts of k_level_def. */
static int read_levels(PyObject* levels, void* def) {
    tsk_tree_def* d = def;
    if (!PyList_Check(levels) || PyList_Size(levels) > TSK_TREE_MAX_LEVELS) {
        tsk_py_raise_arg("level", "must be a list of at most %d dicts", TSK_TREE_MAX_LEVELS);
        return 0;
    }
    for (Py_ssize_t l = 0; l < PyList_Size(levels); ++l) {
        char name[16];
        snprintf(name, sizeof name, "level[%d]", (int)l);
        if (!tsk_py_def_read(&k_level_def, PyList_GetItem(levels, l), &d->level[l], name, NULL,
                             NULL))
            return 0;
    }
    return 1;
}

static PyObject* write_levels(const void* def) {
    const tsk_tree_def* d = def;
    PyObject* levels = PyList_New(TSK_TREE_MAX_LEVELS);
    for (int l = 0; levels != NULL && l < TSK_TREE_MAX_LEVELS; ++l) {
        PyObject* ld = tsk_py_def_dict(&k_level_def, &d->level[l]);
        if (ld == NULL) Py_CLEAR(levels);
        else PyList_SetItem(levels, l, ld); /* steals */
    }
    return levels;
}

static const tsk_py_field k_tree_fields[] = {
    FD(seed, TSK_PY_U64),
    FD(shape, TSK_PY_INT),
    FD(base_size, TSK_PY_FLOAT),
    FD(scale, TSK_PY_FLOAT),
    FD(scale_v, TSK_PY_FLOAT),
    FD(z_scale, TSK_PY_FLOAT),
    FD(z_scale_v, TSK_PY_FLOAT),
    FD(levels, TSK_PY_INT),
    FD(ratio, TSK_PY_FLOAT),
    FD(ratio_power, TSK_PY_FLOAT),
    FD(lobes, TSK_PY_INT),
    FD(lobe_depth, TSK_PY_FLOAT),
    FD(flare, TSK_PY_FLOAT),
    FD(scale0, TSK_PY_FLOAT),
    FD(scale0_v, TSK_PY_FLOAT),
    FD(base_splits, TSK_PY_INT),
    FD(leaves, TSK_PY_INT),
    FD(leaf_shape, TSK_PY_INT),
    FD(leaf_scale, TSK_PY_FLOAT),
    FD(leaf_scale_x, TSK_PY_FLOAT),
    FD(attraction_up, TSK_PY_FLOAT),
    FD(prune_ratio, TSK_PY_FLOAT),
    FD(prune_width, TSK_PY_FLOAT),
    FD(prune_width_peak, TSK_PY_FLOAT),
    FD(prune_power_low, TSK_PY_FLOAT),
    FD(prune_power_high, TSK_PY_FLOAT),
    FD(taper_power, TSK_PY_FLOAT),
    FD(lobe_fade, TSK_PY_FLOAT),
    FD(bulges, TSK_PY_INT),
    FD(bulge_depth, TSK_PY_FLOAT),
    FD(max_branches, TSK_PY_U32),
    FD(max_leaves, TSK_PY_U32),
    {"level", TSK_PY_CUSTOM, 0, NULL, read_levels, write_levels},
};
#undef FD
#undef LD
static const tsk_py_def k_tree_def = {"parameter", TSK_PY_FIELDS(k_tree_fields), NULL, 0};

/* dict -> def, starting from the defaults (missing keys keep their default; unknown keys are
 * an error: typos must not pass). */
static int dict_to_def(PyObject* d, tsk_tree_def* def) {
    *def = tsk_default_tree_def();
    if (!PyDict_Check(d)) {
        tsk_py_raise_arg("def", "must be a dict (see tree_default_def())");
        return 0;
    }
    return tsk_py_def_read(&k_tree_def, d, def, "def", NULL, NULL);
}

static PyObject* def_to_dict(const tsk_tree_def* def) { return tsk_py_def_dict(&k_tree_def, def); }

/* ---- handles ----------------------------------------------------------------------------- */

static void destroy_tree(void* t) { tsk_tree_destroy(t); }
static void destroy_subdiv(void* s) { tsk_subdiv_destroy(s); }

static const tsk_py_kind k_tree = {"tussock.tree",  "tree", "tree",
                                   "tree_create()", NULL,   destroy_tree};
static const tsk_py_kind k_subdiv = {"tussock.subdiv",  "subdiv", "subdivision",
                                     "subdiv_create()", NULL,     destroy_subdiv};

/* ---- functions ----------------------------------------------------------------------------- */

static PyObject* py_tree_default_def(PyObject* self, PyObject* args) {
    (void)self, (void)args;
    tsk_tree_def d = tsk_default_tree_def();
    return def_to_dict(&d);
}

static PyObject* py_tree_presets(PyObject* self, PyObject* args) {
    (void)self, (void)args;
    PyObject* l = PyList_New(0);
    if (l == NULL) return NULL;
    for (int i = 0; i < tsk_tree_preset_count(); ++i) {
        PyObject* s = PyUnicode_FromString(tsk_tree_preset_name(i));
        if (s == NULL || PyList_Append(l, s) != 0) {
            Py_XDECREF(s);
            Py_DECREF(l);
            return NULL;
        }
        Py_DECREF(s);
    }
    return l;
}

static PyObject* py_tree_preset(PyObject* self, PyObject* args) {
    (void)self;
    const char* name;
    if (!PyArg_ParseTuple(args, "s:tree_preset", &name)) return NULL;
    tsk_tree_def d;
    tsk_status s = tsk_tree_preset(name, &d);
    if (s != TSK_OK) return tsk_py_raise(s);
    return def_to_dict(&d);
}

static PyObject* py_tree_create(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* dict;
    if (!PyArg_ParseTuple(args, "O:tree_create", &dict)) return NULL;
    tsk_tree_def def;
    if (!dict_to_def(dict, &def)) return NULL;
    tsk_tree* t = NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_tree_create(&def, &t);
    Py_END_ALLOW_THREADS if (s != TSK_OK) return tsk_py_raise(s);
    return tsk_py_handle_new(&k_tree, t);
}

static PyObject* py_tree_counts(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* cap;
    if (!PyArg_ParseTuple(args, "O:tree_counts", &cap)) return NULL;
    tsk_py_handle* h = tsk_py_handle_get(cap, &k_tree);
    if (h == NULL) return NULL;
    tsk_tree* t = h->ptr;
    return Py_BuildValue("{s:n,s:n,s:(nnnn)}", "branches", (Py_ssize_t)tsk_tree_branch_count(t),
                         "leaves", (Py_ssize_t)tsk_tree_leaf_count(t), "levels",
                         (Py_ssize_t)tsk_tree_level_branch_count(t, 0),
                         (Py_ssize_t)tsk_tree_level_branch_count(t, 1),
                         (Py_ssize_t)tsk_tree_level_branch_count(t, 2),
                         (Py_ssize_t)tsk_tree_level_branch_count(t, 3));
}

static PyObject* py_tree_branches(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* kwlist[] = {"tree",   "parent", "level",  "points", "rest", "attach",
                             "radius", "length", "orient", "depth",  NULL};
    PyObject *cap,
        *o[9] = {Py_None, Py_None, Py_None, Py_None, Py_None, Py_None, Py_None, Py_None, Py_None};
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O|OOOOOOOOO:tree_branches", kwlist, &cap, &o[0],
                                     &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8]))
        return NULL;
    tsk_py_handle* h = tsk_py_handle_get(cap, &k_tree);
    if (h == NULL) return NULL;
    tsk_tree* t = h->ptr;
    const Py_ssize_t n = (Py_ssize_t)tsk_tree_branch_count(t);
    static const char* names[9] = {"parent", "level",  "points", "rest", "attach",
                                   "radius", "length", "orient", "depth"};
    const tsk_py_dtype types[9] = {TSK_PY_I32, TSK_PY_I32, TSK_PY_F32, TSK_PY_F32, TSK_PY_F32,
                                   TSK_PY_F32, TSK_PY_F32, TSK_PY_F32, TSK_PY_I32};
    const Py_ssize_t per[9] = {1, 1, 12, 12, 3, 2, 1, 3, 1};
    tsk_py_views v = {.n = 0};
    void* p[9];
    int ok = 1;
    for (int i = 0; i < 9 && ok; ++i)
        ok = tsk_py_views_get(&v, o[i], names[i], types[i], per[i] * n, 1, 1, &p[i]);
    if (ok) {
        tsk_tree_branches out = {p[0], p[1], p[8], p[2], p[3], p[4], p[5], p[6], p[7]};
        tsk_status s;
        h->busy = 1;
        Py_BEGIN_ALLOW_THREADS s = tsk_tree_get_branches(t, &out);
        Py_END_ALLOW_THREADS h->busy = 0;
        if (s != TSK_OK) ok = 0, tsk_py_raise(s);
    }
    tsk_py_views_release(&v);
    if (!ok) return NULL;
    Py_RETURN_NONE;
}

static PyObject* py_tree_leaves(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* kwlist[] = {"tree", "position", "direction", "normal", "size", "parent", NULL};
    PyObject *cap, *o[5] = {Py_None, Py_None, Py_None, Py_None, Py_None};
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O|OOOOO:tree_leaves", kwlist, &cap, &o[0], &o[1],
                                     &o[2], &o[3], &o[4]))
        return NULL;
    tsk_py_handle* h = tsk_py_handle_get(cap, &k_tree);
    if (h == NULL) return NULL;
    tsk_tree* t = h->ptr;
    const Py_ssize_t m = (Py_ssize_t)tsk_tree_leaf_count(t);
    static const char* names[5] = {"position", "direction", "normal", "size", "parent"};
    const tsk_py_dtype types[5] = {TSK_PY_F32, TSK_PY_F32, TSK_PY_F32, TSK_PY_F32, TSK_PY_I32};
    const Py_ssize_t per[5] = {3, 3, 3, 2, 1};
    tsk_py_views v = {.n = 0};
    void* p[5];
    int ok = 1;
    for (int i = 0; i < 5 && ok; ++i)
        ok = tsk_py_views_get(&v, o[i], names[i], types[i], per[i] * m, 1, 1, &p[i]);
    if (ok) {
        tsk_status s;
        h->busy = 1;
        Py_BEGIN_ALLOW_THREADS s = tsk_tree_get_leaves(t, p[0], p[1], p[2], p[3], p[4]);
        Py_END_ALLOW_THREADS h->busy = 0;
        if (s != TSK_OK) ok = 0, tsk_py_raise(s);
    }
    tsk_py_views_release(&v);
    if (!ok) return NULL;
    Py_RETURN_NONE;
}

static PyObject* py_tree_tips(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *cap, *out_obj;
    if (!PyArg_ParseTuple(args, "OO:tree_tips", &cap, &out_obj)) return NULL;
    tsk_py_handle* h = tsk_py_handle_get(cap, &k_tree);
    if (h == NULL) return NULL;
    tsk_tree* t = h->ptr;
    Py_buffer out;
    if (!tsk_py_buffer(out_obj, "out", TSK_PY_F32, 3 * (Py_ssize_t)tsk_tree_branch_count(t), 1,
                       &out))
        return NULL;
    tsk_status s;
    h->busy = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_tree_tip_positions(t, out.buf);
    Py_END_ALLOW_THREADS h->busy = 0;
    PyBuffer_Release(&out);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

#define W(name) \
    { #name, TSK_PY_FLOAT, offsetof(tsk_tree_wind_def, name), NULL, NULL, NULL }
static const tsk_py_field k_wind_fields[] = {
    {"mode", TSK_PY_INT, offsetof(tsk_tree_wind_def, mode), NULL, NULL, NULL},
    W(strength),
    W(bend_power),
    W(length_power),
};
#undef W
static const tsk_py_def k_wind_def = {"tree wind setting", TSK_PY_FIELDS(k_wind_fields), NULL, 0};

static PyObject* py_tree_wind_step(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* kwlist[] = {"tree", "force", NULL};
    PyObject *cap, *force_obj, *rest;
    tsk_tree_wind_def w = tsk_default_tree_wind_def();
    if (!tsk_py_def_read(&k_wind_def, kw, &w, NULL, kwlist, &rest)) return NULL;
    const int parsed =
        PyArg_ParseTupleAndKeywords(args, rest, "OO:tree_wind_step", kwlist, &cap, &force_obj);
    Py_XDECREF(rest);
    if (!parsed) return NULL;
    tsk_py_handle* h = tsk_py_handle_get(cap, &k_tree);
    if (h == NULL) return NULL;
    tsk_tree* t = h->ptr;
    Py_buffer f;
    if (!tsk_py_buffer(force_obj, "force", TSK_PY_F32, 3 * (Py_ssize_t)tsk_tree_branch_count(t), 0,
                       &f))
        return NULL;
    tsk_status s;
    h->busy = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_tree_wind_step(t, f.buf, &w);
    Py_END_ALLOW_THREADS h->busy = 0;
    PyBuffer_Release(&f);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_tree_reset(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* cap;
    if (!PyArg_ParseTuple(args, "O:tree_reset", &cap)) return NULL;
    tsk_py_handle* h = tsk_py_handle_get(cap, &k_tree);
    if (h == NULL) return NULL;
    tsk_tree* t = h->ptr;
    tsk_tree_reset_pose(t);
    Py_RETURN_NONE;
}

static PyObject* py_tree_attachment_gap(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* cap;
    if (!PyArg_ParseTuple(args, "O:tree_attachment_gap", &cap)) return NULL;
    tsk_py_handle* h = tsk_py_handle_get(cap, &k_tree);
    if (h == NULL) return NULL;
    tsk_tree* t = h->ptr;
    double g = 0, m = 0;
    tsk_status s = tsk_tree_attachment_gap(t, &g, &m);
    if (s != TSK_OK) return tsk_py_raise(s);
    return Py_BuildValue("(dd)", g, m);
}

/* mesh options: along (4 ints), around (4 ints), leaves (bool) */
static int parse_mesh(PyObject* along, PyObject* around, int leaves, tsk_tree_mesh_def* m) {
    *m = tsk_default_tree_mesh_def();
    m->leaves = leaves != 0;
    PyObject* src[2] = {along, around};
    int* dst[2] = {m->along, m->around};
    const char* names[2] = {"along", "around"};
    for (int k = 0; k < 2; ++k) {
        if (src[k] == Py_None) continue;
        if (!PyTuple_Check(src[k]) && !PyList_Check(src[k])) {
            tsk_py_raise_arg(names[k], "must be a tuple of %d ints", TSK_TREE_MAX_LEVELS);
            return 0;
        }
        PyObject* seq = PySequence_Tuple(src[k]);
        if (seq == NULL) return 0;
        if (PyTuple_Size(seq) != TSK_TREE_MAX_LEVELS) {
            Py_DECREF(seq);
            tsk_py_raise_arg(names[k], "must have %d entries (one per level)", TSK_TREE_MAX_LEVELS);
            return 0;
        }
        for (int l = 0; l < TSK_TREE_MAX_LEVELS; ++l) {
            long v = PyLong_AsLong(PyTuple_GetItem(seq, l));
            if (v == -1 && PyErr_Occurred()) {
                PyErr_Clear();
                Py_DECREF(seq);
                tsk_py_raise_arg(names[k], "entries must be integers");
                return 0;
            }
            dst[k][l] = v > 100000 ? 100000 : v < -100000 ? -100000 : (int)v;
        }
        Py_DECREF(seq);
    }
    return 1;
}

/* The tree and mesh settings of a tree_mesh_* call and the mesh's sizes; NULL with a Python
 * error set. */
static tsk_tree* mesh_call(PyObject* cap, PyObject* along, PyObject* around, int leaves,
                           tsk_tree_mesh_def* m, size_t* nv, size_t* nf, tsk_py_handle** h) {
    *h = tsk_py_handle_get(cap, &k_tree);
    if (*h == NULL || !parse_mesh(along, around, leaves, m)) return NULL;
    tsk_tree* t = (*h)->ptr;
    tsk_status s = tsk_tree_mesh_count(t, m, nv, nf);
    if (s != TSK_OK) {
        tsk_py_raise(s);
        return NULL;
    }
    return t;
}

static PyObject* py_tree_mesh_count(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* kwlist[] = {"tree", "along", "around", "leaves", NULL};
    PyObject *cap, *along = Py_None, *around = Py_None;
    int leaves = 1;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O|OOp:tree_mesh_count", kwlist, &cap, &along,
                                     &around, &leaves))
        return NULL;
    tsk_tree_mesh_def m;
    size_t nv = 0, nf = 0;
    tsk_py_handle* h;
    if (mesh_call(cap, along, around, leaves, &m, &nv, &nf, &h) == NULL) return NULL;
    return Py_BuildValue("(nn)", (Py_ssize_t)nv, (Py_ssize_t)nf);
}

/* tree_mesh_topology, tree_mesh_edges and tree_mesh_deform: a tree, two arrays sized by the
 * mesh and the meshing arguments. */
typedef enum { MESH_TOPOLOGY, MESH_EDGES, MESH_DEFORM } mesh_kind;
typedef struct mesh_op {
    mesh_kind kind;
    const char* format;
    char* kwlist[7];
    tsk_py_dtype dtype[2];
    Py_ssize_t per_vertex[2], per_face[2]; /* elements per vertex and per quad */
    int optional[2];
} mesh_op;

static const mesh_op mesh_ops[] = {
    {MESH_TOPOLOGY,
     "OO|OOOp:tree_mesh_topology",
     {"tree", "faces", "uvs", "along", "around", "leaves", NULL},
     {TSK_PY_I32, TSK_PY_F32},
     {0, 0},
     {4, 8},
     {0, 1}},
    {MESH_EDGES,
     "OOO|OOp:tree_mesh_edges",
     {"tree", "edges", "corner_edges", "along", "around", "leaves", NULL},
     {TSK_PY_I32, TSK_PY_I32},
     {0, 0},
     {8, 4},
     {0, 0}},
    {MESH_DEFORM,
     "OO|OOOp:tree_mesh_deform",
     {"tree", "positions", "normals", "along", "around", "leaves", NULL},
     {TSK_PY_F32, TSK_PY_F32},
     {3, 3},
     {0, 0},
     {0, 1}},
};

static PyObject* tree_mesh_arrays(PyObject* args, PyObject* kw, const mesh_op* op) {
    PyObject *cap, *obj[2] = {Py_None, Py_None}, *along = Py_None, *around = Py_None;
    int leaves = 1;
    if (!PyArg_ParseTupleAndKeywords(args, kw, op->format, (char**)op->kwlist, &cap, &obj[0],
                                     &obj[1], &along, &around, &leaves))
        return NULL;
    tsk_tree_mesh_def m;
    size_t nv = 0, nf = 0, count = 0;
    tsk_py_handle* h;
    tsk_tree* t = mesh_call(cap, along, around, leaves, &m, &nv, &nf, &h);
    if (t == NULL) return NULL;
    tsk_py_views v = {.n = 0};
    void* a[2];
    for (int i = 0; i < 2; ++i) {
        const Py_ssize_t n = op->per_vertex[i] * (Py_ssize_t)nv + op->per_face[i] * (Py_ssize_t)nf;
        if (!tsk_py_views_get(&v, obj[i], op->kwlist[1 + i], op->dtype[i], n, 1, op->optional[i],
                              &a[i])) {
            tsk_py_views_release(&v);
            return NULL;
        }
    }
    tsk_status s;
    h->busy = 1;
    Py_BEGIN_ALLOW_THREADS switch (op->kind) {
        case MESH_TOPOLOGY:
            s = tsk_tree_mesh_topology(t, &m, a[0], a[1]);
            break;
        case MESH_EDGES:
            s = tsk_tree_mesh_edges(t, &m, a[0], a[1], &count);
            break;
        default:
            s = tsk_tree_mesh_deform(t, &m, a[0], a[1]);
            break;
    }
    Py_END_ALLOW_THREADS h->busy = 0;
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    if (op->kind == MESH_EDGES) return PyLong_FromSize_t(count);
    Py_RETURN_NONE;
}

static PyObject* py_tree_mesh_topology(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    return tree_mesh_arrays(args, kw, &mesh_ops[MESH_TOPOLOGY]);
}

static PyObject* py_tree_mesh_edges(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    return tree_mesh_arrays(args, kw, &mesh_ops[MESH_EDGES]);
}

static PyObject* py_tree_mesh_deform(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    return tree_mesh_arrays(args, kw, &mesh_ops[MESH_DEFORM]);
}

static PyObject* py_subdiv_create(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* faces_obj;
    Py_ssize_t nv;
    int levels;
    if (!PyArg_ParseTuple(args, "Oni:subdiv_create", &faces_obj, &nv, &levels)) return NULL;
    if (nv < 0) return tsk_py_raise_arg("vertex_count", "must be >= 0");
    Py_buffer faces;
    if (!tsk_py_buffer(faces_obj, "faces", TSK_PY_I32, -1, 0, &faces)) return NULL;
    const Py_ssize_t count = tsk_py_count(&faces);
    if (count % 4 != 0) {
        PyBuffer_Release(&faces);
        return tsk_py_raise_arg("faces", "length must be a multiple of 4 (quads), got %zd", count);
    }
    tsk_subdiv* sd = NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s =
        tsk_subdiv_create(faces.buf, (size_t)count / 4, (size_t)nv, levels, &sd);
    Py_END_ALLOW_THREADS PyBuffer_Release(&faces);
    if (s != TSK_OK) return tsk_py_raise(s);
    return tsk_py_handle_new(&k_subdiv, sd);
}

static PyObject* py_subdiv_counts(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* cap;
    if (!PyArg_ParseTuple(args, "O:subdiv_counts", &cap)) return NULL;
    tsk_py_handle* h = tsk_py_handle_get(cap, &k_subdiv);
    if (h == NULL) return NULL;
    tsk_subdiv* sd = h->ptr;
    return Py_BuildValue("(nn)", (Py_ssize_t)tsk_subdiv_vertex_count(sd),
                         (Py_ssize_t)tsk_subdiv_face_count(sd));
}

static PyObject* py_subdiv_faces(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *cap, *out_obj;
    if (!PyArg_ParseTuple(args, "OO:subdiv_faces", &cap, &out_obj)) return NULL;
    tsk_py_handle* h = tsk_py_handle_get(cap, &k_subdiv);
    if (h == NULL) return NULL;
    tsk_subdiv* sd = h->ptr;
    Py_buffer out;
    if (!tsk_py_buffer(out_obj, "out", TSK_PY_I32, 4 * (Py_ssize_t)tsk_subdiv_face_count(sd), 1,
                       &out))
        return NULL;
    tsk_status s = tsk_subdiv_faces(sd, out.buf);
    PyBuffer_Release(&out);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_subdiv_apply(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *cap, *cage_obj, *out_obj;
    if (!PyArg_ParseTuple(args, "OOO:subdiv_apply", &cap, &cage_obj, &out_obj)) return NULL;
    tsk_py_handle* h = tsk_py_handle_get(cap, &k_subdiv);
    if (h == NULL) return NULL;
    tsk_subdiv* sd = h->ptr;
    Py_buffer cage, out;
    if (!tsk_py_buffer(out_obj, "out", TSK_PY_F32, 3 * (Py_ssize_t)tsk_subdiv_vertex_count(sd), 1,
                       &out))
        return NULL;
    if (!tsk_py_buffer(cage_obj, "cage", TSK_PY_F32,
                       3 * (Py_ssize_t)tsk_subdiv_cage_vertex_count(sd), 0, &cage)) {
        PyBuffer_Release(&out);
        return NULL;
    }
    tsk_status s = TSK_OK;
    h->busy = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_subdiv_apply(sd, cage.buf, out.buf);
    Py_END_ALLOW_THREADS h->busy = 0;
    PyBuffer_Release(&cage);
    PyBuffer_Release(&out);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_quad_normals(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *pos_obj, *faces_obj, *out_obj;
    if (!PyArg_ParseTuple(args, "OOO:quad_normals", &pos_obj, &faces_obj, &out_obj)) return NULL;
    Py_buffer pos, faces, out;
    if (!tsk_py_buffer(pos_obj, "positions", TSK_PY_F32, -1, 0, &pos)) return NULL;
    const Py_ssize_t n3 = tsk_py_count(&pos);
    if (n3 % 3 != 0) {
        PyBuffer_Release(&pos);
        return tsk_py_raise_arg("positions", "length must be a multiple of 3");
    }
    if (!tsk_py_buffer(out_obj, "out", TSK_PY_F32, n3, 1, &out)) {
        PyBuffer_Release(&pos);
        return NULL;
    }
    if (!tsk_py_buffer(faces_obj, "faces", TSK_PY_I32, -1, 0, &faces)) {
        PyBuffer_Release(&pos), PyBuffer_Release(&out);
        return NULL;
    }
    const Py_ssize_t nq = tsk_py_count(&faces);
    tsk_status s = TSK_OK;
    if (nq % 4 != 0) {
        PyBuffer_Release(&pos), PyBuffer_Release(&out), PyBuffer_Release(&faces);
        return tsk_py_raise_arg("faces", "length must be a multiple of 4 (quads)");
    }
    Py_BEGIN_ALLOW_THREADS s =
        tsk_quad_normals(pos.buf, (size_t)n3 / 3, faces.buf, (size_t)nq / 4, out.buf);
    Py_END_ALLOW_THREADS PyBuffer_Release(&pos), PyBuffer_Release(&out), PyBuffer_Release(&faces);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

PyMethodDef tsk_py_tree_methods[] = {
    {"tree_default_def", py_tree_default_def, METH_NOARGS,
     "tree_default_def($module, /)\n--\n\n"
     "-> dict: every Weber-Penn parameter with its default; 'level' is a list of 4 per-level "
     "dicts."},
    {"tree_presets", py_tree_presets, METH_NOARGS,
     "tree_presets($module, /)\n--\n\n"
     "-> list of preset names."},
    {"tree_preset", py_tree_preset, METH_VARARGS,
     "tree_preset($module, name, /)\n--\n\n"
     "-> dict of that preset."},
    {"tree_create", py_tree_create, METH_VARARGS,
     "tree_create($module, definition, /)\n--\n\n"
     "-> tree handle. Missing keys keep their defaults; unknown keys and bad values raise "
     "tussock.Error naming the parameter."},
    {"tree_counts", py_tree_counts, METH_VARARGS,
     "tree_counts($module, tree, /)\n--\n\n"
     "-> {'branches', 'leaves', 'levels': (n0, n1, n2, n3)}."},
    {"tree_branches", (PyCFunction)(void (*)(void))py_tree_branches, METH_VARARGS | METH_KEYWORDS,
     "tree_branches($module, tree, parent=None, level=None, points=None, rest=None, attach=None, "
     "radius=None, length=None, orient=None, depth=None)\n--\n\n"
     "fills the given buffers (int32 n, int32 n, float32 12n, 12n, 3n, 2n, n, 3n, int32 n)."},
    {"tree_leaves", (PyCFunction)(void (*)(void))py_tree_leaves, METH_VARARGS | METH_KEYWORDS,
     "tree_leaves($module, tree, position=None, direction=None, normal=None, size=None, "
     "parent=None)\n--\n\n"
     "float32 3m, 3m, 3m, 2m, int32 m."},
    {"tree_tips", py_tree_tips, METH_VARARGS,
     "tree_tips($module, tree, out, /)\n--\n\n"
     "branch tips, float32 3n (where to sample the wind)."},
    {"tree_wind_step", (PyCFunction)(void (*)(void))py_tree_wind_step, METH_VARARGS | METH_KEYWORDS,
     "tree_wind_step($module, tree, force, *, mode=0, strength=1.0, bend_power=1.8, "
     "length_power=1.0)\n--\n\n"
     "force float32 3n at the tips; mode 0 = lagged (seed), 1 = exact."},
    {"tree_reset", py_tree_reset, METH_VARARGS,
     "tree_reset($module, tree, /)\n--\n\n"
     "back to the rest pose."},
    {"tree_attachment_gap", py_tree_attachment_gap, METH_VARARGS,
     "tree_attachment_gap($module, tree, /)\n--\n\n"
     "-> (largest child gap / parent radius, largest gap in m)."},
    {"tree_mesh_count", (PyCFunction)(void (*)(void))py_tree_mesh_count,
     METH_VARARGS | METH_KEYWORDS,
     "tree_mesh_count($module, tree, along=None, around=None, leaves=True)\n--\n\n"
     "-> (vertices, quads)."},
    {"tree_mesh_topology", (PyCFunction)(void (*)(void))py_tree_mesh_topology,
     METH_VARARGS | METH_KEYWORDS,
     "tree_mesh_topology($module, tree, faces, uvs=None, along=None, around=None, "
     "leaves=True)\n--\n\n"
     "faces int32 4q, uvs float32 8q (per corner)."},
    {"tree_mesh_edges", (PyCFunction)(void (*)(void))py_tree_mesh_edges,
     METH_VARARGS | METH_KEYWORDS,
     "tree_mesh_edges($module, tree, edges, corner_edges, along=None, around=None, "
     "leaves=True)\n--\n\n"
     "-> edge count: edges int32 8q (2 per edge, the first 2 * count written), corner_edges "
     "int32 4q; the edges of tree_mesh_topology's faces in closed form."},
    {"tree_mesh_deform", (PyCFunction)(void (*)(void))py_tree_mesh_deform,
     METH_VARARGS | METH_KEYWORDS,
     "tree_mesh_deform($module, tree, positions, normals=None, along=None, around=None, "
     "leaves=True)\n--\n\n"
     "float32 3v each, for the current pose."},
    {"subdiv_create", py_subdiv_create, METH_VARARGS,
     "subdiv_create($module, faces, vertex_count, levels, /)\n--\n\n"
     "-> handle (OpenSubdiv stencils, built once)."},
    {"subdiv_counts", py_subdiv_counts, METH_VARARGS,
     "subdiv_counts($module, h, /)\n--\n\n"
     "-> (vertices, quads)."},
    {"subdiv_faces", py_subdiv_faces, METH_VARARGS,
     "subdiv_faces($module, h, out, /)\n--\n\n"
     "int32 4q."},
    {"subdiv_apply", py_subdiv_apply, METH_VARARGS,
     "subdiv_apply($module, h, cage, out, /)\n--\n\n"
     "cage float32 3*cage_vertices, out float32 3*vertices."},
    {"quad_normals", py_quad_normals, METH_VARARGS,
     "quad_normals($module, positions, faces, out, /)\n--\n\n"
     "area-weighted vertex normals."},
    {NULL, NULL, 0, NULL},
};
