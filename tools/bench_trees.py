"""Benchmarks of trees in Blender (run by ./build.sh bench in background Blender):

* `tree_generate_blender_<species>`: time to add a tree with `tussock.add_tree` (operator +
  depsgraph
  evaluation) against Blender's bundled Sapling Tree Gen (`bpy.ops.curve.tree_add`) growing
  the same species from the same Weber-Penn parameters — Sapling's own preset file, read
  with ast.literal_eval and mapped onto Tussock's definition (docs/trees.md, "Sapling
  presets"). The peer lines carry `"peer": "sapling"`; `tree_generate_blender_speedup`
  is the median over species of Sapling's time divided by Tussock's, and
  `tree_generate_blender_<species>_native` the native part alone (grow + mesh arrays).
  (bench_tree's `tree_generate_<preset>` lines time the native generator of the built-in
  presets.)
* `tree_playback_50k`: frames per second of `scene.frame_set` for a tree of more than
  50,000 leaves swaying in the scene's wind, and the same for Sapling's armature wind
  animation (armAnim) of its tree with leaves, where Sapling can make one (with Blender's
  allocator as Blender sets it). `tree_playback_50k_pages_given_back`: Tussock's tree again
  with Preferences > Reuse Freed Memory off (addon/allocator.py; only where Blender uses
  jemalloc).

usage: blender_run.py tools/bench_trees.py -- [NAME...]"""

import ast
import os
import statistics
import sys
import time

import addon_utils
import bpy
import numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import emit, wanted  # noqa: E402

SAPLING_DIR = None  # found when the add-on is enabled
SPECIES = ("quaking_aspen", "weeping_willow", "douglas_fir", "small_pine", "white_birch")
REPEATS = 5


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("tussock", default_set=True)
    addon_utils.enable("add_curve_sapling", default_set=True)


def sapling_dir():
    """Sapling Tree Gen's presets folder, or None: Blender 3.4-4.1 bundle Sapling; from 4.2
    it is an extension of its own that background Blender here does not have, so its lines
    (the peers, and tree_generate_blender, whose species are Sapling's presets) are left out."""
    try:
        import add_curve_sapling
    except ImportError:
        return None
    return os.path.join(os.path.dirname(add_curve_sapling.__file__), "presets")


def sapling_preset(name):
    with open(os.path.join(sapling_dir(), name + ".py")) as f:
        text = f.read()
    return ast.literal_eval(text[text.index("{"):])


def tussock_def(sp, lib):
    """Tussock's definition for a Sapling preset dict (docs/trees.md key table). Sapling's
    shape 8 (a custom envelope) has no Weber-Penn counterpart: tend flame (7) is used."""
    d = lib.tree_default_def()
    shape = int(sp["shape"])
    d["shape"] = shape if shape <= 7 else 7
    for s, t in (("baseSize", "base_size"), ("scale", "scale"), ("scaleV", "scale_v"),
                 ("levels", "levels"), ("ratio", "ratio"), ("ratioPower", "ratio_power"),
                 ("baseSplits", "base_splits"), ("scale0", "scale0"), ("scaleV0", "scale0_v"),
                 ("leafScale", "leaf_scale"), ("leafScaleX", "leaf_scale_x")):
        d[t] = type(d[t])(sp[s])
    d["leaves"] = abs(int(sp["leaves"]))
    up = sp["attractUp"]
    d["attraction_up"] = float(up[min(2, len(up) - 1)] if isinstance(up, (tuple, list)) else up)
    if sp.get("prune"):
        for s, t in (("pruneRatio", "prune_ratio"), ("pruneWidth", "prune_width"),
                     ("pruneWidthPeak", "prune_width_peak"), ("prunePowerLow", "prune_power_low"),
                     ("prunePowerHigh", "prune_power_high")):
            d[t] = float(sp[s])
    else:
        d["prune_ratio"] = 0.0
    per = (("length", "length"), ("lengthV", "length_v"), ("taper", "taper"),
           ("segSplits", "seg_splits"), ("splitAngle", "split_angle"),
           ("splitAngleV", "split_angle_v"), ("curveRes", "curve_res"), ("curve", "curve"),
           ("curveBack", "curve_back"), ("curveV", "curve_v"), ("downAngle", "down_angle"),
           ("downAngleV", "down_angle_v"), ("rotate", "rotate"), ("rotateV", "rotate_v"),
           ("branches", "branches"))
    for n in range(4):
        for s, t in per:
            lv = d["level"][n]
            lv[t] = type(lv[t])(sp[s][n])
        d["level"][n]["taper"] = min(max(d["level"][n]["taper"], 0.0), 1.0)
    return d


