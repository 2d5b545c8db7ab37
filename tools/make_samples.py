"""Makes Tussock's sample data (run in background Blender through tools/blender_run.py):
samples/blades/depth_####.png, a 16-bit depth sequence (millimetres) of a five-blade
cluster swaying in a light wind, rendered by Cycles from analytic blades
(tools/depth_scene.py), and samples/blades/cluster.exr, its first frame in metres.

usage: blender_run.py tools/make_samples.py -- OUTPUT_DIR [FRAMES]"""

import math
import os
import shutil
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import depth_scene  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
out = os.path.abspath(args[0])
frames = int(args[1]) if len(args) > 1 else 12
os.makedirs(out, exist_ok=True)

for f in range(frames):
    scene = depth_scene.setup_camera_scene()
    import addon_utils
    addon_utils.enable("tussock")
    phase = 2.0 * math.pi * f / frames
    sway = [0.18 * math.sin(phase + 0.9 * i) for i in range(5)]
    for i, blade in enumerate(depth_scene.standard_cluster(sway=sway)):
        depth_scene.blade_mesh(f"blade {i}", blade["centre"], blade["width"])
    exr, png = depth_scene.render_depth(scene, out, f"depth_{f + 1:04d}")
    if f == 0:
        shutil.copyfile(exr, os.path.join(out, "cluster.exr"))
    os.remove(exr)
    print(f"wrote {png}")
bpy.ops.wm.read_factory_settings(use_empty=True)
