"""Blades that objects touch (seed 000 §4.5 with Han & Harada's solver): on every frame
the meadow's colliders — spheres or capsules fitted to the objects of its collider
collection, rigid bodies included — activate the tiles they touch; those tiles' blades are
simulated natively in the shared wind and written into one dynamic mesh per meadow, and the
instances of those tiles are hidden. Tiles at rest are released and blend back into the
instances. Going back in time restarts from rest, using the collider positions recorded
when those frames were played."""

import bpy
import numpy as np

from .. import compat, handlers, native
from ..wind import runtime as wind_runtime
from . import build, material

STEPS_PER_FRAME = 2
_cache = {}  # meadow object name -> dict


def sim_settings(s):
    return dict(iterations=s.sim_iterations, damping=s.sim_damping,
                global_stiffness_root=s.sim_stiffness, local_stiffness=s.sim_local_stiffness)


def colliders(scene, coll, depsgraph=None):
    """float32 (n, 8) collider rows (kind, radius, a xyz, b xyz) fitted to the evaluated
    bounds of the objects in `coll`: a sphere for round objects and sphere rigid bodies,
    else a capsule along the longest axis. Objects without extent (empties, cameras,
    lights) are skipped."""
    rows = []
    if coll is None:
        return np.zeros((0, 8), np.float32)
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    for obj in coll.all_objects:  # one row per collider object
        ev = obj.evaluated_get(depsgraph)
        m = np.array(ev.matrix_world, np.float64)
        corners = np.array(ev.bound_box, np.float64)
        lo, hi = corners.min(axis=0), corners.max(axis=0)
        centre = m[:3, :3] @ ((lo + hi) / 2) + m[:3, 3]
        axes = m[:3, :3] * ((hi - lo) / 2)[None, :]  # columns: half-extent vectors
        half = np.linalg.norm(axes, axis=0)
        if half.max() == 0.0:  # no extent (an empty, camera, light, empty mesh): not a collider
            continue           # (NaN bounds go on, and the native check reports them)
        order = np.argsort(half)
        rb = obj.rigid_body
        if (rb is not None and rb.collision_shape == "SPHERE") or half[order[2]] < 1.5 * half[order[1]]:
            rows.append((0, half.max(), *centre, *centre))
        else:
            r = half[order[1]]
            d = axes[:, order[2]] / half[order[2]] * max(half[order[2]] - r, 0.0)
            rows.append((1, r, *(centre - d), *(centre + d)))
    return np.array(rows, np.float32).reshape(-1, 8)


def _entry(obj, scene):
    s = obj.tussock_meadow
    origin, size = build.area_of(obj, s)
    key = repr((build.patch_key(s), origin, size, sorted(sim_settings(s).items()),
                s.density, s.blades_per_tile, s.chunk_blades, scene.frame_start))
    e = _cache.get(obj.name)
    if e is not None and e["key"] == key:
        return e
    lib = native.require()
    patch = build.make_patch(s)
    meadow = build.make_meadow(s, origin, size)
    info = lib.meadow_info(meadow)
    k = lib.patch_info(patch)["knot_count"]
    n = info["chunk_instances"]
    origins = np.empty(n * 3, np.float32)
    chunk = np.empty(n, np.int32)
    tile = np.empty(n, np.int32)
    lib.meadow_chunk_instances(meadow, origins, chunk, tile)
    blade_rand = np.empty(lib.patch_info(patch)["blade_count"], np.float32)
    lib.rand_fill(s.seed, build.BLADE_RAND_STREAM, blade_rand)
    e = dict(key=key, patch=patch, meadow=meadow, info=info, K=k, instance_tile=tile,
             blade_rand=blade_rand, colliders={}, sim=None, frame=None, tiles={})
    _cache[obj.name] = e
    return e


def _restart(e, obj, scene):
    lib = native.require()
    info = e["info"]
    d = dict(origin=tuple(info["origin"]), tile_size=info["tile_size"], tiles_x=info["tiles_x"],
             tiles_y=info["tiles_y"], knot_count=e["K"], ground_height=info["origin"][2],
             **sim_settings(obj.tussock_meadow))
    e["sim"] = lib.blade_sim_create(**d)
    e["frame"] = scene.frame_start
    e["tiles"] = {}


