"""Long operations in a real Blender window (Xvfb), as an artist runs them from the sidebar:
their progress is shown while they run and Esc (a real key event) cancels them with the scene
as it was.

Capture of a sequence of 60 depth images: progress advances; Esc creates no blade; run to its
end, it creates the blades.

Add Meadow of a 20 m square (its 1,024 chunk objects): progress advances; Esc adds nothing,
not even orphan data; run to its end, it grows the meadow.

An interactive bake of a tree and a simulated meadow that a keyframed ball crosses:

- While it runs, its progress advances (the status bar and cursor show it; the numbers are
  read from tussock.progress.STATE) and Blender keeps handling events between slices.
- Esc (a real key event) cancels it, first while the meadow's frames are played and then
  while frames are baked; either way the scene is as it was: same frame, same objects, no
  cache modifier.
- The tree renamed and the meadow deleted while it bakes: the bake ends without an error,
  the renamed tree plays its cache, the deleted meadow's frames are removed.
- The record of what bakes wrote (tussock_written.json, Free Bake's list) names only files
  on disk: after the deleted meadow's frames went, and after a bake of the tree with new
  wind is cancelled before it assembled its .pc2.
- Free Bake then leaves no file in the cache folder."""

import os
import shutil
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import override, report, wait_until, window  # noqa: E402

import bpy  # noqa: E402

TMP = os.path.join(os.environ.get("TSK_TEST_TMP") or "/tmp", "window_bake")
FRAMES = 200  # enough that reading them takes several of the bake's 50 ms slices, in every Blender
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
    meadow, _ball = harness.meadow_crossed_by_ball(FRAMES)
    scene.frame_set(SHOWN)
    os.makedirs(TMP, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(TMP, "bake.blend"))
    return tree, meadow


def scene_state():
    scene = bpy.context.scene
    from tussock import cache
    return (scene.frame_current, sorted(o.name for o in scene.objects),
            sorted(o.name for o in scene.objects if o.modifiers.get(cache.MODIFIER)))


def cache_files():
    root = os.path.join(TMP, "tussock_cache")
    out = []
    for dirpath, _, files in os.walk(root):
        out += [os.path.relpath(os.path.join(dirpath, f), root) for f in files]
    return sorted(out)


def record_missing():
    """What tussock_written.json lists that is not on disk (Free Bake's list of the files to
    remove must be true; soak seed 71302 found it listing removed ones)."""
    from tussock import bake
    root = os.path.join(TMP, "tussock_cache")
    listed = bake.recorded_outputs(bpy.context.scene, root)
    return sorted(os.path.relpath(p, root) for p in listed if not os.path.exists(p))


def cancel_with_esc(what):
    """Esc pressed and released (real key events); the running operator must end."""
    from tussock.progress import STATE
    window().event_simulate(type="ESC", value="PRESS")
    window().event_simulate(type="ESC", value="RELEASE")
    ended = yield from wait_until(lambda: STATE["operator"] == "", 10, 0.05)
    expect(what, ended, str(STATE))


def capture_scenario():
    """Capture of a 60-frame sequence (the sample tuft's nine images over and over)."""
    from tussock.progress import STATE
    folder = os.path.join(TMP, "sequence")
    os.makedirs(folder, exist_ok=True)
    samples = os.path.join(harness.REPO, "samples", "blades")
    for i in range(60):
        shutil.copy(os.path.join(samples, f"depth_{i % 9 + 1:04d}.png"),
                    os.path.join(folder, f"depth_{i + 1:04d}.png"))
    s = bpy.context.scene.tussock_capture
    s.source, s.filepath, s.frames, s.frame = "FILES", os.path.join(folder, "depth_####.png"), 60, 0

    def blades():
        coll = bpy.data.collections.get("Tussock Blades")
        return len(coll.all_objects) if coll else 0
    before = (scene_state(), blades())
    with override():
        result = bpy.ops.tussock.capture_blades("INVOKE_DEFAULT")
    expect("capture runs modal", result == {"RUNNING_MODAL"}, str(result))
    seen = set()
    for _ in range(400):
        seen.add(STATE["done"])
        if len(seen - {0}) >= 2 or STATE["operator"] == "":
            break
        yield 0.005
    expect("capture progress advances", len(seen - {0}) >= 2 and STATE["total"] == 60,
           f"{sorted(seen)} {STATE}")
    yield from cancel_with_esc("Esc cancels the capture")
    expect("the cancelled capture left the scene as it was", (scene_state(), blades()) == before,
           f"{(scene_state(), blades())} != {before}")
    with override():
        result = bpy.ops.tussock.capture_blades("INVOKE_DEFAULT")
    done = yield from wait_until(lambda: STATE["operator"] == "" and blades() > before[1], 60)
    expect("a capture left to run creates the tuft's blades", done and blades() >= 5,
           f"{blades()} blades")
    for o in list(bpy.context.scene.objects):
        bpy.data.objects.remove(o)


