"""Resident memory over many add/delete cycles (issue 42): in one Blender, adds a meadow or a
tree the way an artist does (the operator), plays two frames, deletes it with the ground Add
Meadow made (the Delete operator; Tussock tidies what the meadow owned), and purges orphan
data as saving and reopening the file would. After cycle 100 and after the last it prints
the process's resident memory (VmRSS), Tussock's native bytes in use and the counts of
objects, meshes and collections; a leak shows as growth between the two.

    blender -b --factory-startup --python tools/leak_cycles.py -- KIND [CYCLES]
    KIND: meadow (a simulated 3 m meadow with a ball in its grass) | tree (a leafy aspen)

(with the add-on enabled as tools/blender_env.py sets it up; ./build.sh leaks runs it in each
Blender). Prints `LEAKS kind=... cycles=... rss100=... rssN=... growth=...%`, then a `LEAK:` line
for each bound broken (exit status 1): resident memory more than 5 % above cycle 100's, or
native bytes or data-block counts other than cycle 100's."""

import gc
import os
import sys
import time

import bpy


def trim():
    """Returns the C heap's free memory to the system (glibc's malloc_trim), so that resident
    memory counts what is in use, not what the allocator keeps for later."""
    import ctypes
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):  # not glibc
        pass


def rss_bytes():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    return 0


def counts():
    return len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.collections)


def setup(kind):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    import addon_utils
    addon_utils.enable("tussock", default_set=True)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 4
    if kind == "meadow":
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.3, location=(0.0, 0.0, 0.2))
        ball = bpy.context.active_object
        ball.name = "Sphere"
        coll = bpy.data.collections.new("Colliders")
        scene.collection.children.link(coll)
        coll.objects.link(ball)
    return scene


def cycle(kind, scene):
    bpy.ops.object.select_all(action="DESELECT")
    if kind == "meadow":
        assert bpy.ops.tussock.add_meadow(size=(3.0, 3.0), blades_per_tile=32,
                                          patch_blades=1024, chunk_blades=16) == {"FINISHED"}
        obj = bpy.context.active_object
        obj.tussock_meadow.colliders = bpy.data.collections["Colliders"]
        obj.tussock_meadow.use_simulation = True
    else:
        assert bpy.ops.tussock.add_tree(preset="quaking_aspen", leaves=True) == {"FINISHED"}
        obj = bpy.context.active_object
    for f in (2, 3):
        scene.frame_set(f)
    bpy.ops.object.select_all(action="DESELECT")
    for o in scene.objects:  # the meadow and the ground Add Meadow made under it
        o.select_set(o.name != "Sphere")
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.object.delete() == {"FINISHED"}
    scene.frame_set(1)  # a frame change: Tussock tidies what the meadow owned
    bpy.ops.outliner.orphans_purge(do_local_ids=True, do_linked_ids=True, do_recursive=True)


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    kind = argv[0] if argv else "meadow"
    total = int(argv[1]) if len(argv) > 1 else 1000
    if kind not in ("meadow", "tree") or total < 100:
        raise SystemExit("usage: leak_cycles.py -- meadow|tree [CYCLES >= 100]")
    scene = setup(kind)
    from tussock import native
    lib = native.require()
    marks = {}
    t0 = time.monotonic()
    for i in range(1, total + 1):
        cycle(kind, scene)
        if i in (100, total) or i % 250 == 0:
            gc.collect()
            trim()
            marks[i] = (rss_bytes(), lib.allocated_bytes(), counts())
            print(f"cycle {i}: resident {marks[i][0] / 2**20:.1f} MiB, native "
                  f"{marks[i][1] / 2**20:.2f} MiB, objects/meshes/collections {marks[i][2]}, "
                  f"{time.monotonic() - t0:.0f} s", flush=True)
    r100, rn = marks[100][0], marks[total][0]
    print(f"LEAKS kind={kind} cycles={total} blender={bpy.app.version_string} "
          f"rss100={r100 / 2**20:.1f}MiB rss{total}={rn / 2**20:.1f}MiB "
          f"growth={(rn - r100) / r100 * 100:+.2f}% native100={marks[100][1]} "
          f"native{total}={marks[total][1]} counts100={marks[100][2]} "
          f"counts{total}={marks[total][2]} secs={time.monotonic() - t0:.0f}", flush=True)
    # issue 42's bound: within 5 % of the resident memory after 100 cycles; and what Tussock
    # itself holds (native bytes, data-blocks) exactly as it was
    bad = []
    if rn > r100 * 1.05:
        bad.append(f"resident memory grew {(rn - r100) / r100:.1%} (more than 5 %)")
    if marks[total][1] != marks[100][1]:
        bad.append(f"native bytes in use {marks[100][1]} -> {marks[total][1]}")
    if marks[total][2] != marks[100][2]:
        bad.append(f"objects/meshes/collections {marks[100][2]} -> {marks[total][2]}")
    for b in bad:
        print(f"LEAK: {kind}: {b}", flush=True)
    return 1 if bad else 0


status = main()
sys.stdout.flush()
os._exit(status)
