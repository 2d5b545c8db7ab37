"""Every Tussock panel, sub-panel, popover and menu, drawn in a real Blender window (Xvfb) in
each state an artist meets: the start-up scene, an empty scene, captured and refined blades,
a capture running (modal), a meadow with and without its simulation, with colliders, a bake
running (modal), a baked meadow, a tree and a baked tree, an animated picture and one changed
since, wind sources, and other settings. In each state:

- Blender itself draws the 3D view with the sidebar's Tussock tab open; nothing may print a
  Python error or an RNA warning while it draws, and a screenshot of the 3D view goes to
  $TSK_TEST_TMP/window_panels (copied to $TSK_UI_SHOTS too when that is set);
- every panel whose poll() allows it (and whose parent is drawn) is drawn on its own into a
  real UILayout of a popover, header (draw_header) and body (draw), and so is every menu and
  every draw function the add-on appends to Blender's menus and panels: one check each, which
  fails when the draw raises or prints an error or warning.

Every panel must be drawn in at least one state."""

import contextlib
import ctypes
import ctypes.util
import os
import re
import shutil
import sys
import tempfile
import traceback

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import REPO, report  # noqa: E402
from harness import area_of, override, region_of, running, select_only, wait_until, window  # noqa: E402,E501

import bpy  # noqa: E402
import numpy as np  # noqa: E402

TMP = os.path.join(os.environ.get("TSK_TEST_TMP") or tempfile.mkdtemp(), "window_panels")
SHOTS = os.environ.get("TSK_UI_SHOTS", "")  # a folder to keep the screenshots in, if set
BLADES = os.path.join(REPO, "samples", "blades", "depth_####.png")
FRAMES = 4  # the scene's frame range for bakes: short on a loaded 2-core machine
END = 12  # pages to scroll the sidebar down to reach its end (a tree's panel is long)

# What counts as a problem in what Blender prints while something draws: Python tracebacks
# and exceptions, and the RNA warnings that a wrong property or operator name gives
# ("rna_uiItemR: property not found", "uiItemFullO: unknown operator").
PROBLEM = re.compile(r"Traceback|Error|Warning|not found|unknown operator")
HARMLESS = re.compile(r"Draw window and swap")  # wm.redraw_timer's own report of its time

_libc = ctypes.CDLL(None)


@contextlib.contextmanager
def printed():
    """Collects what Python and Blender's C code print to stdout and stderr inside the block
    (at file-descriptor level, so C warnings too); the text is in the yielded list afterwards
    and is echoed to the real output."""
    sys.stdout.flush()
    sys.stderr.flush()
    _libc.fflush(None)
    saved = os.dup(1), os.dup(2)
    out = []
    with tempfile.TemporaryFile() as f:
        os.dup2(f.fileno(), 1)
        os.dup2(f.fileno(), 2)
        try:
            yield out
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            _libc.fflush(None)
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            f.seek(0)
            text = f.read().decode(errors="replace")
    out.append(text)
    if text:
        sys.stdout.write(text)
        sys.stdout.flush()


def problems(text):
    """The lines of printed text that show a drawing problem ('' when none)."""
    return "\n".join(line for line in text.splitlines()
                     if PROBLEM.search(line) and not HARMLESS.search(line))


# ---- where things are drawn ----------------------------------------------------------------

# ---- what the add-on draws -----------------------------------------------------------------

# ---- drawing, the two ways -----------------------------------------------------------------

