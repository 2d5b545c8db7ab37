"""The inside of the soak tester (issue 42): runs in Blender and does what an artist might, at
random — adds meadows, trees, wind sources and pictures, sets Tussock settings, plays and
scrubs, undoes, renames, duplicates, deletes, joins, bakes, saves and reverts, renders, turns
the add-on off and on — and checks invariants after every step. tools/soak.py starts it, and
shrinks a failing run by replaying parts of it.

usage: blender -b --factory-startup --python tools/soak_blender.py -- --journal FILE
           (--seed S [--steps N] [--minutes M] | --replay FILE) [--workdir DIR]
           [--only NAME,...] [--skip NAME,...] [--max-rss-mb MB] [--hard-rss-mb MB]
(in a real window: tools/blender_env.command(..., window=True); steps then run from a timer
inside the event loop, panels are drawn, and modal bakes and captures are started and
cancelled with Esc).

Every step is recorded as a concrete descriptor (its name and arguments: object names,
values, frames), so that a replay does exactly the same without the random generator; a
step whose objects are gone in a replay is skipped. The journal gets one JSON line per step,
written and flushed before it runs ({"i", "step"}), and one after ({"i", "result", "secs"},
with "kind" and "detail" when an invariant broke). What Blender and the add-on print goes to
JOURNAL.log and, step by step, to the real output. Exit status: 0 when every step kept
every invariant, FAIL_EXIT when one broke (the run stops there), anything else is a crash.

Planted faults, for the tester's own test (TSK_SOAK_PLANT): `raise` adds a step running an
operator that raises in 1 of 50 calls, decided by its recorded argument; `leak` adds a frame
handler that leaves a new mesh datablock behind on every frame change; `hoard` one that keeps
64 MB more of memory that belongs to no data-block on every frame change; `unfreed` adds a
step that, in 1 call of 50, keeps a BMesh that nothing frees (its Python object's count of
references raised by one): Blender's blocks left at exit, which only --debug-memory sees."""

import contextlib
import ctypes
import json
import os
import random
import re
import sys
import time
import traceback

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "blender_tests"))
sys.path.insert(0, os.path.join(REPO, "tools"))
import harness  # noqa: E402
from memory_probe import heap_in_use, rss_bytes, trim  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

FAIL_EXIT = 3
SAMPLES = os.path.join(REPO, "samples")
DEPTH = os.path.join(SAMPLES, "blades", "depth_{:04d}.png")
PICTURE = os.path.join(SAMPLES, "picture")
FRAME_END = 6  # the scene's range is 1..FRAME_END: bakes stay short
PLANT = os.environ.get("TSK_SOAK_PLANT", "")

# What, printed during a step, is a failure: a Python traceback (an exception out of an
# operator, a handler, a timer, a draw or an update callback), an error the add-on turned
# into its "failed unexpectedly" message, Blender's warnings about a wrong property or
# operator in a layout, and what a sanitizer prints.
PROBLEM = re.compile(r"Traceback \(most recent call last\)|failed unexpectedly|"
                     r"rna_uiItem|uiItemFullO|unknown operator|ERROR: AddressSanitizer|"
                     r"runtime error:|Exception ignored")

NAMES = ("Soak", "Meadow", "Tree", "Wind Source", "Meadow ground", "grass é", "Tree.001",
         "a" * 60, "Cube")


class Broken(Exception):
    """An invariant that a step broke: `kind` names it (the shrinker keeps runs that break
    the same one), the message says how."""

    def __init__(self, kind, detail):
        super().__init__(f"{kind}: {detail}")
        self.kind, self.detail = kind, detail


class Skip(Exception):
    """A step whose preconditions do not hold (in a replay: its objects are gone)."""


# ---- what is printed: every step's output, read back and passed on ---------------------------

_libc = ctypes.CDLL(None)


class Output:
    """Sends fds 1 and 2 (Python's and Blender's C output alike) into a log file for the
    whole run; take() returns what was printed since the last call and copies it to the
    real stdout, so that each step's output is checked and still seen."""

    def __init__(self, path):
        self.path = path
        self.offset = 0
        self.real = os.dup(1)
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND | os.O_TRUNC, 0o644)
        self._flush()
        os.dup2(fd, 1)
        os.dup2(fd, 2)
        os.close(fd)

    @staticmethod
    def _flush():
        sys.stdout.flush()
        sys.stderr.flush()
        _libc.fflush(None)

    def take(self):
        self._flush()
        with open(self.path, "rb") as f:
            f.seek(self.offset)
            data = f.read()
        self.offset += len(data)
        if data:
            os.write(self.real, data)
        return data.decode(errors="replace")

    def say(self, text):
        """A line of the tester's own, on the real output only."""
        self.take()
        os.write(self.real, (text + "\n").encode())


_raised = []  # exceptions that reached sys.excepthook (handlers, timers, callbacks)


def _excepthook(kind, value, tb):
    _raised.append("".join(traceback.format_exception(kind, value, tb)))
    sys.__excepthook__(kind, value, tb)


# ---- the scene ---------------------------------------------------------------------------------

def scene():
    return bpy.context.scene


def addon_on():
    return hasattr(bpy.types.Object, "tussock_meadow")


def tussock_kind(obj):
    """'meadow', 'tree', 'wind' or None (read through custom properties as well, so that it
    answers while the add-on is disabled)."""
    if obj.get("tussock_meadow_object"):
        return "meadow"
    if not addon_on():
        return None
    if obj.tussock_tree.is_tree:
        return "tree"
    if obj.tussock_wind_source.is_source:
        return "wind"
    return None


def objects(pred=None):
    return sorted(o.name for o in scene().objects if pred is None or pred(o))


def get_object(name):
    obj = scene().objects.get(name)
    if obj is None:
        raise Skip(f"no object {name!r}")
    return obj


class Context:
    """Where operators run: as the script (background), or in the window's 3D view."""

    window = False

    def __call__(self):
        if self.window and bpy.context.window_manager.windows:
            return harness.override()
        return contextlib.nullcontext()


CTX = Context()


def select(names, active=None):
    objs = [get_object(n) for n in names]
    if bpy.context.mode != "OBJECT":
        with CTX():
            bpy.ops.object.mode_set(mode="OBJECT")
    harness.select_objects(objs)
    if active is not None:
        bpy.context.view_layer.objects.active = get_object(active)
    return objs


