"""Test harness for scripts that run inside `blender -b --factory-startup`: a @test
decorator, a name filter, and the closing line "N passed, N failed". Imported by every
test_*.py in this folder; run.py starts one Blender per file."""

import inspect
import os
import sys
import time
import traceback
import types

_tests = []

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test(fn):
    _tests.append(fn)
    return fn


def args():
    """Arguments after '--' on Blender's command line."""
    return sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def enable_addon(name="tussock"):
    import addon_utils
    mod = addon_utils.enable(name, default_set=True, handle_error=_raise)
    if mod is None:
        raise RuntimeError(f"add-on {name} did not enable")
    return mod


def disable_addon(name="tussock"):
    import addon_utils
    addon_utils.disable(name, default_set=True, handle_error=_raise)


def _raise(exc):
    raise exc


def vertices_of(obj):
    """obj's mesh vertex positions, float32, 3 per vertex."""
    import numpy as np
    co = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co)
    return co


def check_near(a, b, tol, what=""):
    if not abs(a - b) <= tol:
        raise AssertionError(f"{what} |{a} - {b}| = {abs(a - b)} > {tol}")


def _rna_digest(ptr, depth=0):
    """repr of a property group's values (nested groups and collections included; ID
    pointers by name), so that settings an operator might change are in the fingerprint."""
    if ptr is None or depth > 4:
        return "None"
    parts = []
    for prop in ptr.bl_rna.properties:
        key = prop.identifier
        if key == "rna_type":
            continue
        try:
            value = getattr(ptr, key)
        except Exception:  # noqa: BLE001 - a property that cannot be read right now
            continue
        if prop.type == "POINTER":
            if value is None:
                parts.append(f"{key}=None")
            elif hasattr(value, "users"):  # an ID datablock
                parts.append(f"{key}=ID:{value.name}")
            else:
                parts.append(f"{key}={{{_rna_digest(value, depth + 1)}}}")
        elif prop.type == "COLLECTION":
            parts.append(f"{key}=[{';'.join(_rna_digest(v, depth + 1) for v in value)}]")
        elif getattr(prop, "is_array", False) or getattr(prop, "array_length", 0):
            parts.append(f"{key}={tuple(value)!r}")
        else:
            parts.append(f"{key}={value!r}")
    return ",".join(parts)


def _tussock_groups(idb):
    """The Tussock property groups registered on a datablock (tussock_tree, ...)."""
    for prop in idb.bl_rna.properties:
        if prop.identifier.startswith("tussock_") and prop.type == "POINTER":
            yield prop.identifier, getattr(idb, prop.identifier)


def scene_fingerprint():
    """A digest of every datablock and its key properties, to check that a cancelled
    operator left the file exactly as it was."""
    import hashlib
    return hashlib.sha256("\n".join(scene_description()).encode()).hexdigest()


def scene_description():
    """The lines that scene_fingerprint digests (printed when a check fails): names and users
    of all datablocks; objects' transforms, parents, custom properties, modifiers and Tussock
    settings; meshes' sizes and a digest of their vertex positions; images' sizes and custom
    properties; scenes' objects, frame, cursor and Tussock settings (wind, capture)."""
    import hashlib
    import bpy
    import numpy as np
    lines = []

    class _Lines:
        def update(self, b):
            lines.append(b.decode())
    h = _Lines()
    for attr in ("objects", "meshes", "collections", "materials", "images", "node_groups",
                 "textures", "cameras", "lights", "curves", "worlds", "actions"):
        for idb in getattr(bpy.data, attr):
            h.update(f"{attr}:{idb.name}:{idb.users}".encode())
            if attr == "objects":
                h.update(repr([tuple(r) for r in idb.matrix_world]).encode())
                # custom properties; not the storage of registered property groups, which
                # appears in keys() as soon as anything (this function too) reads a group
                rna = {p.identifier for p in idb.bl_rna.properties}
                keys = sorted(k for k in idb.keys() if k not in rna)
                h.update(repr(keys).encode())
                h.update(repr([(k, repr(idb[k])) for k in keys]).encode())
                h.update(repr([m.name for m in idb.modifiers]).encode())
                h.update(repr((idb.parent.name if idb.parent else None,
                               idb.data.name if idb.data else None)).encode())
                for name, group in _tussock_groups(idb):
                    h.update(f"{name}:{_rna_digest(group)}".encode())
            elif attr == "meshes":
                h.update(f"{len(idb.vertices)}:{len(idb.polygons)}:{len(idb.attributes)}".encode())
                co = np.empty(len(idb.vertices) * 3, np.float32)
                idb.vertices.foreach_get("co", co)
                h.update(f"co:{hashlib.sha256(co.tobytes()).hexdigest()}".encode())
            elif attr == "collections":
                h.update(repr(sorted(o.name for o in idb.objects)).encode())
            elif attr == "images":
                h.update(repr((tuple(idb.size), sorted(idb.keys()))).encode())
    for scene in bpy.data.scenes:
        h.update(repr(sorted(o.name for o in scene.objects)).encode())
        h.update(repr(sorted(c.name for c in scene.collection.children)).encode())
        h.update(repr((scene.frame_current, tuple(scene.cursor.location))).encode())
        for name, group in _tussock_groups(scene):
            h.update(f"{name}:{_rna_digest(group)}".encode())
    return lines


