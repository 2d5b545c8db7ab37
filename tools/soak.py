#!/usr/bin/python3
"""The soak tester (issue 42): runs Blender through random steps of an artist's work
(tools/soak_blender.py does them and checks the invariants after each), and when a step
breaks an invariant or Blender dies, shrinks the steps to a short sequence that still fails,
as Hypothesis does, by replaying parts of it in new Blenders.

usage: soak.py [--minutes M | --steps N] [--seed S] [--window] [--gdb] [--debug-memory]
               [--only STEP,...] [--skip STEP,...] [--max-failures F] [--shrink-minutes M]
               [--step-timeout SECONDS] [--out DIR] [--max-rss-mb MB] [--hard-rss-mb MB]
       soak.py --replay FILE [--shrink] [--window] [--gdb] [--debug-memory]
               (FILE: a shrunk sequence, or a journal)

Environment: BLENDER (the Blender to run), TSK_ADDON (tools/blender_env.py),
TSK_SOAK_PRELOAD with TSK_SOAK_ASAN_OPTIONS and TSK_SOAK_UBSAN_OPTIONS (a sanitizer runtime
preloaded into Blender alone: ./build.sh soak --asan),
TSK_SOAK_PLANT=raise|leak|hoard|unfreed (a planted fault, for the tester's own test). Prints
the seed first; for each failure (with --debug-memory, blocks not freed at exit are one,
`unfreed`, but for those Blender leaves by itself: BLENDER_OWN_BLOCKS) the seed, the shrunk
steps, the Python traceback (faulthandler, and whatever the add-on printed) and with --gdb
the native backtrace; last the line
`soak: N steps in S s soaking (T s in all), seed X, F failures`: --minutes counts the
soaking, not the tester's own replays. Exits 1 when anything failed."""

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import blender_env  # noqa: E402

SCRIPT = os.path.join(HERE, "soak_blender.py")
FAIL_EXIT = 3  # soak_blender.py's status when an invariant broke
# Python's faulthandler prints the Python stack of a crash (and, on SIGUSR1, of a hang);
# it is enabled before the soak script runs, on the fd that script later sends to its log.
FAULTHANDLER = ("import faulthandler, signal; faulthandler.enable(all_threads=True); "
                "faulthandler.register(signal.SIGUSR1, all_threads=True)")
LEAKS = re.compile(r"Error: Not freed memory blocks: (\d+)(?:, total unfreed memory ([\d.]+) MB)?")
# Blocks that Blender leaves at exit by itself, with no add-on: (name, Blender major.minor,
# how that was shown). They are reported but are no failure; any other block is.
BLENDER_OWN_BLOCKS = [
    ("ED_mesh_join_objects_exec", (4, 3),
     "4.3's Join leaks 4 bytes for each join of meshes without faces: two meshes of 6 "
     "vertices and 5 edges made with bpy.data, no add-on, joined 5 times leave 5 blocks"),
]


def blender_own(block, version):
    """True when the `--debug-memory` line `block` names a block Blender `version` (major,
    minor) leaves by itself."""
    name = block.split(" len: ")[0].strip()
    return any(name == n and version == v for n, v, _ in BLENDER_OWN_BLOCKS)


class Outcome:
    """One Blender run: the steps it started, how it ended, and what it printed."""

    def __init__(self, steps, results, kind, detail, log, code, secs, leaks=None):
        self.steps, self.results, self.kind, self.detail = steps, results, kind, detail
        self.log, self.code, self.secs, self.leaks = log, code, secs, leaks

    @property
    def failed(self):
        return self.kind is not None