def stock(op, *args, **kw):
    """A stock operator: its refusal (RuntimeError with its report) is the artist's problem,
    not a failure; a Python traceback in it is one (a Tussock handler raised inside)."""
    try:
        with CTX():
            return op(*args, **kw)
    except RuntimeError as exc:
        if "Traceback" in str(exc):
            raise Broken("python-error", f"{op}: {exc}")
        return {"REFUSED: " + str(exc).strip()[:200]}


def tussock(name, *args, **kw):
    """A Tussock operator: when it cancels or reports an error, the scene must be as before;
    an exception that escaped it (a traceback in its error) is a failure."""
    if not addon_on():
        raise Skip("the add-on is disabled")
    op = getattr(bpy.ops.tussock, name)
    before = description()
    try:
        with CTX():
            result = op(*args, **kw)
        error = ""
    except RuntimeError as exc:
        result, error = {"CANCELLED"}, str(exc)
    if "Traceback" in error or "failed unexpectedly" in error:
        raise Broken("python-error", f"tussock.{name}{kw}: {error}")
    if "CANCELLED" in result:
        after = description()
        if after != before:
            raise Broken("fingerprint", f"tussock.{name}{kw} cancelled ({error.strip()}) but "
                                        f"changed the scene:\n{changes(before, after)}")
    return {result.pop() + (f": {error.strip()[:200]}" if error else "")}


# A panel's status line (last_error) is not the artist's data: frame handlers rewrite it
# whenever frames play (e.g. while a bake reads a meadow's colliders before it fails).
_STATUS = re.compile(r"last_error=('(?:[^'\\]|\\.)*'|\"(?:[^\"\\]|\\.)*\")")


def description():
    """harness.scene_description() without the panels' status lines, with every keyframed
    Tussock setting at its F-curve's value of the current frame. A value set by hand on a
    keyframed setting lasts only until the next frame change (Blender writes the F-curve's
    value back): an operator that plays frames (a bake reads a meadow's colliders so) and
    puts the current frame back changes it as any frame change does, and so does Blender 5.2
    when such an operator is cancelled."""
    with animated_at_current_frame():
        return [_STATUS.sub("last_error=...", line) for line in harness.scene_description()]


def _fcurves(anim_data):
    action = anim_data.action if anim_data is not None else None
    if action is None:
        return ()
    if hasattr(action, "fcurves"):  # 3.4-4.5
        return action.fcurves
    from bpy_extras import anim_utils  # 5.0+: slotted actions
    bag = anim_utils.action_get_channelbag_for_slot(action, anim_data.action_slot)
    return bag.fcurves if bag is not None else ()


@contextlib.contextmanager
def animated_at_current_frame():
    """Sets each keyframed Tussock number or switch to its F-curve's value at the current
    frame (as Blender's frame change would, clamped to the property's limits) and puts the
    values back afterwards. Written as ID properties, which runs no update callback: the
    scene is not recomputed, only described."""
    frame = scene().frame_current
    saved = []
    for idb in list(bpy.data.scenes) + list(bpy.data.objects):
        for fc in _fcurves(idb.animation_data):
            path = fc.data_path
            if not path.startswith("tussock_") or "." not in path:
                continue
            owner_path, name = path.rsplit(".", 1)
            try:
                owner = idb.path_resolve(owner_path)
                prop = owner.bl_rna.properties[name]
            except (ValueError, KeyError):
                continue
            if prop.type not in ("FLOAT", "INT", "BOOLEAN") or prop.is_readonly:
                continue
            value = min(max(fc.evaluate(frame), getattr(prop, "hard_min", 0)),
                        getattr(prop, "hard_max", 1))
            value = float(value) if prop.type == "FLOAT" else int(round(value))
            old = getattr(owner, name)
            if getattr(prop, "is_array", False) or getattr(prop, "array_length", 0):
                new = list(old)
                new[fc.array_index] = value
                saved.append((owner, name, list(old)))
                owner[name] = new
            else:
                saved.append((owner, name, old))
                owner[name] = value
    try:
        yield
    finally:
        for owner, name, old in reversed(saved):
            owner[name] = old


def _blocks(lines):
    """A description's lines grouped by the datablock each belongs to (the block starts at
    its `kind:name:users` line): {(kind, name): [lines]}, so two descriptions compare by
    datablock and not by position."""
    blocks, key = {}, ("scene", "")
    for line in lines:
        head = line.split(":", 2)
        if len(head) == 3 and head[0] in ("objects", "meshes", "collections", "materials",
                                          "images", "node_groups", "textures", "cameras",
                                          "lights", "curves", "worlds", "actions"):
            key = (head[0], head[1])
        blocks.setdefault(key, []).append(line)
    return blocks


def changes(before, after, limit=6):
    """What differs between two scene descriptions: for each datablock, the lines that
    differ, each cut to where they differ."""
    a, b = _blocks(before), _blocks(after)
    out = [f"  only before: {k[0]} {k[1]!r}" for k in a if k not in b]
    out += [f"  only after: {k[0]} {k[1]!r}" for k in b if k not in a]
    for k in a:
        if k not in b or a[k] == b[k]:
            continue
        for i, (x, y) in enumerate(zip(a[k] + [""] * len(b[k]), b[k] + [""] * len(a[k]))):
            if x != y:
                at = next((n for n, (p, q) in enumerate(zip(x, y)) if p != q), min(len(x), len(y)))
                lo = max(0, at - 120)
                out.append(f"  {k[0]} {k[1]!r}, line {i}:\n    before: ...{x[lo:at + 120]}\n"
                           f"    after:  ...{y[lo:at + 120]}")
                break
    if not out and before != after:
        out.append("  the same datablocks, listed in another order")
    return "\n".join(out[:limit])


# ---- steps: each has gen(rng) -> args (None when it cannot run now) and run(args) ------------

STEPS = {}


def step(weight, window_only=False, needs_addon=False):
    def wrap(cls):
        cls.name = cls.__name__
        cls.weight, cls.window_only, cls.needs_addon = weight, window_only, needs_addon
        STEPS[cls.name] = cls
        return cls
    return wrap


def rnd_float(rng, lo, hi):
    return round(rng.uniform(lo, hi), 4)


