/* Binding of the wind: a handle in a PyCapsule, keyword parameters mapped onto the
 * definition structs, and sampling / grid read-out into caller numpy float32 buffers.
 * Argument and buffer checks only; the C library validates every value. */
#include "binding.h"

#include <stddef.h>
#include <string.h>

#include "tussock/wind.h"

static void destroy_wind(void* wind) { tsk_wind_destroy(wind); }

static const tsk_py_kind k_wind = {"tussock.wind", "wind",         "wind",
                                   "wind_create",  "wind_destroy", destroy_wind};

/* ---- keyword parameters -> definition ---------------------------------------------- */

enum { WAVE_FIELDS = 7, SOURCE_FIELDS = 8 };

/* waves: float32 buffer of 7 * n values (amplitude, dir_x, dir_y, wavelength, speed,
 * phase, power) per wave, n <= 8 */
static int read_waves(PyObject* value, void* def) {
    tsk_wind_sines_def* s = def;
    Py_buffer view;
    if (!tsk_py_buffer(value, "waves", TSK_PY_F32, -1, 0, &view)) return 0;
    const Py_ssize_t n = tsk_py_count(&view);
    if (n % WAVE_FIELDS != 0 || n / WAVE_FIELDS > TSK_WIND_MAX_WAVES) {
        PyBuffer_Release(&view);
        tsk_py_raise_arg("waves",
                         "must hold 7 floats per wave (amplitude, dir_x, dir_y, "
                         "wavelength, speed, phase, power) for 0..%d waves, got %zd floats",
                         TSK_WIND_MAX_WAVES, n);
        return 0;
    }
    const float* f = view.buf;
    s->wave_count = (int)(n / WAVE_FIELDS);
    for (int i = 0; i < s->wave_count; ++i) {
        const float* w = f + WAVE_FIELDS * i;
        s->waves[i].amplitude = w[0];
        s->waves[i].dir_x = w[1];
        s->waves[i].dir_y = w[2];
        s->waves[i].wavelength = w[3];
        s->waves[i].speed = w[4];
        s->waves[i].phase = w[5];
        s->waves[i].power = w[6];
    }
    PyBuffer_Release(&view);
    return 1;
}

#define F(name, member, type) \
    { name, type, offsetof(tsk_wind_sines_def, member), NULL, NULL, NULL }
static const tsk_py_field k_sines_fields[] = {
    F("base_x", base_x, TSK_PY_FLOAT),
    F("base_y", base_y, TSK_PY_FLOAT),
    {"waves", TSK_PY_CUSTOM, 0, NULL, read_waves, NULL},
    F("gust_strength", gust.strength, TSK_PY_FLOAT),
    F("gust_interval", gust.interval, TSK_PY_FLOAT),
    F("gust_duration", gust.duration, TSK_PY_FLOAT),
    F("gust_dir_x", gust.dir_x, TSK_PY_FLOAT),
    F("gust_dir_y", gust.dir_y, TSK_PY_FLOAT),
    F("gust_front_speed", gust.front_speed, TSK_PY_FLOAT),
    F("seed", gust.seed, TSK_PY_U64),
};
#undef F
static const tsk_py_def k_sines_def = {"wind parameter", TSK_PY_FIELDS(k_sines_fields), NULL, 0};

#define F(name, member, type) \
    { name, type, offsetof(tsk_wind_def, member), NULL, NULL, NULL }
static const tsk_py_field k_wind_fields[] = {
    F("nx", fluid.nx, TSK_PY_INT),
    F("ny", fluid.ny, TSK_PY_INT),
    F("origin_x", fluid.origin_x, TSK_PY_FLOAT),
    F("origin_y", fluid.origin_y, TSK_PY_FLOAT),
    F("cell_size", fluid.cell_size, TSK_PY_FLOAT),
    F("dt", fluid.dt, TSK_PY_FLOAT),
    F("speed", fluid.speed, TSK_PY_FLOAT),
    F("viscosity", fluid.viscosity, TSK_PY_FLOAT),
    F("decay", fluid.decay, TSK_PY_FLOAT),
    F("pressure_iterations", fluid.pressure_iterations, TSK_PY_INT),
    F("pressure_tolerance", fluid.pressure_tolerance, TSK_PY_FLOAT),
    F("diffusion_iterations", fluid.diffusion_iterations, TSK_PY_INT),
    F("continuum", continuum.enabled, TSK_PY_BOOL),
    F("c", continuum.c, TSK_PY_FLOAT),
    F("gamma", continuum.gamma, TSK_PY_FLOAT),
    F("drive", continuum.drive, TSK_PY_FLOAT),
};
#undef F
static const tsk_py_def k_wind_def = {"wind parameter", TSK_PY_FIELDS(k_wind_fields), &k_sines_def,
                                      offsetof(tsk_wind_def, sines)};

