"""tussock.animate_picture (sets a scene up to animate a picture) and the layer list's
add / remove operators."""

import math
import types

import bpy
import numpy as np

from .. import compat, errors, native
from ..nodes import picture_compositor
from ..wind import runtime as wind_runtime
from . import frames, layers
from .props import TussockPictureLayer

PICTURE_TAG = "tussock_picture"  # custom property of the image empty showing the picture


def _abspath(path):
    return bpy.path.abspath(path) if path else ""


def _default_layer(mask_path):
    """A layer with every setting at its default and a mask file (a plain namespace with
    the attributes of TussockPictureLayer)."""
    d = {}
    for p in TussockPictureLayer.bl_rna.properties:
        if p.identifier == "rna_type":
            continue
        d[p.identifier] = tuple(p.default_array) if getattr(p, "is_array", False) \
            else p.default
    d.update(name="Layer 1", mask_mode="FILE", mask_path=mask_path)
    return types.SimpleNamespace(**d)


def _copy_layer(src, dst):
    for name in TussockPictureLayer.__annotations__:
        setattr(dst, name, getattr(src, name))
    dst.name = src.name


def _float_image(name, width, height):
    img = bpy.data.images.get(name)
    if img is not None and (tuple(img.size) != (width, height) or not img.is_float):
        bpy.data.images.remove(img)
        img = None
    if img is None:
        img = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    img.alpha_mode = "PREMUL"
    return img


def _check_motion(scene, built, layer_list, loop_frames):
    """Runs every layer's warp once on a still field, so that a bad motion setting (NaN
    lambda, a negative cell, r out of range...) is refused before the scene changes."""
    lib = native.require()
    if loop_frames < 0:
        raise ValueError(f"loop frames must be >= 0, got {loop_frames}")
    zero = np.zeros(1, np.float32)
    uv = np.empty(built.width * built.height * 4, np.float32)
    for i, layer in enumerate(layer_list):
        kw = frames.warp_kwargs(scene, layer, built.height)
        if built.scale_maps[i] is not None:
            kw["scale_map"] = built.scale_maps[i]
        try:
            lib.picture_layer_frame(built.handle, i, zero, zero, 1, 1, uv=uv, **kw)
        except native.Error as exc:
            raise native.Error(f"layer {i + 1}: {exc}") from None


def _check_wind(scene, enable):
    """Creates the wind the frames will use (fluid and continuum on when `enable`), so
    that an unstable wave speed or a bad grid is refused before the scene changes."""
    w = scene.tussock_wind
    old = (w.use_fluid, w.use_continuum)
    try:
        if enable:
            w.use_fluid, w.use_continuum = True, True
        kwargs = wind_runtime.wind_kwargs(scene)
    finally:
        if (w.use_fluid, w.use_continuum) != old:
            w.use_fluid, w.use_continuum = old
    native.require().wind_create(**kwargs)


