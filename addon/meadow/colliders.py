"""The shapes that push a meadow's blades: for each object of a meadow's Colliders
collection, every frame, spheres and capsules fitted to the object's true shape, as its
Collider Shape setting (Tussock sidebar > Collider) chooses:

- Bones: a mesh deformed by an armature gets one capsule per deforming bone. Which vertices
  make each bone's limb is found once at rest (native collider_fit_bones; bones smaller than
  Merge Below give theirs to their parent); every frame each capsule is fitted, in its bone's
  posed frame, to where those vertices are now (collider_fit_groups), so it holds them
  whatever moves them. A foot pushes grass as a foot, not as a metre-wide capsule.
- Spheres: any other mesh gets at most Max Spheres spheres that hold its evaluated surface,
  fitted again every frame, so shape keys, modifiers and rigid bodies are followed.
- Sphere or Capsule: one shape fitted to the bounds (solver.fit_collider): a ball, a log.
- Auto: Bones for a mesh with an Armature modifier; Sphere or Capsule for a sphere rigid body,
  an object that is not a mesh, or a closed mesh that its bounds' shape holds and that fills
  at least FILL of it (a ball); Spheres otherwise (a box, a log, an L-shaped prop, a sheet).
The fits are native double arithmetic in a fixed order: every farm node fits the same bytes.
How the shapes move between frames is the solver's sweep (solver.substep_rows)."""

import hashlib
import math
import time
import types

import bpy
import numpy as np

from .. import compat, handlers, native
from . import solver

FILL = 0.6  # Auto: a mesh that fills this much of its one bounds shape is that shape ...
HOLD = 1.02  # ... when no vertex is farther out than this times the shape's radius
MAX_CACHED = 64  # fitted rigs and Auto choices kept (one per collider object)

SHAPES = [
    ("AUTO", "Auto", "Bones for an armature-deformed mesh; one sphere or capsule for a round "
     "or long object; spheres over the surface of any other mesh"),
    ("BONES", "Bones", "A capsule per deforming bone of the mesh's armature, fitted at rest "
     "and moved with the pose"),
    ("SPHERES", "Spheres", "Spheres that hold the evaluated mesh's surface, fitted again every "
     "frame (rigid bodies, shape keys, modifiers)"),
    ("BOUNDS", "Sphere or Capsule", "One sphere or capsule fitted to the object's bounds"),
]


class TussockColliderSettings(bpy.types.PropertyGroup):
    shape: bpy.props.EnumProperty(name="Collider Shape", items=SHAPES, default="AUTO",
                                  description="How this object pushes the blades of the "
                                  "meadows whose Colliders collection holds it")
    max_spheres: bpy.props.IntProperty(name="Max Spheres", default=32, min=1, max=1024,
                                       description="Most spheres fitted to the mesh: more "
                                       "follow its shape closer and cost more per frame")
    min_bone_size: bpy.props.FloatProperty(name="Merge Below", default=0.08, min=0.0,
                                           max=10.0, unit="LENGTH",
                                           description="Bones whose vertices span less than "
                                           "this (fingers, toes) are merged into their parent")
    show_shapes: bpy.props.BoolProperty(name="Show Shapes", default=False,
                                        description="Draw the fitted spheres and capsules in "
                                        "the viewport")


classes = (TussockColliderSettings,)


# the settings of an object whose Collider group was never set (reading obj.tussock_collider
# would create it, and so change the file)
DEFAULTS = types.SimpleNamespace(shape="AUTO", max_spheres=32, min_bone_size=0.08,
                                 show_shapes=False)


def settings(obj):
    return compat.settings_of(obj, "tussock_collider") or DEFAULTS


_fits = {}  # object name -> (rest key, the bone of each vertex)
_auto = {}  # object name -> (mesh key, chosen shape)
_shown = {}  # object name -> (shape, its rows) at the last frame read (panel, overlay)
stats = {"fit_seconds": 0.0, "frames": 0}  # time spent fitting (bench_blender_playback)


def _remember(cache, name, value):
    cache.pop(name, None)
    cache[name] = value
    while len(cache) > MAX_CACHED:
        cache.pop(next(iter(cache)))


