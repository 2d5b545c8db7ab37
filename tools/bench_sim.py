"""Benchmarks of simulated blades in background Blender (run by ./build.sh bench):
`blade_playback` — frame time with the issue's 20,000 simulated blades (20,480: a log rolled
in, then lying still, keeps 320 tiles of 64 awake), every one shown in the viewport (Viewport
display 1.0), plus a million instanced ones (target 24 fps in Blender 3.x, 30 in 4.x/5.x);
`blade_playback_display01`, the same at Viewport display 0.1 (the headline of the first
sessions); `blade_playback_22528`, display 0.1 with a longer log (352 tiles, the scene of
sessions 3-6). In the same run, Blender's own hair physics on the same ground under the same
log: the Geometry Nodes "Hair Dynamics" asset where Blender has it (5.x, peer
"blender_hair_gn"), else particle hair dynamics (peer "blender_particle_hair"):
`blade_playback_strand_frame` gives µs per strand-frame for both and the ratio, and
`blade_playback_inside_log` counts the points (Tussock's knots, the hair's points) inside the
log's capsule once it lies on them, so a peer that does nothing fails. `blade_sim_1M`'s peer is
Blender's particle hair dynamics in ns per strand-step. Prints JSON lines (DESIGN.md)."""

import os
import resource
import statistics
import sys
import time

import bpy
import numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import NAMES, emit, wanted  # noqa: E402

# `blade_playback_character` asked for by name runs alone (wanted() would also run the group
# blade_playback, a prefix of it)
NAMES_ONLY_CHARACTER = bool(NAMES) and all(n.startswith("blade_playback_character")
                                           for n in NAMES)


def cpu_seconds():
    """CPU time of this process, all threads (steadier than wall time on a shared machine)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def reset():
    import addon_utils
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("tussock", default_set=True)


LOG_RADIUS = 0.25
INSIDE_TOLERANCE = 0.002  # m: the log's 32-sided mesh lies up to 1.2 mm inside its capsule
TIMED = range(49, 65)  # frames timed: the log lies still on the blades (frames 49-64)


def target_fps():
    """The issue's target: 24 fps in Blender 3.x, 30 in 4.x and 5.x."""
    return 24 if bpy.app.version < (4, 0, 0) else 30


def add_log(scene, log_length):
    """A log (a capsule for Tussock, the same cylinder for Blender's hair) rolling into the
    meadow over 48 frames, keyframed, then lying still on it from frame 48 on; in the
    collection "Colliders"."""
    bpy.ops.mesh.primitive_cylinder_add(radius=LOG_RADIUS, depth=log_length,
                                        location=(-12.0, 0.0, LOG_RADIUS),
                                        rotation=(1.5708, 0.0, 0.0))
    log = bpy.context.active_object
    log.keyframe_insert("location", frame=1)
    log.location.x = -9.0
    log.keyframe_insert("location", frame=48)
    log.keyframe_insert("location", frame=96)
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(log)
    return log, coll


def inside_log(points, scene, coll):
    """(points inside the collider shapes by more than INSIDE_TOLERANCE, deepest in m, points
    not finite) for float (n, 3) `points`: the shapes Tussock fits to the log or the character
    (simulate.colliders), so that Tussock's knots and Blender's hair points are judged alike.
    A point that is not finite (a simulation that blew up) counts as inside."""
    from tussock.meadow import simulate
    rows = simulate.colliders(scene, coll).astype(np.float64)
    p = np.asarray(points, np.float64).reshape(-1, 3)
    depth = np.full(len(p), -np.inf)
    for kind, r, *ab in rows:  # one row per collider (here one log)
        a, b = np.array(ab[:3]), np.array(ab[3:])
        ab_ = b - a
        t = np.clip((p - a) @ ab_ / max(ab_ @ ab_, 1e-30), 0.0, 1.0) if kind == 1 else 0.0
        d = np.linalg.norm(p - (a + np.multiply.outer(t, ab_)), axis=1)
        depth = np.maximum(depth, r - d)
    bad = ~np.isfinite(p).all(axis=1)
    count = int(np.count_nonzero(depth[~bad] > INSIDE_TOLERANCE)) + int(bad.sum())
    good = depth[~bad]
    return count, float(good.max()) if len(good) else 0.0, int(bad.sum())


