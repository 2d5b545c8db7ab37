"""The scene wind in Blender: the sines match seed 001 eq. 11-14 written out here in
numpy, keyframed wind source empties drive the fluid, a frame's wind is the same whether
played to or jumped to, the debug image shows it, and unstable settings are refused."""

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import expect_cancel, test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

harness.enable_addon()
from tussock import compat, native  # noqa: E402
from tussock.wind import runtime  # noqa: E402


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    runtime.clear()
    return bpy.context.scene


@test
def test_sines_match_closed_form():
    scene = fresh()
    w = scene.tussock_wind
    w.base_speed, w.base_direction = 2.0, math.radians(30)
    w.gust_strength = 0.0
    specs = [(3.0, 0.4, 7.0, 2.5, 0.3, 2.0), (1.5, 2.0, 3.0, -1.0, 1.1, 1.0)]
    for a, d, L, s, ph, k in specs:
        wave = w.waves.add()
        wave.amplitude, wave.direction, wave.wavelength = a, d, L
        wave.speed, wave.phase, wave.power = s, ph, k
    rng = np.random.default_rng(3)
    pts = rng.uniform(-20, 20, (500, 3)).astype(np.float32)
    fps = scene.render.fps / scene.render.fps_base
    for frame in (1, 7, 93):
        vel = runtime.sample(scene, frame, pts).astype(np.float64)
        t = (frame - scene.frame_start) / fps
        ref = np.zeros((len(pts), 2))
        ref += 2.0 * np.array([math.cos(math.radians(30)), math.sin(math.radians(30))])
        for a, d, L, s, ph, k in specs:
            D = np.array([math.cos(d), math.sin(d)])
            theta = 2 * math.pi / L * (pts[:, :2].astype(np.float64) @ D - s * t) + ph
            ref += (a * ((np.sin(theta) + 1) / 2) ** k)[:, None] * D
        err = np.abs(vel[:, :2] - ref).max()
        assert err < 2e-4, (frame, err)
        assert np.all(vel[:, 2] == 0)


def fluid_scene():
    scene = fresh()
    w = scene.tussock_wind
    w.base_speed = 0.0
    w.use_fluid = True
    w.fluid_resolution, w.fluid_size, w.fluid_speed = 32, 10.0, 4.0
    assert bpy.ops.tussock.add_wind_source(strength=1.0, radius=1.5) == {"FINISHED"}
    src = bpy.context.active_object
    assert src.empty_display_type == "SINGLE_ARROW" and src.tussock_wind_source.is_source
    return scene, src


@test
def test_keyframed_source_drives_the_fluid():
    scene, src = fluid_scene()
    src.location = (-2.0, 0.0, 0.0)
    s = src.tussock_wind_source
    s.strength = 0.0
    s.keyframe_insert("strength", frame=12)
    s.strength = 1.0
    s.keyframe_insert("strength", frame=13)
    for fc in compat.fcurves(src.animation_data):
        for kp in fc.keyframe_points:
            kp.interpolation = "CONSTANT"
    probe = np.array([[-1.0, 0.0, 0.0]], np.float32)
    assert np.abs(runtime.sample(scene, 12, probe)).max() < 1e-6  # off until frame 12
    v = runtime.sample(scene, 30, probe)
    assert v[0, 0] > 0.5 and abs(v[0, 1]) < 0.5 * v[0, 0], v  # pushes along the arrow (+x)


@test
def test_frame_wind_same_when_played_or_jumped():
    scene, src = fluid_scene()
    probe = np.random.default_rng(1).uniform(-5, 5, (64, 3)).astype(np.float32)
    for f in range(1, 26):  # play
        played = runtime.sample(scene, f, probe)
    runtime.sample(scene, 40, probe)
    back = runtime.sample(scene, 25, probe)      # jump back: recomputed from the start
    runtime.clear()
    jumped = runtime.sample(scene, 25, probe)    # fresh process: straight to 25
    assert played.tobytes() == back.tobytes() == jumped.tobytes()


@test
def test_debug_image_shows_the_source():
    scene, src = fluid_scene()
    scene.frame_set(20)
    assert bpy.ops.tussock.wind_debug_image(size=64) == {"FINISHED"}
    img = bpy.data.images["Tussock Wind"]
    assert tuple(img.size) == (64, 64) and img["tussock_max_speed"] > 0.5
    px = np.empty(64 * 64 * 4, np.float32)
    img.pixels.foreach_get(px)
    rgb = px.reshape(64, 64, 4)[..., :3].max(axis=2)
    # brightest near the source (grid centre, x slightly ahead of it), dark at the corners
    assert rgb[28:40, 30:44].max() > 0.8 and rgb[:4, :4].max() < 0.3


@test
def test_unstable_continuum_refused_with_message():
    scene, src = fluid_scene()
    w = scene.tussock_wind
    w.continuum_c = 1000.0  # c dt / dx far above 1: unstable
    try:
        runtime.sample(scene, 3, np.zeros((1, 3), np.float32))
    except native.Error as exc:
        assert "c" in str(exc) and ("stable" in str(exc) or "CFL" in str(exc)), str(exc)
    else:
        raise AssertionError("an unstable continuum was accepted")
    expect_cancel(bpy.ops.tussock.wind_debug_image, "stable")


harness.main()
