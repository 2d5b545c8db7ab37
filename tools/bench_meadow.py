"""Benchmark `meadow_10M` (run by ./build.sh bench in background Blender): a meadow of
10,000,000 instanced blades — evaluation time and Blender's peak resident memory —
against the same meadow realised as one plain mesh, and a 100,000,000-blade meadow that
must open, evaluate and render a small Cycles frame. Each variant runs in its own Blender
process so that peak memory is its own. Prints JSON lines (DESIGN.md).

usage: blender_run.py tools/bench_meadow.py -- [NAME...] | --variant V BLADES"""

import json
import os
import resource
import subprocess
import sys
import time

import bpy
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import ARGS, emit, wanted  # noqa: E402

TILE, PER_TILE = 0.25, 64


def peak_rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def side_for(blades):
    tiles = blades / PER_TILE
    return (tiles ** 0.5) * TILE


def count_instances(obj):
    dg = bpy.context.evaluated_depsgraph_get()
    return sum(1 for inst in dg.object_instances if inst.is_instance and inst.parent
               and inst.parent.original == obj)


def variant(kind, blades):
    import addon_utils
    addon_utils.enable("tussock", default_set=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("tussock", default_set=True)
    base = peak_rss_mb()
    side = side_for(blades)
    chunk = 64 if blades > 20_000_000 else 16
    t0 = time.time()
    bpy.ops.tussock.add_meadow(size=(side, side), tile_size=TILE, blades_per_tile=PER_TILE,
                               chunk_blades=chunk, density="UNIFORM", display=1.0)
    obj = bpy.context.active_object
    result = {"blades": obj["tussock_blades"], "baseline_mb": round(base, 1)}
    if kind == "realised":
        # Realize Instances after the meadow group: one plain mesh of every blade
        from tussock import compat
        ng = bpy.data.node_groups.new("realise", "GeometryNodeTree")
        compat.node_group_add_socket(ng, "INPUT", "NodeSocketGeometry", "Geometry")
        compat.node_group_add_socket(ng, "OUTPUT", "NodeSocketGeometry", "Geometry")
        gi, go = ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")
        rl = ng.nodes.new("GeometryNodeRealizeInstances")
        ng.links.new(gi.outputs[0], rl.inputs[0])
        ng.links.new(rl.outputs[0], go.inputs[0])
        obj.modifiers.new("realise", "NODES").node_group = ng
        dg = bpy.context.evaluated_depsgraph_get()
        ev = obj.evaluated_get(dg)
        result["vertices"] = len(ev.data.vertices)
    else:
        result["instances"] = count_instances(obj)
    result["seconds"] = round(time.time() - t0, 2)
    if kind == "render":
        scene = bpy.context.scene
        cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
        scene.collection.objects.link(cam)
        cam.location = (side * 0.5, -2.0, 1.6)
        cam.rotation_euler = (1.2, 0.0, 0.0)
        scene.camera = cam
        scene.render.engine = "CYCLES"
        scene.cycles.samples = 4
        scene.cycles.use_denoising = False
        scene.render.resolution_x, scene.render.resolution_y = 320, 180
        scene.render.filepath = os.path.join(os.environ.get("TSK_TEST_TMP", "/tmp"), "m100.png")
        t1 = time.time()
        bpy.ops.render.render(write_still=True)
        result["render_seconds"] = round(time.time() - t1, 2)
    result["peak_rss_mb"] = round(peak_rss_mb(), 1)
    print("RESULT " + json.dumps(result), flush=True)


def run_variant(kind, blades):
    cmd = [os.environ.get("BLENDER", "blender"), "-b", "--factory-startup", "-noaudio",
           "--python-exit-code", "1", "--python", os.path.abspath(__file__), "--",
           "--variant", kind, str(blades)]
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    for line in proc.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    sys.stderr.write(proc.stdout[-3000:])
    return None


def main():
    if "--variant" in ARGS:
        i = ARGS.index("--variant")
        variant(ARGS[i + 1], int(ARGS[i + 2]))
        return
    if wanted("meadow_10M"):
        inst = run_variant("instanced", 10_000_000)
        r1 = run_variant("realised", 1_000_000)
        r2 = run_variant("realised", 2_000_000)
        if inst and r1 and r2:
            per_blade = (r2["peak_rss_mb"] - r1["peak_rss_mb"]) / (r2["blades"] - r1["blades"])
            realised_10m = r1["peak_rss_mb"] + per_blade * (inst["blades"] - r1["blades"])
            emit("meadow_10M", inst["peak_rss_mb"], "MB", dict(inst, target_mb=1024))
            emit("meadow_10M_eval", inst["seconds"], "s", {"blades": inst["blades"]})
            emit("meadow_10M", round(realised_10m, 1), "MB",
                 {"method": "realised mesh measured at 1M and 2M blades, extrapolated "
                            "linearly to 10M", "at_1M": r1, "at_2M": r2},
                 peer="realised plain mesh")
            emit("meadow_10M_ratio", round(realised_10m / inst["peak_rss_mb"], 1), "x",
                 {"target": 10})
    if wanted("meadow_100M"):
        big = run_variant("render", 100_000_000)
        if big:
            emit("meadow_100M", big["peak_rss_mb"], "MB", big)


main()
