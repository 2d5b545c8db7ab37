"""The scene's wind at a frame, for everyone who samples it (trees, meadows, pictures).

The sines and gusts are closed-form in time and hold no state: their settings may be
keyframed and are read at each frame from their F-curves (never by changing the frame).
The fluid grid is stepped from the scene's first frame with a fixed step, so frame N has
the same wind whether it is reached by playing, by jumping or in another process on a
farm; its settings (grid, speed, decay, continuum) hold for the whole shot and keyframes
on them are refused with a message (animate the wind sources instead, which are read per
frame). Going forward steps on from the last frame; going back resumes from the nearest
kept state of the fluid (Stepper snapshots), so a jump costs the frames from the nearest
kept state, not from the first frame."""

import math
import sys
import time

import numpy as np
from mathutils import Euler, Vector

from .. import compat, native

STEPS_PER_FRAME = 2
_cache = {}  # scene name -> Stepper

# Fluid snapshots. A snapshot is about 28 bytes per grid cell (tsk_wind_state_size) and a
# frame of stepping costs time in proportion to the cells too, so one constant bounds the
# re-step after a restore on every grid: SNAPSHOT_CELL_FRAMES cell-frames (about 15 to 90
# ms on one busy core: 64 frames of the default 64x64 grid, 16 frames of 256x256).
# SNAPSHOT_BUDGET is the memory a scene's snapshots may take: 256 MB keep about 130,000
# frames of the default grid and 2,000 of a 256x256 one at that spacing; beyond, every
# other snapshot is dropped and the spacing doubles (as the blade simulation's playback
# does), so a long timeline stays covered at a coarser step.
SNAPSHOT_CELL_FRAMES = 1 << 18
SNAPSHOT_MAX_EVERY = 64
SNAPSHOT_BUDGET = 256 << 20
PROGRESS_SECONDS = 1.0  # a re-step longer than this reports its progress


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
        interval = _animated(obj, "tussock_wind_source.interval", 0, frame, s.interval)
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
                     max(interval, 0.0), 0.0))
    return np.array(rows, np.float32).reshape(-1, 8)


# Scene wind settings the sines read (keyframes are read at every frame) and those the
# fluid grid is made with (they hold for the whole shot: a keyframe on them is refused).
SINES_SETTINGS = ("base_speed", "base_direction", "gust_strength", "gust_interval",
                  "gust_duration", "gust_front_speed", "seed")
WAVE_SETTINGS = ("amplitude", "direction", "wavelength", "speed", "phase", "power")
FLUID_SETTINGS = ("use_fluid", "fluid_resolution", "fluid_size", "fluid_center",
                  "fluid_speed", "fluid_decay", "use_continuum", "continuum_c",
                  "continuum_gamma")
_PREFIX = "tussock_wind."


def _wind_curves(scene):
    """(F-curves, drivers) of the scene that animate its wind settings."""
    ad = scene.animation_data
    if ad is None:
        return [], []
    keyed = [fc for fc in compat.fcurves(ad) if fc.data_path.startswith(_PREFIX)]
    driven = [fc for fc in ad.drivers if fc.data_path.startswith(_PREFIX)]
    return keyed, driven


def _setting_label(scene, path):
    name = path[len(_PREFIX):].split("[")[0].split(".")[0]
    prop = scene.tussock_wind.bl_rna.properties.get(name)
    return prop.name if prop is not None else name


def check_animation(scene, baking=False):
    """Refuses (ValueError) keyframes or drivers on the fluid grid's settings, which hold
    for the whole shot; when `baking`, also drivers on any wind setting (a bake reads every
    frame's values from F-curves, which drivers do not have)."""
    keyed, driven = _wind_curves(scene)
    w = scene.tussock_wind
    for fc in keyed + driven:
        name = fc.data_path[len(_PREFIX):].split("[")[0]
        if name in FLUID_SETTINGS and (w.use_fluid or name == "use_fluid"):
            how = "keyframed" if fc in keyed else "driven"
            raise ValueError(
                f"the scene wind's '{_setting_label(scene, fc.data_path)}' is {how}, but the "
                "fluid wind is simulated from the first frame with one grid and the same "
                "settings for the whole shot: remove its keyframes or driver (right-click it: "
                "Clear Keyframes, or Delete Driver); to vary the fluid wind over time, keyframe "
                "the wind sources' strength, place or direction instead")
    if baking and driven:
        raise ValueError(
            f"the scene wind's '{_setting_label(scene, driven[0].data_path)}' has a driver, "
            "which a bake cannot read at every frame: keyframe the value instead (or remove "
            "the driver) and bake again")