def emit_inside(prefix, who, inside, points, at_rest, extra, peer=None):
    """The correctness line of inside_log's `inside` (`prefix`_inside, or
    blade_playback_inside_log for the log); `at_rest` is the
    count for the same strands left at rest, what a simulation that did nothing would give."""
    count, deepest, bad = inside
    name = "blade_playback_inside_log" if prefix == "blade_playback" else f"{prefix}_inside"
    emit(name, count, "points inside the log" if name.endswith("_log") else
         "points inside the character",
         dict({"result": "pass" if count == 0 else "fail", "points_checked": points,
               "points_not_finite": bad,
               "inside_if_left_at_rest": at_rest,
               "deepest_mm": round(deepest * 1e3, 2),
               "tolerance_mm": INSIDE_TOLERANCE * 1e3, "frame": TIMED[-1],
               "what": who}, **extra), peer=peer)


def add_character(scene):
    """The walking character of tools/walker.py (an armature deforming a mesh of tubes),
    walking along +x from x = -3 m at 1.2 m/s over frames 1-64 (through the meadow during
    frames 49-64), in the collection "Colliders"; (body, collection)."""
    import walker
    scene.render.fps, scene.render.fps_base = 24, 1.0
    _rig, body = walker.build(scene, start=(-3.0, 0.0, 0.0), speed=1.2, frames=(1, TIMED[-1]))
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(body)
    return body, coll