def draw_everything(state, ui, drawn_in):
    """Draws each panel (poll permitting), menu and appended draw function into a popover of
    its editor, each its own check. Returns how many panels were drawn."""
    groups = {}
    for cls in ui.panels:
        groups.setdefault((cls.bl_space_type, cls.bl_region_type), []).append(cls)
    extra = [(m.bl_idname, m, m.draw) for m in ui.menus]
    extra += [(f"{host.__name__} + {fn.__name__}", host, fn) for host, fn in ui.appended]
    drawn = set()
    count = 0
    keys = list(groups) or [("VIEW_3D", "UI")]
    if ("VIEW_3D", "UI") not in keys:
        keys.append(("VIEW_3D", "UI"))
    for key in keys:
        area = area_of(key[0])
        if region_of(area, key[1]) is None:
            for cls in groups.get(key, ()):
                report(f"{state}: {cls.bl_idname} draws",
                       f"the window has no {key[0]} editor with a {key[1]} region")
            continue
        results = []

        def draw(popup, context, key=key):
            for cls in groups.get(key, ()):
                parent = getattr(cls, "bl_parent_id", None)
                if parent and parent not in drawn:
                    continue  # Blender draws a sub-panel only inside its parent
                error, visible = None, False
                with printed() as text:
                    try:
                        poll = getattr(cls, "poll", None)
                        visible = bool(poll(context)) if poll else True
                        if visible:
                            box = popup.layout.box()
                            header = box.row(align=True)
                            draw_header = harness.defines(cls, "draw_header")
                            if draw_header is not None:
                                draw_header(harness.DrawSelf(cls, header), context)
                            header.label(text=cls.bl_label)
                            cls.draw(harness.DrawSelf(cls, box.column()), context)
                    except Exception:  # noqa: BLE001 - the failure this test looks for
                        error = traceback.format_exc()
                error = error or problems(text[0])
                if visible:
                    drawn.add(cls.bl_idname)
                    drawn_in.setdefault(cls.bl_idname, []).append(state)
                if visible or error:
                    results.append((f"{state}: {cls.bl_idname} draws", error))
            if key != ("VIEW_3D", "UI"):
                return
            for name, host, fn in extra:
                error = None
                with printed() as text:
                    try:
                        col = popup.layout.box().column()
                        col.label(text=name)
                        fn(harness.DrawSelf(host, col), context)
                    except Exception:  # noqa: BLE001
                        error = traceback.format_exc()
                drawn_in.setdefault(name, []).append(state)
                results.append((f"{state}: {name} draws", error or problems(text[0])))

        with override(*key):
            with printed() as text:
                try:
                    bpy.context.window_manager.popover(draw, ui_units_x=22)
                except Exception:  # noqa: BLE001
                    results.append((f"{state}: popover of {key[0]} {key[1]} opens",
                                    traceback.format_exc()))
        for name, error in results:
            report(name, error)
        if problems(text[0]) and not any(e for _, e in results):
            report(f"{state}: popover of {key[0]} {key[1]} draws", problems(text[0]))
        count += len([c for c in groups.get(key, ()) if c.bl_idname in drawn])
    return count


def _spy(cls, name, fn, seen, raised):
    # exactly (self, context): Blender checks the argument count of a panel's draw
    def spy(self, context):
        seen.append((cls.bl_idname, name))
        try:
            return fn(self, context)
        except Exception:
            raised.append(f"{cls.bl_idname}.{name}: {traceback.format_exc()}")
            raise
    return spy


@contextlib.contextmanager
def spying(panels):
    """While Blender draws, records which Tussock panels it drew (draw and draw_header
    wrapped on the registered classes) and what they raised (still raised to Blender)."""
    seen, raised, restore = [], [], []
    for cls in panels:
        for name in ("draw_header", "draw"):
            fn = harness.defines(cls, name)
            if fn is None:
                continue
            restore.append((cls, name, cls.__dict__.get(name)))
            setattr(cls, name, _spy(cls, name, fn, seen, raised))
    try:
        yield seen, raised
    finally:
        for cls, name, own in restore:
            if own is not None:
                setattr(cls, name, own)
            else:
                delattr(cls, name)


def blender_draws_sidebar(panels):
    """Blender redraws the window (the sidebar shows the Tussock tab): (the panels it
    drew, the problems it printed or raised)."""
    with spying(panels) as (seen, raised):
        with override("VIEW_3D", "UI"):
            with printed() as text:
                bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)
    names = []
    for idname, _ in seen:
        if idname not in names:
            names.append(idname)
    return names, "\n".join(raised + [problems(text[0])]).strip()