def _value(ad, path, index, frame, owner, name):
    """The setting's value at `frame`: from its F-curve when keyed (clamped to the
    setting's range, as Blender clamps it when it plays the frame), else its value."""
    fc = compat.fcurve(ad, path, index) if ad is not None else None
    if fc is None:
        return getattr(owner, name)
    prop = owner.bl_rna.properties[name]
    return min(max(fc.evaluate(frame), prop.hard_min), prop.hard_max)


def keyed_value(ad, path, frame, owner, name):
    """A float setting `owner.name` (animated through `ad` at `path`) at `frame`, as Blender
    would hold it when playing that frame (float32); for bakes of keyframed settings."""
    return float(np.float32(_value(ad, path, 0, frame, owner, name)))


def _front_speed(v):
    """0 (gusts everywhere at once) or at least the 1 mm/s that the native wind takes for a
    travelling front: a slower front is the slowest one."""
    return v if v == 0.0 or v >= 1e-3 else 1e-3


def sines_kwargs(scene, frame):
    """Keyword arguments of the breeze, waves and gusts at `frame` (wind_set_sines)."""
    w = scene.tussock_wind
    ad = scene.animation_data
    v = {n: _value(ad, _PREFIX + n, 0, frame, w, n) for n in SINES_SETTINGS}
    rows = []
    for i, wv in enumerate(w.waves):
        a, d, L, sp, ph, k = (_value(ad, f"{_PREFIX}waves[{i}].{n}", 0, frame, wv, n)
                              for n in WAVE_SETTINGS)
        rows.append((a, math.cos(d), math.sin(d), L, sp, ph, k))
    waves = np.array(rows, np.float32).reshape(-1, 7)
    speed, heading = v["base_speed"], v["base_direction"]
    return dict(base_x=speed * math.cos(heading), base_y=speed * math.sin(heading),
                waves=waves.ravel(), gust_strength=v["gust_strength"],
                gust_interval=v["gust_interval"],
                gust_duration=min(v["gust_duration"], v["gust_interval"]),
                gust_dir_x=math.cos(heading), gust_dir_y=math.sin(heading),
                gust_front_speed=_front_speed(v["gust_front_speed"]),
                seed=max(0, int(round(v["seed"]))))


def fluid_kwargs(scene):
    """Keyword arguments of the fluid grid and continuum (none without the fluid wind)."""
    w = scene.tussock_wind
    if not w.use_fluid:
        return {}
    fps = scene.render.fps / scene.render.fps_base
    n = w.fluid_resolution
    return dict(nx=n, ny=n, cell_size=w.fluid_size / n,
                origin_x=w.fluid_center[0] - w.fluid_size / 2,
                origin_y=w.fluid_center[1] - w.fluid_size / 2,
                dt=1.0 / (fps * STEPS_PER_FRAME), speed=w.fluid_speed, decay=w.fluid_decay,
                continuum=w.use_continuum, c=w.continuum_c, gamma=w.continuum_gamma)


def wind_kwargs(scene, frame=None):
    """Keyword arguments of wind_create: the sines at `frame` (the current frame when None)
    and the fluid grid. Refuses keyframes on the fluid grid's settings (check_animation)."""
    check_animation(scene)
    kw = sines_kwargs(scene, scene.frame_current if frame is None else frame)
    kw.update(fluid_kwargs(scene))
    return kw


def check_settings(scene):
    """Raises the native wind's own error for the scene's wind settings (an unstable fluid
    or continuum, a grid too large) without stepping it: a bake asks before it plays any
    frame, since the frames it plays change what a simulated meadow shows."""
    lib = native.require()
    lib.wind_destroy(lib.wind_create(**wind_kwargs(scene)))


def frame_settings(scene, frames):
    """{frame: sines keyword arguments} for `frames`, read now on the main thread (F-curves
    need bpy), for a bake worker's Stepper. Refuses what a bake cannot read per frame."""
    check_animation(scene, baking=True)
    return {f: sines_kwargs(scene, f) for f in frames}