def playback(name, add_collider, display=1.0, check=False, params=None):
    """Times frames 49-64 of the meadow that `add_collider(scene)` -> (object, collection)
    goes through, the time Tussock spent fitting collider shapes reported apart; with `check`,
    also emits the knots-inside line (prefixed `name`) and returns (frame seconds, simulated
    blades, their rest knots (n, K, 3)) for the peers."""
    from tussock.meadow import colliders as collider_shapes
    from tussock.meadow import simulate
    reset()
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=32.0)
    bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=64, density="UNIFORM",
                               display=display)
    meadow = bpy.context.active_object
    _, coll = add_collider(scene)
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    load = os.getloadavg()[0]
    for f in range(1, TIMED[0]):  # the collider comes in
        scene.frame_set(f)
    times, cpus, fits, active = [], [], [], []
    for f in TIMED:
        c, t, fit = cpu_seconds(), time.perf_counter(), collider_shapes.stats["fit_seconds"]
        scene.frame_set(f)
        times.append(time.perf_counter() - t)
        cpus.append(cpu_seconds() - c)
        fits.append(collider_shapes.stats["fit_seconds"] - fit)
        active.append(meadow["tussock_active_blades"])
    med = statistics.median(times)
    emit(name, round(1.0 / med, 2), "fps",
         dict({"frame_ms_median": round(med * 1e3, 1),
               "frame_cpu_ms_median": round(statistics.median(cpus) * 1e3, 1),
               "fit_ms_median": round(statistics.median(fits) * 1e3, 2),
               "collider_shapes": len(simulate.colliders(scene, coll)),
               "frames": f"{TIMED[0]}-{TIMED[-1]}",
               "active_blades_min": min(active), "active_blades_max": max(active),
               "active_tiles": meadow["tussock_active_tiles"],
               "instanced_blades": meadow["tussock_blades"],
               "viewport_display": display, "viewport_blades": meadow["tussock_viewport_blades"],
               "load_average": round(load, 2), "target_fps": target_fps()}, **(params or {})))
    if not check:
        return None
    runner = simulate.playback_of(meadow).runner
    knots = runner.knots().reshape(-1, 3)
    inside = inside_log(knots, scene, coll)
    tiles, _ = runner.active()
    rest = np.concatenate([runner.rest_blades(t)[0] for t in tiles])  # one call per tile
    emit_inside(name, "Tussock's simulated knots", inside, len(knots),
                inside_log(rest, scene, coll)[0], {"blades": len(knots) // runner.K})
    return med, active[-1], rest.reshape(-1, runner.K, 3)


def hair_dynamics_group():
    """Blender's Geometry Nodes "Hair Dynamics" asset (5.x), appended, or None where this
    Blender does not ship it."""
    path = os.path.join(bpy.utils.system_resource("DATAFILES"), "assets", "nodes",
                        "geometry_nodes_dynamics_assets.blend")
    if not os.path.exists(path):
        return None
    with bpy.data.libraries.load(path) as (src, dst):
        if "Hair Dynamics" not in src.node_groups or "Collider" not in src.node_groups:
            return None
        dst.node_groups = ["Hair Dynamics", "Collider"]
    return dst.node_groups[0]


def set_input(mod, name, value):
    """Sets the node-group input called `name` of modifier `mod` (a menu by the start of its
    item's name); 5.x keeps the values in mod.properties.inputs, earlier ones as ID
    properties."""
    ident = next(it.identifier for it in mod.node_group.interface.items_tree
                 if it.item_type == "SOCKET" and it.in_out == "INPUT" and it.name == name)
    if not hasattr(mod, "properties"):
        mod[ident] = value
        return
    inp = getattr(mod.properties.inputs, ident)
    prop = inp.bl_rna.properties["value"]
    if prop.type == "ENUM":
        value = next(i.identifier for i in prop.enum_items if i.name.startswith(value))
    inp.value = value


def hair_paths(emitter, pmod, remove=False):
    """World positions (n, 3) of particle hair's paths at the current frame (17 points a
    strand at display_step 4): the hair converted to a mesh, which `remove` deletes again."""
    bpy.ops.object.select_all(action="DESELECT")
    emitter.select_set(True)
    bpy.context.view_layer.objects.active = emitter
    bpy.ops.object.modifier_convert(modifier=pmod.name)
    conv = bpy.context.active_object
    points = np.empty(len(conv.data.vertices) * 3, np.float32)
    conv.data.vertices.foreach_get("co", points)
    m = np.array(conv.matrix_world, np.float64)
    points = points.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    if remove:
        mesh = conv.data
        bpy.data.objects.remove(conv)
        bpy.data.meshes.remove(mesh)
    bpy.context.view_layer.objects.active = emitter
    return points


def timed_frames(scene):
    """Plays frames 1-64 in order (a simulation only steps forward); the wall time of
    each of frames 49-64 and of all frames after the first."""
    times, all_times = [], []
    for f in range(1, TIMED[-1] + 1):
        t = time.perf_counter()
        scene.frame_set(f)
        dt = time.perf_counter() - t
        if f > 1:
            all_times.append(dt)
        if f in TIMED:
            times.append(dt)
    return times, all_times


def peer_hair(tussock, strands, add_collider, prefix="blade_playback", gn_only=False):
    """Blender's own hair physics on the meadow's ground with the same collider: every
    20,480 / `strands`-th of Tussock's simulated blades, rest shapes as they are (16 points,
    roots on the ground). The Geometry Nodes asset where Blender ships it, else (unless
    `gn_only`) particle hair (which grows its own straight strands of the blades' median
    height over the simulated area)."""
    t_frame, t_blades, rest = tussock
    pick = rest[np.linspace(0, len(rest) - 1, min(strands, len(rest))).astype(np.int64)]
    reset()
    group = hair_dynamics_group()
    if group is None and gn_only:
        return
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=32.0)  # the meadow's ground, with its UV map
    ground = bpy.context.active_object
    log, coll = add_collider(scene)
    load = os.getloadavg()[0]
    if group is not None:
        peer, what = "blender_hair_gn", "Geometry Nodes Hair Dynamics asset, Physics mode"
        n, k = pick.shape[:2]
        curves = bpy.data.hair_curves.new("Blender hair")
        curves.add_curves([k] * n)
        curves.attributes["position"].data.foreach_set("vector", pick.astype(np.float32).ravel())
        uv = (pick[:, 0, :2] + 16.0) / 32.0  # the 32 m plane's UVs span [0, 1]
        curves.attributes.new("surface_uv_coordinate", "FLOAT2", "CURVE").data.foreach_set(
            "vector", uv.astype(np.float32).ravel())
        ground.add_rest_position_attribute = True  # the asset samples the surface's rest
        curves.surface = ground
        curves.surface_uv_map = ground.data.uv_layers[0].name
        hair = bpy.data.objects.new("Blender hair", curves)
        scene.collection.objects.link(hair)
        mod = hair.modifiers.new("Hair Dynamics", "NODES")
        mod.node_group = group
        set_input(mod, "Mode", "Physics")
        set_input(mod, "Effectors Collection", coll)
        lmod = log.modifiers.new("Collider", "NODES")
        lmod.node_group = bpy.data.node_groups["Collider"]
        settings = {"substeps": mod.node_group.interface.items_tree["Substeps"].default_value,
                    "constraint_steps":
                        mod.node_group.interface.items_tree["Constraint Steps"].default_value}
        times, all_times = timed_frames(scene)
        settings["node_warnings"] = sorted({getattr(w, "message", str(w)) for m in (mod, lmod)
                                            for w in getattr(m, "node_warnings", ())})
        ev = hair.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        points = np.empty(len(ev.points) * 3, np.float32)
        ev.attributes["position"].data.foreach_get("vector", points)
        moved = float(np.abs(points.reshape(-1, 3) - pick.reshape(-1, 3)).max())
        at_rest = inside_log(pick, scene, coll)[0]
    else:
        peer = "blender_particle_hair"
        what = "particle hair dynamics, log with a Collision modifier"
        n, k = pick.shape[:2]
        lo, hi = rest[:, 0, :2].min(axis=0), rest[:, 0, :2].max(axis=0)
        bpy.ops.mesh.primitive_plane_add(size=1.0, location=(*((lo + hi) / 2), 0.0))
        emitter = bpy.context.active_object  # the simulated area of the ground
        emitter.scale = (hi[0] - lo[0], hi[1] - lo[1], 1.0)
        bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
        pmod = emitter.modifiers.new("hair", "PARTICLE_SYSTEM")
        psys = pmod.particle_system
        ps = psys.settings
        ps.type = "HAIR"
        ps.count = n
        ps.hair_length = float(np.median(np.linalg.norm(rest[:, -1] - rest[:, 0], axis=1)))
        ps.hair_step = k - 1
        ps.display_step = 4  # the strands' paths, as converted below: 17 points for 16 keys
        psys.use_hair_dynamics = True
        psys.cloth.collision_settings.use_collision = True  # hair against collision objects
        log.modifiers.new("Collision", "COLLISION")
        settings = {"substeps": psys.cloth.settings.quality,
                    "hair_length_m": round(ps.hair_length, 3),
                    "emitter_m": [round(float(v), 2) for v in hi - lo]}
        scene.frame_set(1)
        rest_points = hair_paths(emitter, pmod, remove=True)  # the strands at rest
        times, all_times = timed_frames(scene)
        points = hair_paths(emitter, pmod)
        moved = (float(np.abs(points - rest_points).max())
                 if points.shape == rest_points.shape else None)
        # the same strands left at rest, under the log where it lies now
        at_rest = inside_log(rest_points, scene, coll)[0]
        settings["path_points_per_strand"] = len(points) // n
    med = statistics.median(times)
    per = med / n * 1e6
    t_per = t_frame / t_blades * 1e6
    emit(f"{prefix}_strand_frame", round(per, 2), "µs per strand-frame",
         dict({"strands": n, "points_per_strand": k, "frame_ms_median": round(med * 1e3, 1),
               "frame_ms_median_all": round(statistics.median(all_times) * 1e3, 1),
               "frames": f"{TIMED[0]}-{TIMED[-1]}", "what": what,
               "scaled": "no" if n == t_blades else
                         f"{n} strands (every {t_blades / n:.3g}th simulated blade), not "
                         f"{t_blades}: the frame time divided by the strands",
               "ratio_to_tussock": round(per / t_per, 1),
               "tussock_us_per_blade_frame": round(t_per, 3),
               "load_average": round(load, 2)}, **settings), peer=peer)
    inside = inside_log(points, scene, coll)
    extra = {"strands": n}
    if moved is not None:  # JSON has no NaN: a path that blew up gives null
        extra["max_point_moved_mm"] = round(moved * 1e3, 1) if np.isfinite(moved) else None
    emit_inside(prefix, what, inside, len(points.reshape(-1, 3)), at_rest, extra, peer=peer)


def hair_peer(strands=2000, segments=15, frames=24):
    reset()
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=4.0)
    plane = bpy.context.active_object
    mod = plane.modifiers.new("hair", "PARTICLE_SYSTEM")
    ps = mod.particle_system.settings
    ps.type = "HAIR"
    ps.count = strands
    ps.hair_length = 0.3
    ps.hair_step = segments
    mod.particle_system.use_hair_dynamics = True
    times = []
    for f in range(1, frames + 1):
        t = time.perf_counter()
        scene.frame_set(f)
        times.append(time.perf_counter() - t)
    med = statistics.median(times[2:])
    substeps = mod.particle_system.cloth.settings.quality
    ns = med / (strands * substeps) * 1e9
    emit("blade_sim_1M", round(ns, 1), "ns per blade-step",
         {"strands": strands, "segments": segments, "substeps_per_frame": substeps,
          "frame_ms_median": round(med * 1e3, 1), "what": "Blender particle hair dynamics"},
         peer="blender_hair")


