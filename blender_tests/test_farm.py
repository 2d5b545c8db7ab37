"""Render farms (issue 35): the farm command's plan (ranges split evenly, more tasks than
frames, frames outside the scene), the check of rendered frames, Submit to Farm's refusals;
and a shot with a tree, a simulated meadow and an animated picture done by a one-node Slurm
cluster of its own in 4 bake and 4 render tasks: its caches are the bytes of a single-process
bake and its frames the pixels of a single-process render; a cancelled bake job takes the
later steps out of the queue; a render job cancelled mid-way (scancel) resumes to the same
frames, redoing only the missing ones; a task whose output
cannot be written is tried twice and reported with its log; and the same plan run by the
`local` back end, started from Blender's Submit to Farm, gives the same bytes.

Issue 41: the farm's Blenders do not depend on the Python environment of the shell that
starts the farm command (a venv's bin first on the PATH, PYTHONHOME and PYTHONPATH set):
a local run from such a shell bakes and renders; and a bake task that cannot enable
Tussock names the cause (the import error and where Blender's Python runs from; Tussock
not installed; its native library not loaded), not a guess.

The farm runs need the host's Blender 3.4 (its Debian has slurm-wlm and munge, as root):
they run there only, once per ./build.sh test."""

import json
import os
import re
import shutil
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import expect_cancel, test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from farm import assert_same_caches, blender  # noqa: E402

harness.enable_addon()
from tussock.farm import plan as farm_plan  # noqa: E402
from tussock.farm import verify  # noqa: E402

sys.path.insert(0, os.path.join(harness.REPO, "tools"))
import picture_sample_scene  # noqa: E402
from slurm_cluster import SlurmCluster  # noqa: E402

TMP = os.environ.get("TSK_TEST_TMP", "/tmp")
FARM = os.path.join(harness.REPO, "addon", "farm")
PY = "/usr/bin/python3" if os.path.exists("/usr/bin/python3") else sys.executable
FRAMES = 8
HOST_BLENDER = bpy.app.version[0] == 3  # the farm runs: once per suite, in Debian 12's 3.4


def save_png(path, w, h):
    im = bpy.data.images.new("farm_png", w, h, alpha=True)
    im.pixels.foreach_set(np.linspace(0, 1, w * h * 4, dtype=np.float32))
    im.filepath_raw = path
    im.file_format = "PNG"
    im.save()
    bpy.data.images.remove(im)


