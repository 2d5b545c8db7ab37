"""The scene's wind at a frame, for everyone who samples it (trees, meadows, pictures).

The sines and gusts are closed-form in time. The fluid grid is stepped from the scene's
first frame with a fixed step, so frame N has the same wind whether it is reached by
playing, by jumping or in another process on a farm: going forward steps on from the last
frame; going back (or a changed setting) starts again from the first frame. Wind sources
are read at each frame from their keyframes (F-curves), never by changing the frame."""

import math

import numpy as np
from mathutils import Euler, Vector

from .. import compat, native

STEPS_PER_FRAME = 2
_cache = {}  # scene name -> Stepper


def _animated(obj, path, index, frame, default):
    """Value of an animated property at `frame` from its F-curve, else `default`."""
    fc = compat.fcurve(obj.animation_data, path, index)
    return fc.evaluate(frame) if fc is not None else default


def sources(scene, frame):
    """float32 (n, 8) wind sources: x, y, dir_x, dir_y, strength, radius, interval, start."""
    rows = []
    for obj in scene.objects:  # one row per wind source empty
        s = compat.settings_of(obj, "tussock_wind_source")
        if s is None or not s.is_source:
            continue
        loc = [_animated(obj, "location", i, frame, obj.location[i]) for i in range(3)]
        strength = _animated(obj, "tussock_wind_source.strength", 0, frame, s.strength)
        radius = _animated(obj, "tussock_wind_source.radius", 0, frame, s.radius)
        # the arrow of a Single Arrow empty is its local +Z; its ground projection pushes
        if len(obj.rotation_mode) == 3:  # an Euler order: read the keyed rotation
            rot = Euler([_animated(obj, "rotation_euler", i, frame, obj.rotation_euler[i])
                         for i in range(3)], obj.rotation_mode)
            d = rot.to_matrix() @ Vector((0.0, 0.0, 1.0))
        else:
            d = obj.matrix_world.to_3x3() @ Vector((0.0, 0.0, 1.0))
        if math.hypot(d.x, d.y) < 1e-6:
            d = Vector((1.0, 0.0, 0.0))
        rows.append((loc[0], loc[1], d.x, d.y, max(0.0, min(1.0, strength)), max(radius, 1e-3),
                     s.interval, 0.0))
    return np.array(rows, np.float32).reshape(-1, 8)


def wind_kwargs(scene):
    w = scene.tussock_wind
    waves = np.array([(wv.amplitude, math.cos(wv.direction), math.sin(wv.direction),
                       wv.wavelength, wv.speed, wv.phase, wv.power) for wv in w.waves],
                     np.float32).reshape(-1, 7)
    kw = dict(base_x=w.base_speed * math.cos(w.base_direction),
              base_y=w.base_speed * math.sin(w.base_direction), waves=waves.ravel(),
              gust_strength=w.gust_strength, gust_interval=w.gust_interval,
              gust_duration=min(w.gust_duration, w.gust_interval),
              gust_dir_x=math.cos(w.base_direction), gust_dir_y=math.sin(w.base_direction),
              gust_front_speed=w.gust_front_speed, seed=w.seed)
    if w.use_fluid:
        fps = scene.render.fps / scene.render.fps_base
        n = w.fluid_resolution
        kw.update(nx=n, ny=n, cell_size=w.fluid_size / n,
                  origin_x=w.fluid_center[0] - w.fluid_size / 2,
                  origin_y=w.fluid_center[1] - w.fluid_size / 2,
                  dt=1.0 / (fps * STEPS_PER_FRAME), speed=w.fluid_speed, decay=w.fluid_decay,
                  continuum=w.use_continuum, c=w.continuum_c, gamma=w.continuum_gamma)
    return kw


class Stepper:
    """The native wind of one set of settings, stepped frame by frame from `frame_start`.
    Pure: it holds no Blender data, so a bake worker thread can own one. `sources_at`
    gives the float32 (n, 8) source rows of a frame (read from Blender beforehand)."""

    def __init__(self, kwargs, frame_start, fps, sources_at):
        self.lib = native.require()
        self.kwargs = kwargs
        self.handle = self.lib.wind_create(**kwargs)
        self.frame_start = frame_start
        self.fps = fps
        self.frame = frame_start
        self.sources_at = sources_at
        self.fluid = kwargs.get("nx", 0) > 0

    def advance(self, frame):
        """Steps the fluid to `frame` (forward only); returns the time in seconds."""
        if self.fluid:
            while self.frame < frame:  # one frame of fluid at a time, sources as keyed then
                self.lib.wind_set_sources(self.handle, self.sources_at(self.frame).ravel())
                self.lib.wind_step(self.handle, STEPS_PER_FRAME)
                self.frame += 1
        else:
            self.frame = frame
        return (frame - self.frame_start) / self.fps

    def sample(self, frame, xyz):
        t = self.advance(frame)
        xyz = np.ascontiguousarray(xyz, np.float32)
        out = np.empty_like(xyz)
        self.lib.wind_sample_xyz(self.handle, t, xyz.ravel(), out.reshape(-1))
        return out


def _key(scene):
    kw = wind_kwargs(scene)
    return repr(sorted((k, v.tobytes() if isinstance(v, np.ndarray) else v) for k, v in kw.items())) \
        + repr(scene.frame_start) + repr(scene.render.fps)


def settings_key(scene):
    """What the scene's wind at a frame depends on (settings, first frame, frame rate);
    keyframed wind sources are not part of it."""
    return _key(scene)


def fps_of(scene):
    return scene.render.fps / scene.render.fps_base


def stepper(scene, frame):
    """The scene's cached Stepper, able to reach `frame` (recreated when the settings
    changed or when going back in time)."""
    key = _key(scene)
    entry = _cache.get(scene.name)
    if entry is None or entry.key != key or frame < entry.frame:
        entry = Stepper(wind_kwargs(scene), scene.frame_start, fps_of(scene),
                        lambda f, scene=scene: sources(scene, f))
        entry.key = key
        _cache[scene.name] = entry
    return entry


def wind_at(scene, frame):
    """(native wind handle, time in seconds) for `frame` of `scene`."""
    st = stepper(scene, frame)
    t = st.advance(frame)
    return st.handle, t


def sample(scene, frame, xyz):
    """Wind velocity (m/s) at points xyz (float32 (n, 3)) at `frame`."""
    return stepper(scene, frame).sample(frame, xyz)


def clear():
    _cache.clear()


def forget(scene):
    """Drops the scene's stepped wind, so that the next wind_at starts again from the first
    frame (for callers that saw the wind sources change)."""
    _cache.pop(scene.name, None)
