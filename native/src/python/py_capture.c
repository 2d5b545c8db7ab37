/* Binding of the capture module: depth sources and the blade pipeline as handles
 * (PyCapsules that close themselves), with every array passed in as a caller-owned numpy
 * buffer. Argument and buffer checks only; the GIL is released around C calls. */
#include "binding.h"

#include <stddef.h>
#include <string.h>

#include "tussock/capture.h"

static void destroy_source(void* src) { tsk_depth_close(src); }
static void destroy_capture(void* cap) { tsk_capture_destroy(cap); }

static const tsk_py_kind k_source = {
    "tussock.depth_source", "source",
    "depth source",         "depth_open_files, depth_open_oni or depth_open_device",
    "depth_close",          destroy_source};
static const tsk_py_kind k_capture = {"tussock.capture", "capture", "capture",
                                      "capture_create",  NULL,      destroy_capture};

/* ---- depth sources --------------------------------------------------------------- */

static PyObject* open_source(tsk_status (*fn)(const char*, tsk_depth_source**), const char* path) {
    tsk_depth_source* src = NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = fn(path, &src);
    Py_END_ALLOW_THREADS if (s != TSK_OK) return tsk_py_raise(s);
    return tsk_py_handle_new(&k_source, src);
}

static PyObject* py_depth_open_files(PyObject* self, PyObject* args) {
    (void)self;
    const char* path;
    if (!PyArg_ParseTuple(args, "s:depth_open_files", &path)) return NULL;
    return open_source(tsk_depth_open_files, path);
}

static PyObject* py_depth_open_oni(PyObject* self, PyObject* args) {
    (void)self;
    const char* path;
    if (!PyArg_ParseTuple(args, "s:depth_open_oni", &path)) return NULL;
    return open_source(tsk_depth_open_oni, path);
}

static PyObject* py_depth_open_device(PyObject* self, PyObject* args) {
    (void)self;
    const char* uri = NULL;
    if (!PyArg_ParseTuple(args, "|z:depth_open_device", &uri)) return NULL;
    return open_source(tsk_depth_open_device, uri);
}

static PyObject* py_depth_close(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* h;
    if (!PyArg_ParseTuple(args, "O:depth_close", &h)) return NULL;
    if (!tsk_py_handle_close(h, &k_source)) return NULL;
    Py_RETURN_NONE;
}