class TUSSOCK_OT_animate_picture(bpy.types.Operator):
    """Animate the vegetation of a still picture in the scene's wind: separate the layers,
    fill the background, and build the compositor tree that renders every frame"""
    bl_idname = "tussock.animate_picture"
    bl_label = "Animate Picture"
    bl_options = {"REGISTER", "UNDO"}

    filepath: bpy.props.StringProperty(name="Picture", subtype="FILE_PATH",
                                       options=compat.PATH_OPTIONS,
                                       description="Picture file; empty = the scene's "
                                       "Tussock picture settings")
    mask_path: bpy.props.StringProperty(name="Mask", subtype="FILE_PATH",
                                        options=compat.PATH_OPTIONS,
                                        description="Mask file of a single layer with "
                                        "default motion, replacing the scene's layers; "
                                        "empty = the scene's layers")
    enable_wind: bpy.props.BoolProperty(name="Turn on fluid wind", default=True,
                                        description="Turn on the scene wind's fluid grid "
                                        "and wave continuum, which move the picture")
    add_wind_source: bpy.props.BoolProperty(name="Add wind source", default=True,
                                            description="Add a wind source empty at the "
                                            "picture's left edge when the scene has none")

    def execute(self, context):
        return errors.run(self, self._animate, context)

    def _animate(self, context):
        native.require()
        scene = context.scene
        settings = scene.tussock_picture
        layer_list = [_default_layer(self.mask_path)] if self.mask_path \
            else list(settings.layers)
        path = self.filepath or settings.filepath
        spec = frames.spec(settings, path, layer_list)
        picture_path = _abspath(spec["filepath"])
        # everything that can fail runs before the scene changes
        built = layers.build(spec, frames.image_pixels, _abspath)
        _check_motion(scene, built, layer_list, settings.loop_frames)
        _check_wind(scene, self.enable_wind)

        if self.filepath:
            settings.filepath = self.filepath
        if self.mask_path:
            settings.layers.clear()
            _copy_layer(layer_list[0], settings.layers.add())
            settings.active_layer = 0
        w, h = built.width, built.height
        settings.background_image = _float_image("Tussock Background", w, h)
        pairs = []
        settings.images.clear()
        for i, layer in enumerate(settings.layers, 1):
            if not layer.name:
                layer.name = f"Layer {i}"
            out = settings.images.add()
            out.layer_image = _float_image(f"Tussock Layer {i}", w, h)
            out.uv_image = _float_image(f"Tussock UV {i}", w, h)
            pairs.append((out.layer_image, out.uv_image))
        self._remove_stale_images(len(pairs))
        picture_compositor.build(scene, settings.background_image, pairs)
        self._render_settings(scene, w, h, picture_path)
        if self.enable_wind:
            scene.tussock_wind.use_fluid = True
            scene.tussock_wind.use_continuum = True
        self._picture_empty(context, scene, picture_path, w, h)
        if self.add_wind_source:
            self._wind_source(context, scene, w, h)
        settings.applied = frames.dumps(spec)
        settings.last_error = ""
        frames.install(scene, settings.applied, built)
        frames.write_rest_images(scene, built)
        frames.update(scene)
        self.report({"INFO"}, f"Tussock: {w}x{h} picture, {len(pairs)} layer(s)")
        return {"FINISHED"}

    @staticmethod
    def _remove_stale_images(count):
        for prefix in ("Tussock Layer ", "Tussock UV "):
            for img in [im for im in bpy.data.images if im.name.startswith(prefix)]:
                tail = img.name[len(prefix):]
                if tail.isdigit() and int(tail) > count:
                    bpy.data.images.remove(img)

    @staticmethod
    def _render_settings(scene, width, height, path):
        r = scene.render
        r.resolution_x, r.resolution_y = width, height
        r.resolution_percentage = 100
        r.pixel_aspect_x = r.pixel_aspect_y = 1.0
        r.use_compositing = True
        # The layers are Non-Color (the warp works on the stored values): PNG and JPEG
        # values are sRGB-encoded already and go out unchanged (Raw); EXR is linear.
        v = scene.view_settings
        v.view_transform = "Standard" if path.lower().endswith(".exr") else "Raw"
        v.look = "None"
        v.exposure, v.gamma = 0.0, 1.0

    @staticmethod
    def _picture_empty(context, scene, path, width, height):
        """An image empty showing the picture where the wind blows over it."""
        obj = next((o for o in scene.objects if o.get(PICTURE_TAG)), None)
        if obj is None:
            obj = bpy.data.objects.new("Tussock Picture", None)
            obj[PICTURE_TAG] = True
            context.collection.objects.link(obj)
        obj.empty_display_type = "IMAGE"
        obj.data = bpy.data.images.load(path, check_existing=True)
        x0, y0, px = frames.picture_rect(scene, width, height)
        obj.empty_display_size = max(width, height) * px
        obj.location = (x0 + 0.5 * width * px, y0 + 0.5 * height * px, 0.0)
        obj.rotation_euler = (0.0, 0.0, 0.0)
        obj.scale = (1.0, 1.0, 1.0)
        obj.hide_select = False

    @staticmethod
    def _wind_source(context, scene, width, height):
        if any(o.tussock_wind_source.is_source for o in scene.objects):
            return
        x0, y0, px = frames.picture_rect(scene, width, height)
        obj = bpy.data.objects.new("Tussock Wind", None)
        obj.empty_display_type = "SINGLE_ARROW"
        s = obj.tussock_wind_source
        s.is_source = True
        s.radius = 0.3 * max(width, height) * px
        s.strength, s.interval = 1.0, 1.0  # a push a second: the vegetation sways
        obj.empty_display_size = s.radius
        # the arrow (local +Z) points along +X: the wind blows from the left edge
        obj.location = (x0 + 0.1 * width * px, y0 + 0.5 * height * px, 0.0)
        obj.rotation_euler = (0.0, math.pi / 2, 0.0)
        context.collection.objects.link(obj)


class TUSSOCK_OT_picture_layer_add(bpy.types.Operator):
    """Add a vegetation layer (layers go back to front)"""
    bl_idname = "tussock.picture_layer_add"
    bl_label = "Add Picture Layer"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        s = context.scene.tussock_picture
        layer = s.layers.add()
        layer.name = f"Layer {len(s.layers)}"
        s.active_layer = len(s.layers) - 1
        return {"FINISHED"}


class TUSSOCK_OT_picture_layer_remove(bpy.types.Operator):
    """Remove the selected vegetation layer"""
    bl_idname = "tussock.picture_layer_remove"
    bl_label = "Remove Picture Layer"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return len(context.scene.tussock_picture.layers) > 0

    def execute(self, context):
        s = context.scene.tussock_picture
        s.layers.remove(s.active_layer)
        s.active_layer = max(0, min(s.active_layer, len(s.layers) - 1))
        return {"FINISHED"}


classes = (TUSSOCK_OT_animate_picture, TUSSOCK_OT_picture_layer_add,
           TUSSOCK_OT_picture_layer_remove)
