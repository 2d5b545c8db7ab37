"""Movement data for refining: the trajectories of a blade's knots over n frames, either
tracked through the depth sequence the blade was captured from (seed 000 §4.4: knots
acquired every few milliseconds), or simulated by the native bending model for a still
capture. No bpy objects are changed here."""

import bpy
import numpy as np

from .. import native
from ..capture import pipeline


def simulated(knots, widths, frames, fps):
    """(frames, K, 3) trajectories of a still blade under Tussock's standard wind."""
    lib = native.require()
    out = np.empty(frames * len(widths) * 3, np.float32)
    lib.refine_simulate(np.ascontiguousarray(knots, np.float32).ravel(),
                        np.ascontiguousarray(widths, np.float32), frames, out, fps=float(fps))
    return out.reshape(frames, len(widths), 3)


def tracked(obj, knots_camera, frames):
    """Trajectories (camera frame, metres) of the blade's knots through the depth sequence
    it was captured from: each frame is captured again, the blade whose root is nearest to
    this blade's root is taken, and its skeleton is matched to the knots by arc length."""
    lib = native.require()
    if obj.get("tussock_source") not in ("FILES", "ONI"):
        raise ValueError(f"'{obj.name}' was not captured from a depth sequence or recording; "
                         "use simulated movement")
    path = bpy.path.abspath(obj["tussock_path"])
    src = pipeline.open_source(obj["tussock_source"], path, "")
    try:
        info = lib.depth_info(src)
        total = info["frame_count"]
        first = int(obj.get("tussock_frame", info["first_frame"])) - info["first_frame"]
        if total - first < frames:
            raise ValueError(f"frames: the sequence has {total - first} frames from frame "
                             f"{first}, fewer than {frames}")
        lib.depth_seek(src, first)
        w, h = info["width"], info["height"]
        depth = np.empty(w * h, np.float32)
        kw = dict(near=float(obj["tussock_near"]), far=float(obj["tussock_far"]),
                  fx=float(obj["tussock_fx"]), fy=float(obj["tussock_fy"]),
                  cx=float(obj["tussock_cx"]), cy=float(obj["tussock_cy"]), min_area=150)
        root = knots_camera[0]
        skeletons, offsets = [], [0]
        for f in range(frames):  # one capture per frame
            lib.depth_read(src, depth)
            result = pipeline.process(depth, w, h, **kw)
            counts = result["knot_counts"]
            if len(counts) == 0:
                raise ValueError(f"frame {first + f}: no blades found to track")
            starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
            roots = result["camera_xyz"][starts]
            b = int(np.argmin(np.linalg.norm(roots - root, axis=1)))
            skeletons.append(result["camera_xyz"][starts[b]:starts[b] + counts[b]])
            offsets.append(offsets[-1] + int(counts[b]))
    finally:
        lib.depth_close(src)
    frame_knots = np.ascontiguousarray(np.concatenate(skeletons), np.float32)
    out = np.empty(frames * len(knots_camera) * 3, np.float32)
    lib.refine_track(np.ascontiguousarray(knots_camera, np.float32).ravel(), frame_knots.ravel(),
                     np.array(offsets, np.int32), out)
    return out.reshape(frames, len(knots_camera), 3)
