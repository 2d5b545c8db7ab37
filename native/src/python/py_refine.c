/* Binding of skeleton refining: Algorithm 1 for one or many blades, knot tracking,
 * uniform resampling and the bending simulation. Argument and buffer checks only. */
#include "binding.h"
#include "tussock/refine.h"

#include <stddef.h>

/* Number of knots of the float32 xyz buffer acquired last into `v` (its length must be a
 * multiple of 3). */
static int xyz_count(const tsk_py_views* v, const char* name, Py_ssize_t* count) {
    Py_ssize_t n = tsk_py_count(&v->view[v->n - 1]);
    if (n % 3 != 0) {
        tsk_py_raise_arg(name, "length %zd is not a multiple of 3 (x, y, z per knot)", n);
        return 0;
    }
    *count = n / 3;
    return 1;
}

static PyObject* py_refine_blade(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"knots", "widths",    "trajectories", "frame_count", "target_knots",
                            "mu",    "out_knots", "out_widths",   "out_ranges",  "out_trajectories",
                            NULL};
    PyObject *ko, *wo, *to, *oko, *owo, *oro, *oto = Py_None;
    Py_ssize_t frames;
    int target;
    float mu;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "OOOnifOOO|O:refine_blade", names, &ko, &wo, &to,
                                     &frames, &target, &mu, &oko, &owo, &oro, &oto))
        return NULL;
    if (frames < 1) return tsk_py_raise_arg("frame_count", "must be at least 1, got %zd", frames);
    if (target < TSK_REFINE_MIN_TARGET || target > TSK_REFINE_MAX_TARGET)
        return tsk_py_raise_arg("target_knots", "must be from 2 to 64, got %d", target);
    tsk_py_views v = {.n = 0};
    const float *k, *w, *t;
    float *ok, *ow, *ot;
    int32_t* orr;
    Py_ssize_t n;
    if (!tsk_py_views_get(&v, ko, "knots", TSK_PY_F32, -1, 0, 0, (void**)&k) ||
        !xyz_count(&v, "knots", &n) ||
        !tsk_py_views_get(&v, wo, "widths", TSK_PY_F32, n, 0, 0, (void**)&w) ||
        !tsk_py_views_get(&v, to, "trajectories", TSK_PY_F32, frames * n * 3, 0, 0, (void**)&t) ||
        !tsk_py_views_get(&v, oko, "out_knots", TSK_PY_F32, (Py_ssize_t)target * 3, 1, 0,
                          (void**)&ok) ||
        !tsk_py_views_get(&v, owo, "out_widths", TSK_PY_F32, target, 1, 0, (void**)&ow) ||
        !tsk_py_views_get(&v, oro, "out_ranges", TSK_PY_I32, (Py_ssize_t)target * 2, 1, 0,
                          (void**)&orr) ||
        !tsk_py_views_get(&v, oto, "out_trajectories", TSK_PY_F32, frames * target * 3, 1, 1,
                          (void**)&ot)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_refine_def def = {target, mu};
    tsk_refine_input in = {k, w, t, (size_t)n, (size_t)frames};
    tsk_refine_output out = {ok, ow, orr, ot};
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_refine_blade(&def, &in, &out);
    Py_END_ALLOW_THREADS tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_refine_blades(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {
        "knots", "widths",    "trajectories", "blade_count", "frame_count",      "target_knots",
        "mu",    "out_knots", "out_widths",   "out_ranges",  "out_trajectories", NULL};
    PyObject *ko, *wo, *to, *oko, *owo, *oro, *oto = Py_None;
    Py_ssize_t blades, frames;
    int target;
    float mu;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "OOOnnifOOO|O:refine_blades", names, &ko, &wo, &to,
                                     &blades, &frames, &target, &mu, &oko, &owo, &oro, &oto))
        return NULL;
    if (blades < 1) return tsk_py_raise_arg("blade_count", "must be at least 1, got %zd", blades);
    if (frames < 1) return tsk_py_raise_arg("frame_count", "must be at least 1, got %zd", frames);
    if (target < TSK_REFINE_MIN_TARGET || target > TSK_REFINE_MAX_TARGET)
        return tsk_py_raise_arg("target_knots", "must be from 2 to 64, got %d", target);
    tsk_py_views v = {.n = 0};
    const float *k, *w, *t;
    float *ok, *ow, *ot;
    int32_t* orr;
    tsk_refine_input* in = NULL;
    tsk_refine_output* out = NULL;
    tsk_status s = TSK_OK;
    int got = 0;
    Py_ssize_t n;
    if (!tsk_py_views_get(&v, ko, "knots", TSK_PY_F32, -1, 0, 0, (void**)&k) ||
        !xyz_count(&v, "knots", &n))
        goto done;
    if (n % blades != 0) {
        tsk_py_raise_arg("knots", "%zd knots do not split into %zd blades of equal size", n,
                         blades);
        goto done;
    }
    const Py_ssize_t per = n / blades, m = target;
    if (!tsk_py_views_get(&v, wo, "widths", TSK_PY_F32, n, 0, 0, (void**)&w) ||
        !tsk_py_views_get(&v, to, "trajectories", TSK_PY_F32, frames * n * 3, 0, 0, (void**)&t) ||
        !tsk_py_views_get(&v, oko, "out_knots", TSK_PY_F32, blades * m * 3, 1, 0, (void**)&ok) ||
        !tsk_py_views_get(&v, owo, "out_widths", TSK_PY_F32, blades * m, 1, 0, (void**)&ow) ||
        !tsk_py_views_get(&v, oro, "out_ranges", TSK_PY_I32, blades * m * 2, 1, 0, (void**)&orr) ||
        !tsk_py_views_get(&v, oto, "out_trajectories", TSK_PY_F32, blades * frames * m * 3, 1, 1,
                          (void**)&ot))
        goto done;
    in = tsk_alloc((size_t)blades * sizeof *in, "binding blades");
    out = tsk_alloc((size_t)blades * sizeof *out, "binding outputs");
    if (in == NULL || out == NULL) {
        tsk_py_raise(TSK_ERR_MEMORY);
        goto done;
    }
    /* blade b: knots [b][per][3], widths [b][per], trajectories [b][frames][per][3] */
    for (Py_ssize_t b = 0; b < blades; ++b) {
        in[b] = (tsk_refine_input){k + b * per * 3, w + b * per, t + b * frames * per * 3,
                                   (size_t)per, (size_t)frames};
        out[b] = (tsk_refine_output){ok + b * m * 3, ow + b * m, orr + b * m * 2,
                                     oto != Py_None ? ot + b * frames * m * 3 : NULL};
    }
    tsk_refine_def def = {target, mu};
    got = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_refine_blades(&def, in, out, (size_t)blades);
    Py_END_ALLOW_THREADS done : tsk_free(in);
    tsk_free(out);
    tsk_py_views_release(&v);
    if (!got) return NULL;
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_refine_track(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *ro, *fko, *foo, *oto;
    if (!PyArg_ParseTuple(args, "OOOO:refine_track", &ro, &fko, &foo, &oto)) return NULL;
    tsk_py_views v = {.n = 0};
    const float *r, *fk;
    const int32_t* fo;
    float* ot;
    tsk_status s = TSK_OK;
    int got = 0;
    Py_ssize_t n, total, frames;
    if (!tsk_py_views_get(&v, ro, "ref_knots", TSK_PY_F32, -1, 0, 0, (void**)&r) ||
        !xyz_count(&v, "ref_knots", &n) ||
        !tsk_py_views_get(&v, fko, "frame_knots", TSK_PY_F32, -1, 0, 0, (void**)&fk) ||
        !xyz_count(&v, "frame_knots", &total) ||
        !tsk_py_views_get(&v, foo, "frame_offsets", TSK_PY_I32, -1, 0, 0, (void**)&fo))
        goto done;
    frames = tsk_py_count(&v.view[v.n - 1]) - 1;
    if (frames < 1) {
        tsk_py_raise_arg("frame_offsets", "needs frame_count + 1 >= 2 entries");
        goto done;
    }
    const int32_t last = fo[frames];
    if (last != total) {
        tsk_py_raise_arg("frame_offsets", "last entry %d must equal the %zd knots of frame_knots",
                         (int)last, total);
        goto done;
    }
    if (!tsk_py_views_get(&v, oto, "out_trajectories", TSK_PY_F32, frames * n * 3, 1, 0,
                          (void**)&ot))
        goto done;
    got = 1;
    Py_BEGIN_ALLOW_THREADS s = tsk_refine_track(r, (size_t)n, fk, fo, (size_t)frames, ot);
    Py_END_ALLOW_THREADS done : tsk_py_views_release(&v);
    if (!got) return NULL;
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_refine_resample(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *ko, *wo, *oko, *owo;
    if (!PyArg_ParseTuple(args, "OOOO:refine_resample", &ko, &wo, &oko, &owo)) return NULL;
    tsk_py_views v = {.n = 0};
    const float *k, *w;
    float *ok, *ow;
    Py_ssize_t n, m;
    if (!tsk_py_views_get(&v, ko, "knots", TSK_PY_F32, -1, 0, 0, (void**)&k) ||
        !xyz_count(&v, "knots", &n) ||
        !tsk_py_views_get(&v, wo, "widths", TSK_PY_F32, n, 0, 0, (void**)&w) ||
        !tsk_py_views_get(&v, oko, "out_knots", TSK_PY_F32, -1, 1, 0, (void**)&ok) ||
        !xyz_count(&v, "out_knots", &m) ||
        !tsk_py_views_get(&v, owo, "out_widths", TSK_PY_F32, m, 1, 0, (void**)&ow)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_refine_resample(k, w, (size_t)n, (size_t)m, ok, ow);
    Py_END_ALLOW_THREADS tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

#define F(name, member, type) \
    { name, type, offsetof(tsk_refine_bend_def, member), NULL, NULL, NULL }
static const tsk_py_field k_bend_fields[] = {
    F("youngs_modulus", youngs_modulus, TSK_PY_FLOAT),
    F("thickness", thickness, TSK_PY_FLOAT),
    F("density", density, TSK_PY_FLOAT),
    F("min_width_ratio", min_width_ratio, TSK_PY_FLOAT),
    F("gravity_x", gravity[0], TSK_PY_FLOAT),
    F("gravity_y", gravity[1], TSK_PY_FLOAT),
    F("gravity_z", gravity[2], TSK_PY_FLOAT),
    F("gravity_prestress", gravity_prestress, TSK_PY_BOOL),
    F("air_density", air_density, TSK_PY_FLOAT),
    F("drag_coefficient", drag_coefficient, TSK_PY_FLOAT),
    F("damping", damping, TSK_PY_FLOAT),
    F("wind_speed", wind_speed, TSK_PY_FLOAT),
    F("wind_x", wind_direction[0], TSK_PY_FLOAT),
    F("wind_y", wind_direction[1], TSK_PY_FLOAT),
    F("wind_z", wind_direction[2], TSK_PY_FLOAT),
    F("gust", gust, TSK_PY_FLOAT),
    F("fps", fps, TSK_PY_FLOAT),
    F("warmup", warmup, TSK_PY_FLOAT),
    F("time_step", time_step, TSK_PY_FLOAT),
};
#undef F
static const tsk_py_def k_bend_def = {"bending setting", TSK_PY_FIELDS(k_bend_fields), NULL, 0};

static PyObject* py_refine_simulate(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    static char* names[] = {"knots", "widths", "frame_count", "out_trajectories", NULL};
    tsk_refine_bend_def d = tsk_default_refine_bend_def();
    PyObject *ko, *wo, *oto, *rest;
    Py_ssize_t frames;
    if (!tsk_py_def_read(&k_bend_def, kw, &d, NULL, names, &rest)) return NULL;
    const int parsed = PyArg_ParseTupleAndKeywords(args, rest, "OOnO:refine_simulate", names, &ko,
                                                   &wo, &frames, &oto);
    Py_XDECREF(rest);
    if (!parsed) return NULL;
    if (frames < 1) return tsk_py_raise_arg("frame_count", "must be at least 1, got %zd", frames);
    tsk_py_views v = {.n = 0};
    const float *k, *w;
    float* ot;
    Py_ssize_t n;
    if (!tsk_py_views_get(&v, ko, "knots", TSK_PY_F32, -1, 0, 0, (void**)&k) ||
        !xyz_count(&v, "knots", &n) ||
        !tsk_py_views_get(&v, wo, "widths", TSK_PY_F32, n, 0, 0, (void**)&w) ||
        !tsk_py_views_get(&v, oto, "out_trajectories", TSK_PY_F32, frames * n * 3, 1, 0,
                          (void**)&ot)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_refine_simulate(&d, k, w, (size_t)n, (size_t)frames, ot);
    Py_END_ALLOW_THREADS tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

PyMethodDef tsk_py_refine_methods[] = {
    {"refine_blade", (PyCFunction)(void (*)(void))py_refine_blade, METH_VARARGS | METH_KEYWORDS,
     "refine_blade($module, knots, widths, trajectories, frame_count, target_knots, mu, "
     "out_knots, out_widths, out_ranges, out_trajectories=None)\n--\n\n"
     "seed 000 Algorithm 1. knots float32 (3K), widths (K), trajectories (frame_count*K*3, "
     "frame-major); out_knots (3m), out_widths (m), out_ranges int32 (2m: first source knot, "
     "count), out_trajectories (frame_count*m*3)."},
    {"refine_blades", (PyCFunction)(void (*)(void))py_refine_blades, METH_VARARGS | METH_KEYWORDS,
     "refine_blades($module, knots, widths, trajectories, blade_count, frame_count, "
     "target_knots, mu, out_knots, out_widths, out_ranges, out_trajectories=None)\n--\n\n"
     "many blades of equal knot count K, in parallel; arrays are refine_blade's stacked per "
     "blade (trajectories [blade][frame][K][3])."},
    {"refine_track", py_refine_track, METH_VARARGS,
     "refine_track($module, ref_knots, frame_knots, frame_offsets, out_trajectories, /)\n--\n\n"
     "trajectories of the reference knots through captured skeletons (frame f = "
     "frame_knots[offsets[f]:offsets[f+1]] knots), matched by normalised arc length. "
     "frame_offsets int32 (F+1)."},
    {"refine_resample", py_refine_resample, METH_VARARGS,
     "refine_resample($module, knots, widths, out_knots, out_widths, /)\n--\n\n"
     "uniform arc-length resampling to len(out_widths) knots."},
    {"refine_simulate", (PyCFunction)(void (*)(void))py_refine_simulate,
     METH_VARARGS | METH_KEYWORDS,
     "refine_simulate($module, knots, widths, frame_count, out_trajectories, *, "
     "youngs_modulus=3e9, thickness=4e-4, density=900, min_width_ratio=0.05, gravity_x=0, "
     "gravity_y=0, gravity_z=-9.81, gravity_prestress=True, air_density=1.2, "
     "drag_coefficient=1.2, damping=2, wind_speed=3, wind_x=1, wind_y=0, wind_z=0, gust=0.5, "
     "fps=24, warmup=1, time_step=0)\n--\n\n"
     "bending simulation of a still blade under the standard wind; out_trajectories "
     "(frame_count*K*3)."},
    {NULL, NULL, 0, NULL},
};
