"""A walking character made from Blender's own data, for the collider tests
(blender_tests/test_colliders.py), the demo and the character benchmark: an armature (hips,
spine, chest, head; thigh, shin and foot per leg; upper and lower arm per side) deforming one
mesh of closed tubes, each tube in its bone's vertex group, walking along +x with a
keyframed gait (legs swing, knees bend, arms swing against the legs).

    import walker
    rig, body = walker.build(bpy.context.scene, start=(-1.5, 0.0, 0.0), speed=1.2)
    ground, meadow, rig, body = walker.through_meadow(bpy.context.scene, (5.0, 2.5))

Runs inside Blender (3.4 to 5.x); numpy builds the tubes, and a few calls per bone and per
keyed frame set up the rig."""

import math

import bpy
import numpy as np

# bone: (head xyz, tail xyz, parent, tube radius); the rest pose stands at the origin, facing +x
BONES = {
    "hips": ((0.0, 0.0, 0.90), (0.0, 0.0, 1.10), None, 0.14),
    "chest": ((0.0, 0.0, 1.10), (0.0, 0.0, 1.45), "hips", 0.15),
    "head": ((0.0, 0.0, 1.50), (0.0, 0.0, 1.75), "chest", 0.10),
    "thigh.L": ((0.0, 0.10, 0.90), (0.0, 0.10, 0.50), "hips", 0.075),
    "shin.L": ((0.0, 0.10, 0.50), (0.0, 0.10, 0.09), "thigh.L", 0.055),
    "foot.L": ((0.0, 0.10, 0.09), (0.20, 0.10, 0.05), "shin.L", 0.045),
    "thigh.R": ((0.0, -0.10, 0.90), (0.0, -0.10, 0.50), "hips", 0.075),
    "shin.R": ((0.0, -0.10, 0.50), (0.0, -0.10, 0.09), "thigh.R", 0.055),
    "foot.R": ((0.0, -0.10, 0.09), (0.20, -0.10, 0.05), "shin.R", 0.045),
    "arm.L": ((0.0, 0.22, 1.42), (0.0, 0.24, 1.14), "chest", 0.045),
    "forearm.L": ((0.0, 0.24, 1.14), (0.0, 0.25, 0.88), "arm.L", 0.04),
    "arm.R": ((0.0, -0.22, 1.42), (0.0, -0.24, 1.14), "chest", 0.045),
    "forearm.R": ((0.0, -0.24, 1.14), (0.0, -0.25, 0.88), "arm.R", 0.04),
}
LEG_BONES = ("thigh.L", "shin.L", "foot.L", "thigh.R", "shin.R", "foot.R")
SEGMENTS = 16  # around a tube
SPACING = 0.03  # metres between a tube's rings
STRIDE = 1.2  # metres per gait cycle (two steps)


def tube(head, tail, radius):
    """(vertices (n, 3), triangles (m, 3)) of a closed tube about head-tail: rings every
    SPACING, each end closed by a fan about a centre vertex just beyond it."""
    head, tail = np.asarray(head, float), np.asarray(tail, float)
    axis = tail - head
    length = np.linalg.norm(axis)
    axis /= length
    ref = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(axis, ref)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    rings = max(2, int(math.ceil(length / SPACING)) + 1)
    t = np.linspace(0.0, length, rings)
    a = np.linspace(0.0, 2.0 * math.pi, SEGMENTS, endpoint=False)
    circle = np.cos(a)[:, None] * u + np.sin(a)[:, None] * v  # (S, 3)
    verts = (head + t[:, None, None] * axis + radius * circle[None]).reshape(-1, 3)
    caps = np.array([head - 0.5 * radius * axis, tail + 0.5 * radius * axis])
    verts = np.concatenate([verts, caps])
    r = np.arange(rings - 1)[:, None]
    s = np.arange(SEGMENTS)[None, :]
    s1 = (s + 1) % SEGMENTS
    i00, i01 = r * SEGMENTS + s, r * SEGMENTS + s1
    i10, i11 = (r + 1) * SEGMENTS + s, (r + 1) * SEGMENTS + s1
    side = np.concatenate([np.stack([i00, i10, i11], -1).reshape(-1, 3),
                           np.stack([i00, i11, i01], -1).reshape(-1, 3)])
    c0, c1 = rings * SEGMENTS, rings * SEGMENTS + 1
    first = np.stack([np.full(SEGMENTS, c0), s1[0], s[0]], -1)
    last = (rings - 1) * SEGMENTS
    end = np.stack([np.full(SEGMENTS, c1), last + s[0], last + s1[0]], -1)
    return verts, np.concatenate([side, first, end]).astype(np.int64)


def body_mesh(name="WalkerBody"):
    """The character's mesh at rest and the vertex ranges of each bone's tube."""
    verts, tris, ranges = [], [], {}
    n = 0
    for bone, (head, tail, _parent, radius) in BONES.items():
        v, t = tube(head, tail, radius)
        verts.append(v)
        tris.append(t + n)
        ranges[bone] = (n, n + len(v))
        n += len(v)
    verts = np.concatenate(verts)
    tris = np.concatenate(tris)
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts.tolist(), [], tris.tolist())  # (a test scene: a few thousand)
    me.update()
    return me, ranges


