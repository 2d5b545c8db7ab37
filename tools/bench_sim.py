"""Benchmarks of simulated blades in background Blender (run by ./build.sh bench):
`blade_playback` — frame time with the issue's 20,000 simulated blades (20,480: a log rolled
in, then lying still, keeps 320 tiles of 64 awake) plus a million instanced ones, the meadow's
Viewport display at 0.1 as since the first session (target >= 24 fps);
`blade_playback_display1`, the same with every blade shown in the viewport; `blade_playback_22528`, the same with a longer log (352 tiles, the scene of sessions 3-6);
and the peer, Blender's own particle hair
dynamics with the same segments, in ns per strand-step. Prints JSON lines (DESIGN.md)."""

import os
import resource
import statistics
import sys
import time

import bpy
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import emit, wanted  # noqa: E402

def cpu_seconds():
    """CPU time of this process, all threads (steadier than wall time on a shared machine)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def reset():
    import addon_utils
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("tussock", default_set=True)


def playback(name, log_length, display=0.1):
    reset()
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=32.0)
    bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=64, density="UNIFORM",
                               display=display)
    meadow = bpy.context.active_object
    # a log (capsule) rolling into the meadow over 48 frames, keyframed, then lying still on
    # it: from frame 49 on the tiles it passed over are still recovering and those under it
    # still pressed; 4.5 m long, it keeps 20,480 blades simulated (the 20,000)
    bpy.ops.mesh.primitive_cylinder_add(radius=0.25, depth=log_length, location=(-12.0, 0.0, 0.25),
                                        rotation=(1.5708, 0.0, 0.0))
    log = bpy.context.active_object
    log.keyframe_insert("location", frame=1)
    log.location.x = -9.0
    log.keyframe_insert("location", frame=48)
    log.keyframe_insert("location", frame=96)
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(log)
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    load = os.getloadavg()[0]
    for f in range(1, 49):  # the log rolls in
        scene.frame_set(f)
    times, cpus, active = [], [], []
    for f in range(49, 65):  # timed: frame 49 to 64
        c, t = cpu_seconds(), time.perf_counter()
        scene.frame_set(f)
        times.append(time.perf_counter() - t)
        cpus.append(cpu_seconds() - c)
        active.append(meadow["tussock_active_blades"])
    med = statistics.median(times)
    emit(name, round(1.0 / med, 2), "fps",
         {"frame_ms_median": round(med * 1e3, 1),
          "frame_cpu_ms_median": round(statistics.median(cpus) * 1e3, 1),
          "frames": "49-64", "log_m": log_length, "active_blades_min": min(active),
          "active_blades_max": max(active),
          "active_tiles": meadow["tussock_active_tiles"], "instanced_blades": meadow["tussock_blades"],
          "viewport_display": display, "viewport_blades": meadow["tussock_viewport_blades"],
          "load_average": round(load, 2), "target_fps": 24})


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


if wanted("blade_playback"):
    playback("blade_playback", 4.5)
    # every simulated blade in the viewport (Viewport display 1): Blender evaluates them all
    playback("blade_playback_display1", 4.5, display=1.0)
    playback("blade_playback_22528", 5.0)
if wanted("blade_sim_1M") or wanted("blade_hair"):
    hair_peer()
