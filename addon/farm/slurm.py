"""The `slurm` back end: one `sbatch --array` job per step, each depending on the one before
(`--dependency=afterok`, and `--kill-on-invalid-dep=yes` so that the steps after a failed or
cancelled one are removed from the queue instead of waiting forever). Each task writes its
output to <name>_farm/logs/STEP_%A_%a.out (%A the job, %a the task). While the jobs run,
progress is read back from the scheduler with `squeue`; what each task came to is read from
the state files the job script writes (so no accounting database, `sacct`, is needed)."""

import json
import subprocess
import time

from .plan import STEPS


def _run(cmd):
    return subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def submit(plan, todo, extra=()):
    """Submits the steps that have tasks; returns [(step, job id, [Task])]."""
    script = plan.path(plan.farm, "job.sh")
    jobs, prev = [], None
    for step in STEPS:
        tasks = todo[step]
        if not tasks:
            continue
        cmd = ["sbatch", "--parsable", "--array=" + ",".join(str(t.index) for t in tasks),
               f"--job-name=tussock-{step}-{plan.name}", f"--chdir={plan.dir}",
               "--output=" + plan.path(plan.farm, "logs", f"{step}_%A_%a.out")]
        if prev:
            cmd += [f"--dependency=afterok:{prev}", "--kill-on-invalid-dep=yes"]
        cmd += list(extra) + [script, step]
        try:
            proc = _run(cmd)
        except FileNotFoundError:
            raise RuntimeError("sbatch is not installed here: run the farm command on a "
                               "machine that submits to your Slurm cluster") from None
        if proc.returncode != 0:
            if jobs:  # the steps submitted so far would run without the rest
                _run(["scancel"] + [j for _, j, _ in jobs])
            raise RuntimeError(f"sbatch refused the {step} step: "
                               f"{(proc.stderr or proc.stdout).strip()}")
        prev = proc.stdout.strip().split(";")[0]
        jobs.append((step, prev, tasks))
    with open(plan.path(plan.farm, "slurm_jobs.json"), "w") as f:
        json.dump([[s, j, [t.index for t in ts]] for s, j, ts in jobs], f)
    return jobs


def queued(job_ids):
    """{(job id, task): state} of the tasks still in the queue, or None when squeue fails."""
    proc = _run(["squeue", "-h", "-r", "-j", ",".join(job_ids), "-o", "%i %T"])
    if proc.returncode != 0:
        if "Invalid job id" in proc.stderr:  # every job has left the queue
            return {}
        return None
    out = {}
    for line in proc.stdout.split("\n"):
        if "_" in line:
            ident, state = line.split()
            job, task = ident.split("_", 1)
            out[(job, task)] = state
    return out


def watch(plan, jobs, say, poll=1.0, patience=120.0):
    """Follows the jobs until none is queued; says each step's progress when it changes.
    Returns the tasks that did not end well: [(Task, log path, what happened)]."""
    last, failing_since = None, None
    while True:
        q = queued([j for _, j, _ in jobs])
        if q is None:  # the controller did not answer: try again for a while
            failing_since = failing_since or time.time()
            if time.time() - failing_since > patience:
                raise RuntimeError("squeue does not answer: see `sinfo`, then run the farm "
                                   "command again to resume")
            time.sleep(poll)
            continue
        failing_since = None
        parts = []
        for step, job, tasks in jobs:
            states = [q.get((job, str(t.index))) for t in tasks]
            done = sum(s is None and plan.outcome(step, t.index) == "ok"
                       for s, t in zip(states, tasks))
            parts.append(f"{step} (job {job}): {done}/{len(tasks)} done, "
                         f"{states.count('RUNNING')} running, {states.count('PENDING')} waiting")
        line = "; ".join(parts)
        if line != last:
            say(line)
            last = line
        if not q:
            break
        time.sleep(poll)
    bad = []
    for step, job, tasks in jobs:
        for t in tasks:
            outcome = plan.outcome(step, t.index)
            if outcome != "ok":
                what = ("failed twice" if outcome == "failed" else
                        "did not run to its end (cancelled, its node failed, or a step before "
                        "it failed)")
                bad.append((t, plan.path(plan.farm, "logs", f"{step}_{job}_{t.index}.out"), what))
    return bad
