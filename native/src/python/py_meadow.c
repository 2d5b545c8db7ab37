/* Binding of the meadow: blade models, the patch (a capsule handle), its mesh, the meadow
 * grid (a capsule handle) with its per-tile and per-chunk instance data, and realised blades.
 * Argument and buffer checks only; every array is a caller-allocated numpy buffer. */
#include "binding.h"

#include "tussock/meadow.h"

#include <stddef.h>
#include <string.h>

static void destroy_patch(void* p) { tsk_patch_destroy(p); }
static void destroy_meadow(void* m) { tsk_meadow_destroy(m); }

static const tsk_py_kind k_patch = {"tussock.patch", "patch", "patch",
                                    "patch_create",  NULL,    destroy_patch};
static const tsk_py_kind k_meadow = {"tussock.meadow", "meadow", "meadow",
                                     "meadow_create",  NULL,     destroy_meadow};

/* ---- blade models ------------------------------------------------------------------------ */

static PyObject* py_blade_model_default(PyObject* self, PyObject* args) {
    (void)self;
    int knots;
    PyObject *xyz_obj, *width_obj;
    if (!PyArg_ParseTuple(args, "iOO:blade_model_default", &knots, &xyz_obj, &width_obj))
        return NULL;
    tsk_blade_model m;
    tsk_status s = tsk_blade_model_default(&m, knots);
    if (s != TSK_OK) return tsk_py_raise(s);
    tsk_py_views v = {.n = 0};
    float *xyz, *width;
    if (!tsk_py_views_get(&v, xyz_obj, "xyz", TSK_PY_F32, 3 * knots, 1, 0, (void**)&xyz) ||
        !tsk_py_views_get(&v, width_obj, "width", TSK_PY_F32, knots, 1, 0, (void**)&width)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    memcpy(xyz, m.xyz, 3 * (size_t)knots * sizeof(float));
    memcpy(width, m.width, (size_t)knots * sizeof(float));
    tsk_py_views_release(&v);
    Py_RETURN_NONE;
}

/* ---- the patch --------------------------------------------------------------------------- */

#define F(name, type) \
    { #name, type, offsetof(tsk_patch_def, name), NULL, NULL, NULL }
static const tsk_py_field k_patch_fields[] = {
    F(blade_count, TSK_PY_INT), F(scale_min, TSK_PY_FLOAT), F(scale_max, TSK_PY_FLOAT),
    F(seed, TSK_PY_U64),        F(knot_count, TSK_PY_INT),
};
#undef F
static const tsk_py_def k_patch_def = {"patch setting", TSK_PY_FIELDS(k_patch_fields), NULL, 0};

static PyObject* py_patch_create(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    /* the models' arrays; the rest of the keywords are the def's */
    static char* names[] = {"knots", "widths", "knot_counts", "weights", NULL};
    tsk_patch_def d = tsk_default_patch_def();
    PyObject *knots_obj = Py_None, *widths_obj = Py_None, *counts_obj = Py_None,
             *weights_obj = Py_None, *rest;
    if (!tsk_py_def_read(&k_patch_def, kw, &d, NULL, names, &rest)) return NULL;
    const int parsed =
        PyArg_ParseTupleAndKeywords(args, rest, "|$OOOO:patch_create", names, &knots_obj,
                                    &widths_obj, &counts_obj, &weights_obj);
    Py_XDECREF(rest);
    if (!parsed) return NULL;
    tsk_py_views v = {.n = 0};
    const int32_t* counts = NULL;
    Py_ssize_t model_count = 0;
    if (counts_obj != Py_None) {
        if (!tsk_py_views_get(&v, counts_obj, "knot_counts", TSK_PY_I32, -1, 0, 0, (void**)&counts))
            return NULL;
        model_count = tsk_py_count(&v.view[0]);
    }
    if (model_count > TSK_PATCH_MAX_MODELS) {
        tsk_py_views_release(&v);
        return tsk_py_raise_arg("knot_counts", "%zd models exceed the limit of %d", model_count,
                                TSK_PATCH_MAX_MODELS);
    }
    const float *knots = NULL, *widths = NULL, *weights = NULL;
    Py_ssize_t total = 0;
    if (model_count > 0) {
        if (!tsk_py_views_get(&v, widths_obj, "widths", TSK_PY_F32, -1, 0, 0, (void**)&widths)) {
            tsk_py_views_release(&v);
            return NULL;
        }
        total = tsk_py_count(&v.view[v.n - 1]);
        if (!tsk_py_views_get(&v, knots_obj, "knots", TSK_PY_F32, 3 * total, 0, 0,
                              (void**)&knots) ||
            !tsk_py_views_get(&v, weights_obj, "weights", TSK_PY_F32, model_count, 0, 1,
                              (void**)&weights)) {
            tsk_py_views_release(&v);
            return NULL;
        }
    }
    tsk_blade_model* models = NULL;
    if (model_count > 0) {
        models = PyMem_Malloc((size_t)model_count * sizeof(tsk_blade_model));
        if (models == NULL) {
            tsk_py_views_release(&v);
            return PyErr_NoMemory();
        }
    }
    d.models = models;
    d.model_count = (int32_t)model_count;
    d.model_weights = weights;
    tsk_patch* patch = NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s =
        tsk_blade_models_set(models, (int32_t)model_count, knots, widths, counts, (size_t)total);
    if (s == TSK_OK) s = tsk_patch_create(&d, &patch);
    Py_END_ALLOW_THREADS PyMem_Free(models);
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    return tsk_py_handle_new(&k_patch, patch);
}

static PyObject* py_patch_info(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* obj;
    if (!PyArg_ParseTuple(args, "O:patch_info", &obj)) return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(obj, &k_patch);
    if (hp == NULL) return NULL;
    tsk_patch* p = hp->ptr;
    size_t nv = 0, nt = 0;
    tsk_patch_mesh_counts(p, &nv, &nt);
    return Py_BuildValue("{s:i,s:i,s:i,s:n,s:n}", "blade_count", (int)tsk_patch_blade_count(p),
                         "knot_count", (int)tsk_patch_knot_count(p), "model_count",
                         (int)tsk_patch_model_count(p), "vertex_count", (Py_ssize_t)nv,
                         "triangle_count", (Py_ssize_t)nt);
}

static PyObject* py_patch_blades(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *obj, *xy_o, *turn_o, *scale_o, *model_o;
    if (!PyArg_ParseTuple(args, "OOOOO:patch_blades", &obj, &xy_o, &turn_o, &scale_o, &model_o))
        return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(obj, &k_patch);
    if (hp == NULL) return NULL;
    tsk_patch* p = hp->ptr;
    const Py_ssize_t n = tsk_patch_blade_count(p);
    tsk_py_views v = {.n = 0};
    float *xy, *turn, *scale;
    int32_t* model;
    if (!tsk_py_views_get(&v, xy_o, "xy", TSK_PY_F32, 2 * n, 1, 1, (void**)&xy) ||
        !tsk_py_views_get(&v, turn_o, "turn", TSK_PY_F32, n, 1, 1, (void**)&turn) ||
        !tsk_py_views_get(&v, scale_o, "scale", TSK_PY_F32, n, 1, 1, (void**)&scale) ||
        !tsk_py_views_get(&v, model_o, "model", TSK_PY_I32, n, 1, 1, (void**)&model)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    hp->busy = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_patch_get_blades(p, xy, turn, scale, model);
    Py_END_ALLOW_THREADS hp->busy = 0;
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_patch_model(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *obj, *xyz_o, *width_o;
    int index;
    if (!PyArg_ParseTuple(args, "OiOO:patch_model", &obj, &index, &xyz_o, &width_o)) return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(obj, &k_patch);
    if (hp == NULL) return NULL;
    tsk_patch* p = hp->ptr;
    tsk_blade_model m;
    tsk_status s = tsk_patch_get_model(p, index, &m);
    if (s != TSK_OK) return tsk_py_raise(s);
    tsk_py_views v = {.n = 0};
    float *xyz, *width;
    if (!tsk_py_views_get(&v, xyz_o, "xyz", TSK_PY_F32, 3 * m.knot_count, 1, 0, (void**)&xyz) ||
        !tsk_py_views_get(&v, width_o, "width", TSK_PY_F32, m.knot_count, 1, 0, (void**)&width)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    memcpy(xyz, m.xyz, 3 * (size_t)m.knot_count * sizeof(float));
    memcpy(width, m.width, (size_t)m.knot_count * sizeof(float));
    tsk_py_views_release(&v);
    Py_RETURN_NONE;
}

static PyObject* py_patch_expand(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *obj, *pos_o, *nrm_o, *uv_o, *tri_o, *bid_o = Py_None;
    float tile_size;
    if (!PyArg_ParseTuple(args, "OfOOOO|O:patch_expand", &obj, &tile_size, &pos_o, &nrm_o, &uv_o,
                          &tri_o, &bid_o))
        return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(obj, &k_patch);
    if (hp == NULL) return NULL;
    tsk_patch* p = hp->ptr;
    size_t nv = 0, nt = 0;
    tsk_patch_mesh_counts(p, &nv, &nt);
    tsk_py_views v = {.n = 0};
    float *pos, *nrm, *uv;
    int32_t *tris, *bid;
    if (!tsk_py_views_get(&v, pos_o, "positions", TSK_PY_F32, 3 * (Py_ssize_t)nv, 1, 1,
                          (void**)&pos) ||
        !tsk_py_views_get(&v, nrm_o, "normals", TSK_PY_F32, 3 * (Py_ssize_t)nv, 1, 1,
                          (void**)&nrm) ||
        !tsk_py_views_get(&v, uv_o, "uvs", TSK_PY_F32, 2 * (Py_ssize_t)nv, 1, 1, (void**)&uv) ||
        !tsk_py_views_get(&v, tri_o, "tris", TSK_PY_I32, 3 * (Py_ssize_t)nt, 1, 1, (void**)&tris) ||
        !tsk_py_views_get(&v, bid_o, "blade_index", TSK_PY_I32, (Py_ssize_t)nv, 1, 1,
                          (void**)&bid)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    hp->busy = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_patch_expand(p, tile_size, pos, nrm, uv, tris, bid);
    Py_END_ALLOW_THREADS hp->busy = 0;
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_blades_expand(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *knots_o, *widths_o, *sides_o, *pos_o, *nrm_o, *uv_o;
    int knot_count;
    if (!PyArg_ParseTuple(args, "OOOiOOO:blades_expand", &knots_o, &widths_o, &sides_o, &knot_count,
                          &pos_o, &nrm_o, &uv_o))
        return NULL;
    if (knot_count < 2 || knot_count > TSK_BLADE_MAX_KNOTS)
        return tsk_py_raise_arg("knot_count", "must be 2..%d, got %d", TSK_BLADE_MAX_KNOTS,
                                knot_count);
    tsk_py_views v = {.n = 0};
    float *sides, *knots, *widths, *pos, *nrm, *uv;
    const Py_ssize_t K = knot_count;
    Py_ssize_t n = 0;
    if (!tsk_py_views_get_xyz(&v, sides_o, "sides", &sides, &n) ||
        !tsk_py_views_get(&v, knots_o, "knots", TSK_PY_F32, 3 * K * n, 0, 0, (void**)&knots) ||
        !tsk_py_views_get(&v, widths_o, "widths", TSK_PY_F32, K * n, 0, 0, (void**)&widths) ||
        !tsk_py_views_get(&v, pos_o, "positions", TSK_PY_F32, 6 * K * n, 1, 1, (void**)&pos) ||
        !tsk_py_views_get(&v, nrm_o, "normals", TSK_PY_F32, 6 * K * n, 1, 1, (void**)&nrm) ||
        !tsk_py_views_get(&v, uv_o, "uvs", TSK_PY_F32, 4 * K * n, 1, 1, (void**)&uv)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s =
        tsk_blades_expand(knots, widths, sides, (size_t)n, knot_count, pos, nrm, uv);
    Py_END_ALLOW_THREADS tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_blade_indices(PyObject* self, PyObject* args) {
    (void)self;
    int knot_count, blade_count;
    PyObject* tri_o;
    if (!PyArg_ParseTuple(args, "iiO:blade_indices", &knot_count, &blade_count, &tri_o))
        return NULL;
    if (knot_count < 2 || knot_count > TSK_BLADE_MAX_KNOTS)
        return tsk_py_raise_arg("knot_count", "must be 2..%d, got %d", TSK_BLADE_MAX_KNOTS,
                                knot_count);
    if (blade_count < 0)
        return tsk_py_raise_arg("blade_count", "must be >= 0, got %d", blade_count);
    tsk_py_views v = {.n = 0};
    int32_t* tris;
    const Py_ssize_t per = 3 * (Py_ssize_t)tsk_blade_triangle_count(knot_count);
    if (!tsk_py_views_get(&v, tri_o, "tris", TSK_PY_I32, per * blade_count, 1, 0, (void**)&tris))
        return NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_blades_indices(knot_count, (size_t)blade_count, tris);
    Py_END_ALLOW_THREADS tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

/* ---- the meadow -------------------------------------------------------------------------- */

static const char* const k_densities[] = {"uniform", "noise", "image", NULL};
_Static_assert(TSK_DENSITY_UNIFORM == 0 && TSK_DENSITY_NOISE == 1 && TSK_DENSITY_IMAGE == 2,
               "k_densities is in enum order");
_Static_assert(sizeof(tsk_density_kind) == sizeof(int), "density is read as an int");

#define F(name, type) \
    { #name, type, offsetof(tsk_meadow_def, name), NULL, NULL, NULL }
static const tsk_py_field k_meadow_fields[] = {
    F(origin, TSK_PY_VEC3),
    F(size, TSK_PY_VEC2),
    F(tile_size, TSK_PY_FLOAT),
    F(blades_per_tile, TSK_PY_INT),
    F(patch_blades, TSK_PY_INT),
    F(chunk_blades, TSK_PY_INT),
    F(seed, TSK_PY_U64),
    {"density", TSK_PY_CHOICE, offsetof(tsk_meadow_def, density), k_densities, NULL, NULL},
    F(noise_scale, TSK_PY_FLOAT),
    F(noise_octaves, TSK_PY_INT),
    F(noise_persistence, TSK_PY_FLOAT),
    F(noise_threshold, TSK_PY_FLOAT),
    F(noise_contrast, TSK_PY_FLOAT),
};
#undef F
static const tsk_py_def k_meadow_def = {"meadow setting", TSK_PY_FIELDS(k_meadow_fields), NULL, 0};

static PyObject* py_meadow_create(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    /* the density image and its size, used when density is 'image'; the rest of the
     * keywords are the def's */
    static char* names[] = {"image", "image_width", "image_height", NULL};
    tsk_meadow_def d = tsk_default_meadow_def();
    PyObject *image_o = Py_None, *rest;
    int iw = 0, ih = 0;
    if (!tsk_py_def_read(&k_meadow_def, kw, &d, NULL, names, &rest)) return NULL;
    const int parsed =
        PyArg_ParseTupleAndKeywords(args, rest, "|$Oii:meadow_create", names, &image_o, &iw, &ih);
    Py_XDECREF(rest);
    if (!parsed) return NULL;
    tsk_py_views v = {.n = 0};
    if (d.density == TSK_DENSITY_IMAGE) {
        if (iw < 1 || ih < 1 || iw > TSK_MEADOW_MAX_IMAGE_SIDE || ih > TSK_MEADOW_MAX_IMAGE_SIDE)
            return tsk_py_raise_arg("image", "size must be 1..%d pixels a side, got %d x %d",
                                    TSK_MEADOW_MAX_IMAGE_SIDE, iw, ih);
        float* img;
        if (!tsk_py_views_get(&v, image_o, "image", TSK_PY_F32, (Py_ssize_t)iw * ih, 0, 0,
                              (void**)&img))
            return NULL;
        d.image = img;
        d.image_width = iw;
        d.image_height = ih;
    }
    tsk_meadow* m = NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_meadow_create(&d, &m);
    Py_END_ALLOW_THREADS tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    return tsk_py_handle_new(&k_meadow, m);
}

static PyObject* py_meadow_info(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* obj;
    if (!PyArg_ParseTuple(args, "O:meadow_info", &obj)) return NULL;
    tsk_py_handle* hm = tsk_py_handle_get(obj, &k_meadow);
    if (hm == NULL) return NULL;
    tsk_meadow* m = hm->ptr;
    tsk_meadow_info i;
    tsk_status s = tsk_meadow_get_info(m, &i);
    if (s != TSK_OK) return tsk_py_raise(s);
    return Py_BuildValue("{s:i,s:i,s:L,s:L,s:L,s:L,s:i,s:i,s:f,s:(fff)}", "tiles_x", i.tiles_x,
                         "tiles_y", i.tiles_y, "tile_count", (long long)i.tile_count, "blade_count",
                         (long long)i.blade_count, "nonempty_tiles", (long long)i.nonempty_tiles,
                         "chunk_instances", (long long)i.chunk_instances, "patch_blades",
                         i.patch_blades, "chunk_blades", i.chunk_blades, "tile_size",
                         (double)i.tile_size, "origin", (double)i.origin[0], (double)i.origin[1],
                         (double)i.origin[2]);
}

static PyObject* py_meadow_tiles(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *obj, *c_o, *o_o, *d_o = Py_None;
    if (!PyArg_ParseTuple(args, "OOO|O:meadow_tiles", &obj, &c_o, &o_o, &d_o)) return NULL;
    tsk_py_handle* hm = tsk_py_handle_get(obj, &k_meadow);
    if (hm == NULL) return NULL;
    tsk_meadow* m = hm->ptr;
    tsk_meadow_info i;
    tsk_meadow_get_info(m, &i);
    const Py_ssize_t T = (Py_ssize_t)i.tile_count;
    tsk_py_views v = {.n = 0};
    int32_t *counts, *offsets;
    float* dens;
    if (!tsk_py_views_get(&v, c_o, "counts", TSK_PY_I32, T, 1, 1, (void**)&counts) ||
        !tsk_py_views_get(&v, o_o, "offsets", TSK_PY_I32, T, 1, 1, (void**)&offsets) ||
        !tsk_py_views_get(&v, d_o, "density", TSK_PY_F32, T, 1, 1, (void**)&dens)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    hm->busy = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_meadow_get_tiles(m, counts, offsets, dens);
    Py_END_ALLOW_THREADS hm->busy = 0;
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_meadow_instances(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *obj, *org_o, *off_o, *cnt_o;
    if (!PyArg_ParseTuple(args, "OOOO:meadow_instances", &obj, &org_o, &off_o, &cnt_o)) return NULL;
    tsk_py_handle* hm = tsk_py_handle_get(obj, &k_meadow);
    if (hm == NULL) return NULL;
    tsk_meadow* m = hm->ptr;
    tsk_meadow_info i;
    tsk_meadow_get_info(m, &i);
    const Py_ssize_t T = (Py_ssize_t)i.tile_count;
    tsk_py_views v = {.n = 0};
    float* org;
    int32_t *off, *cnt;
    if (!tsk_py_views_get(&v, org_o, "origins", TSK_PY_F32, 3 * T, 1, 1, (void**)&org) ||
        !tsk_py_views_get(&v, off_o, "offsets", TSK_PY_I32, T, 1, 1, (void**)&off) ||
        !tsk_py_views_get(&v, cnt_o, "counts", TSK_PY_I32, T, 1, 1, (void**)&cnt)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    hm->busy = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_meadow_instances(m, org, off, cnt);
    Py_END_ALLOW_THREADS hm->busy = 0;
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_meadow_chunk_instances(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *obj, *org_o, *chunk_o, *tile_o = Py_None;
    if (!PyArg_ParseTuple(args, "OOO|O:meadow_chunk_instances", &obj, &org_o, &chunk_o, &tile_o))
        return NULL;
    tsk_py_handle* hm = tsk_py_handle_get(obj, &k_meadow);
    if (hm == NULL) return NULL;
    tsk_meadow* m = hm->ptr;
    tsk_meadow_info i;
    tsk_meadow_get_info(m, &i);
    const Py_ssize_t N = (Py_ssize_t)i.chunk_instances;
    tsk_py_views v = {.n = 0};
    float* org;
    int32_t *chunk, *tile;
    if (!tsk_py_views_get(&v, org_o, "origins", TSK_PY_F32, 3 * N, 1, 1, (void**)&org) ||
        !tsk_py_views_get(&v, chunk_o, "chunk", TSK_PY_I32, N, 1, 1, (void**)&chunk) ||
        !tsk_py_views_get(&v, tile_o, "tile", TSK_PY_I32, N, 1, 1, (void**)&tile)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    hm->busy = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_meadow_chunk_instances(m, org, chunk, tile);
    Py_END_ALLOW_THREADS hm->busy = 0;
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_meadow_blade_count(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* obj;
    long long b, e;
    if (!PyArg_ParseTuple(args, "OLL:meadow_blade_count", &obj, &b, &e)) return NULL;
    tsk_py_handle* hm = tsk_py_handle_get(obj, &k_meadow);
    if (hm == NULL) return NULL;
    tsk_meadow* m = hm->ptr;
    int64_t n = 0;
    tsk_status s = tsk_meadow_blade_count(m, b, e, &n);
    if (s != TSK_OK) return tsk_py_raise(s);
    return PyLong_FromLongLong(n);
}

static PyObject* py_meadow_realise(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *mo, *po, *xyz_o, *turn_o, *scale_o, *idx_o;
    long long b, e;
    if (!PyArg_ParseTuple(args, "OOLLOOOO:meadow_realise", &mo, &po, &b, &e, &xyz_o, &turn_o,
                          &scale_o, &idx_o))
        return NULL;
    tsk_py_handle* hm = tsk_py_handle_get(mo, &k_meadow);
    if (hm == NULL) return NULL;
    tsk_meadow* m = hm->ptr;
    tsk_py_handle* hp = tsk_py_handle_get(po, &k_patch);
    if (hp == NULL) return NULL;
    tsk_patch* p = hp->ptr;
    int64_t n = 0;
    tsk_status s = tsk_meadow_blade_count(m, b, e, &n);
    if (s != TSK_OK) return tsk_py_raise(s);
    tsk_py_views v = {.n = 0};
    float *xyz, *turn, *scale;
    int32_t* idx;
    if (!tsk_py_views_get(&v, xyz_o, "xyz", TSK_PY_F32, 3 * (Py_ssize_t)n, 1, 1, (void**)&xyz) ||
        !tsk_py_views_get(&v, turn_o, "turn", TSK_PY_F32, (Py_ssize_t)n, 1, 1, (void**)&turn) ||
        !tsk_py_views_get(&v, scale_o, "scale", TSK_PY_F32, (Py_ssize_t)n, 1, 1, (void**)&scale) ||
        !tsk_py_views_get(&v, idx_o, "patch_index", TSK_PY_I32, (Py_ssize_t)n, 1, 1,
                          (void**)&idx)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    hm->busy = 1;
    hp->busy = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_meadow_realise(m, p, b, e, xyz, turn, scale, idx);
    Py_END_ALLOW_THREADS hm->busy = 0;
    hp->busy = 0;
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_meadow_realise_knots(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *mo, *po, *k_o, *w_o, *s_o;
    long long b, e;
    if (!PyArg_ParseTuple(args, "OOLLOOO:meadow_realise_knots", &mo, &po, &b, &e, &k_o, &w_o, &s_o))
        return NULL;
    tsk_py_handle* hm = tsk_py_handle_get(mo, &k_meadow);
    if (hm == NULL) return NULL;
    tsk_meadow* m = hm->ptr;
    tsk_py_handle* hp = tsk_py_handle_get(po, &k_patch);
    if (hp == NULL) return NULL;
    tsk_patch* p = hp->ptr;
    int64_t n = 0;
    tsk_status s = tsk_meadow_blade_count(m, b, e, &n);
    if (s != TSK_OK) return tsk_py_raise(s);
    const Py_ssize_t K = tsk_patch_knot_count(p);
    tsk_py_views v = {.n = 0};
    float *knots, *widths, *sides;
    if (!tsk_py_views_get(&v, k_o, "knots", TSK_PY_F32, 3 * K * (Py_ssize_t)n, 1, 1,
                          (void**)&knots) ||
        !tsk_py_views_get(&v, w_o, "widths", TSK_PY_F32, K * (Py_ssize_t)n, 1, 1,
                          (void**)&widths) ||
        !tsk_py_views_get(&v, s_o, "sides", TSK_PY_F32, 3 * (Py_ssize_t)n, 1, 1, (void**)&sides)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    hm->busy = 1;
    hp->busy = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_meadow_realise_knots(m, p, b, e, knots, widths, sides);
    Py_END_ALLOW_THREADS hm->busy = 0;
    hp->busy = 0;
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

PyMethodDef tsk_py_meadow_methods[] = {
    {"blade_model_default", py_blade_model_default, METH_VARARGS,
     "blade_model_default($module, knot_count, xyz, width, /)\n--\n\n"
     "the built-in blade into float32 xyz (3n) and width (n)."},
    {"patch_create", (PyCFunction)(void (*)(void))py_patch_create, METH_VARARGS | METH_KEYWORDS,
     "patch_create($module, *, knots=None, widths=None, knot_counts=None, weights=None, "
     "blade_count=16384, scale_min=0.8, scale_max=1.2, seed=1, knot_count=0)\n--\n\n"
     "-> patch handle. knots float32 (3 per knot), widths float32 (1 per knot), knot_counts "
     "int32 (1 per model), weights float32 (1 per model) or None; no models -> the default "
     "blade."},
    {"patch_info", py_patch_info, METH_VARARGS,
     "patch_info($module, patch, /)\n--\n\n"
     "-> dict(blade_count, knot_count, model_count, vertex_count, triangle_count)."},
    {"patch_blades", py_patch_blades, METH_VARARGS,
     "patch_blades($module, patch, xy, turn, scale, model, /)\n--\n\n"
     "per-blade data (float32 2n, n, n; int32 n); None skips."},
    {"patch_model", py_patch_model, METH_VARARGS,
     "patch_model($module, patch, index, xyz, width, /)\n--\n\n"
     "the resampled rest model (float32 3K, K)."},
    {"patch_expand", py_patch_expand, METH_VARARGS,
     "patch_expand($module, patch, tile_size, positions, normals, uvs, tris, blade_index=None, "
     "/)\n--\n\n"
     "the patch as one mesh in tile-local metres; float32 3V, 3V, 2V; int32 3T, V; None skips."},
    {"blades_expand", py_blades_expand, METH_VARARGS,
     "blades_expand($module, knots, widths, sides, knot_count, positions, normals, uvs, /)\n--\n\n"
     "ribbons of n blades of K knots; float32 3Kn, Kn, 3n in; 6Kn, 6Kn, 4Kn out (None skips)."},
    {"blade_indices", py_blade_indices, METH_VARARGS,
     "blade_indices($module, knot_count, blade_count, tris, /)\n--\n\n"
     "triangle indices of blade_count ribbons laid out blade after blade; int32 6(K-1) per "
     "blade."},
    {"meadow_create", (PyCFunction)(void (*)(void))py_meadow_create, METH_VARARGS | METH_KEYWORDS,
     "meadow_create($module, *, origin=(0,0,0), size=(10,10), tile_size=0.5, blades_per_tile=64, "
     "patch_blades=16384, chunk_blades=1, seed=1, density='noise', noise_scale=8, "
     "noise_octaves=3, noise_persistence=0.5, noise_threshold=0.15, noise_contrast=2.5, "
     "image=None, image_width=0, image_height=0)\n--\n\n"
     "-> meadow handle. density: 'uniform' | 'noise' | 'image' (float32 image of "
     "image_width*image_height values in [0,1], row 0 at origin y)."},
    {"meadow_info", py_meadow_info, METH_VARARGS,
     "meadow_info($module, meadow, /)\n--\n\n"
     "-> dict(tiles_x, tiles_y, tile_count, blade_count, nonempty_tiles, chunk_instances, "
     "patch_blades, chunk_blades, tile_size, origin)."},
    {"meadow_tiles", py_meadow_tiles, METH_VARARGS,
     "meadow_tiles($module, meadow, counts, offsets, density=None, /)\n--\n\n"
     "int32, int32, float32 per tile; None skips."},
    {"meadow_instances", py_meadow_instances, METH_VARARGS,
     "meadow_instances($module, meadow, origins, offsets, counts, /)\n--\n\n"
     "per tile float32 corner (3), int32 patch offset, int32 count; None skips."},
    {"meadow_chunk_instances", py_meadow_chunk_instances, METH_VARARGS,
     "meadow_chunk_instances($module, meadow, origins, chunk, tile=None, /)\n--\n\n"
     "per used chunk float32 tile corner (3), int32 chunk index into the patch, int32 tile "
     "index; chunk_instances of them; None skips."},
    {"meadow_blade_count", py_meadow_blade_count, METH_VARARGS,
     "meadow_blade_count($module, meadow, tile_begin, tile_end, /)\n--\n\n"
     "-> int."},
    {"meadow_realise", py_meadow_realise, METH_VARARGS,
     "meadow_realise($module, meadow, patch, tile_begin, tile_end, xyz, turn, scale, "
     "patch_index, /)\n--\n\n"
     "explicit blades; float32 3n, n, n; int32 n; None skips."},
    {"meadow_realise_knots", py_meadow_realise_knots, METH_VARARGS,
     "meadow_realise_knots($module, meadow, patch, tile_begin, tile_end, knots, widths, sides, "
     "/)\n--\n\n"
     "rest skeletons in world metres; float32 3Kn, Kn, 3n; None skips."},
    {NULL, NULL, 0, NULL},
};
