"""tools/demo_run.py, the runner of ./build.sh demo, on a stand-in for Blender (plain python3
printing the demo's lines among thousands of Cycles' and the video writer's): one terminal
line per step, everything in the log, the progress bounded, a failure's log tail and status.
Run by ./build.sh test, or alone: /usr/bin/python3 tests/test_demo_run.py [NAME...]"""

import ast
import io
import os
import re
import subprocess
import sys
import tempfile

TOOLS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools")
sys.path.insert(0, TOOLS)
import demo_run  # noqa: E402
import harness  # noqa: E402

STEPS = 5
FRAMES = 24
# a stand-in for `blender -b ... --python demo.py -- OUT`; argv: OUT, and how it ends
# (ok | fail: a traceback and status 1 | traceback: a traceback and status 0 |
# short: status 0 before the demo's last line)
FAKE = r'''
import os, sys
out, end = sys.argv[1], sys.argv[2]
w = sys.stdout.buffer.write
w(b"Blender 3.4.1 (hash 55485cb379f7 built 2023-01-20)\n")
w(b"Read prefs: /tmp/x/config/userpref.blend\n\xff\xfe not UTF-8\n")
k = 0
def step(msg):
    global k
    k += 1
    w(("[demo %d/%d] %s (%.1f s)\n" % (k, STEPS, msg, 1.5 * k)).encode())
def render(frames, first=1):
    for f in range(first, first + frames):
        for s in range(120):
            w(("Fra:%d Mem:120.4M (Peak 300.2M) | Time:00:0%d.12 | Remaining:00:01.00 | "
               "Mem:80.2M, Peak:80.3M | Scene, ViewLayer | Sample %d/120\n"
               % (f, s % 10, s + 1)).encode())
        w(("Saved: '%s/frames/demo_%04d.png'\n Time: 00:01.20 (Saving: 00:00.02)\n\n"
           % (out, f)).encode())
def encode(frames):
    for f in range(1, frames + 1):
        w(("Fra:%d Mem:20.1M (Peak 20.1M) | Time:00:00.01 | Sequencer\n" % f).encode())
        w(("Append frame %d Time: 00:00.05 (Saving: 00:00.03)\n" % f).encode())
step("Tussock 0.9 in Blender 3.4.1, 2 threads")
render(3)  # frames played before any "rendering" line: not progress
step("grew a meadow of 1,048,576 blades")
w(("[demo] rendering %d frames ...\n" % FRAMES).encode())
render(FRAMES)
step("rendered %d frames into %s/frames" % (FRAMES, out))
if end != "ok":
    w(b"Traceback (most recent call last):\n  File \"demo.py\", line 9, in <module>\n")
    w(b"RuntimeError: Error: the demo broke\n")
    sys.stdout.flush()
    sys.exit({"fail": 1, "traceback": 0, "short": 0}[end])
w(("[demo] encoding %d frames ...\n" % FRAMES).encode())
encode(FRAMES)
step("wrote %s/demo.mp4" % out)
w(b"[demo] rendering 2 frames ...\n")
render(2)
step("rendered 2 frames of the picture")
w(("[demo] outputs in %s; total 12 s\n" % out).encode())
w(b"\nBlender quit\n")
'''.replace("STEPS", str(STEPS)).replace("FRAMES", str(FRAMES))


def fake_run(end="ok", tty=False):
    """Runs the runner on the stand-in: (status, terminal text, log bytes, the stand-in's
    own output)."""
    with tempfile.TemporaryDirectory() as tmp:
        fake = os.path.join(tmp, "fake_blender.py")
        with open(fake, "w") as f:
            f.write(FAKE)
        out = os.path.join(tmp, "out")
        os.makedirs(out)
        open(os.path.join(out, "demo.mp4"), "wb").close()
        cmd = [sys.executable, fake, out, "ok" if end == "short" else end]
        if end == "short":  # the same run without its last lines
            cmd = [sys.executable, "-c", "import subprocess, sys; o = subprocess.run(sys.argv[1:],"
                   " stdout=subprocess.PIPE).stdout; sys.stdout.buffer.write(o[:o.index("
                   "b'[demo] outputs')])", *cmd]
        term = io.StringIO()
        log = os.path.join(out, "demo.log")
        with open(log, "w") as f:
            f.write("an older run's log\n" * 1000)
        code = demo_run.run(cmd, log, out=term, tty=tty)
        with open(log, "rb") as f:
            logged = f.read()
        own = subprocess.run(cmd, stdout=subprocess.PIPE).stdout
        return code, term.getvalue(), logged, own