def expect_cancel(op, needle, **kwargs):
    """Runs an operator that must fail: it reports an error containing `needle`, returns
    CANCELLED (raised as RuntimeError in background) and leaves the scene unchanged."""
    before = scene_description()
    try:
        result = op(**kwargs)
    except RuntimeError as exc:
        msg = str(exc)
        assert needle in msg, f"error {msg!r} lacks {needle!r}"
    else:
        raise AssertionError(f"{op} with {kwargs} returned {result}, expected an error")
    after = scene_description()
    if before != after:
        gone = [x[:300] for x in before if x not in after][:3]
        new = [x[:300] for x in after if x not in before][:3]
        raise AssertionError(f"{op} with {kwargs} changed the scene: before {gone}, after {new}")


def main():
    flt = os.environ.get("TSK_TEST_FILTER", "")
    passed = failed = 0
    for fn in _tests:
        if flt and flt not in fn.__name__:
            continue
        try:
            fn()
        except Exception:
            failed += 1
            print(f"FAIL {fn.__name__}")
            traceback.print_exc()
        else:
            passed += 1
            print(f"ok   {fn.__name__}")
        sys.stdout.flush()
    print(f"{passed} passed, {failed} failed")
    sys.stdout.flush()
    # Leave without running Blender's exit path with half-registered state.
    os._exit(0 if failed == 0 else 1)


# ---- tests in a real window (test_window_*.py) ----------------------------------------------

_window_counts = {"passed": 0, "failed": 0}


def report(name, error=None):
    """Records one check of a window test: prints 'ok   name', or 'FAIL name' and why."""
    if error:
        _window_counts["failed"] += 1
        print(f"FAIL {name}\n{str(error).rstrip()}")
    else:
        _window_counts["passed"] += 1
        print(f"ok   {name}")
    sys.stdout.flush()


def window_main(steps, first_interval=0.5):
    """Runs a window test. Blender runs test_window_*.py during its start-up, before the
    window's event loop; this drives the generator `steps` from a bpy.app.timers callback
    once the loop runs. Each value that `steps` yields is how many seconds the event loop
    runs before `steps` goes on (modal operators, timers and simulated events get their
    turn). An exception out of `steps` is one failure and ends the run. At the end prints
    "N passed, N failed" and leaves with exit code 0 or 1, as main() does."""
    import bpy
    bpy.context.preferences.view.show_splash = False  # the splash would take every event

    def tick():
        try:
            delay = next(steps)
        except StopIteration:
            delay = None
        except Exception:  # noqa: BLE001 - reported as a failure, then the run ends
            report("window test ran to its end", traceback.format_exc())
            delay = None
        if delay is not None:
            return max(float(delay), 0.01)
        counts = _window_counts
        print(f"{counts['passed']} passed, {counts['failed']} failed")
        sys.stdout.flush()
        os._exit(0 if counts["failed"] == 0 else 1)

    bpy.app.timers.register(tick, first_interval=first_interval, persistent=True)

# ---- real-window tests: where things are, and waiting for the event loop ------------------
# (bpy is imported inside: the harness is also imported where Blender is not)


def window():
    return _bpy().context.window_manager.windows[0]


def area_of(space_type="VIEW_3D"):
    """The largest area of this editor in the window (the factory layout has one 3D view)."""
    areas = [a for a in window().screen.areas if a.type == space_type]
    return max(areas, key=lambda a: a.width * a.height) if areas else None


def region_of(area, region_type):
    return next((r for r in area.regions if r.type == region_type), None) if area else None


def override(space_type="VIEW_3D", region_type="WINDOW"):
    """The context of one region of the window: operators and draws run as if there."""
    area = area_of(space_type)
    return _bpy().context.temp_override(window=window(), area=area,
                                        region=region_of(area, region_type))


