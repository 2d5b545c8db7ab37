"""The plan of a farm run, and the job script that carries it out (plain Python, no bpy).

A saved .blend is done in three steps, each a list of tasks that may run at once:
  bake      the scene's whole frame range split into N parts; each task bakes its part
            (`tussock.bake(frame_start=a, frame_end=b)`, without saving: parallel saves of
            one .blend would race);
  assemble  one task, after every bake task: a bake over the whole range. Every frame is
            there and verifies, so it only assembles the caches, wires the Mesh Cache
            modifiers and image sequences, and saves the .blend;
  render    the frames asked for split into N parts; each task is a plain
            `blender -b scene.blend -o //render/<name>_#### -F PNG -x 1 -f a..b`.
Every path is relative to the .blend's folder: the farm's own files go to
`<name>_farm/` beside it (job.sh, the task scripts, logs/, state/), the frames to
`render/<name>_NNNN.png`.

Resuming: a task's outcome is written to `<name>_farm/state/<step>.<task>` by the job
script ("ok" or "failed"; nothing when it was killed or cancelled). Bake tasks that say
"ok" are not run again, nor is the whole bake once the assembly said "ok"; a bake task run
again writes only the frames whose files are missing or fail their header and checksum
check (Tussock's bake does that by itself). A render task runs again only for its frames
that fail verify.check_png (missing, cut short, damaged, another size); those files are
deleted first. `fresh` forgets every outcome and rendered frame of the plan."""

import json
import os
import re
import shlex
import shutil

from . import verify

BAKE, ASSEMBLE, RENDER = "bake", "assemble", "render"
STEPS = (BAKE, ASSEMBLE, RENDER)
HERE = os.path.dirname(os.path.abspath(__file__))

# Bash lines that give the Blenders started after them a Python-neutral environment: the job
# script runs them before its task, the farm command before it reads the scene (cli.probe).
PYTHON_NEUTRAL = r"""
# Blender gets a Python-neutral environment. A Blender that uses the system's Python
# (Debian's, other distributions') takes its Python prefix from the first python3.X on the
# PATH and reads PYTHONHOME and PYTHONPATH: started from a shell with a venv, conda or pyenv
# Python active (Slurm passes the submitting shell's environment on), it looks for numpy in
# that environment, and Tussock cannot load. So those variables go, and so does every
# directory of the PATH that belongs to a Python environment.
python_env_dir() {  # is directory $1 the bin of a venv, conda or pyenv Python?
  local dir="${1%/}" up
  up="${dir%/*}"
  [ -e "$up/pyvenv.cfg" ] || [ -d "$up/conda-meta" ] && return 0        # venv, conda
  [ "${dir##*/}" = shims ] && [ -d "$up/versions" ] && return 0          # pyenv shims
  case "$up" in */versions/*) [ -d "${up%/versions/*}/shims" ] && return 0 ;; esac  # pyenv
  [ -n "${VIRTUAL_ENV:-}" ] && [ "$dir" = "${VIRTUAL_ENV%/}/bin" ] && return 0
  [ -n "${CONDA_PREFIX:-}" ] && [ "$dir" = "${CONDA_PREFIX%/}/bin" ] && return 0
  return 1
}
kept=""
IFS=: read -r -a path_dirs <<<"${PATH:-}"
for dir in "${path_dirs[@]}"; do
  if [ -n "$dir" ] && ! python_env_dir "$dir"; then kept="${kept:+$kept:}$dir"; fi
done
export PATH="$kept"
unset PYTHONHOME PYTHONPATH PYTHONSTARTUP PYTHONUSERBASE PYTHONEXECUTABLE PYTHONPLATLIBDIR \
  VIRTUAL_ENV VIRTUAL_ENV_PROMPT PYENV_VERSION PYENV_VIRTUAL_ENV \
  CONDA_PREFIX CONDA_DEFAULT_ENV CONDA_SHLVL CONDA_PYTHON_EXE "${!CONDA_PREFIX_@}"
""".strip("\n")