class Stepper:
    """The native wind of one set of settings, stepped frame by frame from `frame_start`.
    Pure: it holds no Blender data, so a bake worker thread can own one. `sources_at`
    gives the float32 (n, 8) source rows of a frame (read from Blender beforehand);
    `settings_at`, when given, the sines keyword arguments of a frame (keyframed breeze,
    waves and gusts: set before each frame is sampled; they hold no state, so they never
    change the fluid). With `keep`, fluid states are kept while stepping (see
    SNAPSHOT_BUDGET), so that going back restores the nearest kept state at or before the
    frame instead of stepping again from the first frame; without, going back starts
    again from the first frame."""

    def __init__(self, kwargs, frame_start, fps, sources_at, settings_at=None, keep=False,
                 progress=None):
        self.lib = native.require()
        self.kwargs = kwargs
        self.handle = self.lib.wind_create(**kwargs)
        self.frame_start = frame_start
        self.fps = fps
        self.frame = frame_start
        self.sources_at = sources_at
        self.settings_at = settings_at
        self.sines = None  # signature of the sines last set (None: those of `kwargs`)
        self.fluid = kwargs.get("nx", 0) > 0
        self.progress = progress  # progress(done, total, frame) during long re-steps
        self.frames_stepped = 0  # frames of fluid stepped so far (tests, panel)
        self.restored_from = None  # frame of the state the last jump resumed from
        self.snapshots = {}  # frame -> saved state (bytes)
        self.keep = keep and self.fluid
        cells = kwargs.get("nx", 0) * kwargs.get("ny", 0)
        self.every = max(1, min(SNAPSHOT_MAX_EVERY, SNAPSHOT_CELL_FRAMES // max(cells, 1)))
        if self.keep:
            self.snapshots[frame_start] = self.lib.wind_save_state(self.handle)

    # -- snapshots ------------------------------------------------------------------------
    def snapshot_bytes(self):
        return sum(len(b) for b in self.snapshots.values())

    def _keep_state(self):
        f = self.frame
        if (f - self.frame_start) % self.every or f in self.snapshots:
            return
        self.snapshots[f] = self.lib.wind_save_state(self.handle)
        while self.snapshot_bytes() > SNAPSHOT_BUDGET and len(self.snapshots) > 1:
            self.every *= 2  # thin out: keep every other one, take them half as often
            for g in [g for g in self.snapshots if (g - self.frame_start) % self.every]:
                del self.snapshots[g]

    def invalidate(self):
        """Forgets the kept states after the first frame (the wind sources changed, so they
        no longer are what stepping would give); the current state steps on as it is."""
        for f in [f for f in self.snapshots if f != self.frame_start]:
            del self.snapshots[f]

    def _restart(self):
        self.lib.wind_destroy(self.handle)
        self.handle = self.lib.wind_create(**self.kwargs)
        self.frame = self.frame_start
        self.sines = None

    # -- stepping -------------------------------------------------------------------------
    def advance(self, frame):
        """Steps the fluid to `frame` (restoring a kept state first when that is shorter or
        when going back) and sets the frame's sines; returns the time in seconds."""
        if self.fluid:
            target = max(frame, self.frame_start)  # still air before the first frame
            known = [f for f in self.snapshots if f <= target]
            snap = max(known) if known else None
            if target < self.frame or (snap is not None and snap > self.frame):
                if snap is not None:
                    self.lib.wind_load_state(self.handle, self.snapshots[snap])
                    self.frame = snap
                    self.sines = None  # the state holds the sines it was saved with
                else:
                    self._restart()
                self.restored_from = self.frame
            total, began, told = target - self.frame, time.monotonic(), None
            while self.frame < target:  # one frame of fluid at a time, sources as keyed then
                self.lib.wind_set_sources(self.handle, self.sources_at(self.frame).ravel())
                self.lib.wind_step(self.handle, STEPS_PER_FRAME)
                self.frame += 1
                self.frames_stepped += 1
                if self.keep:
                    self._keep_state()
                if self.progress is not None:
                    now = time.monotonic()
                    if now - (told or began) >= PROGRESS_SECONDS:
                        told = now
                        self.progress(total - (target - self.frame), total, target)
            if told is not None:
                self.progress(total, total, target)  # done: ends what was reported
        else:
            self.frame = frame
        if self.settings_at is not None:
            kw = self.settings_at(frame)
            sig = _signature(kw)
            if sig != self.sines:
                # a start long before any frame and no blend: exactly this set from now on
                self.lib.wind_set_sines(self.handle, -1e12, 0.0, **kw)
                self.sines = sig
        return (frame - self.frame_start) / self.fps

    def sample(self, frame, xyz):
        t = self.advance(frame)
        xyz = np.ascontiguousarray(xyz, np.float32)
        out = np.empty_like(xyz)
        self.lib.wind_sample_xyz(self.handle, t, xyz.ravel(), out.reshape(-1))
        return out


def _signature(kw):
    return repr(sorted((k, v.tobytes() if isinstance(v, np.ndarray) else v)
                       for k, v in kw.items()))


def _key(scene):
    """What the fluid of the scene's Stepper is made with: the fluid settings, the first
    frame and the frame rate (the sines are set per frame, they do not make a new one)."""
    return _signature(fluid_kwargs(scene)) + repr(scene.frame_start) + repr(fps_of(scene))


def _rna_values(struct):
    out = []
    for p in struct.bl_rna.properties:
        if p.identifier == "rna_type" or p.type not in {"FLOAT", "INT", "BOOLEAN", "ENUM"}:
            continue
        v = getattr(struct, p.identifier)
        out.append((p.identifier, tuple(v) if getattr(p, "is_array", False) else v))
    return out


def _curve_print(fc):
    """What an F-curve's values depend on: its keys, their handles and easing, its
    extrapolation, muting and modifiers."""
    keys = tuple((tuple(k.co), tuple(k.handle_left), tuple(k.handle_right), k.interpolation,
                  k.easing, k.back, k.amplitude, k.period) for k in fc.keyframe_points)
    mods = tuple(repr(_rna_values(m)) for m in fc.modifiers)
    return (fc.data_path, fc.array_index, fc.extrapolation, fc.mute, keys, mods)


def _channel(ad, path, index, current):
    fc = compat.fcurve(ad, path, index) if ad is not None else None
    return _curve_print(fc) if fc is not None else current


def keyed_print(ad, path, current):
    """For keys of what a frame depends on: a setting's keyframes when it is keyed (they
    do not change along the timeline), else its value `current`."""
    return _channel(ad, path, 0, current)


def settings_key(scene):
    """What the scene's wind at every frame depends on (settings, first frame, frame rate):
    a keyed setting by its keyframes, not by its value at the current frame, so that the
    key stays the same along the timeline. Keyframed wind sources are not part of it."""
    w = scene.tussock_wind
    ad = scene.animation_data
    sines = [_channel(ad, _PREFIX + n, 0, getattr(w, n)) for n in SINES_SETTINGS]
    for i, wv in enumerate(w.waves):
        sines += [_channel(ad, f"{_PREFIX}waves[{i}].{n}", 0, getattr(wv, n))
                  for n in WAVE_SETTINGS]
    return _key(scene) + repr(sines)


def sources_key(scene):
    """What the wind sources at every frame depend on: per source empty, its keyed channels
    by their keyframes and the others by their values."""
    parts = []
    for obj in scene.objects:
        s = compat.settings_of(obj, "tussock_wind_source")
        if s is None or not s.is_source:
            continue
        ad = obj.animation_data
        ch = [_channel(ad, "location", i, obj.location[i]) for i in range(3)]
        ch += [_channel(ad, "tussock_wind_source.strength", 0, s.strength),
               _channel(ad, "tussock_wind_source.radius", 0, s.radius),
               _channel(ad, "tussock_wind_source.interval", 0, s.interval), obj.rotation_mode]
        if len(obj.rotation_mode) == 3:
            ch += [_channel(ad, "rotation_euler", i, obj.rotation_euler[i]) for i in range(3)]
        else:
            ch.append(tuple(tuple(r) for r in obj.matrix_world.to_3x3()))
        parts.append((obj.name, ch))
    return repr(parts)


def fps_of(scene):
    return scene.render.fps / scene.render.fps_base


_progress_shown = [False]


def _report(done, total, frame):
    """Progress of a long re-step of the fluid (a first jump far ahead), on the console and
    on the mouse cursor of a window, so that Blender is not silently busy."""
    print(f"Tussock: stepping the fluid wind to frame {frame}: {done}/{total} frames",
          file=sys.stdout, flush=True)
    try:
        import bpy
        wm = bpy.context.window_manager
        if wm is None or bpy.context.window is None:
            return
        if done >= total:
            if _progress_shown[0]:
                wm.progress_end()
            _progress_shown[0] = False
            return
        if not _progress_shown[0]:
            wm.progress_begin(0, 100)
            _progress_shown[0] = True
        wm.progress_update(int(100 * done / max(total, 1)))
    except (AttributeError, RuntimeError):
        pass


def stepper(scene, frame):
    """The scene's cached Stepper (recreated when the fluid settings changed; its kept
    states are dropped when the wind sources changed)."""
    key = _key(scene)
    entry = _cache.get(scene.name)
    if entry is None or entry.key != key:
        entry = Stepper(wind_kwargs(scene), scene.frame_start, fps_of(scene),
                        lambda f, scene=scene: sources(scene, f),
                        settings_at=lambda f, scene=scene: sines_kwargs(scene, f),
                        keep=True, progress=_report)
        entry.key = key
        entry.sources_key = sources_key(scene) if entry.fluid else None
        _cache[scene.name] = entry
    else:
        # read this scene object (another file's scene of the same name, after a load or
        # a factory reset, gives the same wind if its key and sources are the same)
        entry.sources_at = lambda f, scene=scene: sources(scene, f)
        entry.settings_at = lambda f, scene=scene: sines_kwargs(scene, f)
        if entry.fluid and frame != entry.frame:  # (checked when the fluid is to move)
            skey = sources_key(scene)
            if entry.sources_key != skey:
                entry.invalidate()
                entry.sources_key = skey
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