static PyObject* source_call(PyObject* args, const char* fmt, tsk_status (*fn)(tsk_depth_source*)) {
    PyObject* h;
    if (!PyArg_ParseTuple(args, fmt, &h)) return NULL;
    tsk_py_handle* box = tsk_py_handle_get(h, &k_source);
    if (box == NULL) return NULL;
    tsk_status s;
    TSK_PY_UNLOCKED(box, s = fn(box->ptr));
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_depth_start(PyObject* self, PyObject* args) {
    (void)self;
    return source_call(args, "O:depth_start", tsk_depth_start);
}

static PyObject* py_depth_stop(PyObject* self, PyObject* args) {
    (void)self;
    return source_call(args, "O:depth_stop", tsk_depth_stop);
}

static const char* kind_name(tsk_depth_kind k) {
    switch (k) {
        case TSK_DEPTH_FILES:
            return "FILES";
        case TSK_DEPTH_ONI:
            return "ONI";
        case TSK_DEPTH_DEVICE:
            return "DEVICE";
    }
    return "?";
}

static PyObject* py_depth_info(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* h;
    if (!PyArg_ParseTuple(args, "O:depth_info", &h)) return NULL;
    tsk_py_handle* box = tsk_py_handle_get(h, &k_source);
    if (box == NULL) return NULL;
    tsk_depth_info info;
    tsk_status s = tsk_depth_get_info(box->ptr, &info);
    if (s != TSK_OK) return tsk_py_raise(s);
    return Py_BuildValue("{s:s,s:i,s:i,s:i,s:i,s:O,s:d,s:d,s:d,s:d,s:s}", "kind",
                         kind_name(info.kind), "width", info.width, "height", info.height,
                         "frame_count", info.frame_count, "first_frame", info.first_frame,
                         "has_device_intrinsics", info.has_device_intrinsics ? Py_True : Py_False,
                         "fx", (double)info.intrinsics.fx, "fy", (double)info.intrinsics.fy, "cx",
                         (double)info.intrinsics.cx, "cy", (double)info.intrinsics.cy,
                         "description", info.description);
}

static PyObject* py_depth_seek(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* h;
    int index;
    if (!PyArg_ParseTuple(args, "Oi:depth_seek", &h, &index)) return NULL;
    tsk_py_handle* box = tsk_py_handle_get(h, &k_source);
    if (box == NULL) return NULL;
    tsk_status s;
    TSK_PY_UNLOCKED(box, s = tsk_depth_seek(box->ptr, index));
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_depth_read(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *h, *out_obj;
    if (!PyArg_ParseTuple(args, "OO:depth_read", &h, &out_obj)) return NULL;
    tsk_py_handle* box = tsk_py_handle_get(h, &k_source);
    if (box == NULL) return NULL;
    tsk_depth_info info;
    tsk_depth_get_info(box->ptr, &info);
    Py_buffer out;
    if (!tsk_py_buffer(out_obj, "out", TSK_PY_F32, (Py_ssize_t)info.width * info.height, 1, &out))
        return NULL;
    tsk_depth_frame fr;
    tsk_status s;
    TSK_PY_UNLOCKED(box, s = tsk_depth_read(box->ptr, out.buf, (size_t)tsk_py_count(&out), &fr));
    PyBuffer_Release(&out);
    if (s != TSK_OK) return tsk_py_raise(s);
    return Py_BuildValue("{s:O,s:O,s:i,s:d,s:i}", "is_new", fr.is_new ? Py_True : Py_False, "end",
                         fr.end ? Py_True : Py_False, "index", fr.index, "timestamp", fr.timestamp,
                         "invalid_pixels", fr.invalid_pixels);
}

static PyObject* write_depth(PyObject* args, const char* fmt,
                             tsk_status (*fn)(const char*, const float*, int, int)) {
    const char* path;
    PyObject* obj;
    int w, h;
    if (!PyArg_ParseTuple(args, fmt, &path, &obj, &w, &h)) return NULL;
    if (w <= 0 || h <= 0 || w > TSK_DEPTH_MAX_SIDE || h > TSK_DEPTH_MAX_SIDE)
        return tsk_py_raise_arg("width", "size %dx%d outside 1..%d", w, h, TSK_DEPTH_MAX_SIDE);
    Py_buffer in;
    if (!tsk_py_buffer(obj, "depth", TSK_PY_F32, (Py_ssize_t)w * h, 0, &in)) return NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = fn(path, in.buf, w, h);
    Py_END_ALLOW_THREADS PyBuffer_Release(&in);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_depth_write_png16(PyObject* self, PyObject* args) {
    (void)self;
    return write_depth(args, "sOii:depth_write_png16", tsk_depth_write_png16);
}

static PyObject* py_depth_write_exr(PyObject* self, PyObject* args) {
    (void)self;
    return write_depth(args, "sOii:depth_write_exr", tsk_depth_write_exr);
}

static PyObject* py_default_intrinsics(PyObject* self, PyObject* args) {
    (void)self;
    int w, h;
    if (!PyArg_ParseTuple(args, "ii:default_intrinsics", &w, &h)) return NULL;
    if (w <= 0 || h <= 0) return tsk_py_raise_arg("width", "size %dx%d must be positive", w, h);
    tsk_intrinsics k = tsk_default_intrinsics(w, h);
    return Py_BuildValue("(dddd)", (double)k.fx, (double)k.fy, (double)k.cx, (double)k.cy);
}

/* ---- the pipeline ---------------------------------------------------------------- */

static PyObject* py_capture_create(PyObject* self, PyObject* args) {
    (void)self;
    (void)args;
    tsk_capture* cap = NULL;
    tsk_status s = tsk_capture_create(&cap);
    if (s != TSK_OK) return tsk_py_raise(s);
    return tsk_py_handle_new(&k_capture, cap);
}

static const char* const k_roots[] = {"BOTTOM", "CENTROID", NULL};
_Static_assert(TSK_ROOT_BOTTOM == 0 && TSK_ROOT_CENTROID == 1, "k_roots is in enum order");
_Static_assert(sizeof(tsk_capture_root) == sizeof(int), "root is read as an int");

#define F(name, member, type) \
    { name, type, offsetof(tsk_capture_def, member), NULL, NULL, NULL }
static const tsk_py_field k_capture_fields[] = {
    F("near", near_m, TSK_PY_FLOAT),
    F("far", far_m, TSK_PY_FLOAT),
    F("fx", intrinsics.fx, TSK_PY_FLOAT),
    F("fy", intrinsics.fy, TSK_PY_FLOAT),
    F("cx", intrinsics.cx, TSK_PY_FLOAT),
    F("cy", intrinsics.cy, TSK_PY_FLOAT),
    F("min_area", min_area, TSK_PY_INT),
    F("hole_radius", hole_radius, TSK_PY_INT),
    F("open_radius", open_radius, TSK_PY_INT),
    F("contour_smooth", contour_smooth, TSK_PY_FLOAT),
    F("split_smooth", split_smooth, TSK_PY_FLOAT),
    F("split_prominence", split_prominence, TSK_PY_FLOAT),
    {"root", TSK_PY_CHOICE, offsetof(tsk_capture_def, root), k_roots, NULL, NULL},
    F("knot_spacing", knot_spacing, TSK_PY_FLOAT),
    F("width_smooth", width_smooth, TSK_PY_FLOAT),
    F("depth_window", depth_window, TSK_PY_INT),
    F("min_knots", min_knots, TSK_PY_INT),
    F("root_trim", root_trim, TSK_PY_FLOAT),
};
#undef F
static const tsk_py_def k_capture_def = {"capture setting", TSK_PY_FIELDS(k_capture_fields), NULL,
                                         0};

static PyObject* py_capture_process(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"capture", "depth", "width", "height", NULL};
    tsk_capture_def d = tsk_default_capture_def();
    PyObject *h, *depth_obj, *rest;
    int w, hh;
    /* the settings by the table; the four arguments, when given by name, as Python parses
     * them */
    if (!tsk_py_def_read(&k_capture_def, kw, &d, NULL, names, &rest)) return NULL;
    const int parsed = PyArg_ParseTupleAndKeywords(args, rest, "OOii:capture_process", names, &h,
                                                   &depth_obj, &w, &hh);
    Py_XDECREF(rest);
    if (!parsed) return NULL;
    if (w <= 0 || hh <= 0 || w > TSK_DEPTH_MAX_SIDE || hh > TSK_DEPTH_MAX_SIDE)
        return tsk_py_raise_arg("width", "size %dx%d outside 1..%d", w, hh, TSK_DEPTH_MAX_SIDE);
    tsk_py_handle* box = tsk_py_handle_get(h, &k_capture);
    if (box == NULL) return NULL;
    Py_buffer depth;
    if (!tsk_py_buffer(depth_obj, "depth", TSK_PY_F32, (Py_ssize_t)w * hh, 0, &depth)) return NULL;
    tsk_status s;
    TSK_PY_UNLOCKED(box, s = tsk_capture_process(box->ptr, &d, depth.buf, w, hh));
    PyBuffer_Release(&depth);
    if (s != TSK_OK) return tsk_py_raise(s);
    return PyLong_FromLong(tsk_capture_blade_count(box->ptr));
}

static PyObject* py_capture_propose_band(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* obj;
    int w, h, min_pixels = 150;
    if (!PyArg_ParseTuple(args, "Oii|i:capture_propose_band", &obj, &w, &h, &min_pixels))
        return NULL;
    if (w <= 0 || h <= 0 || w > TSK_DEPTH_MAX_SIDE || h > TSK_DEPTH_MAX_SIDE)
        return tsk_py_raise_arg("width", "size %dx%d outside 1..%d", w, h, TSK_DEPTH_MAX_SIDE);
    Py_buffer in;
    if (!tsk_py_buffer(obj, "depth", TSK_PY_F32, (Py_ssize_t)w * h, 0, &in)) return NULL;
    float near_m = 0.0f, far_m = 0.0f;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_capture_propose_band(in.buf, w, h, min_pixels, &near_m, &far_m);
    Py_END_ALLOW_THREADS PyBuffer_Release(&in);
    if (s != TSK_OK) return tsk_py_raise(s);
    return Py_BuildValue("(dd)", (double)near_m, (double)far_m);
}

static PyObject* py_capture_summary(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* h;
    if (!PyArg_ParseTuple(args, "O:capture_summary", &h)) return NULL;
    tsk_py_handle* box = tsk_py_handle_get(h, &k_capture);
    if (box == NULL) return NULL;
    float near_m, far_m;
    tsk_capture_band(box->ptr, &near_m, &far_m);
    tsk_intrinsics k = tsk_capture_intrinsics(box->ptr);
    return Py_BuildValue("{s:i,s:i,s:d,s:d,s:d,s:d,s:d,s:d,s:s}", "blades",
                         tsk_capture_blade_count(box->ptr), "knots",
                         tsk_capture_knot_total(box->ptr), "near", (double)near_m, "far",
                         (double)far_m, "fx", (double)k.fx, "fy", (double)k.fy, "cx", (double)k.cx,
                         "cy", (double)k.cy, "message", tsk_capture_status_message(box->ptr));
}

static PyObject* py_capture_blades(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *h, *counts_obj, *flags_obj = Py_None;
    if (!PyArg_ParseTuple(args, "OO|O:capture_blades", &h, &counts_obj, &flags_obj)) return NULL;
    tsk_py_handle* box = tsk_py_handle_get(h, &k_capture);
    if (box == NULL) return NULL;
    const Py_ssize_t n = tsk_capture_blade_count(box->ptr);
    tsk_py_views v = {.n = 0};
    int32_t* counts;
    uint32_t* flags;
    if (!tsk_py_views_get(&v, counts_obj, "knot_counts", TSK_PY_I32, n, 1, 1, (void**)&counts) ||
        !tsk_py_views_get(&v, flags_obj, "flags", TSK_PY_I32, n, 1, 1, (void**)&flags)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s = tsk_capture_get_blades(box->ptr, counts, flags, (size_t)n);
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

/* Gets up to three optional float32 output buffers of 3n, n and 2n elements into `v`
 * (p[i] = NULL for a None); on failure the caller releases `v`. */
static int knot_buffers(tsk_py_views* v, PyObject* xyz_o, PyObject* w_o, PyObject* uv_o,
                        Py_ssize_t n, void* p[3]) {
    PyObject* objs[3] = {xyz_o, w_o, uv_o};
    const char* names[3] = {"camera_xyz", "width", "pixel_uv"};
    const Py_ssize_t mult[3] = {3, 1, 2};
    for (int i = 0; i < 3; ++i)
        if (!tsk_py_views_get(v, objs[i], names[i], TSK_PY_F32, mult[i] * n, 1, 1, &p[i])) return 0;
    return 1;
}

static PyObject* py_capture_knots(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *h, *xyz = Py_None, *w = Py_None, *uv = Py_None;
    if (!PyArg_ParseTuple(args, "O|OOO:capture_knots", &h, &xyz, &w, &uv)) return NULL;
    tsk_py_handle* box = tsk_py_handle_get(h, &k_capture);
    if (box == NULL) return NULL;
    const Py_ssize_t n = tsk_capture_knot_total(box->ptr);
    tsk_py_views v = {.n = 0};
    void* p[3];
    if (!knot_buffers(&v, xyz, w, uv, n, p)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s = tsk_capture_get_knots(box->ptr, p[0], p[1], p[2], (size_t)n);
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_capture_blade(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *h, *xyz = Py_None, *w = Py_None, *uv = Py_None;
    int blade;
    if (!PyArg_ParseTuple(args, "Oi|OOO:capture_blade", &h, &blade, &xyz, &w, &uv)) return NULL;
    tsk_py_handle* box = tsk_py_handle_get(h, &k_capture);
    if (box == NULL) return NULL;
    const int nb = tsk_capture_blade_count(box->ptr);
    if (blade < 0 || blade >= nb)
        return tsk_py_raise_arg("blade", "%d is not in 0..%d", blade, nb - 1);
    int32_t counts[TSK_CAPTURE_MAX_BLADES];
    tsk_capture_get_blades(box->ptr, counts, NULL, (size_t)nb);
    const Py_ssize_t n = counts[blade];
    tsk_py_views v = {.n = 0};
    void* p[3];
    if (!knot_buffers(&v, xyz, w, uv, n, p)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s = tsk_capture_get_blade(box->ptr, blade, p[0], p[1], p[2], (size_t)n);
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    return PyLong_FromSsize_t(n);
}

static PyObject* py_capture_image(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *h, *out_obj;
    const char* which;
    if (!PyArg_ParseTuple(args, "OsO:capture_image", &h, &which, &out_obj)) return NULL;
    tsk_capture_image img;
    if (strcmp(which, "DEPTH") == 0) img = TSK_IMAGE_DEPTH;
    else if (strcmp(which, "MASK") == 0) img = TSK_IMAGE_MASK;
    else if (strcmp(which, "LABELS") == 0) img = TSK_IMAGE_LABELS;
    else if (strcmp(which, "OVERLAY") == 0) img = TSK_IMAGE_OVERLAY;
    else
        return tsk_py_raise_arg("which", "must be DEPTH, MASK, LABELS or OVERLAY, got '%s'", which);
    tsk_py_handle* box = tsk_py_handle_get(h, &k_capture);
    if (box == NULL) return NULL;
    Py_buffer out;
    if (!tsk_py_buffer(out_obj, "out", TSK_PY_U8, -1, 1, &out)) return NULL;
    tsk_status s = tsk_capture_get_image(box->ptr, img, out.buf, (size_t)tsk_py_count(&out));
    PyBuffer_Release(&out);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_capture_constants(PyObject* self, PyObject* args) {
    (void)self;
    (void)args;
    return Py_BuildValue(
        "{s:i,s:i,s:i,s:i,s:i,s:i}", "BLADE_CUT_BY_BORDER", (int)TSK_BLADE_CUT_BY_BORDER,
        "BLADE_TIP_AT_BORDER", (int)TSK_BLADE_TIP_AT_BORDER, "BLADE_ASYMMETRIC",
        (int)TSK_BLADE_ASYMMETRIC, "DEPTH_MAX_SIDE", TSK_DEPTH_MAX_SIDE, "DEPTH_MAX_FRAMES",
        TSK_DEPTH_MAX_FRAMES, "CAPTURE_MAX_BLADES", TSK_CAPTURE_MAX_BLADES);
}

PyMethodDef tsk_py_capture_methods[] = {
    {"depth_open_files", py_depth_open_files, METH_VARARGS,
     "depth_open_files($module, path, /)\n--\n\n"
     "-> source: a 16-bit PNG (mm) or float EXR (m), or a sequence with '#' for the frame "
     "number."},
    {"depth_open_oni", py_depth_open_oni, METH_VARARGS,
     "depth_open_oni($module, path, /)\n--\n\n"
     "-> source: an OpenNI2 recording, read frame by frame."},
    {"depth_open_device", py_depth_open_device, METH_VARARGS,
     "depth_open_device($module, uri=None, /)\n--\n\n"
     "-> source: a live OpenNI2 device (None = first)."},
    {"depth_close", py_depth_close, METH_VARARGS,
     "depth_close($module, source, /)\n--\n\n"
     "close now."},
    {"depth_start", py_depth_start, METH_VARARGS,
     "depth_start($module, source, /)\n--\n\n"
     "start a device."},
    {"depth_stop", py_depth_stop, METH_VARARGS,
     "depth_stop($module, source, /)\n--\n\n"
     "stop a device."},
    {"depth_info", py_depth_info, METH_VARARGS,
     "depth_info($module, source, /)\n--\n\n"
     "-> dict(kind, width, height, frame_count, first_frame, has_device_intrinsics, fx, fy, "
     "cx, cy, description)."},
    {"depth_seek", py_depth_seek, METH_VARARGS,
     "depth_seek($module, source, index, /)\n--\n\n"
     "files and .oni."},
    {"depth_read", py_depth_read, METH_VARARGS,
     "depth_read($module, source, out, /)\n--\n\n"
     "-> dict(is_new, end, index, timestamp, invalid_pixels); out float32 (width*height) in "
     "metres, 0 = no data. Never blocks on a device."},
    {"depth_write_png16", py_depth_write_png16, METH_VARARGS,
     "depth_write_png16($module, path, depth, width, height, /)\n--\n\n"
     "depth float32 metres -> PNG in mm."},
    {"depth_write_exr", py_depth_write_exr, METH_VARARGS,
     "depth_write_exr($module, path, depth, width, height, /)\n--\n\n"
     "depth float32 metres -> float EXR."},
    {"default_intrinsics", py_default_intrinsics, METH_VARARGS,
     "default_intrinsics($module, width, height, /)\n--\n\n"
     "-> (fx, fy, cx, cy) of a 640x480 sensor, scaled."},
    {"capture_create", py_capture_create, METH_NOARGS,
     "capture_create($module, /)\n--\n\n"
     "-> capture handle."},
    {"capture_process", (PyCFunction)(void (*)(void))py_capture_process,
     METH_VARARGS | METH_KEYWORDS,
     "capture_process($module, capture, depth, width, height, *, near=0, far=0, fx=0, fy=0, "
     "cx=0, cy=0, min_area=150, hole_radius=2, open_radius=0, contour_smooth=1.5, "
     "split_smooth=3, split_prominence=12, root='BOTTOM', knot_spacing=2, width_smooth=2, "
     "depth_window=2, min_knots=4, root_trim=1)\n--\n\n"
     "-> blade count. near=far=0: automatic band; fx..cy all 0: default intrinsics."},
    {"capture_propose_band", py_capture_propose_band, METH_VARARGS,
     "capture_propose_band($module, depth, width, height, min_pixels=150, /)\n--\n\n"
     "-> (near, far) metres."},
    {"capture_summary", py_capture_summary, METH_VARARGS,
     "capture_summary($module, capture, /)\n--\n\n"
     "-> dict(blades, knots, near, far, fx, fy, cx, cy, message)."},
    {"capture_blades", py_capture_blades, METH_VARARGS,
     "capture_blades($module, capture, knot_counts, flags=None, /)\n--\n\n"
     "int32 arrays of blade count."},
    {"capture_knots", py_capture_knots, METH_VARARGS,
     "capture_knots($module, capture, camera_xyz=None, width=None, pixel_uv=None, /)\n--\n\n"
     "float32 arrays of 3, 1, 2 x knot total; blades one after the other, root -> tip."},
    {"capture_blade", py_capture_blade, METH_VARARGS,
     "capture_blade($module, capture, blade, camera_xyz=None, width=None, pixel_uv=None, /)\n--\n\n"
     "-> knots."},
    {"capture_image", py_capture_image, METH_VARARGS,
     "capture_image($module, capture, which, out, /)\n--\n\n"
     "which DEPTH|MASK|LABELS|OVERLAY, out uint8 (width*height)."},
    {"capture_constants", py_capture_constants, METH_NOARGS,
     "capture_constants($module, /)\n--\n\n"
     "-> dict of blade flags and limits."},
    {NULL, NULL, 0, NULL},
};
