/* Binding of the picture module: pictures as PyCapsule handles, layers, GrabCut proposals,
 * frames (warped RGBA and the UV pass for Map UV) into caller-owned numpy float32 buffers.
 * Argument and buffer checks only; a picture in use by one thread is refused to another. */
#include "binding.h"

#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "tussock/picture.h"

static void destroy_picture(void* p) { tsk_picture_destroy(p); }

static const tsk_py_kind k_picture = {
    "tussock.picture", "picture", "picture", "picture_load or picture_create", NULL,
    destroy_picture};

static PyObject* wrap(tsk_picture* p) { return tsk_py_handle_new(&k_picture, p); }

static PyObject* py_picture_load(PyObject* self, PyObject* args) {
    (void)self;
    const char* path;
    if (!PyArg_ParseTuple(args, "s:picture_load", &path)) return NULL;
    tsk_picture* p = NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_picture_load(path, &p);
    Py_END_ALLOW_THREADS if (s != TSK_OK) return tsk_py_raise(s);
    return wrap(p);
}

static PyObject* py_picture_create(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"width", "height", "rgba", "bottom_up", NULL};
    int w, h, bottom_up = 0;
    PyObject* obj;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "iiO|p:picture_create", names, &w, &h, &obj,
                                     &bottom_up))
        return NULL;
    Py_buffer rgba;
    if (!tsk_py_buffer(obj, "rgba", TSK_PY_F32, -1, 0, &rgba)) return NULL;
    tsk_picture* p = NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s =
        tsk_picture_create(w, h, rgba.buf, (size_t)tsk_py_count(&rgba), bottom_up, &p);
    Py_END_ALLOW_THREADS PyBuffer_Release(&rgba);
    if (s != TSK_OK) return tsk_py_raise(s);
    return wrap(p);
}

static PyObject* py_picture_size(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* cap;
    if (!PyArg_ParseTuple(args, "O:picture_size", &cap)) return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(cap, &k_picture);
    if (hp == NULL) return NULL;
    tsk_picture* p = hp->ptr;
    int w, h;
    tsk_picture_size(p, &w, &h);
    return Py_BuildValue("(ii)", w, h);
}

static PyObject* py_picture_layer_count(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* cap;
    if (!PyArg_ParseTuple(args, "O:picture_layer_count", &cap)) return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(cap, &k_picture);
    if (hp == NULL) return NULL;
    tsk_picture* p = hp->ptr;
    return PyLong_FromLong(tsk_picture_layer_count(p));
}

/* picture_read_rgba / _background (no layer) and _layer / _matte (with a layer index). */
enum { READ_RGBA, READ_BACKGROUND, READ_LAYER, READ_MATTE };

