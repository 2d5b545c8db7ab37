"""The artist's path through the sidebar by real UI events, in a real Blender window (Xvfb,
`--enable-event-simulate`): open the Tussock tab, add a meadow with its button, switch its
simulation on and set its blades per tile in the panel, choose a collider collection, play
frames with the arrow key, bake with the Bake button, delete the meadow and undo, save, and
submit the shot to the farm on this machine. Every step is checked on the scene or on disk.

Buttons are found as an artist finds them, by pointing: the mouse moves down the sidebar
and, at each place, Blender's own "Copy Python Command" / "Copy Data Path" (what
Ctrl+Alt+Shift+C / Ctrl+Shift+C do) says what is under it. A click is a press and a release
of the left button there; a value is typed into a field by pasting it (Ctrl+V over it)."""

import os
import sys

import bmesh
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import area_of, override, region_of, report, wait_until, window  # noqa: E402

import bpy  # noqa: E402

TMP = os.path.join(os.environ.get("TSK_TEST_TMP") or "/tmp", "window_artist")
FRAMES = 6


def expect(what, ok, detail=""):
    report(what, None if ok else (detail or "it did not happen"))
    return ok


def sidebar():
    area = area_of("VIEW_3D")
    return area, region_of(area, "UI")


def tussock_tab_drawn():
    """Whether Blender's own redraw of the sidebar draws Tussock's main panel."""
    from tussock import ui
    cls, seen = ui.TUSSOCK_PT_main, []
    draw = cls.draw

    def spy(self, context):
        seen.append(1)
        return draw(self, context)
    cls.draw = spy
    try:
        area, region = sidebar()
        with bpy.context.temp_override(window=window(), area=area, region=region):
            bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)
    finally:
        cls.draw = draw
    return bool(seen)


def open_tussock_tab():
    """The sidebar shown with its Tussock tab: Region.active_panel_category where Blender
    has it, else Ctrl+wheel over the tab strip (3.4), a tab at a time."""
    area, region = sidebar()
    area.spaces.active.show_region_ui = True
    yield 0.3
    area, region = sidebar()
    if hasattr(region, "active_panel_category"):
        region.active_panel_category = "Tussock"
        yield 0.3
        return
    for _ in range(8):
        if tussock_tab_drawn():
            return
        x, y = region.x + region.width - 6, region.y + region.height // 2
        window().event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
        window().event_simulate(type="WHEELDOWNMOUSE", value="PRESS", x=x, y=y, ctrl=True)
        yield 0.3


def under_mouse(area, region):
    """(python command, data path) of the button under the mouse, '' where none."""
    wm = bpy.context.window_manager
    out = []
    for op, kw in ((bpy.ops.ui.copy_python_command_button, {}),
                   (bpy.ops.ui.copy_data_path_button, {"full_path": True})):
        wm.clipboard = ""
        with bpy.context.temp_override(window=window(), area=area, region=region):
            try:
                op(**kw)
            except RuntimeError:  # nothing of that kind under the mouse
                pass
        out.append(wm.clipboard)
    return out


def scroll(pages):
    """Scrolls the sidebar by whole pages (down when positive), as the mouse wheel would."""
    area, region = sidebar()
    with bpy.context.temp_override(window=window(), area=area, region=region):
        for _ in range(abs(pages)):
            if pages > 0:
                bpy.ops.view2d.scroll_down(page=True)
            else:
                bpy.ops.view2d.scroll_up(page=True)


def find(target, tries=1, pages=3, fx=None):
    """Moves the mouse down the sidebar, a page at a time from its top, until the button
    whose Python command or data path ends with `target` is under it; returns its (x, y) or
    None. Operators are looked for near a row's left end (Bake shares its row with Free
    Bake), fields right of the property split's labels, unless `fx` says where."""
    if fx is None:
        fx = 0.25 if target.startswith("bpy.ops.") else 0.65
    for _ in range(tries):
        scroll(-20)
        yield 0.2
        for _page in range(pages):
            area, region = sidebar()
            x = region.x + int(region.width * fx)
            for y in range(region.y + region.height - 20, region.y + 10, -14):
                window().event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
                yield 0.01
                if any(s.endswith(target) for s in under_mouse(area, region)):
                    return x, y
            scroll(1)
            yield 0.2
    return None


def open_subpanel(at):
    """Opens a closed sub-panel by a click on its header, right of the header's checkbox."""
    area, region = sidebar()
    click((region.x + int(region.width * 0.6), at[1]))


def click(at):
    x, y = at
    win = window()
    win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
    win.event_simulate(type="LEFTMOUSE", value="PRESS", x=x, y=y)
    win.event_simulate(type="LEFTMOUSE", value="RELEASE", x=x, y=y)