def open_tussock_tab(panels):
    """Shows the 3D view's sidebar with the Tussock tab in front: Region.active_panel_category
    where Blender has it (4.x, 5.x), else Ctrl+wheel over the tab strip, one tab at a time,
    until Blender draws Tussock's main panel."""
    area = area_of("VIEW_3D")
    area.spaces.active.show_region_ui = True
    region = region_of(area, "UI")
    with contextlib.suppress(AttributeError, TypeError):
        region.active_panel_category = "Tussock"
    for _ in range(16):
        names, _problems = blender_draws_sidebar(panels)
        if "TUSSOCK_PT_main" in names:
            return True
        x, y = region.x + region.width - 6, region.y + region.height // 2
        win = window()
        win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
        win.event_simulate(type="WHEELDOWNMOUSE", value="PRESS", x=x, y=y, ctrl=True)
        yield 0.2
    return False


def close_popovers(count):
    """Esc closes the newest popup first (its handler takes the key before any modal
    operator's); the popovers would otherwise pile up in the window. Only the press: the
    release would reach a running modal capture or bake, which Esc cancels."""
    win = window()
    for _ in range(count):
        win.event_simulate(type="ESC", value="PRESS")
        yield 0.15


class _XImage(ctypes.Structure):  # the head of Xlib's XImage, up to what is read here
    _fields_ = [(name, ctypes.c_int) for name in ("width", "height", "xoffset", "format")] + \
        [("data", ctypes.c_void_p)] + \
        [(name, ctypes.c_int) for name in ("byte_order", "bitmap_unit", "bitmap_bit_order",
                                           "bitmap_pad", "depth", "bytes_per_line",
                                           "bits_per_pixel")]


def grab_from_x(x, y, width, height):
    """(height, width, 3) uint8 RGB of a rectangle of the X screen (top-left origin), read
    from the X server (Xvfb holds what Blender swapped to the window)."""
    x11 = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
    x11.XOpenDisplay.restype, x11.XOpenDisplay.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
    x11.XDefaultRootWindow.restype = ctypes.c_ulong
    x11.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
    x11.XGetImage.restype = ctypes.POINTER(_XImage)
    x11.XGetImage.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_int,
                              ctypes.c_uint, ctypes.c_uint, ctypes.c_ulong, ctypes.c_int]
    x11.XFree.argtypes = [ctypes.c_void_p]
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    display = x11.XOpenDisplay(None)
    if not display:
        raise RuntimeError(f"cannot open the X display {os.environ.get('DISPLAY')!r}")
    try:
        ptr = x11.XGetImage(display, x11.XDefaultRootWindow(display), x, y, width, height,
                            0xFFFFFFFF, 2)  # AllPlanes, ZPixmap
        if not ptr:
            raise RuntimeError("XGetImage failed")
        im = ptr.contents
        if im.bits_per_pixel != 32:
            raise RuntimeError(f"{im.bits_per_pixel} bits per pixel; 32 expected")
        raw = np.frombuffer(ctypes.string_at(im.data, im.bytes_per_line * im.height), np.uint8)
        bgrx = raw.reshape(im.height, im.bytes_per_line)[:, :im.width * 4]
        rgb = bgrx.reshape(im.height, im.width, 4)[..., 2::-1].copy()
        x11.XFree(im.data)
        x11.XFree(ptr)
        return rgb
    finally:
        x11.XCloseDisplay(display)