def armature_of(obj):
    """The armature object that deforms mesh `obj` (its first enabled Armature modifier's),
    or None."""
    if obj.type != "MESH":
        return None
    for mod in obj.modifiers:
        if (mod.type == "ARMATURE" and mod.show_viewport and mod.object is not None
                and mod.object.type == "ARMATURE"):
            return mod.object
    return None


def _matrix(m):
    """A mathutils Matrix as 16 float32, row by row."""
    return np.ascontiguousarray(np.array(m, np.float32).reshape(16))


def _bone_arrays(arm, name):
    """float32 (n, 16) of a 4x4 matrix property of every bone, row by row (foreach_get copies
    Blender's column-major storage)."""
    bones = arm.data.bones if name == "matrix_local" else arm.pose.bones
    flat = np.empty(len(bones) * 16, np.float32)
    bones.foreach_get(name, flat)
    return np.ascontiguousarray(flat.reshape(-1, 4, 4).transpose(0, 2, 1))


def _bone_groups(obj, arm, settings):
    """The bone of each vertex of mesh `obj` deformed by `arm` (int32, -1 none: the limbs
    found at rest), found again only when the rest mesh, the rig or the setting changed."""
    lib = native.require()
    me = obj.data
    points = np.empty(len(me.vertices) * 3, np.float32)
    compat.get_positions(me, points)
    bones = arm.data.bones
    n = len(bones)
    heads = np.empty(n * 3, np.float32)
    tails = np.empty(n * 3, np.float32)
    bones.foreach_get("head_local", heads)
    bones.foreach_get("tail_local", tails)
    rest = _bone_arrays(arm, "matrix_local")
    index = {b.name: i for i, b in enumerate(bones)}  # one entry per bone
    parent = np.array([index[b.parent.name] if b.parent else -1 for b in bones], np.int32)
    use = np.empty(n, bool)
    bones.foreach_get("use_deform", use)
    groups = {g.name for g in obj.vertex_groups}
    deforms = (use & np.array([b.name in groups for b in bones], bool)).astype(np.uint8)
    to_armature = _matrix(arm.matrix_world.inverted() @ obj.matrix_world)
    key = hashlib.blake2b(digest_size=16)
    for part in (points, heads, tails, rest, parent, deforms, to_armature,
                 np.float32(settings.min_bone_size)):
        key.update(np.ascontiguousarray(part).tobytes())
    key = key.hexdigest()
    got = _fits.get(obj.name_full)
    if got is not None and got[0] == key:
        return got[1]
    group = np.empty(len(me.vertices), np.int32)
    lib.collider_fit_bones(points, to_armature, heads, tails, rest, parent, deforms,
                           float(settings.min_bone_size), np.empty(n * 8, np.float32), group)
    _remember(_fits, obj.name_full, (key, group))
    return group


def _bone_rows(obj, arm, depsgraph, settings):
    """Each bone's capsule fitted to its limb's vertices where the evaluated mesh has them;
    None when the evaluated mesh has other vertices than the rest mesh (a modifier that
    changes them: the caller fits spheres instead)."""
    group = _bone_groups(obj, arm, settings)
    ev = obj.evaluated_get(depsgraph)
    if len(ev.data.vertices) != len(group):
        return None
    points, tris = _mesh_arrays(ev)
    ev_arm = arm.evaluated_get(depsgraph)
    pose = _bone_arrays(ev_arm, "matrix")
    rows_ = np.empty(len(pose) * 8, np.float32)
    native.require().collider_fit_groups(points, tris if len(tris) else None, group,
                                         _matrix(ev.matrix_world), _matrix(ev_arm.matrix_world),
                                         pose, rows_)
    rows_ = rows_.reshape(-1, 8)
    return np.ascontiguousarray(rows_[rows_[:, 0] >= 0])


