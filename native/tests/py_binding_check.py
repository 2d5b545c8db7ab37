"""The binding's handles and def tables under plain python3 with numpy (run by ./build.sh test:
PYTHONPATH=build/release python3 native/tests/py_binding_check.py). A meadow of tufts under a
rolling ball, stepped by two Python threads through one simulation handle: the one stepping
without the GIL makes the handle busy, the other gets tussock.Error instead of a race, and the
steps that ran give the bytes of the same number of steps on one thread.
Prints 'N passed, N failed' last."""
import threading

import numpy as np

import _tussock as t

from pycheck import check, finish  # noqa: E402


def error_of(fn):
    try:
        fn()
    except t.Error as exc:
        return str(exc)
    return ""


K = 6
TILES = 4          # 4 x 4 tiles of 1 m
TUFTS = 12         # per tile, 60 blades each
DT = 1.0 / 48.0


def meadow_sim():
    sim = t.blade_sim_create(tiles_x=TILES, tiles_y=TILES, knot_count=K, tile_size=1.0)
    # a ball rolling over the middle of the meadow wakes every tile it touches
    t.blade_sim_set_colliders(sim, np.array([[0, 1.2, 2.0, 2.0, 0.3, 0, 0, 0]], np.float32))
    for tile in range(TILES * TILES):
        t.blade_sim_activate_tile(sim, tile)
    n = t.blade_sim_pending(sim)
    pending = np.empty(n, np.int32)
    t.blade_sim_pending(sim, pending)
    rng = np.random.default_rng(7)
    u = np.linspace(0.0, 1.0, K, dtype=np.float32)
    for tile in pending:
        tx, ty = tile % TILES, tile // TILES
        centres = rng.uniform(0.1, 0.9, (TUFTS, 2)) + (tx, ty)
        roots = (centres[:, None, :] + rng.normal(0, 0.03, (TUFTS, 60, 2))).reshape(-1, 2)
        lean = rng.normal(0, 0.05, roots.shape)
        height = rng.uniform(0.15, 0.35, len(roots))
        knots = np.empty((len(roots), K, 3), np.float32)
        knots[:, :, :2] = roots[:, None, :] + lean[:, None, :] * u[None, :, None]
        knots[:, :, 2] = height[:, None] * u[None, :]
        widths = np.tile(np.float32(0.004) * (1.0 - 0.8 * u), len(roots))
        sides = np.tile(np.array([1.0, 0.0, 0.0], np.float32), len(roots))
        t.blade_sim_provide_tile(sim, int(tile), knots.ravel(), widths, sides)
    return sim


def knots_of(sim):
    info = t.blade_sim_info(sim)
    out = np.empty(info["active_blades"] * K * 3, np.float32)
    t.blade_sim_get_knots(sim, out)
    return out


