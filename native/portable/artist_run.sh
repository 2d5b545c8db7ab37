#!/bin/bash
# Inside an artist's root (build.sh run_artist_checks): installs the linux_x64 zip as an
# artist does, checks where its libraries come from, and runs the artist's path
# (tools/artist_check.py) in a new Blender that has Tussock enabled by its preferences.
#   artist_run.sh REPO OUT ONI      (environment: TSK_ARTIST_ZIP, HOME: a fresh folder)
set -euo pipefail
repo="$1"
out="$2"
oni="$3"
zip="${TSK_ARTIST_ZIP:?the zip to install}"
rm -rf "$HOME" "$out"
mkdir -p "$HOME" "$out/work"
blender --version 2>/dev/null | head -n 1
blender --command extension install-file -r user_default -e "$zip"
# Where the module's libraries come from: OpenNI2 from the extension's own lib/ (OpenCV,
# OpenSubdiv and libstdc++ are inside the module; any of the system's that is mapped was
# loaded by Blender itself, and is listed for the record).
blender -b --python-exit-code 1 --python-expr '
import sys
import addon_utils
from importlib import import_module
name = "bl_ext.user_default.tussock"
assert addon_utils.check(name)[1], f"{name} is not enabled after install-file -e"
folder = sys.modules[name].__path__[0]
native = import_module(name + ".native")
assert native.available(), native.error
maps = sorted({ln.split()[-1] for ln in open("/proc/self/maps") if "/" in ln})
oni = [p for p in maps if "OpenNI2" in p]
assert oni and all(p.startswith(folder + "/") for p in oni), oni
print("Tussock", native.version(), "enabled from", folder)
print("OpenNI2:", oni)
print("mapped by Blender itself:", [p for p in maps if any(k in p for k in ("opencv", "osd", "stdc++"))])
'
blender -b --python-exit-code 1 --python "$repo/tools/artist_check.py" -- "$out/out.json" \
  "$out/work" "$repo/samples" "$oni"

# A farm node is an artist's machine too (TSK_ARTIST_FARM=1): the shot artist_check saved
# (64x48), made shorter (4 samples, frames 1-6), baked and rendered by the farm command's
# local back end in 2 tasks with the installed extension, and by one Blender process that
# bakes and renders it alone. The caches must have the same bytes and the frames the same
# pixels (the PNG files also hold Cycles' render times). This found that render tasks run
# as `-s 4 -e 6 -a` showed the live animation: -s and -e change the frame range that
# Tussock checks a bake against (addon/farm/plan.py now renders with -f 4..6).
if [ "${TSK_ARTIST_FARM:-0}" = 1 ]; then
  ext="$(echo "$HOME"/.config/blender/*/extensions/user_default/tussock)"
  [ -f "$ext/farm/__main__.py" ] || { echo "no farm command in $ext" >&2; exit 1; }
  shot="$out/shot"
  cp -a "$out/work" "$shot"
  rm -rf "$shot/tussock_cache" "$shot/frame.png"
  blender -b "$shot/shot.blend" --python-exit-code 1 --python-expr '
import bpy
s = bpy.context.scene
s.frame_start, s.frame_end = 1, 6
s.cycles.samples = 4
bpy.ops.wm.save_mainfile()
'
  cp -a "$shot" "$out/single"
  python3 "$ext/farm" run "$shot/shot.blend" --backend local --tasks 2
  blender -b "$out/single/shot.blend" --python-exit-code 1 --python-expr '
import bpy
assert bpy.ops.tussock.bake(frame_start=1, frame_end=6) == {"FINISHED"}
r = bpy.context.scene.render
r.filepath = "//render/shot_####"
r.use_file_extension = True
r.image_settings.file_format = "PNG"
bpy.ops.render.render(animation=True)
'
  blender -b --python-exit-code 1 --python-expr '
import sys
import bpy
import numpy as np
def pixels(path):
    img = bpy.data.images.load(path)
    px = np.empty(img.size[0] * img.size[1] * img.channels, np.float32)
    img.pixels.foreach_get(px)
    return px
for f in range(1, 7):
    a = pixels(f"'"$shot"'/render/shot_{f:04d}.png")
    b = pixels(f"'"$out"'/single/render/shot_{f:04d}.png")
    assert a.shape == b.shape and a.std() > 0, f"farm frame {f} is blank or of another size"
    assert np.array_equal(a, b), f"farm frame {f} differs from the single-process render"
print("farm: frames 1-6 of 2 render tasks equal the single-process render, pixel for pixel")
'
  diff -r "$shot/tussock_cache" "$out/single/tussock_cache" >/dev/null \
    || { echo "farm: the 2-task bake's caches differ from the single-process bake's" >&2; exit 1; }
  echo "farm: the 2-task bake's caches equal the single-process bake's, byte for byte"
fi
