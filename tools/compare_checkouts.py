#!/usr/bin/python3
"""Before and after in one run: the Blender benchmarks of two checkouts, taken in turns.

usage: compare_checkouts.py --old DIR [--rounds N] [--env-old K=V]... SCRIPT [NAME...]

SCRIPT is a tools/bench_*.py file name (bench_sim.py, bench_trees.py); each round runs it
once in the checkout DIR (its own add-on and native build) and once in this one, alternately,
in this machine's Blender, so that both see the same load as it drifts. Each benchmark line
(DESIGN.md's JSON) is collected per side; the result is one JSON line per benchmark name and
peer: the median over rounds on each side, every value, and new / old. `--env-old` sets an
environment variable for the old side only (for instance MALLOC_CONF, to give a checkout from
before addon/allocator.py the allocator setting the new one applies itself)."""

import argparse
import json
import os
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)


def run_side(checkout, script, names, env):
    """The JSON lines of one run of `script` in `checkout`, by (name, peer)."""
    cmd = [sys.executable, os.path.join(checkout, "tools", "blender_run.py"),
           os.path.join(checkout, "tools", script), "--", *names]
    proc = subprocess.run(cmd, cwd=checkout, env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.DEVNULL, text=True, errors="replace")
    found = {}
    for line in proc.stdout.splitlines():
        if not line.startswith("{"):
            continue
        try:
            rec = json.loads(line)
        except ValueError:
            continue
        if isinstance(rec.get("value"), (int, float)):
            found[(rec["name"], rec.get("peer"))] = (rec["value"], rec.get("unit", ""))
    if proc.returncode != 0 and not found:
        raise SystemExit(f"{script} failed in {checkout} (exit {proc.returncode})")
    return found


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--old", required=True, help="the checkout to compare against")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--env-old", action="append", default=[], metavar="K=V")
    ap.add_argument("script")
    ap.add_argument("names", nargs="*")
    a = ap.parse_args()
    old_env = dict(os.environ)
    for kv in a.env_old:
        k, _, v = kv.partition("=")
        old_env[k] = v
    sides = {"old": (os.path.abspath(a.old), old_env), "new": (REPO, dict(os.environ))}
    values = {}  # (name, peer) -> side -> [values]
    units = {}
    for r in range(a.rounds):
        order = ("old", "new") if r % 2 == 0 else ("new", "old")  # neither always goes first
        for side in order:
            checkout, env = sides[side]
            for k, (v, unit) in run_side(checkout, a.script, a.names, env).items():
                values.setdefault(k, {}).setdefault(side, []).append(v)
                units[k] = unit
    load = os.getloadavg()[0]
    for (name, peer), by in sorted(values.items(), key=lambda kv: (kv[0][0], kv[0][1] or "")):
        rec = {"name": name, "unit": units[(name, peer)], "rounds": a.rounds,
               "load_average_after": round(load, 2)}
        if peer:
            rec["peer"] = peer
        for side in ("old", "new"):
            if by.get(side):
                rec[side] = round(statistics.median(by[side]), 4)
                rec[side + "_values"] = [round(v, 4) for v in by[side]]
        if rec.get("old"):
            rec["new_over_old"] = round(rec.get("new", float("nan")) / rec["old"], 3)
        print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
