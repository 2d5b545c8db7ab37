"""Resident memory over many add/delete cycles (issue 42): in one Blender, adds a meadow or a
tree the way an artist does (the operator), plays two frames, deletes it with the ground Add
Meadow made (the Delete operator; Tussock tidies what the meadow owned), and purges orphan
data as saving and reopening the file would. After cycle 100 and after the last it prints
the process's resident memory (VmRSS, after the C allocator gave its free pages back:
tools/memory_probe.py), the bytes that allocator has in use, Blender's own allocations,
Tussock's native bytes in use, the blocks Python has allocated and the length of every
bpy.data collection; a leak shows as growth between the two. In a window each cycle is one
timer call, so that Blender's event loop runs between cycles as between an artist's clicks
(Blender 3.4 queues notifiers that only that loop frees: docs/reliability.md).

    blender [-b] --factory-startup --python tools/leak_cycles.py -- KIND [CYCLES]
    KIND: meadow (a simulated 3 m meadow with a ball in its grass) | tree (a leafy aspen) |
          objects (the control: no Tussock, as many plain mesh objects as a meadow makes,
          made with bpy.data in a collection of the scene, played and deleted the same way)

(with the add-on enabled as tools/blender_env.py sets it up: blender_run.py [--window];
./build.sh leaks runs it in each Blender). Prints `LEAKS kind=... cycles=... rss100=...
rssN=... growth=...%`, then a `LEAK:` line for each bound broken (exit status 1): resident
memory more than 5 % above cycle 100's, or native bytes or data-block counts other than
cycle 100's. The control's broken bounds are
Blender's own: `CONTROL:` lines, exit status 0."""

import gc
import os
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from memory_probe import ALLOCATOR, heap_in_use, rss_bytes, trim  # noqa: E402


def counts():
    """The length of every bpy.data collection (objects, meshes, materials, node groups,
    images, actions, ...): a data-block a cycle leaves behind shows in one of them."""
    return {name: len(c) for name in dir(bpy.data)
            if isinstance(c := getattr(bpy.data, name, None), bpy.types.bpy_prop_collection)}


def differing(a, b):
    return {name: (a[name], b.get(name)) for name in a if a[name] != b.get(name)}


def setup(kind):
    if bpy.app.background:
        bpy.ops.wm.read_factory_settings(use_empty=True)
    else:  # the window's file as it opened (--factory-startup), emptied without a file read
        for o in list(bpy.data.objects):
            bpy.data.objects.remove(o)
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


def plain_objects(scene):
    """The control's cycle, made with bpy.data alone: what a meadow makes, without Tussock.
    64 small meshes of triangles with a UV layer and a float attribute in a collection of the
    scene, a ground, and a point cloud whose geometry nodes (Collection Info, Instance on
    Points) instance them."""
    import numpy as np
    coll = bpy.data.collections.new("Plain")
    scene.collection.children.link(coll)
    co = np.linspace(0.0, 1.0, 96 * 3, dtype=np.float32)
    tris = np.arange(96, dtype=np.int32)
    for i in range(65):
        mesh = bpy.data.meshes.new(f"Plain {i:05d}")
        mesh.vertices.add(96)
        mesh.vertices.foreach_set("co", co)
        mesh.loops.add(96)
        mesh.loops.foreach_set("vertex_index", tris)
        mesh.polygons.add(32)
        mesh.polygons.foreach_set("loop_start", tris[::3].copy())
        mesh.polygons.foreach_set("loop_total", np.full(32, 3, np.int32))
        mesh.uv_layers.new(name="UVMap")
        mesh.attributes.new("rand", "FLOAT", "POINT")
        mesh.update()
        obj = bpy.data.objects.new(mesh.name, mesh)
        (coll if i < 64 else scene.collection).objects.link(obj)
    group, collection_input = _plain_group()
    obj = bpy.data.objects.new("Plain points", bpy.data.meshes.new("Plain points"))
    obj.data.vertices.add(96)
    obj.data.vertices.foreach_set("co", co)
    scene.collection.objects.link(obj)
    mod = obj.modifiers.new("Instances", "NODES")
    mod.node_group = group
    inputs = getattr(getattr(mod, "properties", None), "inputs", None)
    if inputs is not None:  # Blender 5.2 on: inputs are RNA structs
        getattr(inputs, collection_input).value = coll
    else:
        mod[collection_input] = coll
    return obj


def _plain_group():
    """The control's node group and the identifier of its collection input."""
    group = bpy.data.node_groups.get("Plain")
    fresh = group is None
    if fresh:
        group = bpy.data.node_groups.new("Plain", "GeometryNodeTree")
    if hasattr(group, "interface"):  # Blender 4.0 on
        if fresh:
            group.interface.new_socket("Geometry", in_out="INPUT",
                                       socket_type="NodeSocketGeometry")
            group.interface.new_socket("Collection", in_out="INPUT",
                                       socket_type="NodeSocketCollection")
            group.interface.new_socket("Geometry", in_out="OUTPUT",
                                       socket_type="NodeSocketGeometry")
        ident = [i.identifier for i in group.interface.items_tree
                 if getattr(i, "socket_type", "") == "NodeSocketCollection"][0]
    else:
        if fresh:
            group.inputs.new("NodeSocketGeometry", "Geometry")
            group.inputs.new("NodeSocketCollection", "Collection")
            group.outputs.new("NodeSocketGeometry", "Geometry")
        ident = group.inputs[1].identifier
    if not fresh:
        return group, ident
    gin, gout = group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")
    info = group.nodes.new("GeometryNodeCollectionInfo")
    info.inputs["Separate Children"].default_value = True
    inst = group.nodes.new("GeometryNodeInstanceOnPoints")
    inst.inputs["Pick Instance"].default_value = True
    group.links.new(gin.outputs[1], info.inputs["Collection"])
    group.links.new(gin.outputs[0], inst.inputs["Points"])
    group.links.new(info.outputs[0], inst.inputs["Instance"])
    group.links.new(inst.outputs[0], gout.inputs[0])
    return group, ident