static PyObject* read_common(PyObject* args, PyObject* kw, int what, const char* fmt) {
    static char* names_plain[] = {"picture", "out", "bottom_up", NULL};
    static char* names_layer[] = {"picture", "layer", "out", "bottom_up", NULL};
    PyObject *cap, *obj;
    int layer = 0, bottom_up = 0;
    int ok = (what == READ_LAYER || what == READ_MATTE)
                 ? PyArg_ParseTupleAndKeywords(args, kw, fmt, names_layer, &cap, &layer, &obj,
                                               &bottom_up)
                 : PyArg_ParseTupleAndKeywords(args, kw, fmt, names_plain, &cap, &obj, &bottom_up);
    if (!ok) return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(cap, &k_picture);
    if (hp == NULL) return NULL;
    tsk_picture* p = hp->ptr;
    int w, h;
    tsk_picture_size(p, &w, &h);
    const Py_ssize_t n = (Py_ssize_t)w * h * (what == READ_MATTE ? 1 : 4);
    Py_buffer out;
    if (!tsk_py_buffer(obj, "out", TSK_PY_F32, n, 1, &out)) return NULL;
    tsk_status s = TSK_OK;
    hp->busy = 1;
    Py_BEGIN_ALLOW_THREADS switch (what) {
        case READ_RGBA:
            s = tsk_picture_read_rgba(p, out.buf, (size_t)n, bottom_up);
            break;
        case READ_BACKGROUND:
            s = tsk_picture_read_background(p, out.buf, (size_t)n, bottom_up);
            break;
        case READ_LAYER:
            s = tsk_picture_read_layer(p, layer, out.buf, (size_t)n, bottom_up);
            break;
        case READ_MATTE:
            s = tsk_picture_read_matte(p, layer, out.buf, (size_t)n, bottom_up);
            break;
    }
    Py_END_ALLOW_THREADS hp->busy = 0;
    PyBuffer_Release(&out);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_picture_read_rgba(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    return read_common(args, kw, READ_RGBA, "OO|p:picture_read_rgba");
}
static PyObject* py_picture_read_background(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    return read_common(args, kw, READ_BACKGROUND, "OO|p:picture_read_background");
}
static PyObject* py_picture_read_layer(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    return read_common(args, kw, READ_LAYER, "OiO|p:picture_read_layer");
}
static PyObject* py_picture_read_matte(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    return read_common(args, kw, READ_MATTE, "OiO|p:picture_read_matte");
}

static const tsk_py_field k_grabcut_fields[] = {
    {"iterations", TSK_PY_INT, offsetof(tsk_grabcut_def, iterations), NULL, NULL, NULL},
};
static const tsk_py_def k_grabcut_def = {"GrabCut setting", TSK_PY_FIELDS(k_grabcut_fields), NULL,
                                         0};

static PyObject* py_picture_propose_mask(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"picture", "rect", "out", "strokes", NULL};
    PyObject *cap, *out_obj, *strokes_obj = Py_None, *rest;
    tsk_grabcut_def g = tsk_default_grabcut_def();
    if (!tsk_py_def_read(&k_grabcut_def, kw, &g, NULL, names, &rest)) return NULL;
    const int parsed = PyArg_ParseTupleAndKeywords(args, rest, "O(iiii)O|O:picture_propose_mask",
                                                   names, &cap, &g.rect_x, &g.rect_y, &g.rect_width,
                                                   &g.rect_height, &out_obj, &strokes_obj);
    Py_XDECREF(rest);
    if (!parsed) return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(cap, &k_picture);
    if (hp == NULL) return NULL;
    tsk_picture* p = hp->ptr;
    int w, h;
    tsk_picture_size(p, &w, &h);
    const Py_ssize_t n = (Py_ssize_t)w * h;
    tsk_py_views v = {.n = 0};
    uint8_t* out;
    const uint8_t* strokes;
    const int has_strokes = strokes_obj != Py_None;
    if (!tsk_py_views_get(&v, out_obj, "out", TSK_PY_U8, n, 1, 0, (void**)&out) ||
        !tsk_py_views_get(&v, strokes_obj, "strokes", TSK_PY_U8, n, 0, 1, (void**)&strokes)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    hp->busy = 1;
    Py_BEGIN_ALLOW_THREADS s =
        tsk_picture_propose_mask(p, &g, strokes, has_strokes ? (size_t)n : 0, out, (size_t)n);
    Py_END_ALLOW_THREADS hp->busy = 0;
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_picture_add_layer(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *cap, *obj;
    if (!PyArg_ParseTuple(args, "OO:picture_add_layer", &cap, &obj)) return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(cap, &k_picture);
    if (hp == NULL) return NULL;
    tsk_picture* p = hp->ptr;
    Py_buffer mask;
    int is_float = 1;
    if (!tsk_py_buffer(obj, "mask", TSK_PY_F32, -1, 0, &mask)) {
        PyErr_Clear();
        is_float = 0;
        if (!tsk_py_buffer(obj, "mask", TSK_PY_U8, -1, 0, &mask)) {
            PyErr_Clear();
            return tsk_py_raise_arg("mask",
                                    "must be a C-contiguous uint8 (>= 128 = vegetation) "
                                    "or float32 (>= 0.5) array of width*height values");
        }
    }
    int index = -1;
    tsk_status s;
    hp->busy = 1;
    Py_BEGIN_ALLOW_THREADS s =
        is_float ? tsk_picture_add_layer_f32(p, mask.buf, (size_t)tsk_py_count(&mask), &index)
                 : tsk_picture_add_layer_u8(p, mask.buf, (size_t)tsk_py_count(&mask), &index);
    Py_END_ALLOW_THREADS hp->busy = 0;
    PyBuffer_Release(&mask);
    if (s != TSK_OK) return tsk_py_raise(s);
    return PyLong_FromLong(index);
}

static const char* const k_methods[] = {"telea", "ns", NULL};
_Static_assert(TSK_INPAINT_TELEA == 0 && TSK_INPAINT_NS == 1, "k_methods is in enum order");
_Static_assert(sizeof(tsk_inpaint_method) == sizeof(int), "method is read as an int");

static const tsk_py_field k_layers_fields[] = {
    {"method", TSK_PY_CHOICE, offsetof(tsk_layers_def, method), k_methods, NULL, NULL},
    {"radius", TSK_PY_FLOAT, offsetof(tsk_layers_def, inpaint_radius), NULL, NULL, NULL},
    {"grow", TSK_PY_FLOAT, offsetof(tsk_layers_def, grow), NULL, NULL, NULL},
    {"feather", TSK_PY_FLOAT, offsetof(tsk_layers_def, feather), NULL, NULL, NULL},
};
static const tsk_py_def k_layers_def = {"layer setting", TSK_PY_FIELDS(k_layers_fields), NULL, 0};

static PyObject* py_picture_build(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"picture", NULL};
    PyObject *cap, *rest;
    tsk_layers_def d = tsk_default_layers_def();
    if (!tsk_py_def_read(&k_layers_def, kw, &d, NULL, names, &rest)) return NULL;
    const int parsed = PyArg_ParseTupleAndKeywords(args, rest, "O:picture_build", names, &cap);
    Py_XDECREF(rest);
    if (!parsed) return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(cap, &k_picture);
    if (hp == NULL) return NULL;
    tsk_picture* p = hp->ptr;
    tsk_status s;
    hp->busy = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_picture_build(p, &d);
    Py_END_ALLOW_THREADS hp->busy = 0;
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

/* The warp definition's keywords, shared by picture_layer_frame and warp_corners (whose
 * frames are not sampled, so it has no `sampling`). The root line and height are given both
 * or neither (then found from the mask): finish_warp_def. */
static const char* const k_roots[] = {"none", "bottom", "top", NULL};
static const char* const k_samplings[] = {"bilinear", "map_uv", "map_uv_5", NULL};
_Static_assert(TSK_ROOT_NONE == 0 && TSK_ROOT_BOTTOM == 1 && TSK_ROOT_TOP == 2,
               "k_roots is in enum order");
_Static_assert(TSK_SAMPLE_BILINEAR == 0 && TSK_SAMPLE_MAP_UV == 1 && TSK_SAMPLE_MAP_UV_5 == 2,
               "k_samplings is in enum order");
_Static_assert(sizeof(tsk_picture_root) == sizeof(int) && sizeof(tsk_warp_sampling) == sizeof(int),
               "root and sampling are read as ints");

#define F(name, type) \
    { #name, type, offsetof(tsk_warp_def, name), NULL, NULL, NULL }
static const tsk_py_field k_warp_fields[] = {
    F(cell_x, TSK_PY_INT),
    F(cell_y, TSK_PY_INT),
    F(lambda_x, TSK_PY_FLOAT),
    F(lambda_y, TSK_PY_FLOAT),
    F(dt, TSK_PY_FLOAT),
    F(rigidity, TSK_PY_FLOAT),
    {"root", TSK_PY_CHOICE, offsetof(tsk_warp_def, root), k_roots, NULL, NULL},
};
static const tsk_py_field k_frame_fields[] = {
    {"sampling", TSK_PY_CHOICE, offsetof(tsk_warp_def, sampling), k_samplings, NULL, NULL},
};
#undef F
static const tsk_py_def k_warp_def = {"warp setting", TSK_PY_FIELDS(k_warp_fields), NULL, 0};
static const tsk_py_def k_frame_def = {"warp setting", TSK_PY_FIELDS(k_frame_fields), &k_warp_def,
                                       0};

static int parse_sampling(const char* name, tsk_warp_sampling* out) {
    for (int i = 0; k_samplings[i] != NULL; ++i)
        if (strcmp(name, k_samplings[i]) == 0) {
            *out = (tsk_warp_sampling)i;
            return 1;
        }
    tsk_py_raise_arg("sampling", "must be 'bilinear', 'map_uv' or 'map_uv_5', got '%s'", name);
    return 0;
}

static int finish_warp_def(tsk_warp_def* def, PyObject* root_y, PyObject* height, int allow_auto) {
    const int given_y = root_y != Py_None, given_h = height != Py_None;
    if (given_y != given_h) {
        tsk_py_raise_arg("root_y, height", "give both (pixels) or neither (found from the mask)");
        return 0;
    }
    if (!given_y && !allow_auto && def->root != TSK_ROOT_NONE) {
        tsk_py_raise_arg("root_y, height", "are needed when root is not 'none'");
        return 0;
    }
    def->auto_root = !given_y;
    if (given_y) {
        def->root_y = (float)PyFloat_AsDouble(root_y);
        def->height = (float)PyFloat_AsDouble(height);
        if (PyErr_Occurred()) return 0;
    }
    return 1;
}

static PyObject* py_picture_layer_frame(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"picture",      "layer",  "vx",        "vy",         "field_width",
                            "field_height", "rgba",   "uv",        "field_y_up", "uv_bottom_up",
                            "root_y",       "height", "scale_map", NULL};
    PyObject *cap, *vx_obj, *vy_obj, *rgba_obj = Py_None, *uv_obj = Py_None;
    PyObject *scale_obj = Py_None, *root_y = Py_None, *height = Py_None, *rest;
    int layer, fw, fh, y_up = 1, uv_bottom_up = 1;
    tsk_warp_def def = tsk_default_warp_def();
    if (!tsk_py_def_read(&k_frame_def, kw, &def, NULL, names, &rest)) return NULL;
    const int parsed = PyArg_ParseTupleAndKeywords(
        args, rest, "OiOOii|OOpp$OOO:picture_layer_frame", names, &cap, &layer, &vx_obj, &vy_obj,
        &fw, &fh, &rgba_obj, &uv_obj, &y_up, &uv_bottom_up, &root_y, &height, &scale_obj);
    Py_XDECREF(rest);
    if (!parsed) return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(cap, &k_picture);
    if (hp == NULL || !finish_warp_def(&def, root_y, height, 1)) return NULL;
    tsk_picture* p = hp->ptr;
    if (fw < 1 || fh < 1 || fw > 4096 || fh > 4096)
        return tsk_py_raise_arg("field_width, field_height", "must be 1..4096, got %dx%d", fw, fh);
    int w, h;
    tsk_picture_size(p, &w, &h);
    const Py_ssize_t n = (Py_ssize_t)w * h;
    tsk_py_views v = {.n = 0};
    const float *vx, *vy, *scale;
    float *rgba, *uv;
    const int have_rgba = rgba_obj != Py_None, have_uv = uv_obj != Py_None;
    const int have_scale = scale_obj != Py_None;
    if (!tsk_py_views_get(&v, vx_obj, "vx", TSK_PY_F32, (Py_ssize_t)fw * fh, 0, 0, (void**)&vx) ||
        !tsk_py_views_get(&v, vy_obj, "vy", TSK_PY_F32, (Py_ssize_t)fw * fh, 0, 0, (void**)&vy) ||
        !tsk_py_views_get(&v, rgba_obj, "rgba", TSK_PY_F32, 4 * n, 1, 1, (void**)&rgba) ||
        !tsk_py_views_get(&v, uv_obj, "uv", TSK_PY_F32, 4 * n, 1, 1, (void**)&uv) ||
        !tsk_py_views_get(&v, scale_obj, "scale_map", TSK_PY_F32, n, 0, 1, (void**)&scale)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_picture_field f = {vx, vy, fw, fh, y_up};
    tsk_status s;
    hp->busy = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_picture_layer_frame(
        p, layer, &def, &f, scale, have_scale ? (size_t)n : 0, rgba,
        have_rgba ? (size_t)(4 * n) : 0, uv, have_uv ? (size_t)(4 * n) : 0, uv_bottom_up);
    Py_END_ALLOW_THREADS hp->busy = 0;
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

_Static_assert(TSK_PICTURE_MAX_LAYERS + 1 <= TSK_PY_MAX_VIEWS,
               "picture_composite holds every layer and out in one tsk_py_views");

static PyObject* py_picture_composite(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *cap, *seq, *out_obj;
    if (!PyArg_ParseTuple(args, "OOO:picture_composite", &cap, &seq, &out_obj)) return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(cap, &k_picture);
    if (hp == NULL) return NULL;
    tsk_picture* p = hp->ptr;
    int w, h;
    tsk_picture_size(p, &w, &h);
    const Py_ssize_t n4 = (Py_ssize_t)w * h * 4;
    const Py_ssize_t count = PySequence_Size(seq);
    if (count < 0) {
        PyErr_Clear();
        return tsk_py_raise_arg("layers", "must be a sequence of float32 arrays or None");
    }
    if (count > TSK_PICTURE_MAX_LAYERS)
        return tsk_py_raise_arg("layers", "at most %d layers, got %zd", TSK_PICTURE_MAX_LAYERS,
                                count);
    tsk_py_views v = {.n = 0};
    const float* ptrs[TSK_PICTURE_MAX_LAYERS];
    float* out;
    int ok = 1;
    for (Py_ssize_t i = 0; i < count && ok; ++i) {
        PyObject* item = PySequence_GetItem(seq, i);
        if (item == NULL) {
            ok = 0;
            break;
        }
        char name[32];
        snprintf(name, sizeof name, "layers[%zd]", i);
        ok = tsk_py_views_get(&v, item, name, TSK_PY_F32, n4, 0, 1, (void**)&ptrs[i]);
        Py_DECREF(item);
    }
    ok = ok && tsk_py_views_get(&v, out_obj, "out", TSK_PY_F32, n4, 1, 0, (void**)&out);
    tsk_status s = TSK_OK;
    if (ok) {
        hp->busy = 1;
        Py_BEGIN_ALLOW_THREADS s = tsk_picture_composite(p, ptrs, (size_t)count, out, (size_t)n4);
        Py_END_ALLOW_THREADS hp->busy = 0;
    }
    tsk_py_views_release(&v);
    if (!ok) return NULL;
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_warp_grid_size(PyObject* self, PyObject* args) {
    (void)self;
    int w, h, sx, sy, cx, cy;
    if (!PyArg_ParseTuple(args, "iiii:warp_grid_size", &w, &h, &sx, &sy)) return NULL;
    tsk_status s = tsk_warp_grid_size(w, h, sx, sy, &cx, &cy);
    if (s != TSK_OK) return tsk_py_raise(s);
    return Py_BuildValue("(ii)", cx, cy);
}

static PyObject* py_warp_corners(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"width",        "height",    "vx",        "vy",         "field_width",
                            "field_height", "corner_dx", "corner_dy", "field_y_up", "root_y",
                            "height_px",    "scale_map", NULL};
    PyObject *vx_obj, *vy_obj, *dx_obj, *dy_obj, *scale_obj = Py_None;
    PyObject *root_y = Py_None, *height_px = Py_None, *rest;
    int w, h, fw, fh, y_up = 1;
    tsk_warp_def def = tsk_default_warp_def();
    if (!tsk_py_def_read(&k_warp_def, kw, &def, NULL, names, &rest)) return NULL;
    const int parsed = PyArg_ParseTupleAndKeywords(args, rest, "iiOOiiOO|p$OOO:warp_corners", names,
                                                   &w, &h, &vx_obj, &vy_obj, &fw, &fh, &dx_obj,
                                                   &dy_obj, &y_up, &root_y, &height_px, &scale_obj);
    Py_XDECREF(rest);
    if (!parsed) return NULL;
    if (!finish_warp_def(&def, root_y, height_px, 0)) return NULL;
    if (fw < 1 || fh < 1 || fw > 4096 || fh > 4096)
        return tsk_py_raise_arg("field_width, field_height", "must be 1..4096, got %dx%d", fw, fh);
    int cx, cy;
    tsk_status s = tsk_warp_grid_size(w, h, def.cell_x, def.cell_y, &cx, &cy);
    if (s != TSK_OK) return tsk_py_raise(s);
    const Py_ssize_t nc = (Py_ssize_t)cx * cy;
    tsk_py_views v = {.n = 0};
    const float *vx, *vy, *scale;
    float *dx, *dy;
    const int have_scale = scale_obj != Py_None;
    if (!tsk_py_views_get(&v, vx_obj, "vx", TSK_PY_F32, (Py_ssize_t)fw * fh, 0, 0, (void**)&vx) ||
        !tsk_py_views_get(&v, vy_obj, "vy", TSK_PY_F32, (Py_ssize_t)fw * fh, 0, 0, (void**)&vy) ||
        !tsk_py_views_get(&v, dx_obj, "corner_dx", TSK_PY_F32, nc, 1, 0, (void**)&dx) ||
        !tsk_py_views_get(&v, dy_obj, "corner_dy", TSK_PY_F32, nc, 1, 0, (void**)&dy) ||
        !tsk_py_views_get(&v, scale_obj, "scale_map", TSK_PY_F32, (Py_ssize_t)w * h, 0, 1,
                          (void**)&scale)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_picture_field f = {vx, vy, fw, fh, y_up};
    Py_BEGIN_ALLOW_THREADS s =
        tsk_warp_corners(&def, w, h, &f, scale, have_scale ? (size_t)w * h : 0, dx, dy, (size_t)nc);
    Py_END_ALLOW_THREADS tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_warp_apply(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"width",     "height", "src", "cell_x",       "cell_y",   "corner_dx",
                            "corner_dy", "dst",    "uv",  "uv_bottom_up", "sampling", NULL};
    PyObject *src_obj, *dx_obj, *dy_obj, *dst_obj = Py_None, *uv_obj = Py_None;
    int w, h, sx, sy, uv_bottom_up = 1;
    const char* sampling_name = "bilinear";
    tsk_warp_sampling sampling;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "iiOiiOO|OOps:warp_apply", names, &w, &h, &src_obj,
                                     &sx, &sy, &dx_obj, &dy_obj, &dst_obj, &uv_obj, &uv_bottom_up,
                                     &sampling_name))
        return NULL;
    if (!parse_sampling(sampling_name, &sampling)) return NULL;
    int cx, cy;
    tsk_status s = tsk_warp_grid_size(w, h, sx, sy, &cx, &cy);
    if (s != TSK_OK) return tsk_py_raise(s);
    const Py_ssize_t nc = (Py_ssize_t)cx * cy, n4 = (Py_ssize_t)w * h * 4;
    tsk_py_views v = {.n = 0};
    const float *dx, *dy, *src = NULL;
    float *dst = NULL, *uv;
    const int have_dst = dst_obj != Py_None, have_uv = uv_obj != Py_None;
    int ok = tsk_py_views_get(&v, dx_obj, "corner_dx", TSK_PY_F32, nc, 0, 0, (void**)&dx) &&
             tsk_py_views_get(&v, dy_obj, "corner_dy", TSK_PY_F32, nc, 0, 0, (void**)&dy);
    if (ok && have_dst)
        ok = tsk_py_views_get(&v, src_obj, "src", TSK_PY_F32, n4, 0, 0, (void**)&src) &&
             tsk_py_views_get(&v, dst_obj, "dst", TSK_PY_F32, n4, 1, 0, (void**)&dst);
    ok = ok && tsk_py_views_get(&v, uv_obj, "uv", TSK_PY_F32, n4, 1, 1, (void**)&uv);
    if (ok) {
        Py_BEGIN_ALLOW_THREADS s = tsk_warp_apply(
            w, h, src, have_dst ? (size_t)n4 : 0, sx, sy, dx, dy, (size_t)nc, sampling, dst,
            have_dst ? (size_t)n4 : 0, uv, have_uv ? (size_t)n4 : 0, uv_bottom_up);
        Py_END_ALLOW_THREADS
    }
    tsk_py_views_release(&v);
    if (!ok) return NULL;
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

#define KW (PyCFunction)(void (*)(void))

PyMethodDef tsk_py_picture_methods[] = {
    {"picture_load", py_picture_load, METH_VARARGS,
     "picture_load($module, path, /)\n--\n\n"
     "-> picture: PNG/JPEG/EXR as straight float RGBA (size limit 16384 per side, 64 Mpx)."},
    {"picture_create", KW py_picture_create, METH_VARARGS | METH_KEYWORDS,
     "picture_create($module, width, height, rgba, bottom_up=False)\n--\n\n"
     "-> picture; rgba float32 4*W*H straight (bottom_up=True for Image.pixels)."},
    {"picture_size", py_picture_size, METH_VARARGS,
     "picture_size($module, picture, /)\n--\n\n"
     "-> (width, height)."},
    {"picture_layer_count", py_picture_layer_count, METH_VARARGS,
     "picture_layer_count($module, picture, /)\n--\n\n"
     "-> int."},
    {"picture_read_rgba", KW py_picture_read_rgba, METH_VARARGS | METH_KEYWORDS,
     "picture_read_rgba($module, picture, out, bottom_up=False)\n--\n\n"
     "straight RGBA as loaded; out float32 4*W*H."},
    {"picture_read_background", KW py_picture_read_background, METH_VARARGS | METH_KEYWORDS,
     "picture_read_background($module, picture, out, bottom_up=False)\n--\n\n"
     "inpainted plate, premultiplied."},
    {"picture_read_layer", KW py_picture_read_layer, METH_VARARGS | METH_KEYWORDS,
     "picture_read_layer($module, picture, layer, out, bottom_up=False)\n--\n\n"
     "layer at rest, premultiplied."},
    {"picture_read_matte", KW py_picture_read_matte, METH_VARARGS | METH_KEYWORDS,
     "picture_read_matte($module, picture, layer, out, bottom_up=False)\n--\n\n"
     "matte, float32 W*H."},
    {"picture_propose_mask", KW py_picture_propose_mask, METH_VARARGS | METH_KEYWORDS,
     "picture_propose_mask($module, picture, rect, out, strokes=None, *, iterations=5)\n--\n\n"
     "GrabCut; out uint8 W*H (255 vegetation); strokes uint8 W*H (0 none, 1 fg, 2 bg); top-"
     "first rows."},
    {"picture_add_layer", py_picture_add_layer, METH_VARARGS,
     "picture_add_layer($module, picture, mask, /)\n--\n\n"
     "-> index; mask uint8 (>= 128) or float32 (>= 0.5), W*H, top-first; layers go back to "
     "front."},
    {"picture_build", KW py_picture_build, METH_VARARGS | METH_KEYWORDS,
     "picture_build($module, picture, *, method='telea', radius=5, grow=3, feather=4)\n--\n\n"
     "inpaint the background, matte the layers."},
    {"picture_layer_frame", KW py_picture_layer_frame, METH_VARARGS | METH_KEYWORDS,
     "picture_layer_frame($module, picture, layer, vx, vy, field_width, field_height, rgba=None, "
     "uv=None, field_y_up=True, uv_bottom_up=True, *, cell_x=16, cell_y=16, lambda_x=4, "
     "lambda_y=4, dt=0.0416667, rigidity=1, root='bottom', root_y=None, height=None, "
     "scale_map=None, sampling='bilinear')\n--\n\n"
     "one frame; rgba (premultiplied, top-first) and/or uv (u, v, 1, 1 for Map UV), float32 "
     "4*W*H. 'map_uv' samples as Blender 3.x/4.x's Map UV node, 'map_uv_5' as Blender 5.x's "
     "(Interpolation 'Anisotropic', CPU compositor)."},
    {"picture_composite", py_picture_composite, METH_VARARGS,
     "picture_composite($module, picture, layers, out, /)\n--\n\n"
     "layers back to front (warped frames or None for at rest) over the background; "
     "premultiplied over."},
    {"warp_grid_size", py_warp_grid_size, METH_VARARGS,
     "warp_grid_size($module, width, height, cell_x, cell_y, /)\n--\n\n"
     "-> (corners_x, corners_y)."},
    {"warp_corners", KW py_warp_corners, METH_VARARGS | METH_KEYWORDS,
     "warp_corners($module, width, height, vx, vy, field_width, field_height, corner_dx, "
     "corner_dy, field_y_up=True, *, cell_x=16, cell_y=16, lambda_x=4, lambda_y=4, dt=0.0416667, "
     "rigidity=1, root='bottom', root_y=None, height_px=None, scale_map=None)\n--\n\n"
     "eq. 5-7 corner displacements in pixels."},
    {"warp_apply", KW py_warp_apply, METH_VARARGS | METH_KEYWORDS,
     "warp_apply($module, width, height, src, cell_x, cell_y, corner_dx, corner_dy, dst=None, "
     "uv=None, uv_bottom_up=True, sampling='bilinear')\n--\n\n"
     "eq. 8 inverse warp of premultiplied RGBA and/or the UV pass; sampling as in "
     "picture_layer_frame."},
    {NULL, NULL, 0, NULL},
};
