"""Touched blades in Blender: a rigid-body ball rolls through a meadow (Blender's Bullet
world moves it), the blades under its path bend, none enters the ball, the instances of
simulated tiles are hidden, going back in time gives the same frame again, and bad
settings are reported without harm."""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

harness.enable_addon()
from tussock.meadow import simulate  # noqa: E402

RADIUS = 0.2


def rolling_ball_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    simulate.forget()
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=4.0)
    bpy.ops.rigidbody.object_add(type="PASSIVE")
    assert bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=32, density="UNIFORM",
                                      display=1.0) == {"FINISHED"}
    meadow = bpy.context.active_object
    bpy.ops.mesh.primitive_uv_sphere_add(radius=RADIUS, location=(-1.6, 0.0, RADIUS))
    ball = bpy.context.active_object
    bpy.ops.rigidbody.object_add(type="ACTIVE")
    ball.rigid_body.collision_shape = "SPHERE"
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(ball)
    scene.gravity = (3.0, 0.0, -9.81)  # a slope's pull: Bullet rolls the ball along +x
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    return scene, meadow, ball


def blade_knots(meadow):
    e = simulate._cache[meadow.name]
    lib = simulate.native.lib
    info = lib.blade_sim_info(e["sim"])
    knots = np.empty(info["active_blades"] * e["K"] * 3, np.float32)
    lib.blade_sim_get_knots(e["sim"], knots)
    return knots.reshape(-1, e["K"], 3)


def instance_count(meadow):
    dg = bpy.context.evaluated_depsgraph_get()
    return sum(1 for i in dg.object_instances
               if i.is_instance and i.parent is not None and i.parent.original == meadow)


@test
def test_rolling_ball_bends_blades_on_its_path():
    scene, meadow, ball = rolling_ball_scene()
    total_instances = instance_count(meadow)
    start_x = None
    bent = 0.0
    frames = {}
    for f in range(1, 31):
        scene.frame_set(f)
        centre = np.array(ball.matrix_world.translation)
        if start_x is None:
            start_x = centre[0]
        knots = blade_knots(meadow)
        if len(knots):
            # no knot inside the ball (collision is a hard constraint)
            d = np.linalg.norm(knots - centre[None, None, :], axis=2)
            assert d.min() > RADIUS - 1e-3, (f, d.min())
            bent = max(bent, float(np.abs(knots[:, -1, :2] - knots[:, 0, :2]).max()))
        blades = bpy.data.objects[f"{meadow.name} blades"].data
        co = np.empty(len(blades.vertices) * 3, np.float32)
        blades.vertices.foreach_get("co", co)
        frames[f] = co
    assert np.array(ball.matrix_world.translation)[0] > start_x + 0.8  # Bullet rolled it
    assert meadow["tussock_active_tiles"] > 0 and meadow["tussock_active_blades"] > 0
    assert bent > 0.05, bent  # tips pushed well away from above their roots
    hidden = np.empty(len(meadow.data.vertices), bool)
    meadow.data.attributes["tsk_hidden"].data.foreach_get("value", hidden)
    assert hidden.sum() > 0 and instance_count(meadow) == total_instances - hidden.sum()
    # back in time: restarted from rest with the recorded ball positions, same bytes
    scene.frame_set(12)
    blades = bpy.data.objects[f"{meadow.name} blades"].data
    co = np.empty(len(blades.vertices) * 3, np.float32)
    blades.vertices.foreach_get("co", co)
    assert co.tobytes() == frames[12].tobytes()


def rest_knots(meadow):
    """Rest knots of the active blades, in the simulation's order, from the meadow."""
    e = simulate._cache[meadow.name]
    lib = simulate.native.lib
    info = lib.blade_sim_info(e["sim"])
    tiles = np.empty(info["active_tiles"], np.int32)
    counts = np.empty(info["active_tiles"], np.int32)
    lib.blade_sim_get_active(e["sim"], tiles, counts)
    out = []
    for t in tiles:
        t = int(t)
        n = lib.meadow_blade_count(e["meadow"], t, t + 1)
        k = np.empty(n * e["K"] * 3, np.float32)
        lib.meadow_realise_knots(e["meadow"], e["patch"], t, t + 1, k, None, None)
        out.append(k.reshape(n, e["K"], 3))
    return np.concatenate(out) if out else np.zeros((0, e["K"], 3), np.float32)


@test
def test_blades_recover_after_the_ball_has_passed():
    scene, meadow, ball = rolling_ball_scene()
    scene.gravity = (0.0, 0.0, -9.81)
    scene.tussock_wind.base_speed = 0.0  # no breeze: the blades' shape at rest is the rest pose
    ball.rigid_body.kinematic = True  # pressed into the grass, then lifted away
    ball.location = (-0.5, 0.1, RADIUS)
    ball.keyframe_insert("location", frame=1)
    ball.location = (-0.5, 0.1, 5.0)
    ball.keyframe_insert("location", frame=10)
    for fc in ball.animation_data.action.fcurves:
        for kp in fc.keyframe_points:
            kp.interpolation = "CONSTANT"
    for f in range(1, 10):
        scene.frame_set(f)
    pressed, rest = blade_knots(meadow), rest_knots(meadow)
    assert len(pressed) > 0
    length = np.linalg.norm(np.diff(rest, axis=1), axis=2).sum(axis=1)
    assert np.max(np.linalg.norm(pressed - rest, axis=2).max(axis=1) / length) > 0.05
    for f in range(10, 121):
        scene.frame_set(f)
        # a tile released by a frame's first step used to leave the second step with wind
        # for more blades than were active ("wind: must have exactly ... elements")
        assert meadow.tussock_meadow.last_error == "", (f, meadow.tussock_meadow.last_error)
    after, rest = blade_knots(meadow), rest_knots(meadow)
    if len(after):  # still simulated: within 1 % of the blade length of the rest shape
        length = np.linalg.norm(np.diff(rest, axis=1), axis=2).sum(axis=1)
        err = np.linalg.norm(after - rest, axis=2).max(axis=1) / length
        assert err.max() < 0.01, err.max()
    else:  # released: the instances are shown again
        hidden = np.empty(len(meadow.data.vertices), bool)
        meadow.data.attributes["tsk_hidden"].data.foreach_get("value", hidden)
        assert hidden.sum() == 0


@test
def test_bad_simulation_settings_are_reported():
    scene, meadow, ball = rolling_ball_scene()
    meadow.tussock_meadow.sim_damping = float("nan")
    scene.frame_set(2)
    assert "damping" in meadow.tussock_meadow.last_error, meadow.tussock_meadow.last_error
    meadow.tussock_meadow.sim_damping = 4.0
    scene.frame_set(3)
    assert meadow.tussock_meadow.last_error == ""


harness.main()