def paste(at, text):
    x, y = at
    bpy.context.window_manager.clipboard = text
    win = window()
    win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
    win.event_simulate(type="V", value="PRESS", x=x, y=y, ctrl=True)
    win.event_simulate(type="V", value="RELEASE", x=x, y=y, ctrl=True)


def meadows():
    return [o for o in bpy.context.scene.objects
            if o.get("tussock_meadow_object") and o.tussock_meadow.is_meadow]


def setup():
    """The artist's start: a ground plane selected, a ball that will cross the meadow in a
    collection of its own, the file saved (a bake lives beside it)."""
    scene = bpy.context.scene
    for o in list(scene.objects):
        bpy.data.objects.remove(o)
    scene.frame_start, scene.frame_end = 1, FRAMES
    scene.frame_set(1)
    mesh = bpy.data.meshes.new("Ground")
    mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    ground = bpy.data.objects.new("Ground", mesh)
    scene.collection.objects.link(ground)
    coll = bpy.data.collections.new("Colliders")
    scene.collection.children.link(coll)
    ball = bpy.data.objects.new("Ball", bpy.data.meshes.new("Ball"))
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=16, v_segments=8, radius=0.25)
    bm.to_mesh(ball.data)
    bm.free()
    coll.objects.link(ball)
    ball.location = (-0.8, 0.0, 0.2)
    ball.keyframe_insert("location", frame=1)
    ball.location = (0.8, 0.0, 0.2)
    ball.keyframe_insert("location", frame=FRAMES)
    scene.frame_set(1)
    for o in scene.objects:
        o.select_set(False)
    ground.select_set(True)
    bpy.context.view_layer.objects.active = ground
    # what the farm renders at the end: small, and an engine that needs no GPU
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location, cam.rotation_euler = (0.0, -3.0, 1.5), (1.1, 0.0, 0.0)
    scene.camera = cam
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    os.makedirs(TMP, exist_ok=True)
    with override():
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(TMP, "artist.blend"))
    return coll


def scenario():
    coll = setup()
    yield from open_tussock_tab()

    at = yield from find("bpy.ops.tussock.add_meadow()")
    expect("the Add Meadow button is in the Tussock tab", at is not None)
    if at is None:
        return
    click(at)
    from tussock import progress
    yield from wait_until(lambda: meadows() and progress.STATE["operator"] == "", 60, 0.2)
    expect("its click added a meadow over the selected ground", len(meadows()) == 1,
           str([o.name for o in bpy.context.scene.objects]))
    if not meadows():
        return
    meadow = meadows()[0]
    expect("the meadow is active", bpy.context.view_layer.objects.active == meadow)

    at = yield from find("tussock_meadow.blades_per_tile")
    expect("the meadow's Blades field is in the panel", at is not None)
    if at is not None:
        paste(at, "48")
        yield 1.0
        expect("a value typed into Blades is the meadow's",
               meadow.tussock_meadow.blades_per_tile == 48 and meadow["tussock_blades"] > 0,
               f"{meadow.tussock_meadow.blades_per_tile} a tile, {meadow['tussock_blades']} blades")

    at = yield from find("tussock_meadow.use_simulation", fx=0.2)  # in its sub-panel's header
    expect("the Simulation checkbox is in the panel", at is not None)
    if at is not None:
        click(at)
        yield 0.5
        expect("its click switched the simulation on", meadow.tussock_meadow.use_simulation)

    if at is not None:
        open_subpanel(at)  # the Simulation sub-panel starts closed
        yield 0.5
    at = yield from find("tussock_meadow.colliders")
    expect("the Colliders field is in the panel", at is not None)
    if at is not None:
        paste(at, coll.name)
        yield 0.5
        expect("the collider collection chosen in the panel",
               meadow.tussock_meadow.colliders == coll, str(meadow.tussock_meadow.colliders))

    # play frames: the right arrow over the 3D view steps the timeline
    area = area_of("VIEW_3D")
    view = region_of(area, "WINDOW")
    x, y = view.x + view.width // 2, view.y + view.height // 2
    win = window()
    for _ in range(FRAMES - 1):
        win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
        win.event_simulate(type="RIGHT_ARROW", value="PRESS", x=x, y=y)
        win.event_simulate(type="RIGHT_ARROW", value="RELEASE", x=x, y=y)
        yield 0.3
    scene = bpy.context.scene
    expect("the arrow key played the frames", scene.frame_current == FRAMES,
           str(scene.frame_current))
    moved = 0
    for o in scene.objects:  # the live mesh has room for more blades: those unused are at 0
        if o.get("tussock_simulated_blades"):
            co = np.empty(len(o.data.vertices) * 3, np.float32)
            o.data.vertices.foreach_get("co", co)
            moved += int(np.count_nonzero(np.abs(co.reshape(-1, 3)).sum(axis=1)))
    expect("the ball woke blades up on its way (simulated blades shown)", moved > 0,
           f"{moved} vertices of simulated blades")

    at = yield from find("bpy.ops.tussock.bake()")
    expect("the Bake button is in the Tussock tab", at is not None)
    if at is None:
        return
    click(at)
    from tussock import bake, cache
    done = yield from wait_until(
        lambda: any(o.modifiers.get(cache.MODIFIER) for o in scene.objects)
        and progress.STATE["operator"] == "", 120, 0.2)
    baked = [o for o in scene.objects if bake.cached_range(o, scene) == (1, FRAMES)]
    expect("its click baked the meadow's simulated blades", done and baked,
           str([(o.name, o.modifiers.keys()) for o in scene.objects]))

    # the meadow deleted with the Delete key: its blades objects go with it; Ctrl+Z brings
    # back the meadow and its blades, which play on
    def blades():  # (undo replaces the scene: looked up anew)
        return sorted(o.name for o in bpy.context.scene.objects if "tussock_meadow_name" in o)
    before = blades()
    for o in scene.objects:
        o.select_set(o == meadow)
    bpy.context.view_layer.objects.active = meadow
    for key, ctrl in (("DEL", False), ("Z", True)):
        win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
        win.event_simulate(type=key, value="PRESS", x=x, y=y, ctrl=ctrl)
        win.event_simulate(type=key, value="RELEASE", x=x, y=y, ctrl=ctrl)
        if key == "DEL":
            gone = yield from wait_until(lambda: not meadows() and not blades(), 10, 0.1)
            expect("the Delete key removed the meadow with its blades objects",
                   gone and before, str(blades()))
        else:
            yield from wait_until(lambda: meadows() and blades() == before, 10, 0.1)
    expect("Ctrl+Z brought back the meadow and its blades objects",
           len(meadows()) == 1 and blades() == before, f"{len(meadows())} {blades()}")
    win.event_simulate(type="LEFT_ARROW", value="PRESS", x=x, y=y)
    win.event_simulate(type="LEFT_ARROW", value="RELEASE", x=x, y=y)
    yield 0.5
    errors = [m.tussock_meadow.last_error for m in meadows() if m.tussock_meadow.last_error]
    scene = bpy.context.scene
    expect("the meadow plays on after the undo", scene.frame_current == FRAMES - 1
           and not errors and blades() == before, f"{scene.frame_current} {errors}")

    yield from submit_to_farm(x, y)