def _provide_pending(e):
    lib = native.require()
    sim, k = e["sim"], e["K"]
    n = lib.blade_sim_pending(sim)
    if n == 0:
        return
    pending = np.empty(n, np.int32)
    lib.blade_sim_pending(sim, pending)
    for t in pending:  # one native call per tile that became active
        t = int(t)
        count = lib.meadow_blade_count(e["meadow"], t, t + 1)
        knots = np.empty(count * k * 3, np.float32)
        widths = np.empty(count * k, np.float32)
        sides = np.empty(count * 3, np.float32)
        index = np.empty(count, np.int32)
        lib.meadow_realise_knots(e["meadow"], e["patch"], t, t + 1, knots, widths, sides)
        lib.meadow_realise(e["meadow"], e["patch"], t, t + 1, None, None, None, index)
        lib.blade_sim_provide_tile(sim, t, knots, widths, sides)
        e["tiles"][t] = (widths, sides, e["blade_rand"][index])


def _wind(e, scene, frame):
    """(wind per knot, layout, active blades) at the active blades' knots now."""
    lib = native.require()
    sim, k = e["sim"], e["K"]
    n = lib.blade_sim_info(sim)["active_blades"]
    if not n:
        return None, 0, 0
    knots = np.empty(n * k * 3, np.float32)
    lib.blade_sim_get_knots(sim, knots)
    return np.ascontiguousarray(wind_runtime.sample(scene, frame, knots.reshape(-1, 3)).ravel()), 3, n


def _step_frame(e, scene, frame):
    lib = native.require()
    sim = e["sim"]
    lib.blade_sim_set_colliders(sim, e["colliders"].get(frame, np.zeros((0, 8), np.float32)).ravel())
    _provide_pending(e)
    dt = 1.0 / wind_runtime.fps_of(scene) / STEPS_PER_FRAME
    wind, layout, n = _wind(e, scene, frame)
    for _ in range(STEPS_PER_FRAME):
        if lib.blade_sim_info(sim)["active_blades"] != n:  # the step before released a tile
            wind, layout, n = _wind(e, scene, frame)
        lib.blade_sim_step(sim, dt, wind, layout)


def simulate_to(obj, scene, frame, depsgraph=None):
    """Advances the meadow's simulation to `frame` and returns its entry."""
    e = _entry(obj, scene)
    e["colliders"][frame] = colliders(scene, obj.tussock_meadow.colliders, depsgraph)
    if e["sim"] is None or frame < e["frame"]:
        _restart(e, obj, scene)
    try:
        while e["frame"] < frame:
            e["frame"] += 1
            _step_frame(e, scene, e["frame"])
    except (native.Error, ValueError):
        # A refused step (bad colliders, time step...) must not count as simulated: the
        # next frame restarts from rest, and this frame's colliders are not replayed.
        e["sim"] = None
        e["colliders"].pop(frame, None)
        raise
    return e


CAPACITY_BLOCK = 1024  # the dynamic mesh grows in blocks of blades, so that its topology
                       # (and Blender's work on it) changes seldom while tiles come and go


def active_blades(e):
    """(knots (n*K*3), widths, sides, blade_rand, active tiles) of the simulated blades."""
    lib = native.require()
    sim, k = e["sim"], e["K"]
    info = lib.blade_sim_info(sim)
    na, nb = info["active_tiles"], info["active_blades"]
    tiles = np.empty(na, np.int32)
    counts = np.empty(na, np.int32)
    if na:
        lib.blade_sim_get_active(sim, tiles, counts)
    knots = np.empty(nb * k * 3, np.float32)
    if nb:
        lib.blade_sim_get_knots(sim, knots)
    parts = [e["tiles"][int(t)] for t in tiles]
    widths = np.concatenate([p[0] for p in parts]) if parts else np.zeros(0, np.float32)
    sides = np.concatenate([p[1] for p in parts]) if parts else np.zeros(0, np.float32)
    rand = np.concatenate([p[2] for p in parts]) if parts else np.zeros(0, np.float32)
    return knots, widths, sides, rand, tiles


