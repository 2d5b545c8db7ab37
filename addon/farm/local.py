"""The `local` back end: each step's tasks as `bash job.sh STEP TASK` processes on this
machine, all of a step's tasks at once (N tasks: N Blenders), one step after the other;
a step with a failed task stops the run. Each task's output goes to
<name>_farm/logs/STEP_local_TASK.out."""

import subprocess
import time

from .plan import STEPS


def run(plan, todo, say):
    script = plan.path(plan.farm, "job.sh")
    for step in STEPS:
        tasks = todo[step]
        if not tasks:
            continue
        say(f"{step}: {len(tasks)} task(s) started")
        running = []
        try:
            for t in tasks:
                log = plan.path(plan.farm, "logs", f"{step}_local_{t.index}.out")
                with open(log, "w") as f:
                    proc = subprocess.Popen(["bash", script, step, str(t.index)], cwd=plan.dir,
                                            stdout=f, stderr=subprocess.STDOUT)
                running.append((t, proc, log))
            left = len(running)
            while left:
                time.sleep(0.2)
                now = sum(p.poll() is None for _, p, _ in running)
                if now != left:
                    left = now
                    say(f"{step}: {len(running) - left} of {len(running)} task(s) done")
        finally:  # interrupted: our own processes end with us
            for _, p, _ in running:
                if p.poll() is None:
                    p.terminate()
                    p.wait()
        failed = [(t, log, "failed twice" if plan.outcome(step, t.index) == "failed"
                   else "did not run to its end (interrupted)")
                  for t, _, log in running if plan.outcome(step, t.index) != "ok"]
        if failed:
            return failed
    return []