def submit_to_farm(x, y):
    """Ctrl+S, then Submit to Farm from the Bake panel: its dialog confirmed with Return
    runs the shot on this machine (the local back end, 4 tasks): the job script is written
    beside the .blend, every frame is rendered, and the farm's log says it is done."""
    win = window()
    win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
    win.event_simulate(type="S", value="PRESS", x=x, y=y, ctrl=True)
    win.event_simulate(type="S", value="RELEASE", x=x, y=y, ctrl=True)
    saved = yield from wait_until(lambda: not bpy.data.is_dirty, 10, 0.2)
    expect("Ctrl+S saved the shot", saved)
    at = yield from find("bpy.ops.tussock.farm_submit()")
    expect("the Submit to Farm button is in the Bake panel", at is not None)
    if at is None:
        return
    click(at)
    yield 1.0  # the dialog opens under the mouse; Return confirms it
    win.event_simulate(type="RET", value="PRESS", x=at[0], y=at[1])
    win.event_simulate(type="RET", value="RELEASE", x=at[0], y=at[1])
    farm = os.path.join(TMP, "artist_farm")
    script = os.path.join(farm, "job.sh")
    yield from wait_until(lambda: os.path.isfile(script), 10, 0.2)
    expect("its dialog wrote the job script beside the .blend", os.path.isfile(script))
    log = os.path.join(farm, "logs", "farm.out")

    def ended():
        try:
            with open(log) as f:
                text = f.read()
        except OSError:
            return False
        return "tussock farm: done" in text or "did not end well" in text
    yield from wait_until(ended, 300, 0.5)
    text = open(log).read() if os.path.isfile(log) else ""
    frames = sorted(f for f in os.listdir(os.path.join(TMP, "render"))) \
        if os.path.isdir(os.path.join(TMP, "render")) else []
    expect("the farm baked and rendered every frame on this machine",
           "tussock farm: done" in text and frames == [f"artist_{f:04d}.png"
                                                       for f in range(1, FRAMES + 1)],
           f"{frames}\n{text[-1500:]}")


def main():
    def steps():
        expect("Blender runs with a window", not bpy.app.background and window() is not None)
        harness.enable_addon()
        yield 0.3
        yield from scenario()
    harness.window_main(steps())


main()
