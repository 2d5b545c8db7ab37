"""An interactive bake in a real Blender window (Xvfb), as an artist runs it from the Bake
panel: a tree and a simulated meadow that a keyframed ball crosses.

- While it runs, its progress advances (the status bar and cursor show it; the numbers are
  read from tussock.bake.PROGRESS) and Blender keeps handling events between slices.
- Esc (a real key event) cancels it, first while the meadow's frames are played and then
  while frames are baked; either way the scene is as it was: same frame, same objects, no
  cache modifier.
- The tree renamed and the meadow deleted while it bakes: the bake ends without an error,
  the renamed tree plays its cache, the deleted meadow's frames are removed.
- Free Bake then leaves no file in the cache folder."""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import override, report, wait_until, window  # noqa: E402

import bpy  # noqa: E402

TMP = os.path.join(os.environ.get("TSK_TEST_TMP") or "/tmp", "window_bake")
FRAMES = 40
SHOWN = 30  # the frame the artist is at; reading the frames starts at 1


def expect(what, ok, detail=""):
    report(what, None if ok else (detail or "it did not happen"))
    return ok


def make_scene():
    scene = bpy.context.scene
    for o in list(scene.objects):
        bpy.data.objects.remove(o)
    scene.frame_start, scene.frame_end = 1, FRAMES
    scene.frame_set(SHOWN)  # not the first frame: a cancelled bake must put this one back
    scene.tussock_wind.base_speed = 3.0
    assert bpy.ops.tussock.add_tree(preset="quaking_aspen", seed=3, leaves=False) == {"FINISHED"}
    tree = bpy.context.active_object
    tree.location.x = 6.0
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    assert bpy.ops.tussock.add_meadow(tile_size=0.25, blades_per_tile=32, density="UNIFORM",
                                      display=1.0) == {"FINISHED"}
    meadow = bpy.context.active_object
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.2, location=(-0.9, -0.1, 0.15))
    ball = bpy.context.active_object
    ball.keyframe_insert("location", frame=1)
    ball.location = (0.7, 0.1, 0.15)
    ball.keyframe_insert("location", frame=FRAMES)
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    coll.objects.link(ball)
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    scene.frame_set(SHOWN)
    os.makedirs(TMP, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(TMP, "bake.blend"))
    return tree, meadow


def scene_state():
    scene = bpy.context.scene
    from tussock import bake
    return (scene.frame_current, sorted(o.name for o in scene.objects),
            sorted(o.name for o in scene.objects if o.modifiers.get(bake.MODIFIER)))


def cache_files():
    root = os.path.join(TMP, "tussock_cache")
    out = []
    for dirpath, _, files in os.walk(root):
        out += [os.path.relpath(os.path.join(dirpath, f), root) for f in files]
    return sorted(out)


def start_bake():
    with override():
        return bpy.ops.tussock.bake("INVOKE_DEFAULT")


def scenario():
    from tussock import bake
    tree, meadow = make_scene()
    before = scene_state()

    # 1. progress while the meadow's frames are played, then Esc
    expect("bake runs modal", start_bake() == {"RUNNING_MODAL"})
    seen, shown = [], set()
    for _ in range(400):
        seen.append((bake.PROGRESS["phase"], bake.PROGRESS["done"]))
        shown.add(bpy.context.scene.frame_current)
        steps = sorted({d for p, d in seen if p == "Reading frames"})
        if bake.PROGRESS["reading"] and len(steps) >= 2 or not bake.PROGRESS["reading"] and steps:
            break
        yield 0.005
    expect("progress advances while the frames are played", len(steps) >= 2, str(seen[-5:]))
    expect("Blender runs meanwhile (the frame shown follows the bake)",
           shown - {before[0]}, str(shown))
    window().event_simulate(type="ESC", value="PRESS")
    window().event_simulate(type="ESC", value="RELEASE")
    ended = yield from wait_until(lambda: bake.PROGRESS["phase"] == "", 10, 0.05)
    expect("Esc cancels while frames are played", ended, str(bake.PROGRESS))
    expect("the cancelled bake left the scene as it was", scene_state() == before,
           f"{scene_state()} != {before}")

    # 2. Esc while frames are baked: the frames written are kept on disk, the scene unchanged
    expect("bake runs modal again", start_bake() == {"RUNNING_MODAL"})
    baking = yield from wait_until(lambda: not bake.PROGRESS["reading"]
                                   and bake.PROGRESS["frames"] >= 2, 60, 0.02)
    expect("progress advances while frames are baked", baking, str(bake.PROGRESS))
    window().event_simulate(type="ESC", value="PRESS")
    window().event_simulate(type="ESC", value="RELEASE")
    ended = yield from wait_until(lambda: bake.PROGRESS["phase"] == "", 10, 0.05)
    expect("Esc cancels while frames are baked", ended, str(bake.PROGRESS))
    expect("that cancelled bake left the scene as it was too", scene_state() == before,
           f"{scene_state()} != {before}")
    expect("its frames are kept for the next bake",
           any(f.endswith(".tskf") for f in cache_files()), str(cache_files()))

    # 3. rename the tree and delete the meadow while it bakes
    expect("bake runs modal a third time", start_bake() == {"RUNNING_MODAL"})
    baking = yield from wait_until(lambda: not bake.PROGRESS["reading"]
                                   and bake.PROGRESS["total"] > 0, 60, 0.02)
    expect("the third bake reached its baking phase", baking, str(bake.PROGRESS))
    meadow_name = meadow.name
    tree.name = "Renamed tree"
    bpy.data.objects.remove(meadow)
    ended = yield from wait_until(lambda: bake.PROGRESS["phase"] == "", 120, 0.1)
    expect("the bake ended", ended, str(bake.PROGRESS))
    tree = bpy.context.scene.objects.get("Renamed tree")
    expect("the renamed tree plays its cache",
           tree is not None and bake.cached_range(tree, bpy.context.scene) == (1, FRAMES),
           str(tree and tree.modifiers.keys()))
    left = [f for f in cache_files() if f.startswith(bake.safe_name(meadow_name))]
    expect("the deleted meadow's frames were removed", not left, str(left[:5]))

    # 4. Free Bake leaves no file of Tussock's behind
    with override():
        result = bpy.ops.tussock.free_bake()
    files = [f for f in cache_files() if f != "tussock_written.json"]
    expect("Free Bake removed every file", result == {"FINISHED"} and not cache_files(),
           f"{result} {files[:5]}")


def main():
    def steps():
        expect("Blender runs with a window", not bpy.app.background and window() is not None)
        harness.enable_addon()
        yield 0.2
        yield from scenario()
    harness.window_main(steps())


main()