def best_of(fn, repeats=5):
    """The shortest of `repeats` timings of fn() in seconds (the least disturbed by other
    work on the machine): the time bounds of tests compare these."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def wait_until(done, timeout, step=0.2):
    """Lets the event loop run until done() or timeout seconds; returns done()."""
    end = time.monotonic() + timeout
    while not done() and time.monotonic() < end:
        yield step
    return done()


def running(idname):
    """Whether a modal operator runs in the window: True/False where Blender lists them
    (Window.modal_operators, 4.x and 5.x), None where it cannot say (3.4)."""
    win = window()
    if not hasattr(win, "modal_operators"):
        return None
    short = idname.split(".")[-1]
    return any(short in op.bl_idname.lower() for op in win.modal_operators)


def select_only(obj):
    for o in _bpy().context.view_layer.objects:
        o.select_set(False)
    if obj is not None:
        obj.select_set(True)
    _bpy().context.view_layer.objects.active = obj


def empty_scene(frames):
    """Factory settings with Tussock on and nothing of an earlier test cached (wind, trees,
    meadow simulations): an empty scene of frames 1..frames."""
    bpy = _bpy()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    enable_addon()
    from tussock.meadow import simulate
    from tussock.trees import build as tree_build
    from tussock.wind import runtime
    runtime.clear()
    tree_build.forget()
    simulate.forget()
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, frames
    return scene


def select_objects(objs):
    """Selects exactly `objs` (a list), the first of them active; an empty list leaves the
    active object as it is."""
    for o in _bpy().context.scene.objects:
        o.select_set(False)
    for o in objs:
        o.select_set(True)
    if objs:
        _bpy().context.view_layer.objects.active = objs[0]


def meadow_crossed_by_ball(frames):
    """The suite's small simulated meadow: a 2 m plane of 32-blade tiles (every blade shown)
    that a ball of radius 0.2 m, keyframed from frame 1 to `frames`, crosses; the ball is the
    collection "Colliders". Returns (meadow, ball)."""
    bpy = _bpy()
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    assert bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=32, density="UNIFORM",
                                      display=1.0) == {"FINISHED"}
    meadow = bpy.context.active_object
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.2, location=(-0.9, -0.1, 0.15))
    ball = bpy.context.active_object
    ball.keyframe_insert("location", frame=1)
    ball.location = (0.7, 0.1, 0.15)
    ball.keyframe_insert("location", frame=frames)
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(ball)
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    return meadow, ball


# ---- what an add-on draws (the panel test draws all of it; the soak tester, tools/soak_blender.py,
# draws the panels of each object it has made) -------------------------------------------

def _subclasses(base):
    seen = []
    todo = list(base.__subclasses__())
    while todo:
        cls = todo.pop()
        if cls not in seen:
            seen.append(cls)
            todo.extend(cls.__subclasses__())
    return seen


def _in(module, package):
    return module == package or module.startswith(package + ".")


def _ours(cls, package):
    return getattr(cls, "is_registered", False) and (
        _in(cls.__module__, package)
        or getattr(cls, "bl_idname", "").startswith("TUSSOCK_")
        or getattr(cls, "bl_category", "") == "Tussock")


def ui_of(package):
    """The add-on's panels (parents before children), menus, and the draw functions it
    appended to other classes' draw (as (host class, function))."""
    found = [c for c in _subclasses(_bpy().types.Panel) if _ours(c, package)]

    def level(cls):
        parent = getattr(cls, "bl_parent_id", None)
        up = next((p for p in found if p.bl_idname == parent), None)
        return 0 if up is None else level(up) + 1
    panels = sorted(found, key=lambda c: (level(c), c.bl_idname))
    menus = sorted((c for c in _subclasses(_bpy().types.Menu) if _ours(c, package)),
                   key=lambda c: c.bl_idname)
    appended = []
    for name in dir(_bpy().types):
        host = getattr(_bpy().types, name, None)
        funcs = getattr(getattr(host, "draw", None), "_draw_funcs", None) or ()
        for fn in funcs:
            if _in(getattr(fn, "__module__", None) or "", package):
                appended.append((host, fn))
    return types.SimpleNamespace(panels=panels, menus=menus, appended=appended)


class DrawSelf:
    """What a panel's or menu's draw gets as `self` when this test draws it: the class's
    attributes (methods bound to it) and a real UILayout."""

    is_popover = False

    def __init__(self, cls, layout):
        self._cls, self.layout = cls, layout

    def __getattr__(self, name):
        raw = inspect.getattr_static(self._cls, name)
        if isinstance(raw, types.FunctionType):
            return types.MethodType(raw, self)
        return getattr(self._cls, name)


def defines(cls, name):
    """The function `name` that the class (not bpy's base class) defines, or None."""
    for klass in cls.__mro__:
        if klass.__module__.lstrip("_").startswith("bpy"):  # bpy_types, 5.x's _bpy_types
            return None
        if name in klass.__dict__:
            return klass.__dict__[name]
    return None


def _bpy():
    import bpy
    return bpy