def evaluated():
    bpy.context.view_layer.update()
    bpy.context.evaluated_depsgraph_get()


def clear_objects():
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    for coll in (bpy.data.meshes, bpy.data.curves, bpy.data.armatures, bpy.data.actions):
        for block in list(coll):
            if block.users == 0:
                coll.remove(block)


def sapling_counts():
    branches = leaves = verts = 0
    for o in bpy.context.scene.objects:
        if o.type == "CURVE":
            branches += len(o.data.splines)
        elif o.type == "MESH" and o.name.startswith("leaves"):
            leaves += len(o.data.polygons)
    dg = bpy.context.evaluated_depsgraph_get()
    for o in bpy.context.scene.objects:
        if o.type in ("CURVE", "MESH"):
            ev = o.evaluated_get(dg)
            me = ev.to_mesh()
            verts += len(me.vertices)
            ev.to_mesh_clear()
    return branches, leaves, verts


def bench_generate():
    from tussock import native
    from tussock.trees import presets
    lib = native.require()
    ratios = []
    if sapling_dir() is None:
        print(f"tree_generate_blender: Sapling is not in Blender {bpy.app.version_string}",
              file=sys.stderr)
        return
    for name in SPECIES:
        if not os.path.exists(os.path.join(sapling_dir(), name + ".py")):
            continue
        sp = sapling_preset(name)
        leaves = bool(sp.get("showLeaves"))
        d = tussock_def(sp, lib)
        d["seed"] = int(sp.get("seed", 0))
        pname = presets.save("sapling " + name, d)
        # Sapling: its own preset, as the operator's properties (do_update makes it build)
        kw = {k: v for k, v in sp.items() if k not in ("presetName", "limitImport")}
        kw["do_update"] = True
        ts, tt = [], []
        for _ in range(REPEATS):
            clear_objects()
            t0 = time.perf_counter()
            bpy.ops.curve.tree_add(**kw)
            evaluated()
            ts.append(time.perf_counter() - t0)
        sb, sl, sv = sapling_counts()
        for _ in range(REPEATS):
            clear_objects()
            t0 = time.perf_counter()
            bpy.ops.tussock.add_tree(preset="user:" + pname, seed=d["seed"], leaves=leaves)
            evaluated()
            tt.append(time.perf_counter() - t0)
        obj = bpy.context.active_object
        tb, tl, tv = obj["tussock_branches"], obj["tussock_leaves"], obj["tussock_vertices"]
        clear_objects()
        # the native part alone: grow, mesh topology and vertices (what Blender gets)
        dn = dict(d)
        if not leaves:
            dn["leaves"] = 0
        tn = []
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            tree = lib.tree_create(dn)
            nv, nq = lib.tree_mesh_count(tree, leaves=True)
            faces, uvs = np.empty(nq * 4, np.int32), np.empty(nq * 8, np.float32)
            lib.tree_mesh_topology(tree, faces, uvs, leaves=True)
            pos = np.empty(nv * 3, np.float32)
            lib.tree_mesh_deform(tree, pos, leaves=True)
            tn.append(time.perf_counter() - t0)
            del tree
        s_med, t_med = statistics.median(ts), statistics.median(tt)
        ratios.append(s_med / t_med)
        common = {"species": name, "levels": d["levels"], "leaves_on": leaves,
                  "repeats": REPEATS, "what": "operator + depsgraph evaluation"}
        emit(f"tree_generate_blender_{name}", t_med * 1e3, "ms per tree",
             dict(common, branches=tb, leaves=tl, vertices=tv))
        emit(f"tree_generate_blender_{name}", s_med * 1e3, "ms per tree",
             dict(common, branches=sb, leaves=sl, vertices=sv), peer="sapling")
        emit(f"tree_generate_blender_{name}_native", statistics.median(tn) * 1e3, "ms per tree",
             dict(common, what="native: grow + mesh topology + vertices, no Blender mesh",
                  vertices=nv, sapling_over_native=round(s_med / statistics.median(tn), 1)))
    if ratios:
        emit("tree_generate_blender_speedup", statistics.median(ratios),
             "Sapling time / Tussock time",
             {"species": [s for s in SPECIES], "min": round(min(ratios), 1),
              "max": round(max(ratios), 1), "target": 20})


