/* Binding of the picture module: pictures as PyCapsule handles, layers, GrabCut proposals,
 * frames (warped RGBA and the UV pass for Map UV) into caller-owned numpy float32 buffers.
 * Argument and buffer checks only; a picture must not be used by two threads at once. */
#include "binding.h"

#include <stdio.h>
#include <string.h>

#include "tussock/picture.h"

static void destroy_picture(void* p) { tsk_picture_destroy(p); }

static const tsk_py_kind k_picture = {"tussock.picture", "picture", "picture",
                                      "picture_load or picture_create", destroy_picture};

static PyObject* wrap(tsk_picture* p) { return tsk_py_handle_new(&k_picture, p); }

static PyObject* py_picture_load(PyObject* self, PyObject* args) {
    (void)self;
    const char* path;
    if (!PyArg_ParseTuple(args, "s:picture_load", &path)) return NULL;
    tsk_picture* p = NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS
    s = tsk_picture_load(path, &p);
    Py_END_ALLOW_THREADS
    if (s != TSK_OK) return tsk_py_raise(s);
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
    Py_BEGIN_ALLOW_THREADS
    s = tsk_picture_create(w, h, rgba.buf, (size_t)tsk_py_count(&rgba), bottom_up, &p);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&rgba);
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
                 : PyArg_ParseTupleAndKeywords(args, kw, fmt, names_plain, &cap, &obj,
                                               &bottom_up);
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
    Py_BEGIN_ALLOW_THREADS
    switch (what) {
    case READ_RGBA: s = tsk_picture_read_rgba(p, out.buf, (size_t)n, bottom_up); break;
    case READ_BACKGROUND: s = tsk_picture_read_background(p, out.buf, (size_t)n, bottom_up); break;
    case READ_LAYER: s = tsk_picture_read_layer(p, layer, out.buf, (size_t)n, bottom_up); break;
    case READ_MATTE: s = tsk_picture_read_matte(p, layer, out.buf, (size_t)n, bottom_up); break;
    }
    Py_END_ALLOW_THREADS
    hp->busy = 0;
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

static PyObject* py_picture_propose_mask(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"picture", "rect", "out", "strokes", "iterations", NULL};
    PyObject *cap, *out_obj, *strokes_obj = Py_None;
    tsk_grabcut_def g = tsk_default_grabcut_def();
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O(iiii)O|Oi:picture_propose_mask", names, &cap,
                                     &g.rect_x, &g.rect_y, &g.rect_width, &g.rect_height,
                                     &out_obj, &strokes_obj, &g.iterations))
        return NULL;
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
    Py_BEGIN_ALLOW_THREADS
    s = tsk_picture_propose_mask(p, &g, strokes, has_strokes ? (size_t)n : 0, out, (size_t)n);
    Py_END_ALLOW_THREADS
    hp->busy = 0;
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
            return tsk_py_raise_arg("mask", "must be a C-contiguous uint8 (>= 128 = vegetation) "
                                            "or float32 (>= 0.5) array of width*height values");
        }
    }
    int index = -1;
    tsk_status s;
    hp->busy = 1;
    Py_BEGIN_ALLOW_THREADS
    s = is_float ? tsk_picture_add_layer_f32(p, mask.buf, (size_t)tsk_py_count(&mask), &index)
                 : tsk_picture_add_layer_u8(p, mask.buf, (size_t)tsk_py_count(&mask), &index);
    Py_END_ALLOW_THREADS
    hp->busy = 0;
    PyBuffer_Release(&mask);
    if (s != TSK_OK) return tsk_py_raise(s);
    return PyLong_FromLong(index);
}

static PyObject* py_picture_build(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"picture", "method", "radius", "grow", "feather", NULL};
    PyObject* cap;
    const char* method = "telea";
    tsk_layers_def d = tsk_default_layers_def();
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O|sfff:picture_build", names, &cap, &method,
                                     &d.inpaint_radius, &d.grow, &d.feather))
        return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(cap, &k_picture);
    if (hp == NULL) return NULL;
    tsk_picture* p = hp->ptr;
    if (strcmp(method, "telea") == 0) d.method = TSK_INPAINT_TELEA;
    else if (strcmp(method, "ns") == 0) d.method = TSK_INPAINT_NS;
    else return tsk_py_raise_arg("method", "must be 'telea' or 'ns', got '%s'", method);
    tsk_status s;
    hp->busy = 1;
    Py_BEGIN_ALLOW_THREADS
    s = tsk_picture_build(p, &d);
    Py_END_ALLOW_THREADS
    hp->busy = 0;
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