@step(6, needs_addon=True)
class add_meadow:
    def gen(rng):
        ground = None
        meshes = objects(lambda o: o.type == "MESH" and not tussock_kind(o))
        if meshes and rng.random() < 0.3:
            ground = rng.choice(meshes)
        a = dict(size=[rnd_float(rng, 0.5, 4.0), rnd_float(rng, 0.5, 4.0)],
                 blades_per_tile=rng.choice([4, 16, 32]), patch_blades=rng.choice([256, 1024]),
                 chunk_blades=16, density=rng.choice(["UNIFORM", "NOISE", "IMAGE"]),
                 seed=rng.randrange(100), ground=ground,
                 models=rng.random() < 0.3 and bpy.data.collections.get("Tussock Blades")
                 is not None, simulate=rng.random() < 0.5)
        return a

    def run(a):
        if a["ground"]:
            select([a["ground"]], a["ground"])
        else:
            select([])
            bpy.context.view_layer.objects.active = None
        density = "NOISE" if a["density"] == "IMAGE" else a["density"]
        r = tussock("add_meadow", size=a["size"], blades_per_tile=a["blades_per_tile"],
                    patch_blades=a["patch_blades"], chunk_blades=a["chunk_blades"],
                    density=density, seed=a["seed"], tile_size=0.25)
        obj = bpy.context.view_layer.objects.active
        if "FINISHED" not in next(iter(r)) or obj is None or tussock_kind(obj) != "meadow":
            return r
        s = obj.tussock_meadow
        if a["density"] == "IMAGE":
            s.density_image = density_image(a["seed"])
            s.density = "IMAGE"
        if a["models"] and bpy.data.collections.get("Tussock Blades"):
            s.models = bpy.data.collections["Tussock Blades"]
        if a["simulate"]:
            coll = bpy.data.collections.get("Soak colliders")
            if coll is None:
                coll = bpy.data.collections.new("Soak colliders")
                scene().collection.children.link(coll)
            s.colliders = coll
            s.use_simulation = True
        return r


def density_image(seed):
    """A 16x16 density image (a smooth blob, different per seed), made with numpy."""
    y, x = np.mgrid[0:16, 0:16].astype(np.float32) / 15.0
    cx, cy = (seed % 7) / 6.0, (seed % 5) / 4.0
    v = np.exp(-((x - cx) ** 2 + (y - cy) ** 2) * 4.0)
    rgba = np.ones((16, 16, 4), np.float32)
    rgba[..., :3] = v[..., None]
    img = bpy.data.images.new(f"soak density {seed}", 16, 16)
    img.pixels.foreach_set(rgba.ravel())
    return img


@step(6, needs_addon=True)
class add_tree:
    def gen(rng):
        from tussock import native
        presets = native.require().tree_presets()
        return dict(preset=rng.choice(presets), seed=rng.randrange(1000),
                    leaves=rng.random() < 0.5, smooth_levels=rng.choice([0, 0, 0, 1]),
                    location=[rnd_float(rng, -8, 8), rnd_float(rng, -8, 8), 0.0])

    def run(a):
        scene().cursor.location = a["location"]
        return tussock("add_tree", preset=a["preset"], seed=a["seed"], leaves=a["leaves"],
                       smooth_levels=a["smooth_levels"])


@step(4, needs_addon=True)
class add_wind_source:
    def gen(rng):
        return dict(strength=rnd_float(rng, 0, 1), radius=rnd_float(rng, 0.01, 4),
                    interval=rng.choice([0.0, rnd_float(rng, 0, 3)]),
                    fluid=rng.random() < 0.5)

    def run(a):
        r = tussock("add_wind_source", strength=a["strength"], radius=a["radius"],
                    interval=a["interval"])
        if a["fluid"]:
            scene().tussock_wind.use_fluid = True
        return r


@step(2, needs_addon=True)
class capture:
    def gen(rng):
        return dict(frame=rng.randrange(1, 9), frames=rng.choice([1, 1, 3]))

    def run(a):
        select([])
        return tussock("capture_blades", source="FILES", filepath=DEPTH.format(a["frame"]),
                       frames=a["frames"])


@step(1, needs_addon=True)
class refine:
    def gen(rng):
        coll = bpy.data.collections.get("Tussock Blades")
        names = [o.name for o in coll.all_objects if o.name in scene().objects] if coll else []
        return dict(blades=sorted(rng.sample(names, min(len(names), 3)))) if names else None

    def run(a):
        select(a["blades"], a["blades"][0])
        return tussock("refine_blades")


@step(2, needs_addon=True)
class animate_picture:
    def gen(rng):
        return dict(layers=rng.choice([["grass"], ["grass", "crown"], ["crown"]]),
                    cell=rng.choice([8, 16, 32]), loop=rng.choice([0, 0, 24]))

    def run(a):
        p = scene().tussock_picture
        p.filepath = os.path.join(PICTURE, "meadow.png")
        p.loop_frames = a["loop"]
        while len(p.layers):
            p.layers.remove(0)
        for name in a["layers"]:
            layer = p.layers.add()
            layer.name = name
            layer.mask_path = os.path.join(PICTURE, f"{name}_mask.png")
            layer.cell_x = layer.cell_y = a["cell"]
        return tussock("animate_picture")


@step(12, needs_addon=True)
class set_prop:
    """A Tussock setting set to a random value within its limits or at one of them, and
    keyframed sometimes."""

    def gen(rng):
        groups = []
        for o in scene().objects:
            kind = tussock_kind(o)
            if kind == "meadow":
                groups.append(("object", o.name, ["tussock_meadow"]))
            elif kind == "tree":
                groups += [("object", o.name, ["tussock_tree"]),
                           ("object", o.name, ["tussock_tree", "params"])]
            elif kind == "wind":
                groups.append(("object", o.name, ["tussock_wind_source"]))
        groups += [("scene", scene().name, ["tussock_wind"])] * 2
        groups.append(("scene", scene().name, ["tussock_capture"]))
        if len(scene().tussock_picture.layers):
            groups += [("scene", scene().name, ["tussock_picture"]),
                       ("scene", scene().name, ["tussock_picture", "layers", 0])]
        for i in range(len(scene().tussock_wind.waves)):
            groups.append(("scene", scene().name, ["tussock_wind", "waves", i]))
        owner, name, path = rng.choice(groups)
        ptr = resolve(owner, name, path)
        props = [p for p in ptr.bl_rna.properties if settable(p)]
        if not props:
            return None
        p = rng.choice(props)
        value = random_value(rng, p)
        if value is None:
            return None
        key = rng.randrange(1, FRAME_END + 1) if rng.random() < 0.25 and p.is_animatable \
            else None
        return dict(owner=owner, name=name, path=path, prop=p.identifier, value=value,
                    keyframe=key)

    def run(a):
        ptr = resolve(a["owner"], a["name"], a["path"])
        if a["prop"] not in ptr.bl_rna.properties:
            raise Skip(f"no property {a['prop']}")
        setattr(ptr, a["prop"], a["value"])
        if a["keyframe"] is not None:
            ptr.keyframe_insert(a["prop"], frame=a["keyframe"])
        return {"SET"}