def _topology(mesh, capacity, k):
    """(Re)builds the dynamic mesh for `capacity` blades of k knots: triangles, UVs
    (u across, v = knot / (k - 1) along) and attributes. Positions are set per frame."""
    lib = native.require()
    mesh.clear_geometry()
    tris = np.empty(capacity * 6 * (k - 1), np.int32)
    lib.blade_indices(k, capacity, tris)
    nv = capacity * 2 * k
    mesh.vertices.add(nv)
    mesh.loops.add(tris.size)
    mesh.loops.foreach_set("vertex_index", tris)
    nt = tris.size // 3
    mesh.polygons.add(nt)
    mesh.polygons.foreach_set("loop_start", np.arange(0, tris.size, 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(nt, 3, np.int32))
    mesh.polygons.foreach_set("use_smooth", np.ones(nt, bool))
    v = np.repeat(np.arange(k, dtype=np.float32) / (k - 1), 2)
    u = np.tile(np.array([0.0, 1.0], np.float32), k)
    uv_vertex = np.tile(np.stack([u, v], axis=1), (capacity, 1))
    layer = mesh.uv_layers.new(name="UVMap")
    layer.data.foreach_set("uv", np.ascontiguousarray(uv_vertex[tris]).ravel())
    mesh.attributes.new("tsk_blade_rand", "FLOAT", "POINT")
    if len(mesh.materials) == 0:
        mesh.materials.append(material.grass_material())
    mesh["tussock_capacity"] = capacity


def blades_object(obj):
    """The meadow's dynamic mesh of simulated blades (created once)."""
    name = f"{obj.name} blades"
    child = bpy.data.objects.get(name)
    if child is None:
        child = bpy.data.objects.new(name, bpy.data.meshes.new(name))
        for coll in obj.users_collection:
            coll.objects.link(child)
        child["tussock_simulated_blades"] = True
    return child


def write(obj, e):
    """Writes the simulated blades into the meadow's dynamic mesh and hides the instances
    of their tiles. Unused blade slots collapse to zero-area triangles."""
    lib = native.require()
    knots, widths, sides, rand, tiles = active_blades(e)
    k = e["K"]
    nb = len(widths) // k if k else 0
    capacity = max(1, -(-nb // CAPACITY_BLOCK)) * CAPACITY_BLOCK
    child = blades_object(obj)
    mesh = child.data
    new_topology = mesh.get("tussock_capacity") != capacity
    if new_topology:
        _topology(mesh, capacity, k)
    pos = np.zeros(capacity * 2 * k * 3, np.float32)
    if nb:
        lib.blades_expand(knots, np.ascontiguousarray(widths), np.ascontiguousarray(sides), k,
                          pos[:nb * 2 * k * 3], None, None)
    vrand = np.zeros(capacity * 2 * k, np.float32)
    vrand[:nb * 2 * k] = np.repeat(rand, 2 * k)
    mesh.vertices.foreach_set("co", pos)
    mesh.attributes["tsk_blade_rand"].data.foreach_set("value", vrand)
    mesh.update()
    # hide the instances of simulated tiles
    hidden = np.isin(e["instance_tile"], tiles)
    attr = obj.data.attributes.get("tsk_hidden")
    if attr is not None and len(attr.data) == len(hidden):
        current = np.empty(len(hidden), bool)
        attr.data.foreach_get("value", current)
        if not np.array_equal(current, hidden):
            attr.data.foreach_set("value", hidden)
            obj.data.update()
    obj["tussock_active_tiles"] = len(tiles)
    obj["tussock_active_blades"] = int(nb)


def on_frame(scene, depsgraph=None):
    for obj in scene.objects:  # one simulation per meadow object
        s = compat.settings_of(obj, "tussock_meadow")
        if s is None or not s.is_meadow or not s.use_simulation:
            continue
        try:
            e = simulate_to(obj, scene, scene.frame_current, depsgraph)
            write(obj, e)
            s.last_error = ""
        except (native.Error, ValueError) as exc:
            s.last_error = str(exc)


def forget(name=None):
    if name is None:
        _cache.clear()
    else:
        _cache.pop(name, None)


@bpy.app.handlers.persistent
def _on_frame_change(scene, depsgraph=None):
    if native.available():
        on_frame(scene, depsgraph)


@bpy.app.handlers.persistent
def _on_load(*_args):
    forget()


classes = ()


def register_extra():
    handlers.add("frame_change_post", _on_frame_change)
    handlers.add("load_post", _on_load)
