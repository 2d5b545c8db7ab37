"""The capture pipeline seen from Python: open a depth source, read and average frames,
run the native pipeline, and return plain numpy arrays. No bpy here."""

import numpy as np

from .. import native

SOURCES = ("FILES", "ONI", "DEVICE")
DEVICE_WAIT_S = 5.0  # how long to wait for each frame of a live device


def open_source(source, path, device_uri):
    lib = native.require()
    if source == "FILES":
        if not path:
            raise ValueError("filepath: choose a depth image or a numbered sequence")
        return lib.depth_open_files(path)
    if source == "ONI":
        if not path:
            raise ValueError("filepath: choose an OpenNI2 recording (.oni)")
        return lib.depth_open_oni(path)
    if source == "DEVICE":
        src = lib.depth_open_device(device_uri or "")
        lib.depth_start(src)
        return src
    raise ValueError(f"source: must be one of {', '.join(SOURCES)}, got {source!r}")


class FrameReader:
    """Reads `count` frames from `first` on, one per call to step(), so that a modal
    operator can show progress and cancel between frames."""

    def __init__(self, src, first, count):
        self.lib = native.require()
        self.src = src
        self.info = self.lib.depth_info(src)
        self.width, self.height = self.info["width"], self.info["height"]
        if count < 1:
            raise ValueError(f"frames: must be at least 1, got {count}")
        if self.info["kind"] != "DEVICE":
            total = self.info["frame_count"]
            if first < 0 or first >= total:
                raise ValueError(f"frame: must be in 0..{total - 1} for this source, got {first}")
            count = min(count, total - first)
            self.lib.depth_seek(src, first)
        self.count = count
        self.frames = np.zeros((count, self.width * self.height), np.float32)
        self.done = 0
        self.waited = 0.0

    def step(self, dt=0.02):
        """Reads the next frame if one is there. Returns True when all frames are read."""
        if self.done >= self.count:
            return True
        frame = self.lib.depth_read(self.src, self.frames[self.done])
        if frame["is_new"]:
            self.done += 1
            self.waited = 0.0
        elif frame["end"]:
            raise ValueError(f"the source ended after {self.done} frames")
        else:
            self.waited += dt
            if self.waited > DEVICE_WAIT_S:
                raise ValueError(f"device: no frame for {DEVICE_WAIT_S:.0f} s")
        return self.done >= self.count

    def average(self):
        """Median of the frames per pixel, ignoring pixels without data (0)."""
        if self.done == 1:
            return self.frames[0]
        stack = self.frames[:self.done].copy()
        stack[stack == 0.0] = np.nan
        with np.errstate(all="ignore"):
            med = np.nanmedian(stack, axis=0)
        return np.ascontiguousarray(np.nan_to_num(med, nan=0.0), np.float32)


def intrinsics(info, fx, fy, cx, cy):
    """The operator's intrinsics where given (all four), else the source's."""
    if fx > 0 and fy > 0 and cx > 0 and cy > 0:
        return fx, fy, cx, cy
    if any(v > 0 for v in (fx, fy, cx, cy)):
        raise ValueError("fx, fy, cx, cy: give all four, or leave all at 0 for the source's")
    return info["fx"], info["fy"], info["cx"], info["cy"]


def process(depth, width, height, near, far, fx, fy, cx, cy, min_area):
    """Runs the native pipeline on one depth frame; returns a dict of numpy arrays."""
    lib = native.require()
    cap = lib.capture_create()
    lib.capture_process(cap, depth, width, height, near=near, far=far, fx=fx, fy=fy, cx=cx,
                        cy=cy, min_area=min_area)
    summary = lib.capture_summary(cap)
    n, k = summary["blades"], summary["knots"]
    counts = np.empty(n, np.int32)
    flags = np.empty(n, np.int32)  # bit flags (TSK_BLADE_*), passed as int32
    xyz = np.empty(k * 3, np.float32)
    width_m = np.empty(k, np.float32)
    if n:
        lib.capture_blades(cap, counts, flags)
        lib.capture_knots(cap, xyz, width_m, None)
    images = {}
    for which in ("DEPTH", "MASK", "LABELS", "OVERLAY"):
        img = np.empty(width * height, np.uint8)
        lib.capture_image(cap, which, img)
        images[which] = img.reshape(height, width)
    return dict(summary=summary, knot_counts=counts, flags=flags, camera_xyz=xyz.reshape(-1, 3),
                width=width_m, images=images)