@test
def test_plan_splits_ranges_evenly_and_refuses_bad_ranges():
    split = farm_plan.split
    assert split(1, 8, 4) == [(1, 2), (3, 4), (5, 6), (7, 8)]
    assert split(1, 10, 4) == [(1, 3), (4, 6), (7, 8), (9, 10)]  # lengths differ by one
    assert split(5, 7, 10) == [(5, 5), (6, 6), (7, 7)]  # more tasks than frames: one each
    assert split(3, 3, 1) == [(3, 3)]
    assert split(-2, 1, 2) == [(-2, -1), (0, 1)]
    for lo, hi, n in ((1, 250, 7), (0, 99, 13), (10, 12, 2)):
        parts = split(lo, hi, n)
        lengths = [b - a + 1 for a, b in parts]
        assert parts[0][0] == lo and parts[-1][1] == hi and max(lengths) - min(lengths) <= 1
        assert all(parts[i][1] + 1 == parts[i + 1][0] for i in range(len(parts) - 1))
    for args, needle in (((5, 4, 2), "ends before it starts"), ((1, 4, 0), "at least 1")):
        try:
            split(*args)
        except ValueError as exc:
            assert needle in str(exc), exc
        else:
            raise AssertionError(f"split{args} accepted")
    assert farm_plan.parse_range("12-40") == (12, 40) and farm_plan.parse_range("7") == (7, 7)
    folder = os.path.join(TMP, "plan")
    os.makedirs(folder, exist_ok=True)
    blend = os.path.join(folder, "shot.blend")
    open(blend, "wb").close()
    p = farm_plan.Plan(blend, (1, 8), (3, 5), tasks=5, size=(64, 48), blender="/b/blender")
    # the bake covers the scene's range (a cache needs every frame), the render the frames
    # asked for; never more tasks than frames
    assert [t.frames for t in p.steps["bake"]] == [(1, 2), (3, 4), (5, 6), (7, 7), (8, 8)]
    assert [t.frames for t in p.steps["render"]] == [(3, 3), (4, 4), (5, 5)]
    assert p.steps["assemble"][0].command[-3:] == ["1", "8", "save"]
    assert "save" not in p.steps["bake"][0].command  # parallel saves of one .blend race
    # -f, which leaves the scene's frame range (part of a bake's key) as it is
    assert p.steps["render"][0].command[-4:] == ["-x", "1", "-f", "3..3"]
    for frames, needle in (((0, 4), "outside the scene's frame range 1-8"),
                           ((6, 9), "outside"), ((5, 3), "ends before it starts")):
        try:
            farm_plan.Plan(blend, (1, 8), frames, 2, (64, 48))
        except ValueError as exc:
            assert needle in str(exc), exc
        else:
            raise AssertionError(f"frames {frames} accepted")
    try:
        farm_plan.Plan(os.path.join(folder, "none.blend"), (1, 8))
    except ValueError as exc:
        assert "no such .blend" in str(exc)
    else:
        raise AssertionError("a missing .blend accepted")
    # resuming: a frame that verifies is kept, the others (cut short, another size, a
    # directory in its place, missing) are rendered again, and only those
    os.makedirs(os.path.join(folder, "render"), exist_ok=True)
    good = os.path.join(folder, p.frame_file(3))
    save_png(good, 64, 48)
    assert verify.check_png(good, 64, 48) is None
    save_png(os.path.join(folder, p.frame_file(4)), 32, 48)
    msg = verify.check_png(os.path.join(folder, p.frame_file(4)), 64, 48)
    assert "32 x 48 pixels, not 64 x 48" in msg, msg
    data = open(good, "rb").read()
    cut = os.path.join(folder, "cut.png")
    with open(cut, "wb") as f:
        f.write(data[:len(data) // 2])
    assert "cut short" in verify.check_png(cut, 64, 48)
    with open(cut, "wb") as f:
        f.write(data[:60] + bytes([data[60] ^ 1]) + data[61:])
    assert "damaged" in verify.check_png(cut, 64, 48)
    todo = p.todo()
    assert [t.index for t in todo["bake"]] == [0, 1, 2, 3, 4] and len(todo["assemble"]) == 1
    assert [t.outputs for t in todo["render"]] == [[p.frame_file(4)], [p.frame_file(5)]]
    assert todo["render"][0].command[-2:] == ["-f", "4..4"]
    assert os.path.exists(good) and not os.path.exists(os.path.join(folder, p.frame_file(4)))
    os.makedirs(os.path.join(folder, p.farm, "state"), exist_ok=True)
    with open(p.state_path("assemble", 0), "w") as f:
        f.write("ok\n")
    todo = p.todo()
    assert not todo["bake"] and not todo["assemble"]  # the caches were assembled: kept
    script = open(p.write(todo)).read()
    assert '"render 1")' in script and '"render 0")' not in script  # frame 3 verifies
    assert '"bake 0")' not in script and "attempt 2" not in script and "attempt" in script


@test
def test_submit_to_farm_refuses_an_unsaved_file_and_bad_frames():
    harness.empty_scene(FRAMES)
    assert bpy.ops.tussock.add_tree(preset="quaking_aspen", seed=2, leaves=False) == {"FINISHED"}
    expect_cancel(bpy.ops.tussock.farm_submit, "save the .blend first")
    folder = os.path.join(TMP, "submit")
    os.makedirs(folder, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(folder, "scene.blend"))
    expect_cancel(bpy.ops.tussock.farm_submit, "outside the scene's frame range 1-8",
                  frame_start=4, frame_end=12)
    expect_cancel(bpy.ops.tussock.farm_submit, "ends before it starts",
                  frame_start=6, frame_end=3)
    assert not os.path.exists(os.path.join(folder, "scene_farm", "job.sh"))


def fake_venv(root):
    """A Python environment laid out as `python3 -m venv` makes it (root/pyvenv.cfg,
    root/bin/python3 ...) whose pythons are not the system's: each fails loudly when run.
    A Blender that uses the system's Python and finds root/bin first on the PATH takes root
    as its sys.prefix, where there is no numpy. Returns root/bin."""
    bin_dir = os.path.join(root, "bin")
    os.makedirs(bin_dir, exist_ok=True)
    v = sys.version_info
    with open(os.path.join(root, "pyvenv.cfg"), "w") as f:
        f.write(f"home = {os.path.join(sys.base_prefix, 'bin')}\n"
                f"include-system-site-packages = false\nversion = {v[0]}.{v[1]}.{v[2]}\n")
    for name in ("python", "python3", f"python{v[0]}.{v[1]}"):
        path = os.path.join(bin_dir, name)
        with open(path, "w") as f:
            f.write('#!/bin/sh\necho "$0: the python of a venv ran" >&2\nexit 97\n')
        os.chmod(path, 0o755)
    return bin_dir


@test
def test_python_neutral_environment_drops_only_python_environments():
    """The job script's lines that clear the Python environment (plan.PYTHON_NEUTRAL), run
    under `set -u` with a PATH of every kind of Python environment's bin and plain folders."""
    root = os.path.join(TMP, "python_envs")
    shutil.rmtree(root, ignore_errors=True)
    dirs = {}
    for key, rel in (("venv", "venv/bin"), ("conda", "conda/bin"), ("condabin", "conda/condabin"),
                     ("shims", "pyenv/shims"), ("pyenv", "pyenv/versions/3.11.7/bin"),
                     ("active", "active/bin"), ("prefix", "prefix/bin"),
                     ("tools", "tools/bin"), ("other_shims", "other/shims"),
                     ("versions", "else/versions/2/bin")):
        dirs[key] = os.path.join(root, rel)
        os.makedirs(dirs[key])
    open(os.path.join(root, "venv", "pyvenv.cfg"), "w").close()
    os.makedirs(os.path.join(root, "conda", "conda-meta"))
    system = [d for d in ("/usr/bin", "/bin") if os.path.isdir(d)]
    path = [dirs["venv"], dirs["conda"] + "/", dirs["condabin"], "", dirs["shims"],
            dirs["pyenv"], dirs["active"], dirs["tools"], dirs["prefix"], dirs["other_shims"],
            dirs["versions"], *system]
    env = {"PATH": os.pathsep.join(path), "HOME": root, "KEEP_ME": "yes",
           "PYTHONHOME": "/junk", "PYTHONPATH": "/junk", "PYTHONSTARTUP": "/junk",
           "PYTHONUSERBASE": "/junk", "VIRTUAL_ENV": os.path.dirname(dirs["active"]),
           "CONDA_PREFIX": os.path.dirname(dirs["prefix"]), "CONDA_PREFIX_1": "/junk",
           "CONDA_DEFAULT_ENV": "base", "CONDA_SHLVL": "2", "PYENV_VERSION": "3.11.7"}
    script = ("set -u\n" + farm_plan.PYTHON_NEUTRAL +
              f"\nexec {PY} -c 'import json, os; print(json.dumps(dict(os.environ)))'\n")
    proc = subprocess.run([shutil.which("bash") or "/bin/bash", "-c", script], env=env,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.returncode == 0 and not proc.stderr, proc.stderr
    after = json.loads(proc.stdout)
    # kept: plain folders, a "shims" or "versions" folder that is not pyenv's
    assert after["PATH"].split(os.pathsep) == [dirs["tools"], dirs["other_shims"],
                                               dirs["versions"], *system], after["PATH"]
    assert after["KEEP_ME"] == "yes" and after["HOME"] == root
    for name in env:
        if name.startswith(("PYTHON", "CONDA", "VIRTUAL_ENV", "PYENV")):
            assert name not in after, name


def run_bake_task(blend, env):
    """bake_task.py run by a background Blender on `blend` as the job script runs it, but
    in `env` as it is (no job script: nothing clears it). Returns (exit code, output)."""
    proc = subprocess.run([bpy.app.binary_path, "-b", blend, "--python-exit-code", "1",
                           "--python", os.path.join(FARM, "bake_task.py"), "--", "1", "1"],
                          cwd=os.path.dirname(blend), env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, errors="replace", timeout=120)
    return proc.returncode, proc.stdout


@test
def test_bake_task_names_why_tussock_cannot_bake():
    folder = os.path.join(TMP, "task_causes")
    os.makedirs(folder, exist_ok=True)
    harness.empty_scene(2)
    blend = os.path.join(folder, "scene.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    # Blender's Python cannot import numpy: a venv first on the PATH (what the job script
    # clears) gives Blender that venv's prefix. The import error is named, with where
    # Blender's Python runs from; not "not installed"
    venv = os.path.join(folder, "venv")
    env = dict(os.environ, PATH=fake_venv(venv) + os.pathsep + os.environ["PATH"])
    code, out = run_bake_task(blend, env)
    assert code != 0 and "Tussock is installed (" in out, out[-3000:]
    assert "could not be enabled: ModuleNotFoundError: No module named 'numpy'" in out, \
        out[-3000:]
    assert f"sys.prefix {venv} " in out and "not installed" not in out, out[-3000:]
    # Tussock not installed at all: said so
    empty = os.path.join(folder, "no_addons")
    os.makedirs(os.path.join(empty, "addons"), exist_ok=True)
    code, out = run_bake_task(blend, dict(os.environ, BLENDER_USER_SCRIPTS=empty))
    assert code != 0 and "Tussock is not installed in this Blender" in out, out[-3000:]
    # installed and enabled, but its native library is missing: native.py's message
    scripts = os.path.join(folder, "no_native")
    shutil.rmtree(scripts, ignore_errors=True)
    addon = os.path.dirname(os.path.realpath(sys.modules["tussock"].__file__))
    shutil.copytree(addon, os.path.join(scripts, "addons", "tussock"),
                    ignore=shutil.ignore_patterns("_tussock*.so", "_tussock*.pyd",
                                                  "__pycache__"))
    code, out = run_bake_task(blend, dict(os.environ, BLENDER_USER_SCRIPTS=scripts))
    assert code != 0 and "Tussock's native library is not available" in out, out[-3000:]
    assert "not installed" not in out and "could not be enabled" not in out, out[-3000:]


# ---- the farm runs ------------------------------------------------------------------------

def make_shot(folder):
    """A saved .blend in `folder` with a swaying tree, a simulated meadow crossed by a ball
    and the sample picture animated, rendered small by Cycles; returns its path."""
    scene = harness.empty_scene(FRAMES)
    scene.tussock_wind.base_speed = 3.0
    os.makedirs(folder, exist_ok=True)
    for name in picture_sample_scene.FILES:
        shutil.copyfile(os.path.join(picture_sample_scene.FOLDER, name),
                        os.path.join(folder, name))
    path = os.path.join(folder, "scene.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)  # so that '//' paths resolve
    assert bpy.ops.tussock.add_tree(preset="quaking_aspen", seed=2, leaves=False) == {"FINISHED"}
    bpy.context.active_object.location = (1.5, 3.0, 0.0)
    meadow, ball = harness.meadow_crossed_by_ball(FRAMES)
    picture_sample_scene.describe(scene.tussock_picture, "//", crown_waves=False)
    assert bpy.ops.tussock.animate_picture() == {"FINISHED"}
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(cam)
    cam.location, cam.rotation_euler = (0.0, -3.0, 1.5), (1.2, 0.0, 0.0)
    scene.camera = cam
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    scene.collection.objects.link(sun)
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.use_denoising, scene.cycles.seed = 1, False, 0
    scene.render.resolution_percentage = 20  # the picture's 480 x 270: 96 x 54
    bpy.ops.wm.save_mainfile()
    return path


def render_command(blend):
    """The single-process render: the farm's render command over the whole range."""
    p = farm_plan.Plan(blend, (1, FRAMES), tasks=1, size=(96, 54), blender=bpy.app.binary_path)
    return [a if a != "$BLENDER" else p.blender for a in p.steps["render"][0].command], p


def pixels(path):
    img = bpy.data.images.load(path)
    px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px


def assert_same_frames(ref_dir, other_dir):
    names = sorted(os.listdir(os.path.join(ref_dir, "render")))
    assert names == [f"scene_{f:04d}.png" for f in range(1, FRAMES + 1)], names
    assert sorted(os.listdir(os.path.join(other_dir, "render"))) == names
    for n in names:
        a = pixels(os.path.join(ref_dir, "render", n))
        b = pixels(os.path.join(other_dir, "render", n))
        assert np.array_equal(a, b), n


class Driver:
    """The farm command run in the background; its output collected."""

    def __init__(self, args, env):
        self.proc = subprocess.Popen([PY, FARM, "run", *args], env=env, text=True,
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        self.out = []
        self.reader = threading.Thread(target=lambda: self.out.extend(self.proc.stdout))
        self.reader.start()

    def wait(self, timeout=240):
        self.proc.wait(timeout=timeout)
        self.reader.join()
        return self.proc.returncode, "".join(self.out)


def wait_for(done, timeout, what):
    deadline = time.time() + timeout
    while time.time() < deadline:
        if done():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


@test
def test_farm_local_run_from_a_python_environment_shell():
    """Issue 41: the farm command started from a shell with a venv active (its bin first on
    the PATH, whose python3 is not the system's) and PYTHONHOME and PYTHONPATH set to junk:
    each would keep the tasks' Blender from loading Tussock (or from starting), and the
    venv's python3 fails the frame check. The job script clears them: every task ends well.
    The Blender is named without a folder (TUSSOCK_BLENDER) and found in the venv's bin:
    it is looked up before the PATH is cleared."""
    if not HOST_BLENDER:
        print("test_farm: the farm runs need the host's Blender 3.4: skipped here")
        return
    folder = os.path.join(TMP, "venv_shot")
    shutil.rmtree(folder, ignore_errors=True)
    os.makedirs(folder)
    scene = harness.empty_scene(3)
    blend = os.path.join(folder, "scene.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    assert bpy.ops.tussock.add_tree(preset="quaking_aspen", seed=2, leaves=False) == {"FINISHED"}
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(cam)
    cam.location, cam.rotation_euler = (0.0, -12.0, 4.0), (1.35, 0.0, 0.0)
    scene.camera = cam
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    scene.render.resolution_percentage = 100
    bpy.ops.wm.save_mainfile()
    venv = os.path.join(TMP, "venv_shell")
    shutil.rmtree(venv, ignore_errors=True)
    venv_bin = fake_venv(venv)
    os.symlink(bpy.app.binary_path, os.path.join(venv_bin, "blender-farm"))
    junk = os.path.join(TMP, "venv_shell_pythonpath")
    os.makedirs(os.path.join(junk, "numpy"), exist_ok=True)
    with open(os.path.join(junk, "numpy", "__init__.py"), "w") as f:
        f.write("raise ImportError('the numpy of the PYTHONPATH of the shell')\n")
    env = dict(os.environ, PATH=venv_bin + os.pathsep + os.environ["PATH"], VIRTUAL_ENV=venv,
               PYTHONHOME=os.path.join(TMP, "no_such_python_home"), PYTHONPATH=junk,
               TUSSOCK_BLENDER="blender-farm")
    # the farm command's own Python ignores PYTHON* (-E), as that environment's python would
    # work with them; the Blenders it starts get them all
    proc = subprocess.run([PY, "-E", FARM, "run", blend, "--tasks", "2",
                           "--blender", bpy.app.binary_path], env=env, cwd=folder,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          errors="replace", timeout=300)
    out = proc.stdout
    assert proc.returncode == 0 and "tussock farm: done" in out, out[-4000:]
    for f in range(1, 4):
        assert verify.check_png(os.path.join(folder, "render", f"scene_{f:04d}.png"),
                                64, 48) is None, f
    assert os.path.isfile(os.path.join(folder, "tussock_cache", "Quaking_Aspen.pc2")), \
        sorted(os.listdir(os.path.join(folder, "tussock_cache")))
    log = open(os.path.join(folder, "scene_farm", "logs", "bake_local_0.out")).read()
    assert f"{venv_bin}/blender-farm -b scene.blend" in log, log[-2000:]


@test
def test_farm_slurm_and_local_give_the_bytes_of_one_process():
    if not HOST_BLENDER:
        print("test_farm: the farm runs need the host's Blender 3.4 and its Slurm: skipped here")
        return
    t0 = time.time()
    ref_dir, slurm_dir, local_dir = (os.path.join(TMP, n) for n in ("ref", "slurm", "local"))
    make_shot(ref_dir)
    for d in (slurm_dir, local_dir):
        shutil.copytree(ref_dir, d)
    ref = os.path.join(ref_dir, "scene.blend")
    # one process bakes, one renders
    blender(ref, "assert bpy.ops.tussock.bake(save=True) == {'FINISHED'}")
    cmd, _ = render_command(ref)
    proc = subprocess.run(cmd, cwd=ref_dir, env=dict(os.environ, PWD=ref_dir),  # Blender reads $PWD
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, errors="replace")
    assert proc.returncode == 0, proc.stdout[-3000:]
    px = pixels(os.path.join(ref_dir, "render", "scene_0006.png")).reshape(-1, 4)
    assert px[:, :3].std() > 0.01  # a picture, not a blank frame
    print(f"test_farm: single process {time.time() - t0:.0f} s", flush=True)

    blend = os.path.join(slurm_dir, "scene.blend")
    args = [blend, "--backend", "slurm", "--tasks", "4", "--blender", bpy.app.binary_path]
    jobs_file = os.path.join(slurm_dir, "scene_farm", "slurm_jobs.json")
    render_dir = os.path.join(slurm_dir, "render")
    with SlurmCluster() as cluster:
        # the bake job cancelled before any of its tasks ran (the node drained meanwhile, else
        # a two-frame task may end first): the steps after it leave the queue (else they
        # would wait forever for it) and the command ends, reporting all
        cluster.drain()
        driver = Driver(args, cluster.env)
        wait_for(lambda: os.path.exists(jobs_file) or driver.proc.poll() is not None, 60,
                 "the submission")
        bake_job = [j for s, j, _ in json.load(open(jobs_file)) if s == "bake"][0]
        subprocess.run(["scancel", bake_job], env=cluster.env, check=True)
        code, out = driver.wait(timeout=120)
        cluster.drain(False)
        assert code == 1 and out.count("did not run to its end") == 9, out
        os.remove(jobs_file)
        # resumed: the render job is cancelled as soon as its first frame is written
        driver = Driver(args, cluster.env)
        wait_for(lambda: (os.path.exists(render_dir) and os.listdir(render_dir)) or
                 driver.proc.poll() is not None, 200, "the first rendered frame")
        assert driver.proc.poll() is None, driver.wait()
        render_job = [j for s, j, _ in json.load(open(jobs_file)) if s == "render"][0]
        subprocess.run(["scancel", render_job], env=cluster.env, check=True)
        code, out = driver.wait()
        assert code == 1 and "did not run to its end" in out, out
        assert re.search(r"bake \(job \d+\): 4/4 done", out) and "assemble (job" in out, out
        # the caches are complete: the bytes of the single-process bake
        assert_same_caches(ref_dir, slurm_dir)
        kept = {n: os.stat(os.path.join(render_dir, n)).st_mtime_ns
                for n in os.listdir(render_dir)
                if verify.check_png(os.path.join(render_dir, n), 96, 54) is None}
        assert 0 < len(kept) < FRAMES, sorted(kept)  # cancelled mid-way
        print(f"test_farm: slurm run cancelled with {len(kept)} frames "
              f"({time.time() - t0:.0f} s)", flush=True)
        # resumed with a frame's output unwritable (a folder in its place): that task fails,
        # is tried once more, and is reported with its log
        missing = [f for f in range(1, FRAMES + 1) if f"scene_{f:04d}.png" not in kept]
        blocked = os.path.join(render_dir, f"scene_{missing[-1]:04d}.png")
        for f in missing:
            if os.path.isfile(os.path.join(render_dir, f"scene_{f:04d}.png")):
                os.remove(os.path.join(render_dir, f"scene_{f:04d}.png"))
        os.mkdir(blocked)
        code, out = Driver(args, cluster.env).wait()
        assert code == 1 and "failed twice" in out, out
        assert "submitted: render job" in out and "bake job" not in out, out  # caches kept
        log = re.search(r"failed twice; log: (\S+)", out).group(1)
        assert re.search(r"render_\d+_\d+\.out$", log) and os.path.exists(log), log
        text = open(log).read()
        assert "attempt 1" in text and "attempt 2" in text and "cannot save" in text, text[-2000:]
        assert os.path.basename(blocked) in out  # the log's tail is in the report
        # the cause fixed, resumed again: only the blocked frame is rendered
        os.rmdir(blocked)
        before = {n: os.stat(os.path.join(render_dir, n)).st_mtime_ns
                  for n in os.listdir(render_dir)}
        code, out = Driver(args, cluster.env).wait()
        assert code == 0 and "1 task(s) to run" in out, out
        after = {n: os.stat(os.path.join(render_dir, n)).st_mtime_ns
                 for n in os.listdir(render_dir)}
        assert {n for n in after if after[n] != before.get(n)} == {os.path.basename(blocked)}
        assert all(after[n] == kept[n] for n in kept)  # frames of the first run: not redone
    assert_same_caches(ref_dir, slurm_dir)
    assert_same_frames(ref_dir, slurm_dir)
    print(f"test_farm: slurm done ({time.time() - t0:.0f} s)", flush=True)

    # the same plan on this machine, from Blender's Submit to Farm (detached processes)
    bpy.ops.wm.open_mainfile(filepath=os.path.join(local_dir, "scene.blend"))
    if bpy.data.is_dirty:
        bpy.ops.wm.save_mainfile()
    assert bpy.ops.tussock.farm_submit(backend="LOCAL", tasks=4) == {"FINISHED"}
    script = os.path.join(local_dir, "scene_farm", "job.sh")
    assert os.path.exists(script) and '"render 3")' in open(script).read()
    log = os.path.join(local_dir, "scene_farm", "logs", "farm.out")
    wait_for(lambda: "tussock farm: done" in open(log).read() or
             "did not end well" in open(log).read(), 240, "the local farm run")
    assert "tussock farm: done" in open(log).read(), open(log).read()
    assert_same_caches(ref_dir, local_dir)
    assert_same_frames(ref_dir, local_dir)
    print(f"test_farm: local done ({time.time() - t0:.0f} s)", flush=True)


harness.main()
