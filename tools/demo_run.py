#!/usr/bin/python3
"""usage: demo_run.py [-- OUT]: runs the demo (tools/demo.py) in background Blender for
./build.sh demo, with all of Blender's output in OUT/demo.log (default out/, the log made anew
each run). The terminal gets the log's name, one line per step of the demo with its time, the
frame a step is rendering or encoding (updated in place on a terminal, an occasional line
otherwise), then the outputs and the total time. When Blender exits non-zero, prints a Python
traceback or stops before the demo's last line, it prints the log's last lines and exits
non-zero. Standard library only (Python 3.9+): it also runs inside the Debian roots."""

import collections
import os
import re
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_env  # noqa: E402

DEMO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "demo.py")
STEP = re.compile(r"\[demo (\d+)/(\d+)\] (.*) \(([\d.]+) s\)$")
FRAMES = re.compile(r"\[demo\] (\w+) (\d+) frames \.\.\.$")
DONE = re.compile(r"\[demo\] outputs in (.*); total \d+ s$")
FRAME = re.compile(r"Fra:(\d+) |Append frame (\d+)")  # Blender rendering / writing a video
TAIL = 30  # log lines shown on a failure
QUIET = 30.0  # off a terminal: a progress line at most every QUIET s and every 10 %


def short(path):
    """`path` relative to the current folder when it is inside it."""
    rel = os.path.relpath(path)
    return path if rel.startswith("..") else rel


def duration(seconds):
    return f"{seconds:.0f} s" if seconds < 60 else f"{seconds // 60:.0f} min {seconds % 60:.0f} s"


class Terminal:
    """What the person sees: whole lines, and on a terminal one progress line rewritten in
    place (cleared before the next whole line)."""

    def __init__(self, out, tty):
        self.out, self.tty, self.shown = out, tty, ""
        self.indent = 0  # progress lines start under the text of the step lines

    def line(self, text):
        if self.shown:
            self.out.write("\r\033[K")
            self.shown = ""
        self.out.write(text + "\n")
        self.out.flush()

    def progress(self, text):
        if self.tty and text != self.shown:
            self.out.write("\r\033[K" + text)
            self.out.flush()
            self.shown = text


class Progress:
    """The frames of the step under way, from Blender's "Fra:N" (render) and "Append frame N"
    (video) lines once the demo has said how many it will do."""

    def __init__(self, term):
        self.term, self.what = term, None

    def start(self, what, total):
        self.what, self.total, self.frames = what, total, set()
        self.t0 = self.said_at = time.monotonic()
        self.said = 0

    def stop(self):
        self.what = None

    def frame(self, n):
        if self.what is None or n in self.frames:
            return
        self.frames.add(n)
        done, now = len(self.frames), time.monotonic()
        text = (f"{'':{self.term.indent}}{self.what} frame {min(done, self.total)}/"
                f"{self.total}, {duration(now - self.t0)} so far")
        if self.term.tty:
            self.term.progress(text)
        elif now - self.said_at >= QUIET and (done - self.said) * 10 >= self.total:
            self.term.line(text)
            self.said, self.said_at = done, now


def run(cmd, log_path, env=None, out=None, tty=None):
    """Runs `cmd` (Blender running demo.py, or a stand-in) with its output into `log_path`
    and the summary onto `out`; returns the exit status."""
    out = out or sys.stdout
    term = Terminal(out, out.isatty() if tty is None else tty)
    progress = Progress(term)
    tail = collections.deque(maxlen=TAIL)
    traceback = done = False
    os.makedirs(os.path.dirname(os.path.abspath(log_path)), exist_ok=True)
    t0 = time.time()
    term.line(f"Tussock demo: Blender's own output goes to {short(log_path)}")
    with open(log_path, "wb") as log:
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL)
        try:
            for raw in proc.stdout:
                log.write(raw)
                text = raw.decode("utf-8", "replace").rstrip("\r\n")
                tail.append(text)
                m = FRAME.match(text)
                if m:
                    progress.frame(int(m.group(1) or m.group(2)))
                elif text.startswith("[demo"):
                    log.flush()
                    step, frames, end = STEP.match(text), FRAMES.match(text), DONE.match(text)
                    if step:
                        progress.stop()
                        k, n, msg, took = step.groups()
                        head = f"[{k:>{len(n)}}/{n}] {float(took):6.1f} s  "
                        term.indent = len(head)
                        term.line(head + msg.replace(os.getcwd() + os.sep, ""))
                    elif frames:
                        progress.start(frames.group(1), int(frames.group(2)))
                    elif end:
                        done = end.group(1)
                elif "Traceback (most recent call last):" in text:
                    traceback = True
            code = proc.wait()
        except KeyboardInterrupt:
            proc.terminate()
            proc.wait()
            term.line(f"interrupted; Blender's output so far is in {short(log_path)}")
            return 130
    if code == 0 and not traceback and done:
        outputs = sorted(e.name + ("/" if e.is_dir() else "") for e in os.scandir(done)
                         if e.path != os.path.abspath(log_path)
                         and not e.name.endswith(".blend1"))  # Blender's backup
        term.line(f"done in {duration(time.time() - t0)}: {short(done)}/ holds "
                  + ", ".join(outputs))
        return 0
    why = (f"Blender exited with {code}" if code else
           "a Python traceback" if traceback else "Blender stopped before the demo's end")
    term.line(f"FAILED after {duration(time.time() - t0)}: {why}. "
              f"The log's last {len(tail)} lines:")
    for text in tail:
        term.line("    " + text)
    term.line(f"The whole of Blender's output: {short(log_path)}")
    return code or 1


def main(argv):
    args = argv[argv.index("--") + 1:] if "--" in argv else argv
    out = os.path.abspath(args[0] if args else "out")
    with blender_env.BlenderUser() as user:
        return run(blender_env.command(DEMO, [out]), os.path.join(out, "demo.log"), user.env)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
