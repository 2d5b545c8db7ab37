"""tussock.capture_blades: depth frames in, blade objects out (DESIGN.md's contract).
Interactive runs read frames in a modal loop with a progress bar (Esc cancels); scripted
and background runs read synchronously. Nothing is created unless the capture succeeds."""

import time

import bpy
import numpy as np

from .. import compat, errors, meshes, native, progress
from . import blades, pipeline, preview
from .props import SOURCE_ITEMS, TIPS


class TUSSOCK_OT_capture_blades(bpy.types.Operator):
    """Capture every grass blade seen in depth frames as a blade object"""
    bl_idname = "tussock.capture_blades"
    bl_label = "Capture Blades"
    bl_options = {"REGISTER", "UNDO"}

    source: bpy.props.EnumProperty(name="Source", items=SOURCE_ITEMS, default="FILES",
                                   description=TIPS["source"])
    filepath: bpy.props.StringProperty(name="File", subtype="FILE_PATH",
                                       options=compat.PATH_OPTIONS,
                                       description=TIPS["filepath"])
    device_uri: bpy.props.StringProperty(name="Device", default="",
                                         description=TIPS["device_uri"])
    near: bpy.props.FloatProperty(name="Near", default=0.0, min=0.0, unit="LENGTH",
                                  description=TIPS["near"])
    far: bpy.props.FloatProperty(name="Far", default=0.0, min=0.0, unit="LENGTH",
                                 description=TIPS["far"])
    fx: bpy.props.FloatProperty(name="fx", default=0.0, min=0.0, subtype="PIXEL",
                                description=TIPS["fx"])
    fy: bpy.props.FloatProperty(name="fy", default=0.0, min=0.0, subtype="PIXEL",
                                description=TIPS["fy"])
    cx: bpy.props.FloatProperty(name="cx", default=0.0, min=0.0, subtype="PIXEL",
                                description=TIPS["cx"])
    cy: bpy.props.FloatProperty(name="cy", default=0.0, min=0.0, subtype="PIXEL",
                                description=TIPS["cy"])
    min_area: bpy.props.IntProperty(name="Minimum blade area", default=150, min=1,
                                    subtype="PIXEL",
                                    description=TIPS["min_area"])
    frames: bpy.props.IntProperty(name="Frames to average", default=1, min=1, max=300,
                                  description=TIPS["frames"])
    frame: bpy.props.IntProperty(name="First frame", default=0, min=0,
                                 description=TIPS["frame"])

    _timer = None
    _reader = None
    _src = None

    # ---- synchronous path (scripts, background, redo) ---------------------------------
    def execute(self, context):
        return errors.run(self, self._execute, context)

    def _execute(self, context):
        reader = self._open()
        try:
            while not reader.step(0.02):
                if reader.info["kind"] == "DEVICE":
                    time.sleep(0.02)
            return self._finish(context, reader)
        finally:
            self._close()

    # ---- modal path (interactive): progress and Esc ----------------------------------
    def invoke(self, context, event):
        s = context.scene.tussock_capture
        self.source, self.filepath, self.device_uri = s.source, s.filepath, s.device_uri
        self.near, self.far = (0.0, 0.0) if s.auto_band else (s.near, s.far)
        self.min_area, self.frames, self.frame = s.min_area, s.frames, s.frame
        result = errors.run(self, self._start_modal, context)
        return result

    def _start_modal(self, context):
        self._reader = self._open()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.02, window=context.window)
        progress.begin(context, "Tussock capture", "reading frames", self._reader.count)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC" and event.value == "PRESS":
            self._end_modal(context)
            self.report({"INFO"}, "Capture cancelled")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            done = self._reader.step(0.02)
            progress.update(context, self._reader.done)
        except Exception as exc:  # noqa: BLE001 - reported like any operator's failure
            self._end_modal(context)
            return errors.run(self, errors.reraise, exc)
        if not done:
            return {"RUNNING_MODAL"}
        reader = self._reader
        self._end_modal(context)
        return errors.run(self, self._finish, context, reader)

    def cancel(self, context):  # Blender ends the operator (a file is loaded, it quits)
        self._end_modal(context)

    def _end_modal(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
            progress.end(context)
        self._close()

    # ---- shared ------------------------------------------------------------------------
    def _open(self):
        path = bpy.path.abspath(self.filepath) if self.filepath else ""
        self._src = pipeline.open_source(self.source, path, self.device_uri)
        return pipeline.FrameReader(self._src, self.frame, self.frames)

    def _close(self):
        if self._src is not None:
            lib = native.lib
            if lib is not None:
                lib.depth_close(self._src)
            self._src = None

    def _finish(self, context, reader):
        """Processes the averaged frame and creates the blades (or raises, creating none)."""
        depth = reader.average()
        fx, fy, cx, cy = pipeline.intrinsics(reader.info, self.fx, self.fy, self.cx, self.cy)
        result = pipeline.process(depth, reader.width, reader.height, self.near, self.far, fx,
                                  fy, cx, cy, self.min_area)
        summary = result["summary"]
        if summary["blades"] == 0:
            raise ValueError(f"no blades found: {summary['message']}")
        provenance = {
            "source": self.source,
            "path": self.filepath if self.source != "DEVICE" else "",
            "device": (self.device_uri or "first device") if self.source == "DEVICE" else "",
            "frame": int(reader.info.get("first_frame", 0)) + self.frame,
            "frames_averaged": reader.done,
            "fx": fx, "fy": fy, "cx": cx, "cy": cy,
            "near": summary["near"], "far": summary["far"],
            "image_size": (reader.width, reader.height),
        }
        objs = blades.create_blades(context.scene, result["knot_counts"], result["camera_xyz"],
                                    result["width"], result["flags"], provenance,
                                    context.scene.cursor.location)
        img = result["images"]
        preview.show(preview.compose(img["DEPTH"], img["MASK"], img["LABELS"], img["OVERLAY"]))
        meshes.select_new(context, objs)
        cut = int(np.count_nonzero(result["flags"] & 1))
        msg = f"Captured {len(objs)} blades ({summary['message']})"
        if cut:
            self.report({"WARNING"}, f"{msg}; {cut} touch the image border and may be cut "
                                     "(property tussock_cut_by_border)")
        else:
            self.report({"INFO"}, msg)
        return {"FINISHED"}


def preview_tick(scene, src, info, depth):
    """One step of the live preview: reads the newest frame (a sequence or recording loops)
    and, if there is one, shows its capture in the preview image. Returns the capture's
    summary message, or "" when no new frame had arrived."""
    lib = native.require()
    frame = lib.depth_read(src, depth)
    if frame["end"] and info["kind"] != "DEVICE":
        lib.depth_seek(src, 0)  # a sequence or recording plays in a loop
    if not frame["is_new"]:
        return ""
    s = scene.tussock_capture
    near, far = (0.0, 0.0) if s.auto_band else (s.near, s.far)
    result = pipeline.process(depth, info["width"], info["height"], near, far, info["fx"],
                              info["fy"], info["cx"], info["cy"], s.min_area)
    img = result["images"]
    preview.show(preview.compose(img["DEPTH"], img["MASK"], img["LABELS"], img["OVERLAY"]))
    return result["summary"]["message"]


class TUSSOCK_OT_capture_preview(bpy.types.Operator):
    """Show the capture live in the Image Editor ('Tussock Capture Preview'): depth, mask,
    each blade in its colour, contours and skeletons. Esc or right-click stops"""
    bl_idname = "tussock.capture_preview"
    bl_label = "Live Preview"

    _timer = None
    _src = None

    def invoke(self, context, event):
        return errors.run(self, self._start, context)

    def _start(self, context):
        s = context.scene.tussock_capture
        path = bpy.path.abspath(s.filepath) if s.filepath else ""
        self._src = pipeline.open_source(s.source, path, s.device_uri)
        self._info = native.lib.depth_info(self._src)
        self._depth = np.empty(self._info["width"] * self._info["height"], np.float32)
        wm = context.window_manager
        self._timer = wm.event_timer_add(1.0 / 15.0, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type in {"ESC", "RIGHTMOUSE"}:
            self._stop(context)
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            message = preview_tick(context.scene, self._src, self._info, self._depth)
            if message:
                context.workspace.status_text_set(f"Tussock preview: {message} (Esc to stop)")
        except (native.Error, ValueError) as exc:
            # a frame without blades is not an error for a preview; a lost device is
            if "device" in str(exc).lower():
                self._stop(context)
                self.report({"ERROR"}, f"Tussock: {exc}")
                return {"CANCELLED"}
            context.workspace.status_text_set(f"Tussock preview: {exc}")
        return {"RUNNING_MODAL"}

    def _stop(self, context):
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None
        if self._src is not None and native.lib is not None:
            native.lib.depth_close(self._src)
            self._src = None
        context.workspace.status_text_set(None)


classes = (TUSSOCK_OT_capture_blades, TUSSOCK_OT_capture_preview)