def blender_command(args, soak_args, window, gdb, debug_memory):
    cmd = blender_env.command(SCRIPT, soak_args, window=window)
    at = cmd.index(os.environ.get("BLENDER", "blender"))
    extra = ["--python-expr", FAULTHANDLER]
    if debug_memory:
        extra.insert(0, "--debug-memory")
    python = cmd.index("--python")
    cmd[python:python] = extra
    if gdb:
        cmd[at:at] = ["gdb", "-q", "-batch", "-ex", "set print thread-events off",
                      "-ex", "handle SIGUSR1 nostop noprint pass", "-ex", "run",
                      "-ex", "thread apply all bt 30", "--args"]
    return cmd


def _descendants(pid):
    """pid and every process under it (read from /proc)."""
    found, todo = [], [pid]
    while todo:
        p = todo.pop()
        found.append(p)
        try:
            with open(f"/proc/{p}/task/{p}/children") as f:
                todo += [int(c) for c in f.read().split()]
        except OSError:
            pass
    return found


def _blender_pids(pid):
    out = []
    for p in _descendants(pid):
        try:
            with open(f"/proc/{p}/comm") as f:
                if f.read().strip().startswith("blender"):
                    out.append(p)
        except OSError:
            pass
    return out


def run_blender(args, soak_args, journal, timeout, step_timeout, window=False, gdb=False,
                debug_memory=False, quiet=True, preload=None):
    """Runs soak_blender.py once; returns its Outcome. A run that shows no new journal line
    for step_timeout seconds is a hang: Blender gets SIGUSR1 (faulthandler prints the Python
    stack), then SIGABRT (its own crash handler, or gdb, prints the native one)."""
    log = journal + ".log"
    out_path = journal + ".out"
    for p in (journal, log):
        if os.path.exists(p):
            os.remove(p)
    t0 = time.monotonic()
    hang = None
    with blender_env.BlenderUser() as user:
        env = dict(user.env)
        env["PYTHONFAULTHANDLER"] = "1"
        if os.environ.get("TSK_SOAK_PRELOAD"):  # ./build.sh soak --asan: Blender alone
            env["LD_PRELOAD"] = os.environ["TSK_SOAK_PRELOAD"]
            env["ASAN_OPTIONS"] = os.environ.get("TSK_SOAK_ASAN_OPTIONS", "")
            env["UBSAN_OPTIONS"] = os.environ.get("TSK_SOAK_UBSAN_OPTIONS", "")
        if preload:  # another C allocator, for Blender and the Blenders it starts
            env["LD_PRELOAD"] = preload
        cmd = blender_command(args, soak_args + ["--journal", journal], window, gdb,
                              debug_memory)
        with open(out_path, "w") as out:
            proc = subprocess.Popen(cmd, env=env, stdout=out, stderr=subprocess.STDOUT,
                                    start_new_session=True)
            last, size = time.monotonic(), -1
            while proc.poll() is None:
                time.sleep(0.5)
                now = time.monotonic()
                grown = os.path.getsize(journal) if os.path.exists(journal) else 0
                if grown != size:
                    last, size = now, grown
                if now - last > step_timeout or now - t0 > timeout:
                    hang = f"no step ended for {now - last:.0f} s" if now - last > step_timeout \
                        else f"the run took more than {timeout:.0f} s"
                    for sig, wait in ((signal.SIGUSR1, 3), (signal.SIGABRT, 20)):
                        for p in _blender_pids(proc.pid):
                            os.kill(p, sig)
                        try:
                            proc.wait(wait)
                            break
                        except subprocess.TimeoutExpired:
                            pass
                    if proc.poll() is None:
                        os.killpg(proc.pid, signal.SIGKILL)
                        proc.wait()
    secs = time.monotonic() - t0
    steps, results = read_journal(journal)
    text = _read(out_path) + _read(log)
    kind, detail = None, ""
    if hang:
        kind, detail = "hang", hang
    elif results and results[-1].get("result") == "fail":
        kind, detail = results[-1]["kind"], results[-1].get("detail", "")
    elif proc.returncode != 0 or "Program received signal" in text:
        sig = re.search(r"Program received signal (\w+)", text)
        name = sig.group(1) if sig else (signal.Signals(-proc.returncode).name
                                         if proc.returncode < 0 else
                                         _signal_of(proc.returncode))
        kind, detail = "crash", f"Blender died ({name}) during step {len(steps) - 1}"
    elif len(results) < len(steps):
        kind, detail = "crash", f"Blender ended during step {len(steps) - 1} with status 0"
    leaks = None
    if debug_memory:
        leaks, unfreed = blocks_left(text)
        if kind is None and unfreed:
            kind, detail = "unfreed", unfreed
    return Outcome(steps, results, kind, detail, text, proc.returncode, secs, leaks)


