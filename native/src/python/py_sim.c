/* Binding of the blade simulation (tussock/sim.h): a simulation handle (PyCapsule), colliders as
 * a float32 (n, 8) array, rest blades and wind as float32 arrays, results into caller buffers.
 * Argument and buffer checks only. */
#include "binding.h"

#include <stddef.h>
#include <string.h>

#include "tussock/sim.h"

static void destroy_sim(void* sim) { tsk_blade_sim_destroy(sim); }

static const tsk_py_kind k_sim = {"tussock.blade_sim", "sim", "blade simulation",
                                  "blade_sim_create",  NULL,  destroy_sim};

/* The simulation behind handle `obj` and its handle in *h (NULL, with the exception set, when
 * it is none, closed or busy). */
static tsk_blade_sim* get_sim(PyObject* obj, tsk_py_handle** h) {
    *h = tsk_py_handle_get(obj, &k_sim);
    return *h ? (*h)->ptr : NULL;
}

/* ... and its current info. */
static tsk_blade_sim* get_sim_info(PyObject* obj, tsk_py_handle** h, tsk_blade_sim_info* info) {
    tsk_blade_sim* sim = get_sim(obj, h);
    if (sim) tsk_blade_sim_get_info(sim, info);
    return sim;
}

#define FLD(name, type) \
    { #name, type, offsetof(tsk_blade_sim_def, name), NULL, NULL, NULL }
static const tsk_py_field k_fields[] = {
    FLD(origin, TSK_PY_VEC3),
    FLD(tile_size, TSK_PY_FLOAT),
    FLD(tiles_x, TSK_PY_INT),
    FLD(tiles_y, TSK_PY_INT),
    FLD(knot_count, TSK_PY_INT),
    FLD(gravity, TSK_PY_VEC3),
    FLD(gravity_preload, TSK_PY_FLOAT),
    FLD(damping, TSK_PY_FLOAT),
    FLD(wind_drag, TSK_PY_FLOAT),
    FLD(linear_density, TSK_PY_FLOAT),
    FLD(global_stiffness_root, TSK_PY_FLOAT),
    FLD(global_stiffness_tip, TSK_PY_FLOAT),
    FLD(local_stiffness, TSK_PY_FLOAT),
    FLD(iterations, TSK_PY_INT),
    FLD(ground_height, TSK_PY_FLOAT),
    FLD(collision_margin, TSK_PY_FLOAT),
    FLD(activation_margin, TSK_PY_FLOAT),
    FLD(max_blade_height, TSK_PY_FLOAT),
    FLD(rest_distance, TSK_PY_FLOAT),
    FLD(rest_speed, TSK_PY_FLOAT),
    FLD(rest_frames, TSK_PY_INT),
    FLD(blend_frames, TSK_PY_INT),
    FLD(settle_frames, TSK_PY_INT),
    FLD(settle_blend_frames, TSK_PY_INT),
};
#undef FLD
static const tsk_py_def k_def = {"setting", TSK_PY_FIELDS(k_fields), NULL, 0};

static PyObject* py_default_def(PyObject* self, PyObject* args) {
    (void)self;
    (void)args;
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    return tsk_py_def_dict(&k_def, &def);
}

static PyObject* py_create(PyObject* self, PyObject* args, PyObject* kw) {
    (void)self;
    if (args && PyTuple_Size(args) != 0)
        return tsk_py_raise_arg("blade_sim_create", "takes keyword arguments only");
    tsk_blade_sim_def def = tsk_default_blade_sim_def();
    if (!tsk_py_def_read(&k_def, kw, &def, NULL, NULL, NULL)) return NULL;
    tsk_blade_sim* sim = NULL;
    tsk_status s = tsk_blade_sim_create(&def, &sim);
    if (s != TSK_OK) return tsk_py_raise(s);
    return tsk_py_handle_new(&k_sim, sim);
}

static PyObject* py_clone(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* sim_obj;
    if (!PyArg_ParseTuple(args, "O:blade_sim_clone", &sim_obj)) return NULL;
    tsk_py_handle* h;
    tsk_blade_sim* sim = get_sim(sim_obj, &h);
    if (!sim) return NULL;
    tsk_blade_sim* copy = NULL;
    tsk_status s;
    TSK_PY_UNLOCKED(h, s = tsk_blade_sim_clone(sim, &copy));
    if (s != TSK_OK) return tsk_py_raise(s);
    return tsk_py_handle_new(&k_sim, copy);
}

static PyObject* py_set_colliders(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *sim_obj, *col_obj;
    if (!PyArg_ParseTuple(args, "OO:blade_sim_set_colliders", &sim_obj, &col_obj)) return NULL;
    tsk_py_handle* h;
    tsk_blade_sim* sim = get_sim(sim_obj, &h);
    if (!sim) return NULL;
    Py_buffer cb;
    if (!tsk_py_buffer(col_obj, "colliders", TSK_PY_F32, -1, 0, &cb)) return NULL;
    const Py_ssize_t n = tsk_py_count(&cb);
    if (n % 8 != 0) {
        PyBuffer_Release(&cb);
        return tsk_py_raise_arg("colliders",
                                "must hold 8 floats per collider "
                                "(kind, radius, ax, ay, az, bx, by, bz), got %zd",
                                n);
    }
    const Py_ssize_t count = n / 8;
    if (count > TSK_BLADE_SIM_MAX_COLLIDERS) {
        PyBuffer_Release(&cb);
        tsk_status s = tsk_blade_sim_set_colliders(sim, NULL, TSK_BLADE_SIM_MAX_COLLIDERS + 1);
        return tsk_py_raise(s);
    }
    tsk_blade_collider* cols = NULL;
    if (count > 0) {
        cols = PyMem_Malloc(sizeof(tsk_blade_collider) * (size_t)count);
        if (!cols) {
            PyBuffer_Release(&cb);
            return PyErr_NoMemory();
        }
    }
    const float* v = cb.buf;
    for (Py_ssize_t i = 0; i < count; ++i) {
        const float k = v[8 * i];
        cols[i].kind = k == 0.0f ? TSK_COLLIDER_SPHERE : (k == 1.0f ? TSK_COLLIDER_CAPSULE : -1);
        cols[i].radius = v[8 * i + 1];
        for (int c = 0; c < 3; ++c) {
            cols[i].a[c] = v[8 * i + 2 + c];
            cols[i].b[c] = v[8 * i + 5 + c];
        }
    }
    PyBuffer_Release(&cb);
    tsk_status s;
    TSK_PY_UNLOCKED(h, s = tsk_blade_sim_set_colliders(sim, cols, (int32_t)count));
    PyMem_Free(cols);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_activate_tile(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* sim_obj;
    int tile;
    if (!PyArg_ParseTuple(args, "Oi:blade_sim_activate_tile", &sim_obj, &tile)) return NULL;
    tsk_py_handle* h;
    tsk_blade_sim* sim = get_sim(sim_obj, &h);
    if (!sim) return NULL;
    tsk_status s = tsk_blade_sim_activate_tile(sim, tile);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_pending(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *sim_obj, *out_obj = NULL;
    if (!PyArg_ParseTuple(args, "O|O:blade_sim_pending", &sim_obj, &out_obj)) return NULL;
    tsk_py_handle* h;
    tsk_blade_sim* sim = get_sim(sim_obj, &h);
    if (!sim) return NULL;
    const int32_t n = tsk_blade_sim_pending_count(sim);
    if (out_obj && out_obj != Py_None) {
        Py_buffer out;
        if (!tsk_py_buffer(out_obj, "tiles", TSK_PY_I32, n, 1, &out)) return NULL;
        tsk_status s = tsk_blade_sim_get_pending(sim, out.buf);
        PyBuffer_Release(&out);
        if (s != TSK_OK) return tsk_py_raise(s);
    }
    return PyLong_FromLong(n);
}

static PyObject* py_provide_tile(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *sim_obj, *knots_obj, *widths_obj, *sides_obj = Py_None;
    int tile;
    if (!PyArg_ParseTuple(args, "OiOO|O:blade_sim_provide_tile", &sim_obj, &tile, &knots_obj,
                          &widths_obj, &sides_obj))
        return NULL;
    tsk_blade_sim_info info;
    tsk_py_handle* h;
    tsk_blade_sim* sim = get_sim_info(sim_obj, &h, &info);
    if (!sim) return NULL;
    const Py_ssize_t K = info.knot_count;
    tsk_py_views v = {.n = 0};
    const float *widths, *knots, *sides;
    if (!tsk_py_views_get(&v, widths_obj, "widths", TSK_PY_F32, -1, 0, 0, (void**)&widths))
        return NULL;
    const Py_ssize_t nw = tsk_py_count(&v.view[0]);
    if (nw % K != 0) {
        tsk_py_views_release(&v);
        return tsk_py_raise_arg("widths", "must hold %zd floats per blade, got %zd", K, nw);
    }
    const Py_ssize_t blades = nw / K;
    if (blades > TSK_BLADE_SIM_MAX_BLADES_PER_TILE) {
        tsk_py_views_release(&v);
        tsk_status s = tsk_blade_sim_provide_tile(sim, tile, TSK_BLADE_SIM_MAX_BLADES_PER_TILE + 1,
                                                  NULL, NULL, NULL);
        return tsk_py_raise(s);
    }
    if (!tsk_py_views_get(&v, knots_obj, "knots", TSK_PY_F32, 3 * nw, 0, 0, (void**)&knots) ||
        !tsk_py_views_get(&v, sides_obj, "sides", TSK_PY_F32, 3 * blades, 0, 1, (void**)&sides)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    TSK_PY_UNLOCKED(
        h, s = tsk_blade_sim_provide_tile(sim, tile, (int32_t)blades, knots, widths, sides));
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_step(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *sim_obj, *wind_obj = Py_None;
    float dt;
    int layout = TSK_WIND_NONE;
    if (!PyArg_ParseTuple(args, "Of|Oi:blade_sim_step", &sim_obj, &dt, &wind_obj, &layout))
        return NULL;
    tsk_py_handle* h;
    tsk_blade_sim* sim = get_sim(sim_obj, &h);
    if (!sim) return NULL;
    if (layout < TSK_WIND_NONE || layout > TSK_WIND_PER_KNOT)
        return tsk_py_raise_arg("layout",
                                "must be 0 (none), 1 (uniform), 2 (per blade) or "
                                "3 (per knot), got %d",
                                layout);
    tsk_blade_sim_info info;
    tsk_blade_sim_get_info(sim, &info);
    Py_ssize_t need = 0;
    if (layout == TSK_WIND_UNIFORM) need = 3;
    else if (layout == TSK_WIND_PER_BLADE) need = 3 * (Py_ssize_t)info.active_blades;
    else if (layout == TSK_WIND_PER_KNOT)
        need = 3 * (Py_ssize_t)info.active_blades * info.knot_count;
    Py_buffer wind;
    const float* wp = NULL;
    if (layout != TSK_WIND_NONE) {
        if (wind_obj == Py_None) return tsk_py_raise_arg("wind", "is None but layout needs wind");
        if (!tsk_py_buffer(wind_obj, "wind", TSK_PY_F32, need, 0, &wind)) return NULL;
        wp = wind.buf;
    }
    tsk_status s;
    TSK_PY_UNLOCKED(h, s = tsk_blade_sim_step(sim, dt, wp, (tsk_wind_layout)layout));
    if (wp) PyBuffer_Release(&wind);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_info(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* sim_obj;
    if (!PyArg_ParseTuple(args, "O:blade_sim_info", &sim_obj)) return NULL;
    tsk_py_handle* h;
    tsk_blade_sim* sim = get_sim(sim_obj, &h);
    if (!sim) return NULL;
    tsk_blade_sim_info info;
    tsk_status s = tsk_blade_sim_get_info(sim, &info);
    if (s != TSK_OK) return tsk_py_raise(s);
    return Py_BuildValue("{s:i,s:i,s:L,s:i,s:i,s:i,s:n}", "knot_count", info.knot_count,
                         "active_tiles", info.active_tiles, "active_blades",
                         (long long)info.active_blades, "pending_tiles", info.pending_tiles,
                         "blending_tiles", info.blending_tiles, "collider_count",
                         info.collider_count, "state_bytes", (Py_ssize_t)info.state_bytes);
}

static PyObject* py_get_active(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *sim_obj, *tiles_obj, *counts_obj;
    if (!PyArg_ParseTuple(args, "OOO:blade_sim_get_active", &sim_obj, &tiles_obj, &counts_obj))
        return NULL;
    tsk_blade_sim_info info;
    tsk_py_handle* h;
    tsk_blade_sim* sim = get_sim_info(sim_obj, &h, &info);
    if (!sim) return NULL;
    tsk_py_views v = {.n = 0};
    int32_t *tiles, *counts;
    if (!tsk_py_views_get(&v, tiles_obj, "tiles", TSK_PY_I32, info.active_tiles, 1, 0,
                          (void**)&tiles) ||
        !tsk_py_views_get(&v, counts_obj, "blade_counts", TSK_PY_I32, info.active_tiles, 1, 0,
                          (void**)&counts)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s = tsk_blade_sim_get_active(sim, tiles, counts);
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_get_knots(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *sim_obj, *out_obj;
    if (!PyArg_ParseTuple(args, "OO:blade_sim_get_knots", &sim_obj, &out_obj)) return NULL;
    tsk_blade_sim_info info;
    tsk_py_handle* h;
    tsk_blade_sim* sim = get_sim_info(sim_obj, &h, &info);
    if (!sim) return NULL;
    Py_buffer out;
    if (!tsk_py_buffer(out_obj, "knots", TSK_PY_F32,
                       3 * (Py_ssize_t)info.active_blades * info.knot_count, 1, &out))
        return NULL;
    tsk_status s;
    TSK_PY_UNLOCKED(h, s = tsk_blade_sim_get_knots(sim, out.buf));
    PyBuffer_Release(&out);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_get_ribbons(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *sim_obj, *widths_o, *sides_o, *out_o;
    long long first;
    if (!PyArg_ParseTuple(args, "OLOOO:blade_sim_ribbons", &sim_obj, &first, &widths_o, &sides_o,
                          &out_o))
        return NULL;
    tsk_blade_sim_info info;
    tsk_py_handle* h;
    tsk_blade_sim* sim = get_sim_info(sim_obj, &h, &info);
    if (!sim) return NULL;
    const Py_ssize_t K = info.knot_count;
    tsk_py_views v = {.n = 0};
    float *sides, *widths, *out;
    Py_ssize_t n = 0;
    if (!tsk_py_views_get_xyz(&v, sides_o, "sides", &sides, &n) ||
        !tsk_py_views_get(&v, widths_o, "widths", TSK_PY_F32, K * n, 0, 0, (void**)&widths) ||
        !tsk_py_views_get(&v, out_o, "positions", TSK_PY_F32, 6 * K * n, 1, 0, (void**)&out)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    TSK_PY_UNLOCKED(
        h, s = tsk_blade_sim_get_ribbons(sim, (int64_t)first, (int64_t)n, widths, sides, out));
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_get_ribbon_runs(PyObject* self, PyObject* args) {
    (void)self;
    PyObject *sim_obj, *starts_o, *counts_o, *widths_o, *sides_o, *out_o;
    if (!PyArg_ParseTuple(args, "OOOOOO:blade_sim_ribbon_runs", &sim_obj, &starts_o, &counts_o,
                          &widths_o, &sides_o, &out_o))
        return NULL;
    tsk_blade_sim_info info;
    tsk_py_handle* h;
    tsk_blade_sim* sim = get_sim_info(sim_obj, &h, &info);
    if (!sim) return NULL;
    const Py_ssize_t K = info.knot_count;
    tsk_py_views v = {.n = 0};
    int64_t *starts, *counts;
    float *sides, *widths, *out;
    Py_ssize_t n = 0;
    if (!tsk_py_views_get(&v, starts_o, "starts", TSK_PY_I64, -1, 0, 0, (void**)&starts)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    const Py_ssize_t runs = tsk_py_count(&v.view[v.n - 1]);
    if (!tsk_py_views_get(&v, counts_o, "counts", TSK_PY_I64, runs, 0, 0, (void**)&counts) ||
        !tsk_py_views_get_xyz(&v, sides_o, "sides", &sides, &n)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    /* the runs' blades, in the caller's arrays: sides says how many */
    int64_t sum = 0;
    for (Py_ssize_t r = 0; r < runs; ++r) {
        if (counts[r] < 0 || counts[r] > (int64_t)n - sum) {
            tsk_py_views_release(&v);
            return tsk_py_raise_arg("counts",
                                    "the runs' blades must add up to the %zd blades of "
                                    "sides (run %zd: %lld)",
                                    n, r, (long long)counts[r]);
        }
        sum += counts[r];
    }
    if (sum != (int64_t)n) {
        tsk_py_views_release(&v);
        return tsk_py_raise_arg("counts", "the runs hold %lld blades; sides has %zd",
                                (long long)sum, n);
    }
    if (!tsk_py_views_get(&v, widths_o, "widths", TSK_PY_F32, K * n, 0, 0, (void**)&widths) ||
        !tsk_py_views_get(&v, out_o, "positions", TSK_PY_F32, 6 * K * n, 1, 0, (void**)&out)) {
        tsk_py_views_release(&v);
        return NULL;
    }
    tsk_status s;
    TSK_PY_UNLOCKED(h, s = tsk_blade_sim_get_ribbon_runs(sim, starts, counts, (int64_t)runs, widths,
                                                         sides, out));
    tsk_py_views_release(&v);
    if (s != TSK_OK) return tsk_py_raise(s);
    Py_RETURN_NONE;
}

static PyObject* py_tile_state(PyObject* self, PyObject* args) {
    (void)self;
    PyObject* sim_obj;
    int tile;
    if (!PyArg_ParseTuple(args, "Oi:blade_sim_tile_state", &sim_obj, &tile)) return NULL;
    tsk_py_handle* h;
    tsk_blade_sim* sim = get_sim(sim_obj, &h);
    if (!sim) return NULL;
    return PyLong_FromLong(tsk_blade_sim_tile_state(sim, tile));
}

PyMethodDef tsk_py_sim_methods[] = {
    {"default_blade_sim_def", py_default_def, METH_NOARGS,
     "default_blade_sim_def($module, /)\n--\n\n"
     "-> dict: every blade-simulation setting and its default."},
    {"blade_sim_create", (PyCFunction)(void (*)(void))py_create, METH_VARARGS | METH_KEYWORDS,
     "blade_sim_create($module, **settings)\n--\n\n"
     "-> handle. Settings as default_blade_sim_def()."},
    {"blade_sim_clone", py_clone, METH_VARARGS,
     "blade_sim_clone($module, sim, /)\n--\n\n"
     "-> handle: an independent deep copy of the whole state (a snapshot to resume from; "
     "stepping both the same way gives the same bytes)."},
    {"blade_sim_set_colliders", py_set_colliders, METH_VARARGS,
     "blade_sim_set_colliders($module, sim, colliders, /)\n--\n\n"
     "float32 (n, 8) rows kind (0 sphere, 1 capsule), radius, ax, ay, az, bx, by, bz; updates "
     "which tiles are touched and pending."},
    {"blade_sim_activate_tile", py_activate_tile, METH_VARARGS,
     "blade_sim_activate_tile($module, sim, tile, /)\n--\n\n"
     "make a tile pending (or keep it active) without a collider."},
    {"blade_sim_pending", py_pending, METH_VARARGS,
     "blade_sim_pending($module, sim, tiles=None, /)\n--\n\n"
     "-> count; fills int32 tiles (count) when given."},
    {"blade_sim_provide_tile", py_provide_tile, METH_VARARGS,
     "blade_sim_provide_tile($module, sim, tile, knots, widths, sides=None, /)\n--\n\n"
     "rest blades of a tile, float32 knots (n*K*3), widths (n*K), sides (n*3)."},
    {"blade_sim_step", py_step, METH_VARARGS,
     "blade_sim_step($module, sim, dt, wind=None, layout=0, /)\n--\n\n"
     "advance dt seconds; wind float32 for layout 1 uniform (3), 2 per active blade (3n), 3 "
     "per knot (3nK)."},
    {"blade_sim_info", py_info, METH_VARARGS,
     "blade_sim_info($module, sim, /)\n--\n\n"
     "-> dict."},
    {"blade_sim_get_active", py_get_active, METH_VARARGS,
     "blade_sim_get_active($module, sim, tiles, blade_counts, /)\n--\n\n"
     "int32 arrays of info['active_tiles']."},
    {"blade_sim_ribbons", py_get_ribbons, METH_VARARGS,
     "blade_sim_ribbons($module, sim, first, widths, sides, positions, /)\n--\n\n"
     "ribbon vertices of n active blades from `first` on (n = len(sides) / 3; widths n*K, "
     "positions n*2K*3 float32), the bytes blades_expand gives on their knots."},
    {"blade_sim_ribbon_runs", py_get_ribbon_runs, METH_VARARGS,
     "blade_sim_ribbon_runs($module, sim, starts, counts, widths, sides, positions, /)\n--\n\n"
     "ribbon vertices, as blade_sim_ribbons makes them, of the runs of active blades counts[r]"
     " long from starts[r] (int64 arrays), one run after another in widths, sides and "
     "positions."},
    {"blade_sim_get_knots", py_get_knots, METH_VARARGS,
     "blade_sim_get_knots($module, sim, out, /)\n--\n\n"
     "float32 out of info['active_blades'] * K * 3."},
    {"blade_sim_tile_state", py_tile_state, METH_VARARGS,
     "blade_sim_tile_state($module, sim, tile, /)\n--\n\n"
     "-> 1 active, 2 pending, 0 neither, -1 out of range."},
    {NULL, NULL, 0, NULL},
};