def png_pixels(path):
    """An image file's pixels as Blender reads them: (H, W, channels) floats, bottom row
    first."""
    img = bpy.data.images.load(path)
    w, h, c = img.size[0], img.size[1], img.channels
    px = np.empty(w * h * c, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(h, w, c)


def screenshot(path):
    """Saves the 3D view (its sidebar included) as a PNG: Blender's own screenshot_area,
    or, where that reads a black front buffer (4.x and 5.x on Xvfb's llvmpipe), the
    same rectangle read from the X server."""
    with override("VIEW_3D", "UI"):
        bpy.ops.screen.screenshot_area(filepath=path)
    if png_pixels(path)[..., :3].max() > 0:
        return "Blender"
    win, area = window(), area_of("VIEW_3D")
    top = win.height - area.y - area.height  # Blender counts from the bottom, X from the top
    rgb = grab_from_x(win.x + area.x, win.y + top, area.width, area.height)
    rgba = np.ones(rgb.shape[:2] + (4,), np.float32)
    rgba[..., :3] = rgb / 255.0
    save_png(os.path.splitext(os.path.basename(path))[0], rgba)
    return "X server" if rgb.max() > 0 else "nowhere: black in Blender and on the X server"


def sidebar_shot(shot, path):
    """The sidebar's columns of a 3D-view screenshot, as a PNG at `path` (the docs' images
    of the panels)."""
    area = area_of("VIEW_3D")
    region = region_of(area, "UI")
    px = png_pixels(shot)
    h, w, c = px.shape
    left = max(0, min(w - 1, region.x - area.x))
    crop = px[:, left:left + region.width]
    rgba = np.ones(crop.shape[:2] + (4,), np.float32)
    rgba[..., :min(c, 4)] = crop[..., :4]
    os.makedirs(os.path.dirname(path), exist_ok=True)
    out = save_png("sidebar_" + os.path.basename(path)[:-4], rgba[::-1])
    shutil.move(out, path)


def viewport_pixels(path):
    """The 3D view's main region of a screenshot, without what may overlap it (the sidebar
    and toolbar drawn over it with region overlap, the headers along its top): (H, W, 3)."""
    area = area_of("VIEW_3D")
    main = region_of(area, "WINDOW")
    px = png_pixels(path)
    x0, x1 = main.x - area.x, main.x - area.x + main.width
    for r in area.regions:
        if r.type in ("UI", "TOOLS") and r.width > 1:
            if r.x - area.x > (x0 + x1) / 2:
                x1 = min(x1, r.x - area.x)
            else:
                x0 = max(x0, r.x - area.x + r.width)
    y0 = max(0, main.y - area.y)
    y1 = y0 + main.height - 80  # (the headers)
    return px[y0:y1, max(0, x0):x1, :3]


def shapes_are_drawn(objs):
    """Show Shapes draws over the viewport: the main region's pixels with the shapes shown
    differ from those without them, and two frames drawn without them do not differ (so the
    difference is the overlay, not something else moving)."""
    shots = []
    for show in (True, False, False):
        for o in objs:
            o.tussock_collider.show_shapes = show
        yield 0.4
        shots.append(os.path.join(TMP, f"overlay_{len(shots)}.png"))
        screenshot(shots[-1])
    on, off, again = (viewport_pixels(p) for p in shots)
    drawn = int((np.abs(on - off).max(-1) > 0.05).sum())
    still = int((np.abs(off - again).max(-1) > 0.05).sum())
    expect("Show Shapes draws the fitted shapes over the viewport", drawn > 1000,
           f"{drawn} pixels differ with the shapes shown")
    expect("without Show Shapes, the viewport draws the same twice", still == 0,
           f"{still} pixels differ")
    print(f"overlay: {drawn} pixels of the viewport drawn by Show Shapes, {still} unstable")
    for o in objs:
        o.tussock_collider.show_shapes = True


class States:
    """Counts and screenshots of the states drawn so far."""

    def __init__(self, ui):
        self.ui = ui
        self.index = 0
        self.drawn_in = {}

    def draw(self, state, pages=0, during=None):
        """Both ways of drawing in one state: Blender's own sidebar (and a screenshot), then
        every panel and menu on its own. A generator: it lets the event loop draw the new
        state first (panels that moved slide into place over a few frames), and close the
        popovers it opened. With `during`, the state is a modal operator running: the event
        loop does not run before the drawing (the operator could finish), and during()
        must still be true after it. `pages`: the sidebar scrolled down so many pages for
        the screenshot."""
        self.index += 1
        if during is None:
            yield 0.4
        with override("VIEW_3D", "UI"):  # the screenshot shows the panels further down
            for _ in range(pages):
                bpy.ops.view2d.scroll_down(page=True)
        names, trouble = blender_draws_sidebar(self.ui.panels)
        shot = os.path.join(TMP, f"{self.index:02d}_{state}.png")
        source = screenshot(shot)
        with override("VIEW_3D", "UI"):
            for _ in range(pages):
                bpy.ops.view2d.scroll_up(page=True)
        if SHOTS:
            sidebar_shot(shot, os.path.join(SHOTS, f"ui_{state}.png"))
        if "TUSSOCK_PT_main" not in names:
            trouble = (trouble + "\n" if trouble else "") + \
                f"the Tussock tab is not open: Blender drew {names}"
        if source.startswith("nowhere"):
            trouble = (trouble + "\n" if trouble else "") + f"screenshot {shot}: {source}"
        report(f"{state}: Blender draws the Tussock sidebar tab ({', '.join(names)})", trouble)
        count = draw_everything(state, self.ui, self.drawn_in)
        print(f"{state}: {count} of {len(self.ui.panels)} panels drawn, "
              f"{len(self.ui.menus)} menus, {len(self.ui.appended)} appended draws; "
              f"screenshot {shot} (from {source})")
        if during is not None:
            expect(f"{state}: the operator still ran while everything drew", during())
        yield from close_popovers(1)


# ---- the scenes ----------------------------------------------------------------------------

def blade_count():
    coll = bpy.data.collections.get("Tussock Blades")
    return len(coll.all_objects) if coll else 0


def save_png(name, rgba):
    """Writes (H, W, 4) straight RGBA, top row first, as an 8-bit PNG in TMP."""
    h, w = rgba.shape[:2]
    img = bpy.data.images.new("panels_" + name, w, h, alpha=True)
    img.pixels.foreach_set(np.ascontiguousarray(rgba[::-1], np.float32).ravel())
    path = os.path.join(TMP, name + ".png")
    img.filepath_raw, img.file_format = path, "PNG"
    img.save()
    bpy.data.images.remove(img)
    return path


def picture_files():
    """A 96x64 picture (sky over a band of grass with a wavy top) and the grass's mask."""
    y, x = np.mgrid[0:64, 0:96].astype(np.float32)
    grass = y > 40 + 4 * np.sin(x / 5.0)
    rgba = np.empty((64, 96, 4), np.float32)
    rgba[...] = (0.5, 0.7, 0.9, 1.0)
    rgba[grass] = (0.15, 0.5, 0.1, 1.0)
    rgba[grass, 1] += 0.2 * np.sin(x[grass] * 1.3)
    mask = np.zeros_like(rgba)
    mask[grass] = 1.0
    mask[..., 3] = 1.0
    return save_png("picture", rgba), save_png("grass_mask", mask)


def expect(what, ok, detail=""):
    report(what, None if ok else (detail or "it did not happen"))
    return ok


def scenario(package):
    """The states an artist meets, one after the other, each drawn."""
    ui = harness.ui_of(package)
    print("panels:", [c.bl_idname for c in ui.panels])
    print("menus:", [c.bl_idname for c in ui.menus])
    print("appended draws:", [f"{h.__name__}:{f.__name__}" for h, f in ui.appended])
    states = States(ui)
    tab = yield from open_tussock_tab(ui.panels)
    expect("the sidebar shows the Tussock tab", tab)
    scene = bpy.context.scene

    yield from states.draw("startup")  # the factory scene: the cube selected and active

    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    yield from states.draw("empty_scene")

    with override():
        result = bpy.ops.tussock.capture_blades(source="FILES", filepath=BLADES, frames=4)
    expect("capture_blades finished with the blades selected",
           result == {"FINISHED"} and blade_count() > 0
           and all(o.select_get() for o in bpy.data.collections["Tussock Blades"].all_objects),
           f"{result}, {blade_count()} blades")
    yield from states.draw("captured_blades")

    with override():
        result = bpy.ops.tussock.refine_blades()
    expect("refine_blades finished", result == {"FINISHED"}, str(result))
    yield from states.draw("refined_blades")

    # an interactive capture: a modal operator reads frames on a timer, with a progress bar
    s = scene.tussock_capture
    s.source, s.filepath, s.frames = "FILES", BLADES, 9
    before = blade_count()
    with override():
        result = bpy.ops.tussock.capture_blades("INVOKE_DEFAULT")
    expect("capture_blades (interactive) runs modal", result == {"RUNNING_MODAL"}, str(result))
    yield from states.draw("capture_running", during=lambda: blade_count() == before
                           and running("capture_blades") in (True, None))
    finished = yield from wait_until(
        lambda: blade_count() > before and not running("capture_blades"), 60)
    expect("the interactive capture finished with new blades", finished,
           f"{blade_count()} blades, {before} before")
    with override():  # the new blades are selected: refined too, to grow a meadow from
        result = bpy.ops.tussock.refine_blades()
    expect("refine_blades finished on the new blades", result == {"FINISHED"}, str(result))

    select_only(None)
    with override():
        result = bpy.ops.tussock.add_meadow(size=(4.0, 4.0), blades_per_tile=32,
                                            density="UNIFORM")
    meadow = bpy.context.view_layer.objects.active
    expect("add_meadow made the active meadow",
           result == {"FINISHED"} and meadow is not None and meadow.tussock_meadow.is_meadow,
           str(result))
    yield from states.draw("meadow")

    meadow.tussock_meadow.use_simulation = True
    yield from states.draw("meadow_simulated")

    # a ball keyframed across the meadow, in the collection the simulation collides with
    with override():
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.3, location=(-1.5, 0.0, 0.2))
    ball = bpy.context.view_layer.objects.active
    ball.keyframe_insert("location", frame=1)
    ball.location.x = 1.5
    ball.keyframe_insert("location", frame=FRAMES)
    colliders = bpy.data.collections.new("Colliders")
    scene.collection.children.link(colliders)
    colliders.objects.link(ball)
    meadow.tussock_meadow.colliders = colliders
    scene.frame_start, scene.frame_end = 1, FRAMES
    select_only(meadow)
    for f in range(1, 3):  # plays two frames: the ball wakes tiles up
        scene.frame_set(f)
    yield from states.draw("meadow_colliders")

    # the ball selected: its Collider panel, its shape drawn over the viewport; then a walking
    # character in the same collection, a capsule per bone
    from tussock.meadow import colliders as collider_shapes  # noqa: E402
    select_only(ball)
    ball.tussock_collider.show_shapes = True
    yield from states.draw("collider_ball")
    sys.path.insert(0, os.path.join(harness.REPO, "tools"))
    import walker  # noqa: E402
    with override():
        _rig, body = walker.build(scene, start=(-1.5, 1.0, 0.0), frames=(1, FRAMES))
    colliders.objects.link(body)
    body.tussock_collider.show_shapes = True
    select_only(body)
    scene.frame_set(3)
    shape, rows = collider_shapes.shown(body) or (None, ())
    expect("the character is fitted a capsule per bone", shape == "BONES" and len(rows) > 8,
           f"{shape}, {len(rows)} shapes")
    yield from states.draw("collider_character")
    yield from shapes_are_drawn([ball, body])

    # an interactive bake: in slices on the main thread under a modal timer (a bake needs a
    # saved file); in 3.4 too, where a worker thread once crashed Blender
    os.makedirs(TMP, exist_ok=True)
    from tussock import cache  # noqa: E402 - the add-on is enabled by now

    def cached():
        return [o.name for o in scene.objects if o.modifiers.get(cache.MODIFIER)]
    with override():
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(TMP, "panels.blend"))
        result = bpy.ops.tussock.bake("INVOKE_DEFAULT")
    expect("bake (interactive) runs modal", result == {"RUNNING_MODAL"}, str(result))
    yield from states.draw("bake_running",
                           during=lambda: not cached() and running("bake") in (True, None))
    finished = yield from wait_until(lambda: cached() and not running("bake"), 120)
    expect("the interactive bake finished with a cache", finished, f"cached: {cached()}")
    select_only(meadow)
    yield from states.draw("meadow_baked", pages=END)

    select_only(None)
    scene.cursor.location = (6.0, 0.0, 0.0)
    with override():
        result = bpy.ops.tussock.add_tree(preset="black_tupelo")
    tree = bpy.context.view_layer.objects.active
    expect("add_tree made the active tree",
           result == {"FINISHED"} and tree is not None and tree.tussock_tree.is_tree, str(result))
    yield from states.draw("tree", pages=1)

    with override():
        result = bpy.ops.tussock.bake()
    expect("bake finished with the tree cached",
           result == {"FINISHED"} and tree.modifiers.get(cache.MODIFIER) is not None, str(result))
    yield from states.draw("tree_baked", pages=END)

    # a picture in a scene of its own, as an artist animating a photo starts one
    picture, mask = picture_files()
    pic_scene = bpy.data.scenes.new("Picture")
    window().scene = pic_scene
    p = pic_scene.tussock_picture
    p.filepath = picture
    layer = p.layers.add()
    layer.name, layer.mask_path = "Grass", mask
    layer = p.layers.add()
    layer.name, layer.mask_path, layer.root = "Sky", mask, "NONE"
    with override():
        result = bpy.ops.tussock.animate_picture()
    expect("animate_picture finished", result == {"FINISHED"} and p.applied, str(result))
    yield from states.draw("picture_animated")

    p.active_layer = 1  # the artist turns the second layer into a GrabCut one
    layer.mask_mode, layer.root, layer.root_auto = "GRABCUT", "TOP", False
    layer.rect = (0, 0, 96, 40)
    yield from states.draw("picture_changed")

    wind = pic_scene.tussock_wind
    with override():
        result = bpy.ops.tussock.add_wind_source()
        bpy.ops.tussock.wind_wave_add()
        bpy.ops.tussock.wind_wave_add()
    expect("add_wind_source made the active source",
           result == {"FINISHED"} and bpy.context.view_layer.objects.active is not None
           and bpy.context.view_layer.objects.active.tussock_wind_source.is_source
           and len(wind.waves) == 2, str(result))
    wind.use_fluid = wind.use_continuum = True
    yield from states.draw("wind_sources", pages=1)

    # back in the meadow's scene: a device to capture from, a hand-set depth band, a
    # meadow whose density comes from an image, the picture's mask from a painted image
    window().scene = scene
    select_only(meadow)
    s.source, s.auto_band = "DEVICE", False
    density = bpy.data.images.new("density", 8, 8)
    meadow.tussock_meadow.density_image = density
    meadow.tussock_meadow.density = "IMAGE"
    scene.tussock_picture.layers.add().mask_mode = "IMAGE"
    yield from states.draw("other_settings")

    for cls in ui.panels:
        where = states.drawn_in.get(cls.bl_idname, [])
        expect(f"{cls.bl_idname} was drawn in at least one state ({len(where)} states)",
               bool(where))
    for cls in ui.menus:
        expect(f"{cls.bl_idname} was drawn in at least one state",
               bool(states.drawn_in.get(cls.bl_idname)))


def main():
    """Enables the add-on once the window is up, then goes through the states."""
    def steps():
        expect("Blender runs with a window", not bpy.app.background and window() is not None)
        os.makedirs(TMP, exist_ok=True)
        mod = harness.enable_addon()
        yield 0.2
        yield from scenario(mod.__name__)
    harness.window_main(steps())


main()