/* Keyword arguments of a warp definition shared by picture_layer_frame and warp_corners. */
typedef struct warp_args {
    tsk_warp_def def;
    const char* sampling;
    const char* root;
    PyObject* root_y;
    PyObject* height;
} warp_args;

static int parse_sampling(const char* name, tsk_warp_sampling* out) {
    if (strcmp(name, "bilinear") == 0) *out = TSK_SAMPLE_BILINEAR;
    else if (strcmp(name, "map_uv") == 0) *out = TSK_SAMPLE_MAP_UV;
    else if (strcmp(name, "map_uv_5") == 0) *out = TSK_SAMPLE_MAP_UV_5;
    else {
        tsk_py_raise_arg("sampling", "must be 'bilinear', 'map_uv' or 'map_uv_5', got '%s'",
                         name);
        return 0;
    }
    return 1;
}

static int finish_warp_def(warp_args* a, int allow_auto) {
    if (!parse_sampling(a->sampling, &a->def.sampling)) return 0;
    if (strcmp(a->root, "none") == 0) a->def.root = TSK_ROOT_NONE;
    else if (strcmp(a->root, "bottom") == 0) a->def.root = TSK_ROOT_BOTTOM;
    else if (strcmp(a->root, "top") == 0) a->def.root = TSK_ROOT_TOP;
    else {
        tsk_py_raise_arg("root", "must be 'none', 'bottom' or 'top', got '%s'", a->root);
        return 0;
    }
    const int given_y = a->root_y != Py_None, given_h = a->height != Py_None;
    if (given_y != given_h) {
        tsk_py_raise_arg("root_y, height", "give both (pixels) or neither (found from the mask)");
        return 0;
    }
    if (!given_y && !allow_auto && a->def.root != TSK_ROOT_NONE) {
        tsk_py_raise_arg("root_y, height", "are needed when root is not 'none'");
        return 0;
    }
    a->def.auto_root = !given_y;
    if (given_y) {
        a->def.root_y = (float)PyFloat_AsDouble(a->root_y);
        a->def.height = (float)PyFloat_AsDouble(a->height);
        if (PyErr_Occurred()) return 0;
    }
    return 1;
}