def _mesh_arrays(ev):
    """(points float32 xyz, triangles int32 triples) of an evaluated mesh object."""
    me = ev.data
    points = np.empty(len(me.vertices) * 3, np.float32)
    compat.get_positions(me, points)
    me.calc_loop_triangles()
    tris = np.empty(len(me.loop_triangles) * 3, np.int32)
    me.loop_triangles.foreach_get("vertices", tris)
    return points, tris


def _sphere_rows(ev, settings):
    points, tris = _mesh_arrays(ev)
    if len(points) == 0:
        return np.zeros((0, 8), np.float32)
    most = settings.max_spheres
    rows = np.empty(most * 8, np.float32)
    n = native.require().collider_fit_spheres(points, tris if len(tris) else None,
                                              _matrix(ev.matrix_world), most, rows)
    return rows[:8 * n].reshape(-1, 8)


def _bounds_row(obj, ev):
    rb = obj.rigid_body
    return solver.fit_collider(np.array(ev.matrix_world, np.float64),
                               np.array(ev.bound_box, np.float64),
                               rb is not None and rb.collision_shape == "SPHERE")


def _auto_shape(obj, ev):
    """Auto's choice for an object that no armature deforms: BOUNDS or SPHERES, made once per
    mesh (so the shapes keep their number while it moves or deforms)."""
    rb = obj.rigid_body
    if obj.type != "MESH" or (rb is not None and rb.collision_shape == "SPHERE"):
        return "BOUNDS"
    me_key = (obj.data.name_full, len(obj.data.vertices), len(obj.data.polygons))
    got = _auto.get(obj.name_full)
    if got is not None and got[0] == me_key:
        return got[1]
    row = _bounds_row(obj, ev)
    choice = "SPHERES"
    if row is not None:
        points, tris = _mesh_arrays(ev)
        if len(tris) and _holds(row, points, np.array(ev.matrix_world, np.float64)):
            volume = native.require().collider_mesh_volume(points, tris)
            volume *= abs(np.linalg.det(np.array(ev.matrix_world, np.float64)[:3, :3]))
            r, length = float(row[1]), float(np.linalg.norm(np.subtract(row[5:8], row[2:5])))
            shape = math.pi * r * r * length + 4.0 / 3.0 * math.pi * r ** 3
            if shape > 0.0 and volume >= FILL * shape:
                choice = "BOUNDS"
    _remember(_auto, obj.name_full, (me_key, choice))
    return choice