def split(first, last, parts):
    """`parts` consecutive ranges (a, b) covering first..last, their lengths differing by at
    most one (the longer ones first); fewer parts when there are fewer frames."""
    if last < first:
        raise ValueError(f"the frame range {first}-{last} ends before it starts")
    if parts < 1:
        raise ValueError(f"the number of tasks must be at least 1, not {parts}")
    count = last - first + 1
    parts = min(parts, count)
    size, extra = divmod(count, parts)
    out, a = [], first
    for i in range(parts):
        b = a + size + (i < extra) - 1
        out.append((a, b))
        a = b + 1
    return out


def parse_range(text):
    """'12-40' or '12' -> (12, 40) / (12, 12)."""
    m = re.fullmatch(r"\s*(-?\d+)\s*(?:-\s*(-?\d+)\s*)?", text)
    if not m:
        raise ValueError(f"a frame range is written FIRST-LAST (e.g. 1-250), not '{text}'")
    return int(m.group(1)), int(m.group(2) or m.group(1))


class Task:
    def __init__(self, step, index, frames, command, outputs=()):
        self.step, self.index = step, index
        self.frames = frames        # (first, last) of the task
        self.command = command      # argv, run in the .blend's folder
        self.outputs = list(outputs)  # render: the frame files, relative to the folder

    def __repr__(self):
        return f"Task({self.step} {self.index}: {self.frames[0]}-{self.frames[1]})"