def cycle(kind, scene):
    bpy.ops.object.select_all(action="DESELECT")
    if kind == "meadow":
        assert bpy.ops.tussock.add_meadow(size=(3.0, 3.0), blades_per_tile=32,
                                          patch_blades=1024, chunk_blades=16) == {"FINISHED"}
        obj = bpy.context.active_object
        obj.tussock_meadow.colliders = bpy.data.collections["Colliders"]
        obj.tussock_meadow.use_simulation = True
    elif kind == "tree":
        assert bpy.ops.tussock.add_tree(preset="quaking_aspen", leaves=True) == {"FINISHED"}
        obj = bpy.context.active_object
    else:
        obj = plain_objects(scene)
    for f in (2, 3):
        scene.frame_set(f)
    bpy.ops.object.select_all(action="DESELECT")
    for o in scene.objects:  # the meadow and the ground Add Meadow made under it
        o.select_set(o.name != "Sphere")
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.object.delete() == {"FINISHED"}
    if kind == "objects":
        bpy.data.collections.remove(bpy.data.collections["Plain"])
    scene.frame_set(1)  # a frame change: Tussock tidies what the meadow owned
    bpy.ops.outliner.orphans_purge(do_local_ids=True, do_linked_ids=True, do_recursive=True)


def mib(n):
    return "n/a" if n is None else f"{n / 2**20:.1f} MiB"


def blender_stats():
    """Blender's own allocations in use (its guarded allocator's count, whatever the C
    allocator), as its status bar shows them."""
    text = bpy.context.scene.statistics(bpy.context.view_layer)
    return next((part.strip() for part in text.split("|") if "Memory" in part), "n/a")


def run(kind, total, scene):
    """The cycles, one per iteration (a window's timer runs each in its own call, so that
    Blender's event loop handles what the cycle queued before the next). Returns the exit
    status through StopIteration."""
    from tussock import native
    lib = native.require()
    marks = {}
    t0 = time.monotonic()
    for i in range(1, total + 1):
        cycle(kind, scene)
        if i in (100, total) or i % 250 == 0:
            gc.collect()
            trim()
            marks[i] = (rss_bytes(), lib.allocated_bytes(), counts(), heap_in_use(),
                        sys.getallocatedblocks())
            c = marks[i][2]
            print(f"cycle {i}: resident {marks[i][0] / 2**20:.1f} MiB, {ALLOCATOR} heap in use "
                  f"{mib(marks[i][3])}, Blender's {blender_stats()}, native "
                  f"{marks[i][1] / 2**20:.2f} MiB, Python blocks {marks[i][4]}, "
                  f"objects/meshes/collections {(c['objects'], c['meshes'], c['collections'])}, "
                  f"{time.monotonic() - t0:.0f} s", flush=True)
        yield
    r100, rn = marks[100][0], marks[total][0]
    print(f"LEAKS kind={kind} cycles={total} blender={bpy.app.version_string} "
          f"{'background' if bpy.app.background else 'window'} "
          f"rss100={r100 / 2**20:.1f}MiB rss{total}={rn / 2**20:.1f}MiB "
          f"growth={(rn - r100) / r100 * 100:+.2f}% allocator={ALLOCATOR} "
          f"heap100={mib(marks[100][3])} heap{total}={mib(marks[total][3])} "
          f"native100={marks[100][1]} "
          f"native{total}={marks[total][1]} pyblocks100={marks[100][4]} "
          f"pyblocks{total}={marks[total][4]} "
          f"counts_changed={differing(marks[100][2], marks[total][2]) or 'none'} "
          f"secs={time.monotonic() - t0:.0f}", flush=True)
    # issue 42's bound: within 5 % of the resident memory after 100 cycles; and what Tussock
    # itself holds (native bytes, data-blocks) exactly as it was
    bad = []
    if rn > r100 * 1.05:
        bad.append(f"resident memory grew {(rn - r100) / r100:.1%} (more than 5 %)")
    if marks[total][1] != marks[100][1]:
        bad.append(f"native bytes in use {marks[100][1]} -> {marks[total][1]}")
    if marks[total][2] != marks[100][2]:
        bad.append(f"data-blocks (cycle 100, last) {differing(marks[100][2], marks[total][2])}")
    for b in bad:
        print(f"{'CONTROL' if kind == 'objects' else 'LEAK'}: {kind}: {b}", flush=True)
    return 1 if bad and kind != "objects" else 0


def finish(status):
    sys.stdout.flush()
    os._exit(status)


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    kind = argv[0] if argv else "meadow"
    total = int(argv[1]) if len(argv) > 1 else 1000
    if kind not in ("meadow", "tree", "objects") or total < 100:
        raise SystemExit("usage: leak_cycles.py -- meadow|tree|objects [CYCLES >= 100]")
    if bpy.app.background:
        cycles = run(kind, total, setup(kind))
        try:
            while True:
                next(cycles)
        except StopIteration as done:
            finish(done.value)
    cycles = None

    def step():
        nonlocal cycles
        try:
            if cycles is None:  # in the event loop, where the window's context is whole
                cycles = run(kind, total, setup(kind))
            next(cycles)
        except StopIteration as done:
            finish(done.value)
        except Exception:
            import traceback
            traceback.print_exc()
            finish(2)
        return 0.0

    bpy.app.timers.register(step, first_interval=1.0)


main()