def resolve(owner, name, path):
    idb = (scene().objects if owner == "object" else bpy.data.scenes).get(name)
    if idb is None:
        raise Skip(f"no {owner} {name!r}")
    ptr = idb
    for part in path:
        try:
            ptr = ptr[part] if isinstance(part, int) else getattr(ptr, part)
        except (AttributeError, IndexError) as exc:
            raise Skip(f"{name}: no {path} ({exc})")
    return ptr


def settable(p):
    return (p.type in ("BOOLEAN", "INT", "FLOAT", "ENUM") and not p.is_readonly
            and not p.is_hidden and not getattr(p, "is_array", False)
            and getattr(p, "array_length", 0) == 0 and p.identifier != "rna_type")


def random_value(rng, p):
    if p.type == "BOOLEAN":
        return rng.random() < 0.5
    if p.type == "ENUM":
        items = [i.identifier for i in p.enum_items]
        return rng.choice(items) if items else None
    mode = rng.choices(("soft", "min", "max"), (8, 1, 1))[0]
    if mode == "min":
        return p.hard_min
    if mode == "max":
        return p.hard_max
    lo, hi = p.soft_min, p.soft_max
    if hi - lo > 1e4:  # unbounded in the UI: a magnitude around its default
        v = p.default * rng.choice((0.1, 0.5, 2.0, 10.0)) + rng.uniform(-1, 1)
        v = min(max(v, lo), hi)
    else:
        v = rng.uniform(lo, hi)
    return int(round(v)) if p.type == "INT" else round(v, 4)


# ---- frames --------------------------------------------------------------------------------------

def frames_leak_check(frames):
    """Plays `frames` in order; a frame change must not leave datablocks behind: the count
    after the first frame is the count after the last."""
    first = None
    for i, f in enumerate(frames):
        scene().frame_set(f)
        if i == 0:
            first = datablocks()
    now = datablocks()
    grown = {k: now[k] - first.get(k, 0) for k in now if now[k] > first.get(k, 0)}
    if grown and len(frames) > 1:
        raise Broken("leak", f"frames {frames} left datablocks behind: {grown}")
    return {"PLAYED"}


def datablocks():
    return {attr: len(getattr(bpy.data, attr)) for attr in
            ("objects", "meshes", "materials", "images", "node_groups", "collections",
             "actions", "textures", "curves")}


@step(6)
class frame_set:
    def gen(rng):
        return dict(frame=rng.randrange(-1, FRAME_END + 4))

    def run(a):
        scene().frame_set(a["frame"])
        return {"FRAME"}


@step(6)
class play:
    def gen(rng):
        start = rng.randrange(1, FRAME_END + 1)
        return dict(frames=list(range(start, start + rng.randrange(2, 8))))

    def run(a):
        return frames_leak_check(a["frames"])


@step(3)
class scrub:
    def gen(rng):
        return dict(frames=[rng.randrange(-2, FRAME_END + 4) for _ in range(rng.randrange(3, 8))])

    def run(a):
        return frames_leak_check(a["frames"])


# ---- undo, objects -------------------------------------------------------------------------------

@step(5)
class undo:
    def gen(rng):
        return dict(times=rng.choice([1, 1, 2, 3]))

    def run(a):
        for _ in range(a["times"]):
            r = stock(bpy.ops.ed.undo)
        return r


@step(3)
class redo:
    def gen(rng):
        return dict(times=rng.choice([1, 1, 2]))

    def run(a):
        for _ in range(a["times"]):
            r = stock(bpy.ops.ed.redo)
        return r


def pick(rng, pred=None):
    names = objects(pred)
    return rng.choice(names) if names else None


@step(3)
class rename:
    def gen(rng):
        obj = pick(rng)
        return dict(obj=obj, to=rng.choice(NAMES) + rng.choice(["", "", " 2", ".001"])) \
            if obj else None

    def run(a):
        get_object(a["obj"]).name = a["to"]
        return {"RENAMED"}


@step(4)
class duplicate:
    def gen(rng):
        obj = pick(rng)
        return dict(obj=obj, linked=rng.random() < 0.5) if obj else None

    def run(a):
        select([a["obj"]], a["obj"])
        return stock(bpy.ops.object.duplicate, linked=a["linked"])


@step(4)
class delete:
    def gen(rng):
        obj = pick(rng)
        return dict(obj=obj) if obj else None

    def run(a):
        select([a["obj"]], a["obj"])
        return stock(bpy.ops.object.delete)


@step(2)
class join:
    def gen(rng):
        names = objects(lambda o: o.type == "MESH")
        if len(names) < 2:
            return None
        return dict(objs=rng.sample(names, 2))

    def run(a):
        select(a["objs"], a["objs"][0])
        return stock(bpy.ops.object.join)


@step(2)
class parent:
    def gen(rng):
        names = objects()
        if len(names) < 2:
            return None
        child, par = rng.sample(names, 2)
        return dict(child=child, parent=par, clear=rng.random() < 0.2)

    def run(a):
        if a["clear"]:
            select([a["child"]], a["child"])
            return stock(bpy.ops.object.parent_clear, type="CLEAR_KEEP_TRANSFORM")
        select([a["child"], a["parent"]], a["parent"])
        return stock(bpy.ops.object.parent_set, type="OBJECT")


@step(2)
class link:
    """Ctrl+L (Link/Transfer Data) from one object to another, or the object linked into a
    second collection."""

    def gen(rng):
        names = objects()
        if len(names) < 2:
            return None
        src, dst = rng.sample(names, 2)
        return dict(src=src, dst=dst, type=rng.choice(["OBDATA", "MODIFIERS", "MATERIAL",
                                                       "COLLECTION"]))

    def run(a):
        if a["type"] == "COLLECTION":
            coll = bpy.data.collections.get("Soak linked")
            if coll is None:
                coll = bpy.data.collections.new("Soak linked")
                scene().collection.children.link(coll)
            obj = get_object(a["src"])
            if obj.name not in coll.objects:
                coll.objects.link(obj)
            return {"LINKED"}
        select([a["dst"], a["src"]], a["src"])
        return stock(bpy.ops.object.make_links_data, type=a["type"])


@step(3)
class edit_toggle:
    def gen(rng):
        if bpy.context.mode != "OBJECT":
            return dict(obj=None)
        obj = pick(rng, lambda o: o.type == "MESH")
        return dict(obj=obj) if obj else None

    def run(a):
        if a["obj"] is None:
            r = stock(bpy.ops.object.mode_set, mode="OBJECT")
            if addon_on() and not CTX.window:  # the add-on's timer (no timers in background)
                from tussock import meshes
                meshes._poll_edit_mode()
            return r
        select([a["obj"]], a["obj"])
        return stock(bpy.ops.object.mode_set, mode="EDIT")


