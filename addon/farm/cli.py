"""The farm command:

    python3 <add-on folder>/farm run scene.blend [--backend local|slurm] [--tasks N]
            [--frames FIRST-LAST] [--blender PATH] [--fresh] [--no-wait] [--sbatch-arg ARG]...
    python3 <add-on folder>/farm watch scene.blend      (follow Slurm jobs submitted --no-wait)

Runs again with the same arguments, `run` resumes: see plan.py for what is redone. Exit
status 0 when every task ended well; else each failed task is reported with its log."""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys

from . import local, plan as farm_plan, slurm

PROBE = ("import bpy, json; s = bpy.context.scene; r = s.render; "
         "print('TUSSOCK_FARM_SCENE', json.dumps([s.frame_start, s.frame_end, "
         "r.resolution_x * r.resolution_percentage // 100, "
         "r.resolution_y * r.resolution_percentage // 100]))")


def say(text):
    print(f"tussock farm: {text}", flush=True)


def probe(blender, blend):
    """The scene's frame range and rendered size, read by a background Blender (in the
    Python-neutral environment the job script gives its Blenders)."""
    neutral = farm_plan.PYTHON_NEUTRAL + '\nexec "$@"'
    proc = subprocess.run(["bash", "-c", neutral, "tussock-probe",
                           blender, "-b", "--factory-startup", blend, "--python-expr", PROBE],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          errors="replace")
    m = re.search(r"^TUSSOCK_FARM_SCENE (.*)$", proc.stdout, re.M)
    if not m:
        raise RuntimeError(f"{blender} could not read {blend}:\n{proc.stdout[-2000:]}")
    a, b, w, h = json.loads(m.group(1))
    return (a, b), (w, h)


def make_plan(args):
    blender = shutil.which(args.blender) or args.blender
    blend = os.path.abspath(args.blend)
    if not os.path.isfile(blend):
        raise ValueError(f"{blend}: no such .blend file")
    if args.scene:  # "FIRST-LAST:WIDTHxHEIGHT": given by the Submit to Farm button
        rng, _, size = args.scene.partition(":")
        scene_range, size = farm_plan.parse_range(rng), tuple(int(x) for x in size.split("x"))
    else:
        scene_range, size = probe(blender, blend)
    frames = farm_plan.parse_range(args.frames) if args.frames else None
    return farm_plan.Plan(blend, scene_range, frames, args.tasks, size, blender)


def report(p, bad):
    for t, log, what in bad:
        say(f"{t.step} task {t.index} (frames {t.frames[0]}-{t.frames[1]}) {what}; "
            f"log: {log}")
        sys.stdout.write("".join("    " + line for line in p.log_tail(log).splitlines(True)))
    say(f"{len(bad)} task(s) did not end well: fix the cause, then run the same command "
        "again; only the frames missing or failing verification are done again")


def cmd_run(args):
    p = make_plan(args)
    todo = p.todo(fresh=args.fresh)
    script = p.write(todo)
    count = sum(len(v) for v in todo.values())
    say(f"{p.blend}: bake {p.scene_range[0]}-{p.scene_range[1]} in {len(p.steps['bake'])} "
        f"task(s), render {p.frames[0]}-{p.frames[1]} in {len(p.steps['render'])} task(s); "
        f"{count} task(s) to run; job script {script}")
    if not count:
        say("nothing left to do: every frame is there and verifies")
        return 0
    if args.backend == "local":
        bad = local.run(p, todo, say)
    else:
        jobs = slurm.submit(p, todo, args.sbatch_arg)
        say("submitted: " + ", ".join(f"{s} job {j}" for s, j, _ in jobs))
        if args.no_wait:
            return 0
        bad = slurm.watch(p, jobs, say)
    if bad:
        report(p, bad)
        return 1
    say(f"done: frames in {p.path('render')}")
    return 0


def cmd_watch(args):
    p = make_plan(args)
    with open(p.path(p.farm, "slurm_jobs.json")) as f:
        saved = json.load(f)
    by_index = {s: {t.index: t for t in p.steps[s]} for s in farm_plan.STEPS}
    jobs = [(s, j, [by_index[s][i] for i in idx]) for s, j, idx in saved]
    bad = slurm.watch(p, jobs, say)
    if bad:
        report(p, bad)
        return 1
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 <tussock>/farm",
                                 description="Bake and render a saved .blend on a farm.")
    sub = ap.add_subparsers(dest="cmd", required=True)
    for name in ("run", "watch"):
        r = sub.add_parser(name)
        r.add_argument("blend", help="the saved .blend (its folder holds every output)")
        r.add_argument("--tasks", type=int, default=4, help="tasks per step (default 4)")
        r.add_argument("--frames", help="FIRST-LAST to render (default: the scene's range)")
        r.add_argument("--blender", default=os.environ.get("BLENDER", "blender"),
                       help="the Blender the tasks run (default: $BLENDER or blender)")
        r.add_argument("--scene", help=argparse.SUPPRESS)
    r = sub.choices["run"]
    r.add_argument("--backend", choices=("local", "slurm"), default="local")
    r.add_argument("--fresh", action="store_true",
                   help="forget earlier outcomes and rendered frames: do everything again")
    r.add_argument("--no-wait", action="store_true", help="slurm: submit, do not follow")
    r.add_argument("--sbatch-arg", action="append", default=[],
                   help="an option for every sbatch (e.g. --sbatch-arg=--partition=render)")
    args = ap.parse_args(argv)
    try:
        return cmd_run(args) if args.cmd == "run" else cmd_watch(args)
    except (ValueError, RuntimeError, OSError) as exc:
        say(f"error: {exc}")
        return 2
    except KeyboardInterrupt:
        say("interrupted: local tasks are stopped, Slurm jobs go on (`watch` follows them); "
            "run the same command again to resume")
        return 130