def _holds(row, points, matrix):
    """Whether the one bounds shape `row` holds every vertex (object-space float32 xyz placed
    by `matrix`) within HOLD of its radius: a ball's does, a box's sphere leaves its corners
    out."""
    p = points.reshape(-1, 3).astype(np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
    a, b = np.asarray(row[2:5], np.float64), np.asarray(row[5:8], np.float64)
    d = b - a
    dd = float(d @ d)
    t = np.clip((p - a) @ d / dd, 0.0, 1.0) if dd > 0.0 else np.zeros(len(p))
    dist = np.linalg.norm(p - (a + t[:, None] * d), axis=1)
    return bool((dist <= float(row[1]) * HOLD).all())


def shape_of(obj, depsgraph):
    """The shape Tussock fits to `obj` now: BONES, SPHERES or BOUNDS."""
    shape = settings(obj).shape
    arm = armature_of(obj)
    if shape == "BONES" and arm is None:
        return "SPHERES" if obj.type == "MESH" else "BOUNDS"
    if shape == "SPHERES" and obj.type != "MESH":
        return "BOUNDS"
    if shape != "AUTO":
        return shape
    if arm is not None:
        return "BONES"
    return _auto_shape(obj, obj.evaluated_get(depsgraph))


def object_rows(obj, depsgraph, shape):
    """float32 (n, 8) collider rows of one object at the depsgraph's frame, fitted as
    `shape` (shape_of) says."""
    s = settings(obj)
    ev = obj.evaluated_get(depsgraph)
    if shape == "BONES":
        got = _bone_rows(obj, armature_of(obj), depsgraph, s)
        if got is not None:
            return got
        shape = "SPHERES"
    if shape == "SPHERES":
        return _sphere_rows(ev, s)
    return solver.collider_rows([_bounds_row(obj, ev)])


def rows(scene, coll, depsgraph=None):
    """float32 (n, 8) collider rows (kind, radius, a xyz, b xyz) of every object in `coll`,
    in the collection's order. Objects without extent (empties, cameras, lights) give none."""
    if coll is None:
        return np.zeros((0, 8), np.float32)
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    t0 = time.perf_counter()
    parts = []
    for obj in coll.all_objects:  # one fit per collider object
        shape = shape_of(obj, depsgraph)
        r = object_rows(obj, depsgraph, shape)
        parts.append(r)
        _shown[obj.name_full] = (shape, r)
    stats["fit_seconds"] += time.perf_counter() - t0
    stats["frames"] += 1
    if not parts:
        return np.zeros((0, 8), np.float32)
    return np.ascontiguousarray(np.concatenate(parts), np.float32)


def shown(obj):
    """(shape, rows) of `obj` at the last frame read, or None."""
    return _shown.get(obj.name_full) if obj is not None else None


def forget():
    """Drops every cached fit (a file was loaded)."""
    _fits.clear()
    _auto.clear()
    _shown.clear()


# ---- the viewport overlay ------------------------------------------------------------------

_CIRCLE = 24  # segments of a drawn circle


def outline(rows_):
    """Line segments (float32 (m, 2, 3)) that draw the rows: three great circles at each end,
    and four lines joining the ends of a capsule."""
    rows_ = np.asarray(rows_, np.float32).reshape(-1, 8)
    if not len(rows_):
        return np.zeros((0, 2, 3), np.float32)
    t = np.linspace(0.0, 2.0 * math.pi, _CIRCLE + 1)
    c, s, z = np.cos(t), np.sin(t), np.zeros_like(t)
    rings = np.stack([np.stack([c, s, z], 1), np.stack([c, z, s], 1), np.stack([z, c, s], 1)])
    r = rows_[:, 1, None, None, None]
    ends = np.concatenate([rows_[:, None, 2:5], rows_[:, None, 5:8]], 1)  # (n, 2, 3)
    pts = ends[:, :, None, None, :] + r[:, :, None] * rings[None, None]  # (n, 2, 3, T+1, 3)
    circles = np.stack([pts[..., :-1, :], pts[..., 1:, :]], -2).reshape(-1, 2, 3)
    caps = rows_[rows_[:, 0] == 1]
    if not len(caps):
        return circles.astype(np.float32)
    a, b, rr = caps[:, 2:5], caps[:, 5:8], caps[:, 1:2]
    axis = b - a
    axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-12)
    ref = np.where(np.abs(axis[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(axis, ref)
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-12)
    v = np.cross(axis, u)
    sides = np.stack([u, -u, v, -v], 1) * rr[:, None]  # (k, 4, 3)
    lines = np.stack([a[:, None] + sides, b[:, None] + sides], 2).reshape(-1, 2, 3)
    return np.concatenate([circles, lines]).astype(np.float32)


_shader = None


def _draw():
    global _shader
    import gpu
    from gpu_extras.batch import batch_for_shader

    segs = [outline(r) for name, (_shape, r) in _shown.items()
            if settings(bpy.data.objects.get(name)).show_shapes]
    segs = [s for s in segs if len(s)]
    if not segs:
        return
    if _shader is None:
        try:
            _shader = gpu.shader.from_builtin("UNIFORM_COLOR")
        except (ValueError, SystemError):  # (Blender 3.4 names it 3D_UNIFORM_COLOR)
            _shader = gpu.shader.from_builtin("3D_UNIFORM_COLOR")
    coords = np.concatenate(segs).reshape(-1, 3)
    batch = batch_for_shader(_shader, "LINES", {"pos": coords})
    _shader.bind()
    _shader.uniform_float("color", (1.0, 0.55, 0.1, 1.0))
    batch.draw(_shader)


def register_extra():
    bpy.types.Object.tussock_collider = bpy.props.PointerProperty(type=TussockColliderSettings)
    if not bpy.app.background:
        handlers.add_draw(_draw)


def unregister_extra():
    del bpy.types.Object.tussock_collider
    forget()