def blocks_left(text):
    """(how many blocks a `--debug-memory` Blender's output says it left at exit, 0 when all
    are Blender's own; a failure's detail naming the others, or "" when there are none)"""
    m = LEAKS.search(text)
    if not m:
        return 0, ""
    # Blender's guarded allocator lists each block left at exit with its name: the names
    # say whose they are, the shrunk steps which step left them
    blocks = [line.strip() for line in text.splitlines() if " len: " in line]
    v = re.search(r"^Blender (\d+)\.(\d+)", text, re.M)
    version = (int(v.group(1)), int(v.group(2))) if v else None
    blenders, others = [], []
    for b in blocks:
        (blenders if blender_own(b, version) else others).append(b)
    leaks = int(m.group(1))
    if blenders and not others and len(blenders) == leaks:
        names = sorted({b.split(" len: ")[0] for b in blenders})
        print(f"soak: --debug-memory: the {leaks} blocks not freed at exit are Blender's own "
              f"({', '.join(names)}; tools/soak.py BLENDER_OWN_BLOCKS)", flush=True)
        return 0, ""
    return leaks, (f"{leaks} blocks not freed at exit"
                   + (f" ({m.group(2)} MB)" if m.group(2) else "")
                   + (f", {len(blenders)} of them Blender's own" if blenders else "") + ":\n"
                   + "\n".join(others[:20]) + ("\n..." if len(others) > 20 else ""))


def _signal_of(code):
    if code > 128 and code - 128 in signal.valid_signals():
        return signal.Signals(code - 128).name
    return f"exit status {code}"


def _read(path):
    try:
        with open(path, errors="replace") as f:
            return f.read()
    except OSError:
        return ""


def read_journal(path):
    """(the steps started, in order; their results)"""
    steps, results = [], []
    for line in _read(path).splitlines():
        try:
            rec = json.loads(line)
        except ValueError:
            continue  # a line cut by a crash
        if "step" in rec:
            steps.append(rec["step"])
        elif "result" in rec:
            results.append(rec)
    return steps, results


# Blender 5's Linux builds allocate with TBB's scalable allocator, which keeps no count of the
# bytes it has handed out and, after a peak of gigabytes, holds on to much of it: 5.2 at 5.3 GB,
# its file opened again, held 1,825 MB against a fresh Blender's 1,037 MB; the same steps with
# jemalloc preloaded held 1,073 MB, with 792 MB allocated in both Blenders. A memory failure
# the allocator cannot count is therefore replayed with jemalloc, which can, before it counts.
JEMALLOC = "/usr/lib/x86_64-linux-gnu/libjemalloc.so.2"


def held_by_allocator(outcome, replay):
    """For a memory failure where the allocator kept no count: the line that says the same
    steps pass with jemalloc preloaded (memory the allocator held, not a leak), else None."""
    if outcome.kind != "memory" or "allocated" in outcome.detail or \
            not os.path.exists(JEMALLOC) or os.environ.get("TSK_SOAK_PRELOAD"):
        return None
    again = replay(outcome.steps, preload=JEMALLOC)
    if again.failed:
        return None
    said = [r.get("result", "") for r in again.results if "allocated" in str(r.get("result"))]
    return (f"soak: the memory step's failure ({outcome.detail}) is the allocator's: the "
            f"{len(outcome.steps)} steps replayed with jemalloc pass"
            + (f" ({said[-1]})" if said else ""))