# Blender's hair takes 300-400 µs per strand-frame, so 20,480 strands make 6-8 s frames (the
# run 7-10 minutes); TSK_PEER_STRANDS=2048 takes every 10th blade for a quicker look
PEER_STRANDS = int(os.environ.get("TSK_PEER_STRANDS", "20480"))


def log_of(length):
    # from frame 49 on the tiles the log passed over are still recovering and those under it
    # still pressed; 4.5 m long, it keeps 20,480 blades simulated (the 20,000)
    return lambda scene: add_log(scene, length)


def tussock_line(prefix, tussock):
    emit(f"{prefix}_strand_frame", round(tussock[0] / tussock[1] * 1e6, 3),
         "µs per strand-frame", {"blades": tussock[1],
                                 "frame_ms_median": round(tussock[0] * 1e3, 1),
                                 "what": "Tussock, every simulated blade shown"})


if wanted("blade_playback") and not NAMES_ONLY_CHARACTER:
    tussock = playback("blade_playback", log_of(4.5), check=True, params={"log_m": 4.5})
    tussock_line("blade_playback", tussock)
    peer_hair(tussock, PEER_STRANDS, log_of(4.5))
    playback("blade_playback_display01", log_of(4.5), display=0.1, params={"log_m": 4.5})
    playback("blade_playback_22528", log_of(5.0), display=0.1, params={"log_m": 5.0})
if wanted("blade_playback_character"):
    # the walking character in the blade_playback meadow; beside it, in Blender 5.x, the
    # Geometry Nodes Hair Dynamics asset colliding with the same character
    tussock = playback("blade_playback_character", add_character, check=True,
                       params={"character": "tools/walker.py, 1.2 m/s"})
    tussock_line("blade_playback_character", tussock)
    peer_hair(tussock, PEER_STRANDS, add_character, prefix="blade_playback_character",
              gn_only=True)
if wanted("blade_sim_1M") or wanted("blade_hair"):
    hair_peer()