# ---- bakes, files, renders, the add-on -----------------------------------------------------------

def blend_path():
    return os.path.join(WORKDIR, "soak.blend")


@step(3, needs_addon=True)
class bake:
    def gen(rng):
        return dict() if bpy.data.filepath else None

    def run(a):
        r = tussock("bake")
        if "FINISHED" in next(iter(r)):
            check_record(complete=True)
        return r


@step(2, needs_addon=True)
class free_bake:
    def gen(rng):
        return dict() if bpy.data.filepath else None

    def run(a):
        return tussock("free_bake")


def esc_after(seconds, idname):
    """Lets a modal operator run `seconds`, then presses Esc and waits for it to end."""
    yield seconds
    harness.window().event_simulate(type="ESC", value="PRESS")
    yield 0.1
    harness.window().event_simulate(type="ESC", value="RELEASE")
    end = time.monotonic() + 30
    while harness.running(idname) and time.monotonic() < end:
        yield 0.2
    if harness.running(idname):
        raise Broken("hang", f"{idname} still runs 30 s after Esc")
    if harness.running(idname) is None:
        yield 0.5  # 3.4 cannot list modal operators: give it time to end


@step(2, window_only=True, needs_addon=True)
class bake_cancel:
    def gen(rng):
        return dict(after=rnd_float(rng, 0.05, 2.0)) if bpy.data.filepath else None

    def run(a):
        if not CTX.window:
            # a window's sequence replayed in background (to be shrunk there): no modal
            # operator runs without a window, and where Esc would land is the window's
            # timing; a cancelled bake leaves only frames a later bake resumes from
            raise Skip("a cancelled bake needs a window")
        r = tussock("bake", "INVOKE_DEFAULT")  # refused at once: the scene as it was
        if r == {"RUNNING_MODAL"}:
            yield from esc_after(a["after"], "bake")
        return r


@step(1, window_only=True, needs_addon=True)
class capture_cancel:
    def gen(rng):
        return dict(after=rnd_float(rng, 0.05, 1.5), frames=rng.randrange(2, 9))

    def run(a):
        s = scene().tussock_capture
        s.source, s.filepath, s.frames = "FILES", DEPTH.replace("{:04d}", "####"), a["frames"]
        if not CTX.window:
            # replayed in background: the capture runs to its end, as it does in the window
            # whenever it reads its frames before Esc arrives
            return tussock("capture_blades", source=s.source, filepath=s.filepath,
                           frames=s.frames, near=0.0 if s.auto_band else s.near,
                           far=0.0 if s.auto_band else s.far, min_area=s.min_area,
                           frame=s.frame)
        # a capture refused at once (a setting this source cannot take) is checked as any
        # cancelled operator is (seed 786255, 5.2: a frame of 2^31-1 was a tester-error)
        r = tussock("capture_blades", "INVOKE_DEFAULT")
        if r == {"RUNNING_MODAL"}:
            yield from esc_after(a["after"], "capture_blades")
        return r


@step(3)
class save:
    def gen(rng):
        return dict()

    def run(a):
        if bpy.context.mode != "OBJECT":
            stock(bpy.ops.object.mode_set, mode="OBJECT")
        return stock(bpy.ops.wm.save_as_mainfile, filepath=blend_path())


@step(1)
class revert:
    def gen(rng):
        return dict() if bpy.data.filepath else None

    def run(a):
        if not bpy.data.filepath:
            raise Skip("not saved")
        return stock(bpy.ops.wm.revert_mainfile)


@step(1)
class reopen:
    def gen(rng):
        return dict() if os.path.exists(blend_path()) else None

    def run(a):
        if not os.path.exists(blend_path()):
            raise Skip("no saved file")
        return stock(bpy.ops.wm.open_mainfile, filepath=blend_path())


@step(1)
class render:
    def gen(rng):
        engines = ["CYCLES", "BLENDER_WORKBENCH", "BLENDER_EEVEE"]
        return dict(engine=rng.choice(engines), frame=rng.randrange(1, FRAME_END + 1))

    def run(a):
        s = scene()
        if s.camera is None:
            raise Skip("no camera")
        r = s.render
        try:
            r.engine = a["engine"]
        except TypeError:  # EEVEE is BLENDER_EEVEE_NEXT in Blender 4.2-4.4
            r.engine = a["engine"] + "_NEXT"
        r.resolution_x, r.resolution_y, r.resolution_percentage = 32, 24, 100
        s.cycles.samples = 1
        # Debian's Blender is built without OpenImageDenoise: a refused Cycles render (which
        # is not Tussock's) leaves Blender's break flag set, and Blender then exits with 1
        s.cycles.use_denoising = False
        s.eevee.taa_render_samples = 1
        s.frame_set(a["frame"])
        done = stock(bpy.ops.render.render)
        RENDERED.add(r.engine)  # (its shaders and buffers stay for the session)
        return done


RENDERED = set()  # the render engines this session has rendered with


@step(1)
class addon_toggle:
    def gen(rng):
        return dict()

    def run(a):
        if addon_on():
            harness.disable_addon()
        else:
            harness.enable_addon()
            if not CTX.window:  # the timer register sets (no timers in background: 693756)
                from tussock.meadow import simulate
                if bpy.app.timers.is_registered(simulate.rebuild_stale_models):
                    bpy.app.timers.unregister(simulate.rebuild_stale_models)
                    simulate.rebuild_stale_models()
        return {"ENABLED" if addon_on() else "DISABLED"}


# What this Blender may hold beyond a fresh Blender that opens the same file and plays the
# same frame. Both have loaded the file, evaluated it once and kept one undo step; in a
# window this one also keeps its interface (about 380 MB more with an empty scene) and the
# viewport's GPU batches (Mesa keeps them in process memory), which a fresh background
# Blender does not make. Measured in docs/reliability.md. By window mode:
MEMORY_FACTOR = {False: 1.25, True: 2.0}
MEMORY_SLACK_MB = {False: 400.0, True: 800.0}