# ---- two threads, one simulation ----------------------------------------------------------
sim = meadow_sim()
blades = t.blade_sim_info(sim)["active_blades"]
check(blades >= TILES * TILES * TUFTS * 60 // 2, "a meadow of %d blades" % blades)
counts = {"stepped": 0, "busy": 0, "other": []}
lock = threading.Lock()
start = threading.Barrier(2)


def stepper():
    start.wait()
    for _ in range(150):
        try:
            t.blade_sim_step(sim, DT)
            with lock:
                counts["stepped"] += 1
        except t.Error as exc:
            with lock:
                if "busy" in str(exc):
                    counts["busy"] += 1
                else:
                    counts["other"].append(str(exc))
        except Exception as exc:  # noqa: BLE001 - any other failure is the test's
            with lock:
                counts["other"].append(repr(exc))


threads = [threading.Thread(target=stepper) for _ in range(2)]
for th in threads:
    th.start()
for th in threads:
    th.join()
check(not counts["other"], "only busy errors, got %s" % counts["other"][:3])
check(counts["busy"] > 0, "the second thread is refused while the first steps (%d busy, %d "
      "stepped)" % (counts["busy"], counts["stepped"]))
check(counts["stepped"] + counts["busy"] == 300, "every call stepped or was refused")
msg = ""
long_steps = 0
for _ in range(20):  # the busy message names the handle and says what to do
    long_steps += 1

    def long_step():
        t.blade_sim_step(sim, DT)

    th = threading.Thread(target=long_step)
    th.start()
    while th.is_alive() and not msg:
        msg = error_of(lambda: t.blade_sim_info(sim))
    th.join()
    if msg:
        break
check(msg.startswith("sim: the blade simulation is busy") and "one thread" in msg,
      "busy message: %r" % msg)
alone = meadow_sim()
for _ in range(counts["stepped"] + long_steps):
    t.blade_sim_step(alone, DT)
a, b = knots_of(sim), knots_of(alone)
check(a.shape == b.shape and a.tobytes() == b.tobytes(),
      "the steps that ran are the steps of one thread, bit for bit")
moved = float(np.abs(a - knots_of(meadow_sim())).max())
check(moved > 1e-3, "the ball moved blades (%.4f m)" % moved)

# ---- handles: wrong kind, closed, closed twice -------------------------------------------------
check(error_of(lambda: t.blade_sim_step("a sim", DT)).startswith(
    "sim: expected a blade simulation handle from blade_sim_create"), "wrong object")
wind = t.wind_create(nx=16, ny=16, cell_size=0.5)
check(error_of(lambda: t.blade_sim_info(wind)).startswith("sim: expected"), "wrong kind")
t.wind_step(wind, 2)
t.wind_destroy(wind)
t.wind_destroy(wind)  # closing twice is harmless
check("wind handle is closed" in error_of(lambda: t.wind_step(wind, 1)), "closed handle")
wind = t.wind_create(nx=64, ny=64, cell_size=0.25, speed=4.0)
errors = []


def wind_steps():
    for _ in range(20):
        t.wind_step(wind, 4)


th = threading.Thread(target=wind_steps)
th.start()
while th.is_alive():
    e = error_of(lambda: t.wind_destroy(wind))
    if e:
        errors.append(e)
        break
th.join()
check(not errors or "wind is busy" in errors[0], "no destroy under a running step: %s" % errors)

# ---- def tables: defaults round trip, unknown keys and bad values named ------------------------
d = t.default_blade_sim_def()
check(isinstance(d["origin"], tuple) and isinstance(d["knot_count"], int), "sim def types")
check(t.blade_sim_info(t.blade_sim_create(**d))["knot_count"] == d["knot_count"], "round trip")
check(error_of(lambda: t.blade_sim_create(tile_sise=1.0)) == "tile_sise: unknown setting",
      "unknown sim setting")
check(error_of(lambda: t.blade_sim_create(tiles_x=2.5)).startswith("tiles_x: must be an integer"),
      "float for an int")
check(error_of(lambda: t.blade_sim_create(gravity=(0, 0))) ==
      "gravity: must be a sequence of 3 numbers", "vec3")
check(t.blade_sim_create(tiles_x=np.int64(3)) is not None, "numpy integers are integers")
tree = t.tree_default_def()
check(len(tree["level"]) == 4 and "branches" in tree["level"][1], "tree levels")
check(error_of(lambda: t.tree_create({"colour": 1})) == "def: unknown parameter 'colour'",
      "unknown tree parameter")
check(error_of(lambda: t.tree_create({"level": [{}, {"bend": 1}]})) ==
      "level[1]: unknown parameter 'bend'", "unknown level parameter")
check(error_of(lambda: t.tree_create({"max_branches": -1})).startswith("max_branches: must be"),
      "u32 range")
check(error_of(lambda: t.wind_create(gust_strenght=1.0)) == "gust_strenght: unknown wind "
      "parameter", "unknown wind parameter")
check("waves: must hold 7 floats" in error_of(
    lambda: t.wind_create(waves=np.zeros(6, np.float32))), "waves buffer")
cap = t.capture_create()
depth = np.full(64 * 48, 1.5, np.float32)
check(error_of(lambda: t.capture_process(cap, depth, 64, 48, root="TOP")) ==
      "root: must be 'BOTTOM' or 'CENTROID', got 'TOP'", "capture choice")
check(error_of(lambda: t.capture_process(cap, depth, 64, 48, min_areaa=3)) ==
      "min_areaa: unknown capture setting", "unknown capture setting")
check(isinstance(t.capture_process(capture=cap, depth=depth, width=64, height=48), int),
      "capture arguments by name")
check(error_of(lambda: t.meadow_create(size=(3, 4, 5))) == "size: must be a sequence of 2 numbers",
      "meadow size")
check(error_of(lambda: t.meadow_create(density="dense")) ==
      "density: must be 'uniform', 'noise' or 'image', got 'dense'", "meadow density")
check(t.meadow_info(t.meadow_create(size=(3, 4), density="uniform"))["tile_count"] == 48,
      "meadow settings reach the def")
check(t.patch_info(t.patch_create(blade_count=100, seed=3))["blade_count"] == 100, "patch")
pic = t.picture_create(32, 32, np.random.default_rng(1).random(32 * 32 * 4).astype(np.float32))
check(error_of(lambda: t.picture_build(pic, method="fast")) ==
      "method: must be 'telea' or 'ns', got 'fast'", "inpaint method")
z = np.zeros(64, np.float32)
cx, cy = t.warp_grid_size(32, 32, 16, 16)
corners = np.zeros(cx * cy, np.float32)
check(error_of(lambda: t.warp_corners(32, 32, z, z, 8, 8, corners, corners, sampling="map_uv"))
      == "sampling: unknown warp setting", "warp_corners samples nothing")
check(error_of(lambda: t.warp_corners(32, 32, z, z, 8, 8, corners, corners, root="none")) == "",
      "warp_corners without a root")
# refine_simulate's settings each reach their own field: air density given as its default
# simulates as the default does
knots = np.zeros((10, 3), np.float32)
knots[:, 0] = np.linspace(0.0, 0.05, 10) ** 2
knots[:, 2] = np.linspace(0.0, 0.25, 10)
widths = np.linspace(0.006, 0.001, 10).astype(np.float32)
base, given = np.empty(3 * 30, np.float32), np.empty(3 * 30, np.float32)
t.refine_simulate(knots.ravel(), widths, 3, base)
t.refine_simulate(knots.ravel(), widths, 3, given, air_density=1.2, gravity_prestress=True)
check(base.tobytes() == given.tobytes(), "refine_simulate defaults given by name")
t.refine_simulate(knots.ravel(), widths, 3, given, air_density=0.0)
check(base.tobytes() != given.tobytes(), "air density matters")
check(t.allocated_bytes() >= 0, "alive")

finish()