/* ---- functions ------------------------------------------------------------------------ */

static PyObject* py_wind_create(PyObject* self, PyObject* args, PyObject* kwargs) {
    (void)self;
    if (PyTuple_Size(args) != 0)
        return tsk_py_raise_arg("wind_create", "takes keyword arguments only");
    tsk_wind_def def = tsk_default_wind_def();
    if (!tsk_py_def_read(&k_wind_def, kwargs, &def, NULL, NULL, NULL)) return NULL;
    tsk_wind* w = NULL;
    tsk_status s;
    Py_BEGIN_ALLOW_THREADS s = tsk_wind_create(&def, &w);
    Py_END_ALLOW_THREADS if (s != TSK_OK) return tsk_py_raise(s);
    return tsk_py_handle_new(&k_wind, w);
}

static PyObject* py_wind_destroy(PyObject* self, PyObject* capsule) {
    (void)self;
    if (!tsk_py_handle_close(capsule, &k_wind)) return NULL;
    Py_RETURN_NONE;
}

static PyObject* py_wind_set_sines(PyObject* self, PyObject* args, PyObject* kwargs) {
    (void)self;
    PyObject* capsule;
    double start, blend;
    if (!PyArg_ParseTuple(args, "Odd:wind_set_sines", &capsule, &start, &blend)) return NULL;
    tsk_wind_sines_def sd = tsk_default_wind_sines_def();
    if (!tsk_py_def_read(&k_sines_def, kwargs, &sd, NULL, NULL, NULL)) return NULL;
    tsk_py_handle* box = tsk_py_handle_get(capsule, &k_wind);
    if (box == NULL) return NULL;
    tsk_status s = tsk_wind_set_sines(box->ptr, &sd, start, blend);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_wind_set_sources(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *capsule, *obj;
    if (!PyArg_ParseTuple(args, "OO:wind_set_sources", &capsule, &obj)) return NULL;
    Py_buffer view;
    if (!tsk_py_buffer(obj, "sources", TSK_PY_F32, -1, 0, &view)) return NULL;
    const Py_ssize_t n = tsk_py_count(&view);
    if (n % SOURCE_FIELDS != 0) {
        PyBuffer_Release(&view);
        return tsk_py_raise_arg("sources",
                                "must hold 8 floats per source (x, y, dir_x, dir_y, strength, "
                                "radius, interval, start), got %zd floats",
                                n);
    }
    const size_t count = (size_t)(n / SOURCE_FIELDS);
    if (count > TSK_WIND_MAX_SOURCES) {
        PyBuffer_Release(&view);
        return tsk_py_raise_arg("sources", "at most %d sources, got %zu", TSK_WIND_MAX_SOURCES,
                                count);
    }
    tsk_wind_source src[TSK_WIND_MAX_SOURCES];
    const float* f = view.buf;
    for (size_t i = 0; i < count; ++i) {
        const float* q = f + SOURCE_FIELDS * i;
        src[i].x = q[0];
        src[i].y = q[1];
        src[i].dir_x = q[2];
        src[i].dir_y = q[3];
        src[i].strength = q[4];
        src[i].radius = q[5];
        src[i].interval = q[6];
        src[i].start = q[7];
    }
    PyBuffer_Release(&view);
    tsk_py_handle* box = tsk_py_handle_get(capsule, &k_wind);
    if (box == NULL) return NULL;
    tsk_status s = tsk_wind_set_sources(box->ptr, src, count);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_wind_step(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* capsule;
    int steps;
    if (!PyArg_ParseTuple(args, "Oi:wind_step", &capsule, &steps)) return NULL;
    tsk_py_handle* box = tsk_py_handle_get(capsule, &k_wind);
    if (box == NULL) return NULL;
    tsk_status s;
    TSK_PY_UNLOCKED(box, s = tsk_wind_step(box->ptr, steps));
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_wind_time(PyObject* self, PyObject* capsule) {
    (void)self;
    tsk_py_handle* box = tsk_py_handle_get(capsule, &k_wind);
    if (box == NULL) return NULL;
    const double t = tsk_wind_time(box->ptr);
    return PyFloat_FromDouble(t);
}

static PyObject* py_wind_grid_size(PyObject* self, PyObject* capsule) {
    (void)self;
    tsk_py_handle* box = tsk_py_handle_get(capsule, &k_wind);
    if (box == NULL) return NULL;
    int nx, ny;
    tsk_wind_grid_size(box->ptr, &nx, &ny);
    return Py_BuildValue("(ii)", nx, ny);
}

static PyObject* py_wind_sample(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *capsule, *xo, *yo, *vxo, *vyo, *sxo = Py_None, *syo = Py_None;
    double t;
    if (!PyArg_ParseTuple(args, "OdOOOO|OO:wind_sample", &capsule, &t, &xo, &yo, &vxo, &vyo, &sxo,
                          &syo))
        return NULL;
    if ((sxo == Py_None) != (syo == Py_None))
        return tsk_py_raise_arg("sway_x", "sway_x and sway_y must both be given or both be None");
    tsk_py_views v = {.n = 0};
    const float *x, *y;
    float *vx, *vy, *sx, *sy;
    if (!tsk_py_views_get(&v, xo, "x", TSK_PY_F32, -1, 0, 0, (void**)&x)) return NULL;
    const Py_ssize_t n = tsk_py_count(&v.view[0]);
    const int got = tsk_py_views_get(&v, yo, "y", TSK_PY_F32, n, 0, 0, (void**)&y) &&
                    tsk_py_views_get(&v, vxo, "vx", TSK_PY_F32, n, 1, 0, (void**)&vx) &&
                    tsk_py_views_get(&v, vyo, "vy", TSK_PY_F32, n, 1, 0, (void**)&vy) &&
                    tsk_py_views_get(&v, sxo, "sway_x", TSK_PY_F32, n, 1, 1, (void**)&sx) &&
                    tsk_py_views_get(&v, syo, "sway_y", TSK_PY_F32, n, 1, 1, (void**)&sy);
    tsk_py_handle* box = got ? tsk_py_handle_get(capsule, &k_wind) : NULL;
    tsk_status s = TSK_OK;
    if (box != NULL) {
        TSK_PY_UNLOCKED(box, s = tsk_wind_sample(box->ptr, t, (size_t)n, x, y, vx, vy, sx, sy));
    }
    tsk_py_views_release(&v);
    if (box == NULL) return NULL;
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_wind_sample_xyz(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *capsule, *po, *vo, *so = Py_None;
    double t;
    if (!PyArg_ParseTuple(args, "OdOO|O:wind_sample_xyz", &capsule, &t, &po, &vo, &so)) return NULL;
    tsk_py_views v = {.n = 0};
    const float* p;
    float *vel, *sw;
    if (!tsk_py_views_get(&v, po, "xyz", TSK_PY_F32, -1, 0, 0, (void**)&p)) return NULL;
    const Py_ssize_t n3 = tsk_py_count(&v.view[0]);
    if (n3 % 3 != 0) {
        tsk_py_views_release(&v);
        return tsk_py_raise_arg("xyz", "must hold 3 floats per point, got %zd floats", n3);
    }
    const int got = tsk_py_views_get(&v, vo, "vel_xyz", TSK_PY_F32, n3, 1, 0, (void**)&vel) &&
                    tsk_py_views_get(&v, so, "sway_xyz", TSK_PY_F32, n3, 1, 1, (void**)&sw);
    tsk_py_handle* box = got ? tsk_py_handle_get(capsule, &k_wind) : NULL;
    tsk_status s = TSK_OK;
    if (box != NULL) {
        TSK_PY_UNLOCKED(box, s = tsk_wind_sample_xyz(box->ptr, t, (size_t)(n3 / 3), p, vel, sw));
    }
    tsk_py_views_release(&v);
    if (box == NULL) return NULL;
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* read_grid(PyObject* args, const char* fmt, int continuum) {
    PyObject *capsule, *ao, *bo;
    if (!PyArg_ParseTuple(args, fmt, &capsule, &ao, &bo)) return NULL;
    tsk_py_handle* box = tsk_py_handle_get(capsule, &k_wind);
    if (box == NULL) return NULL;
    int nx, ny;
    tsk_wind_grid_size(box->ptr, &nx, &ny);
    const Py_ssize_t n = (Py_ssize_t)nx * ny;
    tsk_py_views v = {.n = 0};
    float *a, *b;
    if (!tsk_py_views_get(&v, ao, continuum ? "px" : "vx", TSK_PY_F32, n, 1, 0, (void**)&a) ||
        !tsk_py_views_get(&v, bo, continuum ? "py" : "vy", TSK_PY_F32, n, 1, 0, (void**)&b)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    TSK_PY_UNLOCKED(box, s = continuum ? tsk_wind_read_continuum(box->ptr, a, b, (size_t)n)
                                       : tsk_wind_read_fluid(box->ptr, a, b, (size_t)n));
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_wind_read_fluid(PyObject* self, PyObject* args) {
    (void)self;
    return read_grid(args, "OOO:wind_read_fluid", 0);
}

static PyObject* py_wind_read_continuum(PyObject* self, PyObject* args) {
    (void)self;
    return read_grid(args, "OOO:wind_read_continuum", 1);
}

static PyObject* py_wind_save_state(PyObject* self, PyObject* capsule) {
    (void)self;
    tsk_py_handle* box = tsk_py_handle_get(capsule, &k_wind);
    if (box == NULL) return NULL;
    const size_t n = tsk_wind_state_size(box->ptr);
    PyObject* out = PyBytes_FromStringAndSize(NULL, (Py_ssize_t)n);
    if (out == NULL) { return NULL; }
    char* buf = PyBytes_AsString(out);
    if (buf == NULL) {
        Py_DECREF(out);
        return NULL;
    }
    tsk_status s;
    TSK_PY_UNLOCKED(box, s = tsk_wind_save_state(box->ptr, buf, n));
    if (s != TSK_OK) {
        Py_DECREF(out);
        return tsk_py_raise(s);
    }
    return out;
}

static PyObject* py_wind_load_state(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *capsule, *obj;
    if (!PyArg_ParseTuple(args, "OO:wind_load_state", &capsule, &obj)) return NULL;
    Py_buffer view;
    if (!tsk_py_buffer(obj, "state", TSK_PY_U8, -1, 0, &view)) return NULL;
    tsk_py_handle* box = tsk_py_handle_get(capsule, &k_wind);
    if (box == NULL) {
        PyBuffer_Release(&view);
        return NULL;
    }
    tsk_status s;
    TSK_PY_UNLOCKED(box, s = tsk_wind_load_state(box->ptr, view.buf, (size_t)view.len));
    PyBuffer_Release(&view);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

PyMethodDef tsk_py_wind_methods[] = {
    {"wind_create", (PyCFunction)(void (*)(void))py_wind_create, METH_VARARGS | METH_KEYWORDS,
     "wind_create($module, **params)\n--\n\n"
     "-> handle. Keywords (defaults from tsk_default_wind_def): base_x, base_y, waves "
     "(float32, 7 per wave: amplitude, dir_x, dir_y, wavelength, speed, phase, power), "
     "gust_strength, gust_interval, gust_duration, gust_dir_x, gust_dir_y, gust_front_speed, "
     "seed; nx, ny (0, 0 = no grid), origin_x, origin_y, cell_size, dt, speed, viscosity, "
     "decay, pressure_iterations, pressure_tolerance, diffusion_iterations; continuum (bool), "
     "c, gamma, drive."},
    {"wind_destroy", py_wind_destroy, METH_O,
     "wind_destroy($module, handle, /)\n--\n\n"
     "frees the wind now."},
    {"wind_set_sines", (PyCFunction)(void (*)(void))py_wind_set_sines, METH_VARARGS | METH_KEYWORDS,
     "wind_set_sines($module, handle, start_time, blend_time, /, **sines)\n--\n\n"
     "cross-fades to new breeze, waves and gusts (same keywords as wind_create; unset ones "
     "take the defaults)."},
    {"wind_set_sources", py_wind_set_sources, METH_VARARGS,
     "wind_set_sources($module, handle, sources, /)\n--\n\n"
     "float32, 8 per source: x, y, dir_x, dir_y, strength, radius, interval, start."},
    {"wind_step", py_wind_step, METH_VARARGS,
     "wind_step($module, handle, steps, /)\n--\n\n"
     "advances fluid+continuum."},
    {"wind_time", py_wind_time, METH_O,
     "wind_time($module, handle, /)\n--\n\n"
     "-> float: simulation time, s."},
    {"wind_save_state", py_wind_save_state, METH_O,
     "wind_save_state($module, handle, /)\n--\n\n"
     "-> bytes: the wind's state (clock, sines, sources, fluid, continuum), about 28 bytes per"
     " grid cell."},
    {"wind_load_state", py_wind_load_state, METH_VARARGS,
     "wind_load_state($module, handle, state, /)\n--\n\n"
     "restores a state saved from a wind of the same fluid and continuum settings; it then "
     "steps and samples bit for bit as the saving wind did."},
    {"wind_grid_size", py_wind_grid_size, METH_O,
     "wind_grid_size($module, handle, /)\n--\n\n"
     "-> (nx, ny)."},
    {"wind_sample", py_wind_sample, METH_VARARGS,
     "wind_sample($module, handle, t, x, y, vx, vy, sway_x=None, sway_y=None, /)\n--\n\n"
     "float32 arrays of one length; writes the wind (m/s) and optionally the continuum sway."},
    {"wind_sample_xyz", py_wind_sample_xyz, METH_VARARGS,
     "wind_sample_xyz($module, handle, t, xyz, vel_xyz, sway_xyz=None, /)\n--\n\n"
     "float32, 3 per point."},
    {"wind_read_fluid", py_wind_read_fluid, METH_VARARGS,
     "wind_read_fluid($module, handle, vx, vy, /)\n--\n\n"
     "float32 nx*ny each, normalised fluid velocity at centres."},
    {"wind_read_continuum", py_wind_read_continuum, METH_VARARGS,
     "wind_read_continuum($module, handle, px, py, /)\n--\n\n"
     "float32 nx*ny each, continuum Vp at centres."},
    {NULL, NULL, 0, NULL},
};