FRESH = """
import addon_utils, bpy, sys
sys.path.insert(0, sys.argv[-2])
from memory_probe import heap_in_use, rss_bytes, trim
addon_utils.enable("tussock", default_set=True)
bpy.ops.wm.open_mainfile(filepath=sys.argv[-1])
s = bpy.context.scene
s.frame_set(s.frame_current)
engines = [e for e in sys.argv[-3].split(",") if e]
if engines and s.camera is None:
    s.camera = bpy.data.objects.new("memory camera", bpy.data.cameras.new("memory camera"))
    s.collection.objects.link(s.camera)
# the engines render the scene itself: with compositing on, a file whose compositor has no
# Render Layers node (an animated picture's) renders the compositor alone, and the engine's
# shaders and buffers that the soaking Blender keeps from a render before would be missing
# (CI's soak in 4.3, seed 632996: an EEVEE render, then Animate Picture)
s.render.use_compositing = s.render.use_sequencer = False
for e in engines:  # what the soaking Blender's renders keep (an engine's shaders, buffers)
    try:  # (a setting or an engine this Blender lacks: the render is left out)
        s.render.engine = e
        s.render.resolution_x, s.render.resolution_y = 32, 24
        s.render.resolution_percentage = 100
        s.cycles.samples, s.cycles.use_denoising, s.eevee.taa_render_samples = 1, False, 1
        bpy.ops.render.render()
    except (RuntimeError, AttributeError, TypeError):
        pass
trim()
print("FRESH-RSS-BYTES", rss_bytes(), heap_in_use() or 0)
"""


_journal = None  # the run's open journal (soak())


def _wait(proc, timeout):
    """What proc printed, once it ended; a blank line goes to the journal every 30 s while it
    runs. tools/soak.py takes a journal that stops growing for --step-timeout for a hang: a
    fresh Blender opening a scene of gigabytes on a busy machine took longer than that (soak
    seed 232088, 5.2, beside a test run), and the tester killed it. The journal's readers skip
    blank lines."""
    import subprocess
    t0 = time.monotonic()
    while True:
        try:
            out, _ = proc.communicate(timeout=30)
            return out
        except subprocess.TimeoutExpired:
            if time.monotonic() - t0 > timeout:
                proc.kill()
                proc.communicate()
                raise
            if _journal is not None:
                _journal.write("\n")
                _journal.flush()


def fresh_memory_mb(path):
    """Resident memory and the C allocator's bytes in use (0 where it keeps no count), in MB,
    of a fresh background Blender (this binary, the add-on enabled) that
    opens `path`, plays its current frame and renders it with each engine this session has
    rendered with (a render's shaders and buffers stay for the session: soak seed 720004,
    an EEVEE render in 4.3, kept 540 MB that opening a file does not give back)."""
    import subprocess
    cmd = [bpy.app.binary_path, "-b", "--factory-startup", "-noaudio", "--python-exit-code",
           "1", "--python-expr", FRESH, "--", ",".join(sorted(RENDERED)),
           os.path.join(REPO, "tools"), path]
    if "--debug-memory" in sys.argv:  # the same allocator as this Blender's
        cmd.insert(1, "--debug-memory")
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            errors="replace")
    text = _wait(proc, 600)
    m = re.search(r"FRESH-RSS-BYTES (\d+) (\d+)", text)
    if not m:  # (its exit status alone says little: a refused render sets Blender's to 1)
        raise Broken("tester-error", f"the fresh Blender could not open {path}: "
                                     f"{text[-2000:]}")
    return int(m.group(1)) / 2 ** 20, int(m.group(2)) / 2 ** 20


@step(0)
class memory:
    """Not drawn at random: the run puts it after a step that leaves resident memory above
    --max-rss-mb, to tell a leak from a large scene. The scene is saved, opened again here
    (which drops the undo steps and evaluated data it had piled up) and in a fresh Blender;
    this one may hold at most MEMORY_FACTOR times as much as the fresh one, plus
    MEMORY_SLACK_MB. Then, as an artist whose scene has become too big for the machine
    would, it starts a new file, so that the run goes on."""

    def gen(rng):
        return None

    def run(a):
        if bpy.context.mode != "OBJECT":
            stock(bpy.ops.object.mode_set, mode="OBJECT")
        was_on = addon_on()
        path = os.path.join(WORKDIR, "memory.blend")
        before = rss_mb()
        for op, kw in ((bpy.ops.wm.save_as_mainfile, dict(filepath=path, copy=True)),
                       (bpy.ops.wm.open_mainfile, dict(filepath=path))):
            r = stock(op, **kw)
            if "FINISHED" not in r:
                raise Broken("memory", f"{before:.0f} MB, and {op} refused ({r}) to measure "
                                       "what the scene needs")
        if CTX.window:
            yield 0.5  # the viewport draws the opened scene (its batches count)
        scene().frame_set(scene().frame_current)
        trim()
        here, heap = rss_mb(), (heap_in_use() or 0) / 2 ** 20
        fresh, fresh_heap = fresh_memory_mb(path)
        bound = MEMORY_FACTOR[CTX.window] * fresh + MEMORY_SLACK_MB[CTX.window]
        say = (f"{before:.0f} MB before, {here:.0f} MB with the file opened again, a fresh "
               f"Blender {fresh:.0f} MB, so at most {bound:.0f} MB")
        if heap and fresh_heap:  # (what the allocator has handed out, against what it holds)
            say += f"; allocated {heap:.0f} MB here, {fresh_heap:.0f} MB in the fresh Blender"
        if here > bound:
            raise Broken("memory", f"more memory than the scene explains: {say}")
        stock(bpy.ops.wm.read_homefile, use_empty=False)
        if was_on and not addon_on():
            harness.enable_addon()
        scene().frame_start, scene().frame_end = 1, FRAME_END
        os.remove(path)
        return {f"NEW FILE ({say})"}


@step(2, needs_addon=True)
class wind_wave:
    def gen(rng):
        return dict(add=rng.random() < 0.7)

    def run(a):
        if a["add"]:
            return tussock("wind_wave_add")
        if not len(scene().tussock_wind.waves):
            raise Skip("no wave")
        return tussock("wind_wave_remove")


@step(1, needs_addon=True)
class tree_preset:
    def gen(rng):
        from tussock import native
        tree = pick(rng, lambda o: tussock_kind(o) == "tree")
        return dict(obj=tree, preset=rng.choice(native.require().tree_presets())) \
            if tree else None

    def run(a):
        select([a["obj"]], a["obj"])
        return tussock("tree_apply_preset", preset=a["preset"])


# ---- the planted faults (the tester's self-test) -----------------------------------------------

class SOAK_OT_planted(bpy.types.Operator):
    """The planted fault: raises when its argument is 0 (1 call in 50)"""
    bl_idname = "tussock.soak_planted"
    bl_label = "Soak planted fault"

    n: bpy.props.IntProperty()

    def execute(self, context):
        if self.n == 0:
            raise ZeroDivisionError("the planted fault")
        return {"FINISHED"}


