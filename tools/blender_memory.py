"""Measures what Blender itself holds for what Tussock builds, to set the per-element costs
of addon/budget.py: the process's resident memory (VmRSS, /proc/self/status) before and
after Blender gets a tree's mesh or a meadow's instances, with the depsgraph evaluated as
the viewport evaluates it, and the peak (VmHWM, reset through /proc/self/clear_refs) of the
native work and of a small render.

One case per Blender process (a heap that earlier cases grew would hide the cost), with the
add-on enabled as blender_tests/run.py sets it up (tools/blender_env.BlenderUser):
  in background (blender -b --factory-startup --python tools/blender_memory.py -- CASE):
    tree weeping_willow 1        the native work, then Blender's mesh, evaluated
    meadow 100 [CYCLES]          a 100 m meadow of 0.25 m tiles, then a 32x32 render
  in a window (xvfb-run blender --factory-startup --python ... -- CASE; the operator as the
  artist runs it, with its undo step, measured after the viewport has drawn the result):
    window_tree weeping_willow 1
    window_meadow 100
Prints one line starting with MEASURE; addon/budget.py has the numbers it gave."""

import gc
import os
import sys
import time

import bpy


def status(key):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    return 0


def reset_peak():
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")


def settle():
    gc.collect()
    return status("VmRSS")


def tree(preset, smooth):
    from tussock.trees import build, params, presets
    obj = bpy.data.objects.new("Tree", bpy.data.meshes.new("Tree"))
    s = obj.tussock_tree
    params.from_dict(s.params, presets.load(preset))
    s.smooth_levels = smooth
    r0 = settle()
    reset_peak()
    t = time.time()
    data = build.compute(s)
    t_native = time.time() - t
    native_peak = status("VmHWM") - r0
    r1 = settle()
    bpy.context.collection.objects.link(obj)
    reset_peak()
    t = time.time()
    build.write_posed(obj, data, bpy.context.scene, 1, obj.matrix_basis.copy(),
                      by_operator=True)
    s.is_tree = True
    bpy.context.view_layer.update()
    t_blender = time.time() - t
    r2 = settle()
    m = obj.data
    print(f"MEASURE tree {preset} smooth={smooth} V={len(m.vertices)} E={len(m.edges)} "
          f"F={len(m.polygons)} L={len(m.loops)} native_held={r1 - r0} "
          f"native_peak={native_peak} blender_held={r2 - r1} "
          f"blender_peak={status('VmHWM') - r1} t_native={t_native:.2f} "
          f"t_blender={t_blender:.2f}")


def meadow(side, render):
    for obj in list(bpy.data.objects):  # no ground selected: a plane of side x side
        bpy.data.objects.remove(obj)
    r0 = settle()
    t = time.time()
    bpy.ops.tussock.add_meadow(size=(side, side), tile_size=0.25, blades_per_tile=64,
                               density="UNIFORM", chunk_blades=16)
    obj = bpy.context.active_object
    r1 = settle()
    bpy.context.view_layer.update()
    r2 = settle()
    n = obj["tussock_instances"]
    line = (f"MEASURE meadow side={side} blades={obj['tussock_blades']} instances={n} "
            f"points={len(obj.data.vertices)} op_held={r1 - r0} eval_held={r2 - r1} "
            f"t={time.time() - t:.2f}")
    if render:
        scene = bpy.context.scene
        cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
        scene.collection.objects.link(cam)
        cam.location = (0.0, -side, side * 0.5)
        cam.rotation_euler = (1.1, 0.0, 0.0)
        scene.camera = cam
        scene.render.engine = render
        if render == "CYCLES":
            scene.cycles.samples = 1
            scene.cycles.use_denoising = False
        scene.render.resolution_x = scene.render.resolution_y = 32
        scene.render.filepath = f"/tmp/tsk_memory_{os.getpid()}.png"
        reset_peak()
        t = time.time()
        bpy.ops.render.render(write_still=True)
        line += (f" render={render} render_peak={status('VmHWM') - r2} "
                 f"t_render={time.time() - t:.2f}")
    print(line)


def window_tree(preset, smooth):
    """In a window (xvfb): the operator as the artist runs it (undo step, viewport drawing
    of the new mesh), measured once the window has drawn it."""
    state = {}

    def step():
        if "r0" not in state:
            bpy.ops.object.select_all(action="SELECT")
            bpy.ops.object.delete()
            state["r0"] = settle()
            reset_peak()
            win = bpy.context.window_manager.windows[0]
            area = next(a for a in win.screen.areas if a.type == "VIEW_3D")
            with bpy.context.temp_override(window=win, area=area):
                state["t"] = time.time()
                bpy.ops.tussock.add_tree("EXEC_DEFAULT", preset=preset, smooth_levels=smooth)
                state["t"] = time.time() - state["t"]
            return 3.0  # let the viewport draw it
        m = bpy.context.active_object.data
        r = settle()
        print(f"MEASURE window_tree {preset} smooth={smooth} V={len(m.vertices)} "
              f"E={len(m.edges)} F={len(m.polygons)} L={len(m.loops)} "
              f"held={r - state['r0']} peak={status('VmHWM') - state['r0']} "
              f"t_op={state['t']:.2f}")
        sys.stdout.flush()
        os._exit(0)

    bpy.app.timers.register(step, first_interval=2.0)


def window_meadow(side):
    """In a window: add_meadow as the artist runs it, measured once the viewport has drawn
    its instances (a fraction `display` of them)."""
    state = {}

    def step():
        if "r0" not in state:
            for obj in list(bpy.data.objects):
                bpy.data.objects.remove(obj)
            state["r0"] = settle()
            reset_peak()
            win = bpy.context.window_manager.windows[0]
            area = next(a for a in win.screen.areas if a.type == "VIEW_3D")
            with bpy.context.temp_override(window=win, area=area):
                state["t"] = time.time()
                bpy.ops.tussock.add_meadow("EXEC_DEFAULT", size=(side, side), tile_size=0.25,
                                           blades_per_tile=64, density="UNIFORM",
                                           chunk_blades=16)
                state["t"] = time.time() - state["t"]
                area.spaces.active.region_3d.view_distance = side
            return 5.0  # let the viewport draw it
        obj = bpy.context.active_object
        r = settle()
        print(f"MEASURE window_meadow side={side} blades={obj['tussock_blades']} "
              f"instances={obj['tussock_instances']} held={r - state['r0']} "
              f"peak={status('VmHWM') - state['r0']} t_op={state['t']:.2f}")
        sys.stdout.flush()
        os._exit(0)

    bpy.app.timers.register(step, first_interval=2.0)


def main():
    import addon_utils
    addon_utils.enable("tussock", default_set=True)
    args = sys.argv[sys.argv.index("--") + 1:]
    if args[0] == "window_meadow":
        window_meadow(float(args[1]))
        return
    if args[0] == "window_tree":
        window_tree(args[1], int(args[2]))
        return
    if args[0] == "tree":
        tree(args[1], int(args[2]))
    else:
        meadow(float(args[1]), args[2] if len(args) > 2 else "")
    sys.stdout.flush()
    os._exit(0)


main()