def test_one_line_per_step_between_the_log_name_and_the_outputs():
    code, text, _, own = fake_run()
    lines = text.splitlines()
    assert code == 0, text
    assert own.count(b"\n") > 3000, own.count(b"\n")  # Blender's own lines: thousands
    assert len(lines) == 1 + STEPS + 1, text
    assert lines[0].startswith("Tussock demo: ") and lines[0].endswith("demo.log"), lines[0]
    for k, line in enumerate(lines[1:-1], 1):
        assert re.match(rf"\[{k}/{STEPS}\] +\d+\.\d s  \S", line), line
    assert "grew a meadow of 1,048,576 blades" in lines[2], lines[2]
    assert lines[-1].startswith("done in ") and lines[-1].endswith("/ holds demo.mp4"), lines[-1]
    assert "Fra:" not in text and "Append" not in text, text


def test_the_log_holds_every_line_of_blenders_output_and_only_this_runs():
    _, _, logged, own = fake_run()
    assert logged == own, (len(logged), len(own))
    assert b"\xff\xfe not UTF-8" in logged and b"older run" not in logged


def test_progress_off_a_terminal_is_an_occasional_line():
    quiet = demo_run.QUIET
    demo_run.QUIET = 0.0  # as if each frame took over 30 s: then every 10 % at most
    try:
        code, text, _, _ = fake_run()
    finally:
        demo_run.QUIET = quiet
    lines = text.splitlines()
    progress = [line for line in lines if " frame " in line and not line.startswith("[")]
    assert code == 0 and len(lines) == 1 + STEPS + 1 + len(progress), text
    rendering = [line for line in progress if "rendering frame" in line and f"/{FRAMES}" in line]
    encoding = [line for line in progress if "encoding frame" in line]
    assert 5 <= len(rendering) <= 10 and 5 <= len(encoding) <= 10, progress
    assert len(progress) <= len(rendering) + len(encoding) + 2, progress  # 2-frame render
    assert "rendering frame 24/24" in rendering[-1], rendering
    # the frames played before the first "rendering" line are no render's progress
    assert "rendering frame 1/" not in "\n".join(lines[:3]), text
    # and at the normal pace (a fast stand-in), no progress line at all
    assert len(fake_run()[1].splitlines()) == 1 + STEPS + 1


def test_progress_on_a_terminal_is_one_line_rewritten_in_place():
    code, text, _, _ = fake_run(tty=True)
    assert code == 0, text
    rewrites = text.count("\r\033[K")
    assert FRAMES * 2 <= rewrites <= FRAMES * 2 + 2 + 2 * STEPS, rewrites  # once a frame
    shown = [part.split("\r\033[K")[-1] for part in text.split("\n")]
    assert shown[-1] == "", shown  # the progress line is cleared, not left behind
    assert len(shown) - 1 == 1 + STEPS + 1 and shown[3].startswith("[3/"), shown
    assert "rendering frame 24/24" in text and "encoding frame 24/24" in text, text


def test_a_failure_prints_the_logs_tail_and_exits_non_zero():
    for end, status in (("fail", 1), ("traceback", 1), ("short", 1)):
        code, text, logged, _ = fake_run(end)
        lines = text.splitlines()
        assert code == status, (end, code, text)
        fail = next(i for i, line in enumerate(lines) if line.startswith("FAILED"))
        assert fail == 1 + 3 + (end == "short") * 2, (end, text)  # after the steps done
        why = {"fail": "Blender exited with 1", "traceback": "a Python traceback",
               "short": "stopped before the demo's end"}[end]
        assert why in lines[fail], (end, lines[fail])
        tail = [line[4:] for line in lines[fail + 1:-1]]
        assert tail == logged.decode("utf-8", "replace").splitlines()[-30:], (end, tail)
        assert len(tail) == 30 and lines[-1].endswith("demo.log"), (end, lines[-1])
        if end != "short":
            assert "RuntimeError: Error: the demo broke" in tail[-1], tail


def test_the_demo_counts_its_steps():
    """demo.py's STEPS is the number of its step() calls, each made once a run."""
    with open(os.path.join(TOOLS, "demo.py"), encoding="utf-8") as f:
        tree = ast.parse(f.read())
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call)
             and isinstance(n.func, ast.Name) and n.func.id == "step"]
    steps = next(n.value.value for n in tree.body if isinstance(n, ast.Assign)
                 and getattr(n.targets[0], "id", "") == "STEPS")
    loops = [n for n in ast.walk(tree) if isinstance(n, (ast.For, ast.While))
             and any(c in ast.walk(n) for c in calls)]
    assert len(calls) == steps and not loops, (len(calls), steps, loops)


if __name__ == "__main__":
    sys.exit(harness.run(globals()))