class Plan:
    """Everything a farm run does for one .blend. `scene_range` is the scene's frame range
    (the bake covers all of it: a cache needs every frame), `frames` the frames to render,
    `size` the rendered frames' (width, height) in pixels."""

    def __init__(self, blend, scene_range, frames=None, tasks=4, size=(1920, 1080),
                 blender="blender"):
        self.blend = os.path.abspath(blend)
        if not os.path.isfile(self.blend):
            raise ValueError(f"{self.blend}: no such .blend file: save the scene first")
        self.dir = os.path.dirname(self.blend)
        self.name = os.path.splitext(os.path.basename(self.blend))[0]
        self.scene_range = tuple(int(x) for x in scene_range)
        self.frames = tuple(int(x) for x in (frames or self.scene_range))
        lo, hi = self.scene_range
        if self.frames[1] < self.frames[0]:
            raise ValueError(f"the frame range {self.frames[0]}-{self.frames[1]} ends before "
                             "it starts")
        if self.frames[0] < lo or self.frames[1] > hi:
            raise ValueError(f"frames {self.frames[0]}-{self.frames[1]} lie outside the "
                             f"scene's frame range {lo}-{hi}: choose frames within it")
        if int(tasks) < 1:
            raise ValueError(f"the number of tasks must be at least 1, not {tasks}")
        self.tasks = int(tasks)
        self.size = (int(size[0]), int(size[1]))
        self.blender = blender
        self.farm = self.name + "_farm"          # relative to self.dir
        self.render_pattern = f"render/{self.name}_####"
        self.steps = {BAKE: [], ASSEMBLE: [], RENDER: []}
        blend_arg = os.path.basename(self.blend)
        task_py = f"{self.farm}/bake_task.py"
        for i, (a, b) in enumerate(split(lo, hi, self.tasks)):
            self.steps[BAKE].append(Task(BAKE, i, (a, b), [
                "$BLENDER", "-b", blend_arg, "--python-exit-code", "1", "--python", task_py,
                "--", str(a), str(b)]))
        self.steps[ASSEMBLE].append(Task(ASSEMBLE, 0, (lo, hi), [
            "$BLENDER", "-b", blend_arg, "--python-exit-code", "1", "--python", task_py,
            "--", str(lo), str(hi), "save"]))
        for i, (a, b) in enumerate(split(self.frames[0], self.frames[1], self.tasks)):
            self.steps[RENDER].append(Task(RENDER, i, (a, b), self.render_command(a, b),
                                           [self.frame_file(f) for f in range(a, b + 1)]))

    def render_command(self, a, b, only=None):
        cmd = ["$BLENDER", "-b", os.path.basename(self.blend), "-o", "//" + self.render_pattern,
               "-F", "PNG", "-x", "1"]
        # -f, not -s a -e b -a: those set the scene's frame range, which is part of what
        # Tussock checks a bake against, so a node with Tussock installed would find the
        # bake out of date and render the live animation instead (frames of a task that
        # starts mid-range then differ from a single render)
        if only is not None and only != list(range(a, b + 1)):
            return cmd + ["-f", ",".join(str(f) for f in only)]  # a resumed task's frames
        return cmd + ["-f", f"{a}..{b}"]

    def frame_file(self, frame):
        return f"render/{self.name}_{frame:04d}.png"

    def path(self, *rel):
        return os.path.join(self.dir, *rel)

    def state_path(self, step, index):
        return self.path(self.farm, "state", f"{step}.{index}")

    def outcome(self, step, index):
        """'ok', 'failed', or None (not run, or killed before it ended)."""
        try:
            with open(self.state_path(step, index)) as f:
                return f.read().strip() or None
        except OSError:
            return None

    # ---- what is left to do --------------------------------------------------------------
    def todo(self, fresh=False):
        """The tasks still to run, by step: {step: [Task]} (a resumed render task renders only
        its frames that fail verification; their files are deleted here)."""
        if fresh:
            shutil.rmtree(self.path(self.farm, "state"), ignore_errors=True)
        out = {BAKE: [], ASSEMBLE: [], RENDER: []}
        if self.outcome(ASSEMBLE, 0) != "ok":
            out[BAKE] = [t for t in self.steps[BAKE] if self.outcome(BAKE, t.index) != "ok"]
            out[ASSEMBLE] = list(self.steps[ASSEMBLE])
        for t in self.steps[RENDER]:
            frames = list(range(t.frames[0], t.frames[1] + 1))
            bad = []
            for f in frames:
                p = self.path(self.frame_file(f))
                if fresh or verify.check_png(p, *self.size) is not None:
                    bad.append(f)
                    if os.path.isfile(p):
                        os.remove(p)
            if bad:
                out[RENDER].append(Task(RENDER, t.index, t.frames,
                                        self.render_command(*t.frames, only=bad),
                                        [self.frame_file(f) for f in bad]))
        return out

    # ---- the job script --------------------------------------------------------------------
    def write(self, todo):
        """Writes the job script (and the files it runs) into <name>_farm/; forgets the
        outcomes of the tasks about to run. Returns the script's path."""
        farm = self.path(self.farm)
        for d in ("", "logs", "state"):
            os.makedirs(os.path.join(farm, d), exist_ok=True)
        os.makedirs(self.path("render"), exist_ok=True)
        for name in ("bake_task.py", "verify.py"):
            shutil.copyfile(os.path.join(HERE, name), os.path.join(farm, name))
        for step in STEPS:
            for t in todo[step]:
                if os.path.exists(self.state_path(step, t.index)):
                    os.remove(self.state_path(step, t.index))
        script = os.path.join(farm, "job.sh")
        tmp = script + ".tmp"
        with open(tmp, "w") as f:
            f.write(self.script_text(todo))
        os.chmod(tmp, 0o755)
        os.replace(tmp, script)
        with open(os.path.join(farm, "plan.json"), "w") as f:
            json.dump({"blend": self.blend, "scene_range": self.scene_range,
                       "frames": self.frames, "tasks": self.tasks, "size": self.size,
                       "todo": {s: [[t.index, *t.frames] for t in todo[s]] for s in STEPS}},
                      f, indent=1)
        return script

    def script_text(self, todo):
        q = shlex.quote
        lines = [
            "#!/bin/bash",
            f"# Tussock farm job for {os.path.basename(self.blend)}: bake frames "
            f"{self.scene_range[0]}-{self.scene_range[1]} in {len(self.steps[BAKE])} tasks, "
            f"assemble the caches, render frames {self.frames[0]}-{self.frames[1]} in "
            f"{len(self.steps[RENDER])} tasks.",
            "# Written by Tussock's farm command (docs/farm.md); runs one task:",
            "#   job.sh bake|assemble|render [TASK]     (TASK: $SLURM_ARRAY_TASK_ID under Slurm)",
            "# Every path is relative to the .blend's folder, which every node must see (shared",
            "# storage; TUSSOCK_SHOT_DIR if it is mounted elsewhere there). A task that fails is",
            "# tried once more; its outcome goes to state/STEP.TASK beside this script.",
            "set -u",
            f"SHOT_DIR={q(self.dir)}",
            'cd "${TUSSOCK_SHOT_DIR:-$SHOT_DIR}" || exit 2',
            f"DEFAULT_BLENDER={q(self.blender)}",
            'BLENDER="${TUSSOCK_BLENDER:-$DEFAULT_BLENDER}"',
            "# A Blender named without a folder is looked up on the PATH as it is now, before the",
            "# PATH loses the directories of Python environments (below).",
            'case "$BLENDER" in',
            "  */*) ;;",
            '  *) BLENDER="$(command -v -- "$BLENDER" || echo "$BLENDER")" ;;',
            "esac",
            'CHECK_PYTHON="$(command -v python3 || echo python3)"',
            *PYTHON_NEUTRAL.split("\n"),
            "# The frame check (verify.py) needs only Python's standard library: the first python3",
            "# left on the PATH runs it, else the one found before.",
            'CHECK_PYTHON="$(command -v python3 || echo "$CHECK_PYTHON")"',
            f"FARM={q(self.farm)}",
            'step="${1:?usage: job.sh bake|assemble|render [TASK]}"',
            'task="${2:-${SLURM_ARRAY_TASK_ID:?no task: give it after the step}}"',
            "check=()",
            'case "$step $task" in',
        ]
        for step in STEPS:
            for t in todo[step]:
                cmd = " ".join('"$BLENDER"' if a == "$BLENDER" else q(a) for a in t.command)
                lines.append(f'  "{step} {t.index}")  # frames {t.frames[0]}-{t.frames[1]}')
                lines.append(f"    run=({cmd})")
                whole = [self.frame_file(f) for f in range(t.frames[0], t.frames[1] + 1)]
                if t.outputs and t.outputs == whole:  # every frame of the range
                    pattern = q(f"render/{self.name.replace('%', '%%')}_%04d.png\\n")
                    lines.append(f"    mapfile -t check < <(printf {pattern} $(seq "
                                 f"{t.frames[0]} {t.frames[1]}))")
                elif t.outputs:
                    lines.append(f"    check=({' '.join(q(o) for o in t.outputs)})")
                lines.append("    ;;")
        lines += [
            '  *) echo "job.sh: no task \'$step $task\' left in this job" >&2; exit 2 ;;',
            "esac",
            'mkdir -p "$FARM/state"',
            'rm -f "$FARM/state/$step.$task"',
            "for attempt in 1 2; do",
            '  echo "== tussock farm: $step task $task, attempt $attempt, on $(hostname):'
            ' ${run[*]}"',
            '  if "${run[@]}" && { [ ${#check[@]} -eq 0 ] || '
            f'"$CHECK_PYTHON" "$FARM/verify.py" {self.size[0]} {self.size[1]} '
            '"${check[@]}"; }; then',
            '    echo ok >"$FARM/state/$step.$task"',
            "    exit 0",
            "  fi",
            '  echo "== tussock farm: $step task $task failed (attempt $attempt)"',
            "done",
            'echo failed >"$FARM/state/$step.$task"',
            "exit 1",
        ]
        return "\n".join(lines) + "\n"

    def log_tail(self, path, lines=20):
        try:
            with open(path, errors="replace") as f:
                return "".join(f.readlines()[-lines:])
        except OSError as exc:
            return f"(no log: {exc.strerror})\n"