def growth_scenario():
    """Add Meadow of 20 x 20 m (409,600 blades; its patch of 1,024 chunk objects is the long
    part) from the Add menu's invoke: progress, Esc with nothing added, then a full run."""
    from tussock.progress import STATE
    for o in list(bpy.context.scene.objects):
        bpy.data.objects.remove(o)
    counts = lambda: (len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.collections))  # noqa: E731,E501
    before = (scene_state(), counts())

    def grow():
        with override():
            return bpy.ops.tussock.add_meadow("INVOKE_DEFAULT", size=(20.0, 20.0),
                                              density="UNIFORM")
    expect("Add Meadow runs modal", grow() == {"RUNNING_MODAL"})
    seen = set()
    for _ in range(600):
        if STATE["phase"] == "making the blade chunks":
            seen.add(STATE["done"])
        if len(seen) >= 2 or STATE["operator"] == "":
            break
        yield 0.005
    expect("its progress advances while it makes the chunks",
           len(seen) >= 2 and STATE["total"] == 1024, f"{sorted(seen)[:5]} {STATE}")
    yield from cancel_with_esc("Esc cancels Add Meadow")
    expect("the cancelled Add Meadow left the scene and the file's data as they were",
           (scene_state(), counts()) == before, f"{(scene_state(), counts())} != {before}")
    expect("Add Meadow runs modal again", grow() == {"RUNNING_MODAL"})
    done = yield from wait_until(lambda: STATE["operator"] == "", 120, 0.1)
    meadows = [o for o in bpy.context.scene.objects if o.get("tussock_meadow_object")]
    expect("left to run, it grows the meadow",
           done and len(meadows) == 1 and meadows[0]["tussock_blades"] == 409600,
           f"{[(o.name, o.get('tussock_blades')) for o in meadows]}")
    for o in list(bpy.context.scene.objects):
        bpy.data.objects.remove(o)


def start_bake():
    with override():
        return bpy.ops.tussock.bake("INVOKE_DEFAULT")


def scenario():
    from tussock import bake, cache
    from tussock.progress import STATE
    reading = lambda: STATE["phase"] == bake.READING  # noqa: E731
    baking = lambda: STATE["phase"] == bake.BAKING  # noqa: E731
    idle = lambda: STATE["operator"] == ""  # noqa: E731
    tree, meadow = make_scene()
    before = scene_state()

    # 1. progress while the meadow's frames are played, then Esc
    expect("bake runs modal", start_bake() == {"RUNNING_MODAL"})
    seen, shown = [], set()
    for _ in range(400):
        seen.append((STATE["phase"], STATE["done"]))
        shown.add(bpy.context.scene.frame_current)
        steps = sorted({d for p, d in seen if p == bake.READING})
        if len(steps) >= 2 or baking():
            break
        yield 0.005
    expect("progress advances while the frames are played", len(steps) >= 2 and reading(),
           str(seen[-5:]))
    expect("Blender runs meanwhile (the frame shown follows the bake)",
           shown - {before[0]}, str(shown))
    yield from cancel_with_esc("Esc cancels while frames are played")
    expect("the cancelled bake left the scene as it was", scene_state() == before,
           f"{scene_state()} != {before}")

    # 2. Esc while frames are baked: the frames written are kept on disk, the scene unchanged
    expect("bake runs modal again", start_bake() == {"RUNNING_MODAL"})
    # (the frames are read again first: 200 of them took more than 60 s beside two soaks)
    ok = yield from wait_until(lambda: baking() and STATE["done"] >= 2, 240, 0.02)
    expect("progress advances while frames are baked", ok, str(STATE))
    yield from cancel_with_esc("Esc cancels while frames are baked")
    expect("that cancelled bake left the scene as it was too", scene_state() == before,
           f"{scene_state()} != {before}")
    expect("its frames are kept for the next bake",
           any(f.endswith(".tskf") for f in cache_files()), str(cache_files()))

    # 3. rename the tree and delete the meadow while it bakes
    expect("bake runs modal a third time", start_bake() == {"RUNNING_MODAL"})
    ok = yield from wait_until(baking, 60, 0.02)
    expect("the third bake reached its baking phase", ok, str(STATE))
    meadow_name = meadow.name
    tree.name = "Renamed tree"
    bpy.data.objects.remove(meadow)
    ended = yield from wait_until(idle, 120, 0.1)
    expect("the bake ended", ended, str(STATE))
    tree = bpy.context.scene.objects.get("Renamed tree")
    expect("the renamed tree plays its cache",
           tree is not None and bake.cached_range(tree, bpy.context.scene) == (1, FRAMES),
           str(tree and tree.modifiers.keys()))
    left = [f for f in cache_files() if f.startswith(cache.safe_name(meadow_name))]
    expect("the deleted meadow's frames were removed", not left, str(left[:5]))
    expect("and are not listed as written any more", not record_missing(),
           str(record_missing()))

    # 3b. the tree's wind changed, and its new bake cancelled after it wrote some frames:
    # the record, made before anything is written, listed the .pc2 it never assembled
    tree.tussock_tree.wind_strength *= 0.5
    expect("bake runs modal a fourth time", start_bake() == {"RUNNING_MODAL"})
    # (the frames are read again first: 200 of them took more than 60 s beside two soaks)
    ok = yield from wait_until(lambda: baking() and STATE["done"] >= 2, 240, 0.02)
    expect("the fourth bake writes frames", ok, str(STATE))
    yield from cancel_with_esc("Esc cancels the fourth bake")
    expect("the record lists only what the cancelled bake left on disk",
           not record_missing() and any(f.endswith(".tskf") for f in cache_files()),
           f"{record_missing()} {cache_files()[-3:]}")

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
        yield from capture_scenario()
        yield from growth_scenario()
        yield from scenario()
    harness.window_main(steps())


main()
