"""Wind operators: add a wind source empty, add/remove sine waves, and paint the wind
field into a debug image ('Tussock Wind') that the Image Editor shows."""

import math

import bpy
import numpy as np

from .. import bounds, errors, meshes, native
from . import runtime
from .props import MAX_WAVES, TussockWindSource

DEBUG_IMAGE = "Tussock Wind"


class TUSSOCK_OT_add_wind_source(bpy.types.Operator):
    """Add a wind source: an arrow empty that pushes the fluid wind where it points"""
    bl_idname = "tussock.add_wind_source"
    bl_label = "Add Wind Source"
    bl_options = {"REGISTER", "UNDO"}

    # the stored settings' definitions, checked against their limits in _add (bounds.py)
    strength: bounds.operator_property(TussockWindSource.__annotations__["strength"])
    radius: bounds.operator_property(TussockWindSource.__annotations__["radius"])
    interval: bounds.operator_property(TussockWindSource.__annotations__["interval"])

    def execute(self, context):
        return errors.run(self, self._add, context)

    def _add(self, context):
        # the stored limits, then the native wind's (tsk_wind_source_validate), checked before
        # anything is made: a NaN or huge value would otherwise sit in the scene and fail
        # every wind frame
        bounds.check_operator(self, TussockWindSource, ("strength", "radius", "interval"))
        for name, lo, hi in (("strength", 0.0, 1.0), ("radius", 1e-4, 1e6),
                             ("interval", 0.0, 1e6)):
            v = getattr(self, name)
            if not (math.isfinite(v) and lo <= v <= hi):
                raise ValueError(f"{name}: must be finite and in [{lo:g}, {hi:g}], got {v}")
        obj = bpy.data.objects.new("Wind Source", None)
        obj.empty_display_type = "SINGLE_ARROW"
        obj.empty_display_size = 1.0
        obj.location = context.scene.cursor.location
        obj.rotation_euler = (0.0, math.pi / 2, 0.0)  # the arrow (+Z) points along +X
        s = obj.tussock_wind_source
        s.is_source = True
        s.strength, s.radius, s.interval = self.strength, self.radius, self.interval
        context.collection.objects.link(obj)
        meshes.select_new(context, [obj])
        if not context.scene.tussock_wind.use_fluid:
            self.report({"INFO"}, "Wind sources push the fluid wind: turn on Fluid wind")
        return {"FINISHED"}


class TUSSOCK_OT_wind_wave_add(bpy.types.Operator):
    """Add a sine wave to the scene's wind (up to 8)"""
    bl_idname = "tussock.wind_wave_add"
    bl_label = "Add Wave"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        waves = context.scene.tussock_wind.waves
        if len(waves) >= MAX_WAVES:
            self.report({"ERROR"}, f"Tussock: the wind has at most {MAX_WAVES} waves")
            return {"CANCELLED"}
        waves.add()
        return {"FINISHED"}


class TUSSOCK_OT_wind_wave_remove(bpy.types.Operator):
    """Remove a sine wave from the scene's wind"""
    bl_idname = "tussock.wind_wave_remove"
    bl_label = "Remove Wave"
    bl_options = {"REGISTER", "UNDO"}

    index: bpy.props.IntProperty(default=0, min=0,
                                 description="Number of the wave to remove, from 0")

    def execute(self, context):
        waves = context.scene.tussock_wind.waves
        if self.index >= len(waves):
            self.report({"ERROR"}, f"Tussock: no wave {self.index + 1}")
            return {"CANCELLED"}
        waves.remove(self.index)
        return {"FINISHED"}


def field_image(scene, frame, size=128, extent=None):
    """(rgba (size, size, 4) float32 top row first, max speed) of the wind over the ground:
    hue = direction, brightness = speed relative to the largest speed in view."""
    w = scene.tussock_wind
    if extent is None:
        half = w.fluid_size / 2
        extent = (w.fluid_center[0] - half, w.fluid_center[1] - half, w.fluid_size)
    x0, y0, side = extent
    c = (np.arange(size, dtype=np.float32) + 0.5) / size * side
    gx, gy = np.meshgrid(x0 + c, y0 + c)  # row 0 at y0 (bottom)
    xyz = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size, np.float32)], axis=1)
    vel = runtime.sample(scene, frame, xyz)
    speed = np.hypot(vel[:, 0], vel[:, 1])
    top = float(speed.max()) if speed.size else 0.0
    hue = (np.arctan2(vel[:, 1], vel[:, 0]) / (2 * np.pi)) % 1.0
    value = speed / top if top > 0 else speed
    # HSV (s = 1) to RGB, vectorised
    h6 = hue * 6.0
    k = np.stack([(5 + h6) % 6, (3 + h6) % 6, (1 + h6) % 6], axis=1)
    rgb = value[:, None] * (1 - np.clip(np.minimum(k, 4 - k), 0, 1))
    rgba = np.ones((size * size, 4), np.float32)
    rgba[:, :3] = rgb
    return rgba.reshape(size, size, 4)[::-1], top


def show_field(scene, frame, size=128):
    rgba, top = field_image(scene, frame, size)
    img = bpy.data.images.get(DEBUG_IMAGE)
    if img is None or tuple(img.size) != (size, size):
        if img is not None:
            bpy.data.images.remove(img)
        img = bpy.data.images.new(DEBUG_IMAGE, size, size, float_buffer=True)
    img.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())
    img.update()
    img["tussock_max_speed"] = top
    img["tussock_frame"] = frame
    return img


class TUSSOCK_OT_wind_debug_image(bpy.types.Operator):
    """Paint the scene's wind at this frame into the image 'Tussock Wind'
    (hue: direction, brightness: speed)"""
    bl_idname = "tussock.wind_debug_image"
    bl_label = "Show Wind"
    bl_options = {"REGISTER"}

    size: bpy.props.IntProperty(name="Size", default=128, min=8, max=2048,
                                description="Pixels per side of the wind image")

    def execute(self, context):
        return errors.run(self, self._show, context)

    def _show(self, context):
        native.require()
        img = show_field(context.scene, context.scene.frame_current, self.size)
        for window in context.window_manager.windows if context.window_manager else ():
            for area in window.screen.areas:
                if area.type == "IMAGE_EDITOR":
                    area.spaces.active.image = img
        self.report({"INFO"}, f"Wind at frame {context.scene.frame_current}: "
                              f"up to {img['tussock_max_speed']:.2f} m/s")
        return {"FINISHED"}


classes = (TUSSOCK_OT_add_wind_source, TUSSOCK_OT_wind_wave_add, TUSSOCK_OT_wind_wave_remove,
           TUSSOCK_OT_wind_debug_image)