if PLANT == "raise":
    @step(12)
    class planted:
        def gen(rng):
            return dict(n=rng.randrange(50))

        def run(a):
            if not SOAK_OT_planted.is_registered:
                bpy.utils.register_class(SOAK_OT_planted)
            return stock(bpy.ops.tussock.soak_planted, n=a["n"])


if PLANT == "unfreed":
    @step(12)
    class planted_unfreed:
        def gen(rng):
            return dict(n=rng.randrange(50))

        def run(a):
            if a["n"] == 0:
                import bmesh
                bm = bmesh.new()
                bm.verts.new((0.0, 0.0, 0.0))
                ctypes.pythonapi.Py_IncRef(ctypes.py_object(bm))
            return "PLANTED"


@bpy.app.handlers.persistent
def _planted_leak(*_args):
    bpy.data.meshes.new("soak leak")


_hoard = []


def _planted_hoard(*_args):
    _hoard.append(b"\x01" * (64 << 20))  # written, so resident


# ---- invariants --------------------------------------------------------------------------------

def check_output(text):
    bad = [line for line in text.splitlines() if PROBLEM.search(line)]
    if bad or _raised:
        start = text.find("Traceback")
        detail = "\n".join(_raised) or (text[start:start + 3000] if start >= 0 else "")
        _raised.clear()
        raise Broken("python-error", ("\n".join(bad[:5]) + "\n" + detail).strip())


def check_record(complete=False):
    """tussock_written.json lists every file and folder in the cache folder (and, after a
    bake that finished, nothing that is not there)."""
    if not bpy.data.filepath:
        return
    root = os.path.join(os.path.dirname(bpy.data.filepath), "tussock_cache")
    if not os.path.isdir(root):
        return
    try:
        with open(os.path.join(root, "tussock_written.json")) as f:
            data = json.load(f)
    except FileNotFoundError:
        data = {}
    except ValueError as exc:
        raise Broken("cache-record", f"tussock_written.json is not JSON: {exc}")
    listed = {p for paths in data.values() for p in paths}
    on_disk = {n for n in os.listdir(root) if n != "tussock_written.json" and ".tmp" not in n}
    stray = sorted(on_disk - listed)
    if stray:
        raise Broken("cache-record", f"on disk but not in tussock_written.json: {stray[:8]}")
    missing = sorted(p for p in listed if not os.path.exists(os.path.join(root, p)))
    if complete and missing:
        raise Broken("cache-record", f"in tussock_written.json after a finished bake but not "
                                     f"on disk: {missing[:8]}")


def check_finite():
    for mesh in bpy.data.meshes:
        n = len(mesh.vertices)
        if not n:
            continue
        co = np.empty(n * 3, np.float32)
        mesh.vertices.foreach_get("co", co)
        if not np.isfinite(co).all():
            raise Broken("non-finite", f"mesh {mesh.name!r}: {int((~np.isfinite(co)).sum())} "
                                       "coordinates are NaN or infinite")


def rss_mb():
    return rss_bytes() / 2 ** 20


def check_memory(limit):
    rss = rss_mb()
    if rss > limit:
        raise Broken("memory", f"resident memory {rss:.0f} MB is above {limit:.0f} MB, the "
                               "bound no scene may pass")
    return rss


def check_last_errors():
    """A settings group whose last_error says the add-on failed unexpectedly: an update
    callback or a frame handler hit a bug."""
    if not addon_on():
        return
    for o in scene().objects:
        for group in ("tussock_meadow", "tussock_tree"):
            text = getattr(o, group).last_error
            if "unexpectedly" in text:
                raise Broken("python-error", f"{o.name}.{group}.last_error: {text}")


# ---- panels (window mode) ------------------------------------------------------------------------

def draw_panels(out, limit=4):
    """Each Tussock object in turn active (up to `limit` per step, the next ones in the next
    step), every Tussock panel whose poll allows it drawn into a popover of the 3D view's
    sidebar: an exception or a printed error is a failure. A generator (the popover is
    closed with Esc through the event loop)."""
    if not addon_on() or bpy.context.mode != "OBJECT":
        return
    names = objects(tussock_kind)
    if not names:
        return
    start = draw_panels.turn % len(names)
    draw_panels.turn += limit
    chosen = (names[start:] + names[:start])[:limit]
    panels = harness.ui_of("tussock").panels
    keep = ([o.name for o in bpy.context.selected_objects],
            bpy.context.view_layer.objects.active)
    errors = []
    for name in chosen:
        select([name], name)

        def draw(popup, context):
            drawn = set()
            for cls in panels:
                if cls.bl_space_type != "VIEW_3D":
                    continue
                parent = getattr(cls, "bl_parent_id", None)
                if parent and parent not in drawn:
                    continue
                try:
                    poll = getattr(cls, "poll", None)
                    if poll and not poll(context):
                        continue
                    box = popup.layout.box()
                    header = harness.defines(cls, "draw_header")
                    if header is not None:
                        header(harness.DrawSelf(cls, box.row()), context)
                    cls.draw(harness.DrawSelf(cls, box.column()), context)
                    drawn.add(cls.bl_idname)
                except Exception:  # noqa: BLE001 - what this check looks for
                    errors.append(f"{name}: {cls.bl_idname}: {traceback.format_exc()}")
        with harness.override("VIEW_3D", "UI"):
            bpy.context.window_manager.popover(draw, ui_units_x=22)
        yield 0.05
        harness.window().event_simulate(type="ESC", value="PRESS")
        yield 0.05
    harness.select_objects([scene().objects[n] for n in keep[0] if n in scene().objects])
    if keep[1] is not None and keep[1].name in scene().objects:
        bpy.context.view_layer.objects.active = keep[1]
    check_output(out.take())
    if errors:
        raise Broken("panel", "\n".join(errors)[:4000])


draw_panels.turn = 0

# ---- the run -------------------------------------------------------------------------------------


def parse(argv):
    import argparse
    p = argparse.ArgumentParser(prog="soak_blender.py")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--steps", type=int, default=0)
    p.add_argument("--minutes", type=float, default=0.0)
    p.add_argument("--replay")
    p.add_argument("--journal", required=True)
    p.add_argument("--workdir")
    p.add_argument("--only", default="")
    p.add_argument("--skip", default="")
    p.add_argument("--max-rss-mb", type=float, default=6000.0)
    p.add_argument("--hard-rss-mb", type=float, default=16000.0)
    return p.parse_args(argv)