static PyObject* py_picture_layer_frame(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"picture", "layer", "vx", "vy", "field_width", "field_height",
                            "rgba", "uv", "field_y_up", "uv_bottom_up", "cell_x", "cell_y",
                            "lambda_x", "lambda_y", "dt", "rigidity", "root", "root_y",
                            "height", "scale_map", "sampling", NULL};
    PyObject *cap, *vx_obj, *vy_obj, *rgba_obj = Py_None, *uv_obj = Py_None;
    PyObject* scale_obj = Py_None;
    int layer, fw, fh, y_up = 1, uv_bottom_up = 1;
    warp_args a = {tsk_default_warp_def(), "bilinear", "bottom", Py_None, Py_None};
    if (!PyArg_ParseTupleAndKeywords(args, kw, "OiOOii|OOppiiffffsOOOs:picture_layer_frame",
                                     names, &cap, &layer, &vx_obj, &vy_obj, &fw, &fh, &rgba_obj,
                                     &uv_obj, &y_up, &uv_bottom_up, &a.def.cell_x,
                                     &a.def.cell_y, &a.def.lambda_x, &a.def.lambda_y, &a.def.dt,
                                     &a.def.rigidity, &a.root, &a.root_y, &a.height, &scale_obj,
                                     &a.sampling))
        return NULL;
    tsk_py_handle* hp = tsk_py_handle_get(cap, &k_picture);
    if (hp == NULL || !finish_warp_def(&a, 1)) return NULL;
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
    Py_BEGIN_ALLOW_THREADS
    s = tsk_picture_layer_frame(p, layer, &a.def, &f, scale, have_scale ? (size_t)n : 0, rgba,
                                have_rgba ? (size_t)(4 * n) : 0, uv,
                                have_uv ? (size_t)(4 * n) : 0, uv_bottom_up);
    Py_END_ALLOW_THREADS
    hp->busy = 0;
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
        Py_BEGIN_ALLOW_THREADS
        s = tsk_picture_composite(p, ptrs, (size_t)count, out, (size_t)n4);
        Py_END_ALLOW_THREADS
        hp->busy = 0;
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
    static char* names[] = {"width", "height", "vx", "vy", "field_width", "field_height",
                            "corner_dx", "corner_dy", "field_y_up", "cell_x", "cell_y",
                            "lambda_x", "lambda_y", "dt", "rigidity", "root", "root_y",
                            "height_px", "scale_map", NULL};
    PyObject *vx_obj, *vy_obj, *dx_obj, *dy_obj, *scale_obj = Py_None;
    int w, h, fw, fh, y_up = 1;
    warp_args a = {tsk_default_warp_def(), "bilinear", "bottom", Py_None, Py_None};
    if (!PyArg_ParseTupleAndKeywords(args, kw, "iiOOiiOO|piiffffsOOO:warp_corners", names, &w,
                                     &h, &vx_obj, &vy_obj, &fw, &fh, &dx_obj, &dy_obj, &y_up,
                                     &a.def.cell_x, &a.def.cell_y, &a.def.lambda_x,
                                     &a.def.lambda_y, &a.def.dt, &a.def.rigidity, &a.root,
                                     &a.root_y, &a.height, &scale_obj))
        return NULL;
    if (!finish_warp_def(&a, 0)) return NULL;
    if (fw < 1 || fh < 1 || fw > 4096 || fh > 4096)
        return tsk_py_raise_arg("field_width, field_height", "must be 1..4096, got %dx%d", fw, fh);
    int cx, cy;
    tsk_status s = tsk_warp_grid_size(w, h, a.def.cell_x, a.def.cell_y, &cx, &cy);
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
    Py_BEGIN_ALLOW_THREADS
    s = tsk_warp_corners(&a.def, w, h, &f, scale, have_scale ? (size_t)w * h : 0, dx, dy,
                         (size_t)nc);
    Py_END_ALLOW_THREADS
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_warp_apply(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"width", "height", "src", "cell_x", "cell_y", "corner_dx",
                            "corner_dy", "dst", "uv", "uv_bottom_up", "sampling", NULL};
    PyObject *src_obj, *dx_obj, *dy_obj, *dst_obj = Py_None, *uv_obj = Py_None;
    int w, h, sx, sy, uv_bottom_up = 1;
    const char* sampling_name = "bilinear";
    tsk_warp_sampling sampling;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "iiOiiOO|OOps:warp_apply", names, &w, &h,
                                     &src_obj, &sx, &sy, &dx_obj, &dy_obj, &dst_obj, &uv_obj,
                                     &uv_bottom_up, &sampling_name))
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
        Py_BEGIN_ALLOW_THREADS
        s = tsk_warp_apply(w, h, src, have_dst ? (size_t)n4 : 0, sx, sy, dx, dy, (size_t)nc,
                           sampling, dst, have_dst ? (size_t)n4 : 0, uv, have_uv ? (size_t)n4 : 0,
                           uv_bottom_up);
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
    {"picture_size", py_picture_size, METH_VARARGS, "picture_size($module, picture, /)\n--\n\n"
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
     "picture_propose_mask($module, picture, rect, out, strokes=None, iterations=5)\n--\n\n"
     "GrabCut; out uint8 W*H (255 vegetation); strokes uint8 W*H (0 none, 1 fg, 2 bg); top-"
     "first rows."},
    {"picture_add_layer", py_picture_add_layer, METH_VARARGS,
     "picture_add_layer($module, picture, mask, /)\n--\n\n"
     "-> index; mask uint8 (>= 128) or float32 (>= 0.5), W*H, top-first; layers go back to "
     "front."},
    {"picture_build", KW py_picture_build, METH_VARARGS | METH_KEYWORDS,
     "picture_build($module, picture, method='telea', radius=5, grow=3, feather=4)\n--\n\n"
     "inpaint the background, matte the layers."},
    {"picture_layer_frame", KW py_picture_layer_frame, METH_VARARGS | METH_KEYWORDS,
     "picture_layer_frame($module, picture, layer, vx, vy, field_width, field_height, rgba=None, uv=None, field_y_up=True, uv_bottom_up=True, cell_x=16, cell_y=16, lambda_x=4, lambda_y=4, dt=0.0416667, rigidity=1, root='bottom', root_y=None, height=None, scale_map=None, sampling='bilinear')\n--\n\n"
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
     "warp_corners($module, width, height, vx, vy, field_width, field_height, corner_dx, corner_dy, field_y_up=True, cell_x=16, cell_y=16, lambda_x=4, lambda_y=4, dt=0.0416667, rigidity=1, root='bottom', root_y=None, height_px=None, scale_map=None)\n--\n\n"
     "eq. 5-7 corner displacements in pixels."},
    {"warp_apply", KW py_warp_apply, METH_VARARGS | METH_KEYWORDS,
     "warp_apply($module, width, height, src, cell_x, cell_y, corner_dx, corner_dy, dst=None, uv=None, uv_bottom_up=True, sampling='bilinear')\n--\n\n"
     "eq. 8 inverse warp of premultiplied RGBA and/or the UV pass; sampling as in "
     "picture_layer_frame."},
    {NULL, NULL, 0, NULL},
};