# ---- shrinking ----------------------------------------------------------------------------------

class Shrinker:
    """Delta debugging over the steps of a failing run: a candidate is kept when its replay
    fails the same way (the same invariant; any crash for a crash), within a time budget."""

    def __init__(self, kind, replay, budget):
        self.kind, self.replay = kind, replay
        self.deadline = time.monotonic() + budget
        self.runs = 0
        self.last = None

    def fails(self, steps):
        if time.monotonic() > self.deadline:
            return False
        self.runs += 1
        outcome = self.replay(steps)
        if outcome.kind == self.kind:
            self.last = outcome
            return True
        return False

    def shortest_prefix(self, steps):
        """The shortest first part of the steps that still fails, by bisection: for blocks
        not freed at exit, which no step reports, so the last step is not the one that left
        them (blocks a part leaves, the whole nearly always leaves too). Out of time, the
        shortest part found to fail."""
        lo, hi = 0, len(steps)  # steps[:lo] is taken to pass, steps[:hi] fails
        while hi - lo > 1 and time.monotonic() < self.deadline:
            mid = (lo + hi) // 2
            if self.fails(steps[:mid]):
                hi = mid
            else:
                lo = mid
        return steps[:hi]

    def shrink(self, steps):
        """The step that failed is kept last (a failure needs it, nearly always); the steps
        before it are shrunk: first the shortest tail that still fails (1, 2, 4, ... steps
        before it: a cause is usually recent), then ddmin, which removes chunks of them,
        halving the chunks' size down to single steps. Blocks not freed at exit are first
        cut to the shortest first part that leaves them, whose last step is then kept."""
        steps = list(steps)
        if self.kind == "unfreed":
            steps = self.shortest_prefix(steps)
        last, before = steps[-1:], steps[:-1]
        k = 0
        while k < len(before):
            if self.fails(before[len(before) - k:] + last):
                before = before[len(before) - k:]
                break
            k = 1 if k == 0 else k * 2
        n = 2
        while before and time.monotonic() < self.deadline:
            size = max(1, len(before) // n)
            removed = False
            for start in range(0, len(before), size):
                rest = before[:start] + before[start + size:]
                if self.fails(rest + last):
                    before, removed = rest, True
                    n = max(n - 1, 2)
                    break
            if not removed:
                if size == 1:
                    break
                n = min(n * 2, len(before))
        return before + last


# ---- reporting ----------------------------------------------------------------------------------

def tracebacks(text, limit=8000):
    """The Python tracebacks, faulthandler's dump and the native backtrace (gdb's, or the
    one Blender's crash handler prints) in what a run printed."""
    lines = text.splitlines()
    parts = []
    for m in re.finditer(r"Traceback \(most recent call last\):\n(?:[ \t].*\n)*.*", text):
        parts.append(m.group(0))
    for start in ("Fatal Python error", "Program received signal", "Writing: /"):
        at = [i for i, line in enumerate(lines) if line.startswith(start)]
        if at:
            parts.append("\n".join(lines[at[0]:at[0] + 80]))
    seen, out = set(), []
    for p in parts:
        if p not in seen:
            seen.add(p)
            out.append(p.strip())
    return "\n\n".join(out)[:limit]


def report(seed, outcome, shrunk, final, out_dir, window):
    print(f"soak: FAILURE with seed {seed}: {outcome.kind}: "
          f"{outcome.detail.splitlines()[0] if outcome.detail else ''}")
    print(f"soak: {len(outcome.steps)} steps shrunk to {len(shrunk)}:")
    for s in shrunk:
        print("  " + json.dumps(s))
    path = os.path.join(out_dir, f"shrunk-{seed}.json")
    with open(path, "w") as f:
        json.dump({"seed": seed, "kind": outcome.kind, "steps": shrunk}, f, indent=1)
    shown = final or outcome
    print("soak: what failed:\n" + "\n".join("  " + line for line in
                                             shown.detail[:4000].splitlines()))
    tb = tracebacks(shown.log)
    if tb and tb not in shown.detail:
        print("soak: traceback and backtrace printed by Blender:\n" +
              "\n".join("  " + line for line in tb.splitlines()))
    print(f"soak: replay with: {sys.argv[0]} --replay {path}" + (" --window" if window else ""))


def main(argv=None):
    p = argparse.ArgumentParser(prog="soak.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--minutes", type=float, default=0.0)
    p.add_argument("--steps", type=int, default=0)
    p.add_argument("--seed", type=int)
    p.add_argument("--window", action="store_true", help="a real window on Xvfb")
    p.add_argument("--gdb", action="store_true", help="Blender under gdb: native backtraces")
    p.add_argument("--debug-memory", action="store_true",
                   help="Blender with --debug-memory: count the blocks left at exit")
    p.add_argument("--replay", help="replay these steps (a shrunk file or a journal)")
    p.add_argument("--shrink", action="store_true", help="with --replay: shrink it too")
    p.add_argument("--only", default="")
    p.add_argument("--skip", default="")
    p.add_argument("--max-failures", type=int, default=3,
                   help="stop after so many failures (each shrunk and reported)")
    p.add_argument("--shrink-minutes", type=float, default=10.0)
    p.add_argument("--step-timeout", type=float, default=300.0)
    p.add_argument("--out", help="folder for journals and shrunk sequences")
    p.add_argument("--max-rss-mb", type=float, default=6000.0,
                   help="resident memory above which the scene is measured in a fresh "
                        "Blender: a leak fails, a large scene is replaced by a new file")
    p.add_argument("--hard-rss-mb", type=float, default=16000.0,
                   help="resident memory above which a step fails, whatever the scene")
    args = p.parse_args(argv)
    if not (args.minutes or args.steps or args.replay):
        args.minutes = 3.0
    seed = args.seed if args.seed is not None else int(time.time() * 1000) % 1000000
    # absolute: Blender 3.4 refuses to save to a relative path (the memory step saves there)
    out_dir = os.path.abspath(args.out) if args.out else tempfile.mkdtemp(prefix="tussock-soak-")
    os.makedirs(out_dir, exist_ok=True)
    print(f"soak: seed {seed}, {'window' if args.window else 'background'}, "
          f"{args.minutes or '-'} minutes, {args.steps or '-'} steps; files in {out_dir}",
          flush=True)
    common = ["--max-rss-mb", str(args.max_rss_mb), "--hard-rss-mb", str(args.hard_rss_mb)]
    if args.only:
        common += ["--only", args.only]
    if args.skip:
        common += ["--skip", args.skip]
    counter = [0]
    # a replay is a hang after this long without a step ending: shorter while a hang is
    # shrunk, so that each candidate costs half a minute rather than the full timeout
    replay_timeout = [args.step_timeout]

    def replay(steps, gdb=args.gdb, window=args.window, preload=None):
        counter[0] += 1
        work = os.path.join(out_dir, f"replay-{counter[0]}")
        os.makedirs(work, exist_ok=True)
        path = os.path.join(work, "steps.json")
        with open(path, "w") as f:
            json.dump(steps, f)
        # (with the run's --debug-memory: the guarded allocator changes what memory holds)
        return run_blender(args, common + ["--replay", path, "--workdir", work],
                           os.path.join(work, "journal.jsonl"), 600 + 120 * len(steps),
                           replay_timeout[0], window, gdb, args.debug_memory,
                           preload=preload)

    t0 = time.monotonic()
    total = failures = 0
    leaks = []
    if args.replay:
        with open(args.replay) as f:
            text = f.read()
        try:
            data = json.loads(text)
            steps = data["steps"] if isinstance(data, dict) else data
        except ValueError:
            steps, _ = read_journal(args.replay)
        outcome = replay(steps)
        held = held_by_allocator(outcome, replay)
        if held:
            print(held, flush=True)
            outcome.kind = None
        total, failures = len(outcome.steps), int(outcome.failed)
        if outcome.failed:
            shrunk, last = steps, outcome
            if args.shrink:
                shrinker = Shrinker(outcome.kind, replay, args.shrink_minutes * 60)
                shrunk = shrinker.shrink(outcome.steps)
                last = shrinker.last or outcome
                print(f"soak: shrinking took {shrinker.runs} replays", flush=True)
            report(seed, outcome, shrunk, last, out_dir, args.window)
    run_seed = seed
    # --minutes is time spent soaking: the tester's own replays (a failure shrunk, a memory
    # step replayed with jemalloc) come on top, so that an hour's run is an hour of steps
    soaked = 0.0
    while not args.replay:
        if args.minutes and soaked > args.minutes * 60 - 5:
            break
        soak_args = common + ["--seed", str(run_seed),
                              "--workdir", os.path.join(out_dir, f"run-{run_seed}")]
        if args.steps:
            soak_args += ["--steps", str(args.steps - total)]
        if args.minutes:
            soak_args += ["--minutes", f"{args.minutes - soaked / 60:.3f}"]
        left = args.minutes * 60 - soaked if args.minutes else 3600 + 60 * args.steps
        outcome = run_blender(args, soak_args, os.path.join(out_dir, f"journal-{run_seed}.jsonl"),
                              left + args.step_timeout + 60, args.step_timeout, args.window,
                              args.gdb, args.debug_memory)
        total += len(outcome.steps)
        soaked += outcome.secs
        if outcome.leaks is not None:
            leaks.append(outcome.leaks)
            print(f"soak: --debug-memory: {outcome.leaks} blocks not freed at exit "
                  f"(seed {run_seed})")
        for step, rec in zip(outcome.steps, outcome.results):
            if step.get("op") == "memory" and rec.get("result") != "fail":
                print(f"soak: memory at step {rec['i']}: {rec.get('result')}")
        print(f"soak: seed {run_seed}: {len(outcome.steps)} steps in {outcome.secs:.0f} s, "
              f"{outcome.kind or 'ok'}", flush=True)
        held = held_by_allocator(outcome, replay)
        if held:  # not a failure: the run goes on with the next seed
            print(held, flush=True)
            outcome.kind = None
        if outcome.failed:
            failures += 1
            replay_timeout[0] = min(args.step_timeout, 30.0) if outcome.kind == "hang" \
                else args.step_timeout
            how = replay
            if args.window and outcome.kind not in ("panel", "hang") and \
                    replay(outcome.steps, window=False).kind == outcome.kind:
                # it fails in background Blender too, where a replay takes a tenth of the
                # time: shrunk there, and the result checked in a window again
                def how(steps):
                    return replay(steps, window=False)
            shrinker = Shrinker(outcome.kind, how, args.shrink_minutes * 60)
            shrunk = shrinker.shrink(outcome.steps)
            if how is not replay and replay(shrunk).kind != outcome.kind:
                print("soak: the sequence shrunk in background Blender passes in a window")
            print(f"soak: shrinking took {shrinker.runs} replays", flush=True)
            report(run_seed, outcome, shrunk, shrinker.last, out_dir, args.window)
        if args.steps and total >= args.steps or failures >= args.max_failures:
            break
        if not outcome.failed and not args.minutes and not held:
            break
        run_seed += 1
    secs = time.monotonic() - t0
    extra = f", {sum(leaks)} blocks not freed" if leaks else ""
    took = f"{secs:.0f} s" if args.replay else f"{soaked:.0f} s soaking ({secs:.0f} s in all)"
    print(f"soak: {total} steps in {took}, seed {seed}, {failures} failures{extra}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