def read_replay(path):
    """The steps of a replay file: a JSON list of step descriptors, or a journal."""
    with open(path) as f:
        text = f.read()
    try:
        data = json.loads(text)
        return data["steps"] if isinstance(data, dict) else data
    except ValueError:
        return [json.loads(line)["step"] for line in text.splitlines()
                if line.strip() and '"step"' in line]


class Chooser:
    """Random steps (each generated from the current scene, so that it can run), or the
    replay's."""

    def __init__(self, args, window):
        self.rng = random.Random(args.seed)
        only = {s for s in args.only.split(",") if s}
        skip = {s for s in args.skip.split(",") if s}
        unknown = (only | skip) - set(STEPS)
        if unknown:
            raise SystemExit(f"soak_blender: unknown steps {sorted(unknown)}; "
                             f"known: {sorted(STEPS)}")
        self.kinds = [c for n, c in STEPS.items() if (not only or n in only) and n not in skip
                      and (window or not c.window_only)]
        self.replay = read_replay(args.replay) if args.replay else None
        self.pending = None  # a step the run asks for next (the memory check)

    def next(self, i):
        if self.replay is not None:
            return self.replay[i] if i < len(self.replay) else None
        if self.pending is not None:
            desc, self.pending = self.pending, None
            return desc
        for _ in range(50):
            kinds = [c for c in self.kinds if addon_on() or not c.needs_addon]
            if not addon_on():  # an artist who turned the add-on off turns it on again
                kinds += [STEPS["addon_toggle"]] * 20 if "addon_toggle" in STEPS else []
            cls = self.rng.choices(kinds, [c.weight for c in kinds])[0]
            args = cls.gen(self.rng)
            if args is not None:
                return {"op": cls.name, **args}
        return {"op": "frame_set", "frame": 1}


def run_step(desc):
    """Runs one step descriptor; a generator (window steps wait for the event loop)."""
    cls = STEPS.get(desc["op"])
    if cls is None:
        raise Skip(f"unknown step {desc['op']!r}")
    if cls.needs_addon and not addon_on():
        raise Skip("the add-on is disabled")
    args = {k: v for k, v in desc.items() if k != "op"}
    result = cls.run(args)
    if hasattr(result, "__next__"):
        result = yield from result
    return result


def soak(args, window):
    """The whole run, as a generator: each value is how long the event loop runs before it
    goes on (in background the values are ignored). Returns the exit status."""
    global WORKDIR
    WORKDIR = os.path.abspath(args.workdir or os.path.dirname(args.journal))
    os.makedirs(WORKDIR, exist_ok=True)
    out = Output(args.journal + ".log")
    sys.excepthook = _excepthook
    global _journal
    journal = _journal = open(args.journal, "w")
    CTX.window = window
    harness.enable_addon()
    if PLANT == "leak":
        bpy.app.handlers.frame_change_post.append(_planted_leak)
    if PLANT == "hoard":
        bpy.app.handlers.frame_change_post.append(_planted_hoard)
    s = scene()
    s.frame_start, s.frame_end = 1, FRAME_END
    chooser = Chooser(args, window)
    t0 = time.monotonic()
    i = skipped = 0
    peak = 0.0
    status = 0
    out.say(f"soak: seed {args.seed}, {'window' if window else 'background'}, Blender "
            f"{bpy.app.version_string}, workdir {WORKDIR}")
    while True:
        if args.steps and i >= args.steps:
            break
        if args.minutes and time.monotonic() - t0 > args.minutes * 60:
            break
        if not args.steps and not args.minutes and chooser.replay is None:
            break
        desc = chooser.next(i)
        if desc is None:
            break
        journal.write(json.dumps({"i": i, "step": desc}) + "\n")
        journal.flush()
        os.fsync(journal.fileno())
        out.say(f"soak step {i}: {json.dumps(desc)}")
        t1 = time.monotonic()
        record = {"i": i}
        try:
            result = yield from run_step(desc)
            if window:
                yield 0.05  # Blender draws the new state (its panels too)
            check_output(out.take())
            check_last_errors()
            check_record()
            check_finite()
            rss = check_memory(args.hard_rss_mb)
            peak = max(peak, rss)
            if rss > args.max_rss_mb and chooser.replay is None and desc["op"] != "memory":
                chooser.pending = {"op": "memory"}
            if window:
                yield from draw_panels(out)
            record.update(result=str(sorted(result)[0] if result else result)[:300])
        except Skip as exc:
            skipped += 1
            record.update(result="skip", why=str(exc))
        except Broken as exc:
            record.update(result="fail", kind=exc.kind, detail=exc.detail[:6000])
            status = FAIL_EXIT
        except Exception as exc:  # noqa: BLE001 - the tester's own bug, or the add-on's
            text = traceback.format_exc()
            kind = "python-error" if "/tussock/" in text else "tester-error"
            record.update(result="fail", kind=kind, detail=f"{exc!r}\n{text}"[:6000])
            status = FAIL_EXIT
        if bpy.context.mode == "OBJECT" or desc["op"] != "edit_toggle":
            with contextlib.suppress(RuntimeError):
                bpy.ops.ed.undo_push(message=desc["op"])  # the artist's undo history
        record["secs"] = round(time.monotonic() - t1, 3)
        journal.write(json.dumps(record) + "\n")
        journal.flush()
        out.take()
        if status:
            out.say(f"SOAK FAIL at step {i} ({desc['op']}): {record['kind']}: "
                    f"{record['detail']}")
            break
        i += 1
    secs = time.monotonic() - t0
    out.say(f"soak-blender: {i + (status != 0)} steps ({skipped} skipped) in {secs:.1f} s, "
            f"peak resident memory {peak:.0f} MB, {'FAILED' if status else 'ok'}")
    journal.close()
    return status


WORKDIR = None


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    args = parse(argv)
    window = not bpy.app.background
    run = soak(args, window)
    if not window:
        try:
            while True:
                next(run)
        except StopIteration as done:
            status = done.value
        if status:
            sys.stdout.flush()
            os._exit(status)
        return  # Blender quits the usual way (--debug-memory then lists leaked blocks)

    bpy.context.preferences.view.show_splash = False

    def tick():
        try:
            return max(float(next(run)), 0.01)
        except StopIteration as done:
            status = done.value
        except Exception:  # noqa: BLE001 - the tester's own failure
            traceback.print_exc()
            status = FAIL_EXIT
        sys.stdout.flush()
        if status:
            os._exit(status)
        bpy.ops.wm.quit_blender()
        return None
    bpy.app.timers.register(tick, first_interval=0.5, persistent=True)


if __name__ == "__main__":  # not when a test imports its checks
    main()