def _swing_axis(bone):
    """(euler index, sign) of the bone's own axis nearest the world's y axis: a rotation
    about it swings the bone forward and back in the walking direction."""
    m = np.array(bone.matrix_local)[:3, :3]
    k = int(np.argmax(np.abs(m[1, :])))
    return k, 1.0 if m[1, k] > 0 else -1.0


def build(scene, start=(-1.5, 0.0, 0.0), speed=1.2, frames=(1, 48), name="Walker"):
    """The character, linked to `scene`'s collection, walking from `start` along +x at
    `speed` m/s over `frames` (inclusive). Returns (armature object, mesh object)."""
    arm_data = bpy.data.armatures.new(name + "Rig")
    rig = bpy.data.objects.new(name + "Rig", arm_data)
    scene.collection.objects.link(rig)
    view_layer = bpy.context.view_layer
    for o in view_layer.objects:
        o.select_set(False)
    view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    for bone, (head, tail, parent, _r) in BONES.items():  # one edit bone per bone
        eb = arm_data.edit_bones.new(bone)
        eb.head, eb.tail = head, tail
        eb.roll = 0.0
        if parent:
            eb.parent = arm_data.edit_bones[parent]
            eb.use_connect = False
    bpy.ops.object.mode_set(mode="OBJECT")
    me, ranges = body_mesh(name + "Body")
    body = bpy.data.objects.new(name + "Body", me)
    scene.collection.objects.link(body)
    body.parent = rig
    for bone, (lo, hi) in ranges.items():
        body.vertex_groups.new(name=bone).add(list(range(lo, hi)), 1.0, "REPLACE")
    mod = body.modifiers.new("Armature", "ARMATURE")
    mod.object = rig
    animate(rig, start, speed, frames, scene.render.fps / scene.render.fps_base)
    return rig, body


def through_meadow(scene, size, start=(-1.5, 0.0, 0.0), speed=1.2, frames=(1, 48),
                   blades_per_tile=64, display=1.0):
    """A ground plane of `size` (x, y metres) at the origin, a simulated meadow on it (0.25 m
    tiles) and the character walking through it from `start` along +x, the one object of the
    meadow's Colliders collection (Collider Shape Auto: a capsule per bone). For the demo and
    the docs' pictures. Returns (ground, meadow, armature, body)."""
    bpy.ops.mesh.primitive_plane_add(size=1.0)
    ground = bpy.context.active_object
    ground.scale = (size[0], size[1], 1.0)
    result = bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=blades_per_tile,
                                        density="UNIFORM", display=display)
    if result != {"FINISHED"}:
        raise RuntimeError(f"Add Meadow: {result}")
    meadow = bpy.context.active_object
    rig, body = build(scene, start=start, speed=speed, frames=frames)
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(body)
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    return ground, meadow, rig, body


def gait(t):
    """Joint angles (radians) at time t seconds: thighs swing +-25 degrees, knees bend up to
    40 degrees while their leg swings forward, arms swing against the legs."""
    phase = 2.0 * math.pi * t / (STRIDE / 1.2)
    swing = math.radians(25.0) * math.sin(phase)
    knee = math.radians(40.0) * max(0.0, math.cos(phase))
    knee_r = math.radians(40.0) * max(0.0, -math.cos(phase))
    return {"thigh.L": swing, "thigh.R": -swing, "shin.L": -knee, "shin.R": -knee_r,
            "arm.L": -0.6 * swing, "arm.R": 0.6 * swing, "forearm.L": 0.2, "forearm.R": 0.2}


def animate(rig, start, speed, frames, fps):
    first, last = frames
    rig.location = start
    rig.keyframe_insert("location", frame=first)
    rig.location = (start[0] + speed * (last - first) / fps, start[1], start[2])
    rig.keyframe_insert("location", frame=last)
    for fc in _fcurves(rig):  # walking at a steady speed
        for kp in fc.keyframe_points:
            kp.interpolation = "LINEAR"
    axes = {b.name: _swing_axis(b) for b in rig.data.bones}
    for pb in rig.pose.bones:
        pb.rotation_mode = "XYZ"
    for f in range(first, last + 1):  # a key per frame and bone that swings
        angles = gait((f - first) / fps)
        for bone, angle in angles.items():
            pb = rig.pose.bones[bone]
            k, sign = axes[bone]
            e = [0.0, 0.0, 0.0]
            e[k] = sign * angle
            pb.rotation_euler = e
            pb.keyframe_insert("rotation_euler", frame=f)


def _fcurves(obj):
    """Every F-curve of obj's action, in every Blender (from 4.4 an action keeps them in
    its layers' channel bags)."""
    ad = obj.animation_data
    if ad is None or ad.action is None:
        return []
    action = ad.action
    if hasattr(action, "fcurves") and len(getattr(action, "fcurves", [])):
        return list(action.fcurves)
    out = []
    for layer in getattr(action, "layers", []):
        for strip in layer.strips:
            for bag in getattr(strip, "channelbags", []):
                out.extend(bag.fcurves)
    return out


def leg_vertices(body):
    """Indices of the vertices of the legs' tubes (thighs, shins, feet)."""
    names = {body.vertex_groups[b].index for b in LEG_BONES}
    ranges = []
    n = 0
    for bone, (head, tail, _p, radius) in BONES.items():
        v, _t = tube(head, tail, radius)
        if body.vertex_groups[bone].index in names:
            ranges.append(np.arange(n, n + len(v)))
        n += len(v)
    return np.concatenate(ranges)
