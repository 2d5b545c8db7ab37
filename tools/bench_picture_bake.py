"""Benchmarks of picture bakes in background Blender (run by ./build.sh bench):

* `picture_bake_1080p`: ms per frame of tussock.bake for the sample picture enlarged to
  1920 x 1080 with its two layers (UV pass of each layer computed, written as a float EXR
  with its sidecar, synced to disk); `picture_bake_1080p_mb` the EXR megabytes per layer and
  frame.
* `picture_bake_frame_change_1080p`: ms per frame change when the frame is read from the
  bake (each frame's files verified once: read and checksummed), against
  `picture_live_frame_change_1080p`, the same frames computed live and written into
  Blender's images.

usage: blender_run.py tools/bench_picture_bake.py -- [NAME...]"""

import os
import statistics
import sys
import tempfile
import time

import addon_utils
import bpy
import numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import emit, wanted  # noqa: E402
import picture_sample_scene  # noqa: E402

PICTURE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "samples",
                       "picture")
FRAMES = 12
REPEATS = 3


def enlarge(lib, src, dst, f=4):
    """The sample file enlarged f times (nearest pixel), written as 8-bit PNG by Blender."""
    p = lib.picture_load(src)
    w, h = lib.picture_size(p)
    rgba = np.empty((h, w, 4), np.float32)
    lib.picture_read_rgba(p, rgba)
    big = np.repeat(np.repeat(rgba, f, axis=0), f, axis=1)
    im = bpy.data.images.new("tmp", w * f, h * f, alpha=True)
    im.pixels.foreach_set(np.ascontiguousarray(big[::-1]).ravel())
    im.filepath_raw, im.file_format = dst, "PNG"
    im.save()
    bpy.data.images.remove(im)


def scene_in(folder):
    from tussock import native
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("tussock", default_set=True)
    lib = native.require()
    for name in picture_sample_scene.FILES:
        enlarge(lib, os.path.join(PICTURE, name), os.path.join(folder, name))
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(folder, "bench.blend"))
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, FRAMES
    picture_sample_scene.describe(scene.tussock_picture, "//")
    assert bpy.ops.tussock.animate_picture() == {"FINISHED"}
    assert (scene.render.resolution_x, scene.render.resolution_y) == (1920, 1080)
    return scene


def main():
    from tussock.picture import baking as picture_bake
    from tussock.picture import frames
    with tempfile.TemporaryDirectory(dir=os.environ.get("TSK_TEST_TMP")) as folder:
        scene = scene_in(folder)
        params = {"width": 1920, "height": 1080, "layers": 2, "frames": FRAMES,
                  "fluid": scene.tussock_wind.fluid_resolution,
                  "load_average": round(os.getloadavg()[0], 2)}
        bake_ms, live_ms, baked_ms = [], [], []
        for _ in range(REPEATS):
            assert bpy.ops.tussock.free_bake() == {"FINISHED"}
            frames.forget()
            frames.built(scene)  # the separation is Animate Picture's cost, not the bake's
            t = time.perf_counter()
            assert bpy.ops.tussock.bake() == {"FINISHED"}
            bake_ms.append((time.perf_counter() - t) * 1000 / FRAMES)
            picture_bake._verified.clear()
            t = time.perf_counter()
            for f in range(1, FRAMES + 1):
                scene.frame_set(f)
            baked_ms.append((time.perf_counter() - t) * 1000 / FRAMES)
            assert picture_bake.frame_problem(scene, FRAMES) is None
        folder_uv = os.path.join(folder, "tussock_cache", picture_bake.uv_name(scene, 1))
        sizes = [os.path.getsize(os.path.join(folder_uv, n)) for n in os.listdir(folder_uv)
                 if n.endswith(".exr")]
        assert bpy.ops.tussock.free_bake() == {"FINISHED"}
        for _ in range(REPEATS):
            frames.forget()
            frames.built(scene)
            scene.frame_set(1)
            t = time.perf_counter()
            for f in range(2, FRAMES + 1):
                scene.frame_set(f)
            live_ms.append((time.perf_counter() - t) * 1000 / (FRAMES - 1))
        if wanted("picture_bake_1080p"):
            emit("picture_bake_1080p", statistics.median(bake_ms), "ms per frame", params)
            emit("picture_bake_1080p_mb", statistics.median(sizes) / 1e6,
                 "MB per layer and frame", params)
        if wanted("picture_bake_frame_change_1080p"):
            emit("picture_bake_frame_change_1080p", statistics.median(baked_ms),
                 "ms per frame change", params)
            emit("picture_live_frame_change_1080p", statistics.median(live_ms),
                 "ms per frame change", params)


if wanted("picture_bake") or wanted("picture_live"):
    main()
