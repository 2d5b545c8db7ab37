"""Smoke test of the capture binding from Python (run: PYTHONPATH=build/release python3
native/tests/py_capture_check.py). Draws five straight blades into a depth map with numpy,
round-trips it through a PNG, captures it, and checks counts, shapes, errors and handles.
Prints 'N passed, N failed' last."""
import math
import os
import tempfile

import numpy as np

import _tussock as t

from pycheck import check, finish  # noqa: E402


W, H = 640, 480
yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
depth = np.full((H, W), 1.6, np.float32)
for k, ang in enumerate((-0.5, -0.25, 0.0, 0.25, 0.5)):
    bx, by, L, w0 = 320.0, 450.0, 300.0 - 20 * abs(k - 2), 14.0
    dx, dy = math.sin(ang), -math.cos(ang)
    s = (xx - bx) * dx + (yy - by) * dy
    off = np.abs((xx - bx) * -dy + (yy - by) * dx)
    half = 0.5 * w0 * np.clip((L - s) / (0.15 * L), 0, 1) ** 0.5
    inside = (s >= 0) & (s <= L) & (off <= half)
    depth[inside] = np.minimum(depth[inside], 0.8)

with tempfile.TemporaryDirectory() as d:
    path = os.path.join(d, "fan.png")
    t.depth_write_png16(path, depth.ravel(), W, H)
    src = t.depth_open_files(path)
    info = t.depth_info(src)
    check(info["kind"] == "FILES" and info["width"] == W and info["frame_count"] == 1, "info")
    buf = np.zeros(W * H, np.float32)
    fr = t.depth_read(src, buf)
    check(fr["is_new"] and fr["end"], "read flags")
    check(float(np.abs(buf - depth.ravel()).max()) <= 0.0006, "png round trip")
    t.depth_close(src)
    try:
        t.depth_info(src)
        check(False, "closed handle refused")
    except t.Error as e:
        check("closed" in str(e), "closed handle message")
    try:
        t.depth_open_files(os.path.join(d, "missing.png"))
        check(False, "missing file raises")
    except t.Error as e:
        check("cannot open" in str(e), "missing file message")

cap = t.capture_create()
n = t.capture_process(cap, buf, W, H)
check(n == 5, "five blades, got %d" % n)
summ = t.capture_summary(cap)
check(summ["blades"] == 5 and 0.6 < summ["near"] < 0.8 < summ["far"] < 1.0, "summary")
counts = np.zeros(n, np.int32)
flags = np.zeros(n, np.int32)
t.capture_blades(cap, counts, flags)
total = int(counts.sum())
check(total == summ["knots"] and (flags == 0).all(), "counts and flags")
xyz = np.zeros(3 * total, np.float32)
width = np.zeros(total, np.float32)
uv = np.zeros(2 * total, np.float32)
t.capture_knots(cap, xyz, width, uv)
z = xyz[2::3]
check(np.allclose(z, 0.8, atol=0.002), "knot depths at 0.8 m")
w_px = width * 570.3 / 0.8
check(6.0 < float(np.median(w_px)) < 15.0, "widths in pixels, median %.2f" % np.median(w_px))
uv0 = np.zeros(2 * counts[0], np.float32)
check(t.capture_blade(cap, 0, None, None, uv0) == counts[0], "one blade")
check(uv0[1] > uv0[-1], "root below tip")
img = np.zeros(W * H, np.uint8)
for which in ("DEPTH", "MASK", "LABELS", "OVERLAY"):
    t.capture_image(cap, which, img)
check(set(np.unique(img)) <= {0, 64, 128, 255}, "overlay values")
try:
    t.capture_knots(cap, np.zeros(5, np.float32))
    check(False, "wrong buffer size raises")
except t.Error as e:
    check("camera_xyz" in str(e), "wrong buffer message")
try:
    t.capture_process(cap, buf, W, H, near=0.1, far=0.2)
    check(False, "empty band raises")
except t.Error as e:
    check("selects no pixel" in str(e), "empty band message")
try:
    t.capture_process(cap, buf.astype(np.float64), W, H)
    check(False, "float64 refused")
except t.Error as e:
    check("float32" in str(e), "dtype message")
try:
    t.depth_open_device("tussock://none")
    check(False, "no device raises")
except t.Error as e:
    check("no depth device" in str(e), "no device message")
dev = t.depth_open_device("Dummy")
t.depth_start(dev)
dbuf = np.zeros(320 * 240, np.float32)
got = 0
for _ in range(400):
    if t.depth_read(dev, dbuf)["is_new"]:
        got += 1
        break
    import time
    time.sleep(0.005)
check(got == 1 and abs(dbuf[0] - 2.0) < 1e-6, "dummy device frame")
t.depth_stop(dev)
del dev
finish()