def windy(scene):
    w = scene.tussock_wind
    w.base_speed = 4.0
    wave = w.waves.add()
    wave.amplitude, wave.wavelength, wave.speed = 3.0, 6.0, 4.0


def play(scene, frames):
    """Per-frame wall and CPU times of scene.frame_set over `frames` frames (after one)."""
    scene.frame_set(1)
    wall, cpu = [], []
    for f in range(2, 2 + frames):
        t0, c0 = time.perf_counter(), time.process_time()
        scene.frame_set(f)
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return statistics.median(wall), statistics.median(cpu)


def bench_playback():
    fresh()
    scene = bpy.context.scene
    windy(scene)
    bpy.ops.tussock.add_tree(preset="ca_black_oak", seed=1, leaves=True)
    obj = bpy.context.active_object
    wall, cpu = play(scene, 48)
    # Tussock's share of a frame: the pose alone (wind, wind step, deform, foreach_set)
    from tussock.trees import build
    pose_wall, pose_cpu = [], []
    for f in range(60, 84):
        t0, c0 = time.perf_counter(), time.process_time()
        build.pose(obj, scene, f)
        pose_wall.append(time.perf_counter() - t0)
        pose_cpu.append(time.process_time() - c0)
    emit("tree_playback_50k", 1.0 / wall, "frames per second",
         {"preset": "ca_black_oak", "branches": obj["tussock_branches"],
          "leaves": obj["tussock_leaves"], "vertices": obj["tussock_vertices"],
          "frames": 48, "ms_per_frame": round(wall * 1e3, 2),
          "cpu_ms_per_frame": round(cpu * 1e3, 2),
          "pose_ms": round(statistics.median(pose_wall) * 1e3, 2),
          "pose_cpu_ms": round(statistics.median(pose_cpu) * 1e3, 2),
          "what": "scene.frame_set, wind + pose + mesh; pose_ms: Tussock's handler alone",
          "target_fps": 30})
    # the same with Blender's allocator giving freed pages back at once (as before Tussock
    # kept them: addon/allocator.py), where that allocator is jemalloc
    from tussock import allocator, prefs
    if allocator.state()[0] is not None:
        p = prefs.get()
        p.keep_freed_memory = False
        wall_back, cpu_back = play(scene, 48)
        p.keep_freed_memory = True
        emit("tree_playback_50k_pages_given_back", 1.0 / wall_back, "frames per second",
             {"ms_per_frame": round(wall_back * 1e3, 2),
              "cpu_ms_per_frame": round(cpu_back * 1e3, 2),
              "what": "tree_playback_50k with Preferences > Reuse Freed Memory off"})
    # Sapling: its armature wind animation (armAnim) on its small_pine with leaves (10 %
    # more per twig than the preset, to pass 50,000), a bone per branch segment (curves)
    if sapling_dir() is None:
        print(f"tree_playback_50k: no Sapling peer in Blender {bpy.app.version_string}",
              file=sys.stderr)
        return
    clear_objects()
    # Sapling as Blender runs it without Tussock: freed pages given back at once
    keep = prefs.get().keep_freed_memory
    prefs.get().keep_freed_memory = False
    sp = sapling_preset("small_pine")
    kw = {k: v for k, v in sp.items() if k not in ("presetName", "limitImport")}
    kw.update(do_update=True, showLeaves=True, useArm=True, armAnim=True, leafAnim=False,
              makeMesh=False, leaves=int(abs(int(sp["leaves"])) * 1.1 + 0.5))
    t0 = time.perf_counter()
    bpy.ops.curve.tree_add(**kw)
    build = time.perf_counter() - t0
    sb, sl, sv = sapling_counts()
    bones = sum(len(o.data.bones) for o in scene.objects if o.type == "ARMATURE")
    wall, cpu = play(scene, 12)
    emit("tree_playback_50k", 1.0 / wall, "frames per second",
         {"species": "small_pine", "branches": sb, "leaves": sl, "vertices": sv,
          "bones": bones, "frames": 12, "ms_per_frame": round(wall * 1e3, 2),
          "cpu_ms_per_frame": round(cpu * 1e3, 2), "build_s": round(build, 2),
          "what": "scene.frame_set, armature deform of curve bevel + leaves"}, peer="sapling")
    prefs.get().keep_freed_memory = keep


fresh()
if wanted("tree_generate_blender"):
    bench_generate()
if wanted("tree_playback"):
    bench_playback()
