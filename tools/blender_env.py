"""Runs a script in background Blender (`blender -b --factory-startup`) with a fresh,
private user folder whose addons/tussock links to this checkout's addon/ (or to $TSK_ADDON:
the add-on folder build.sh lays out for a Blender in a Debian root, with the native library
built there), so nothing of the person's own Blender setup is read or changed. Used by the
test runner, the demo, the docs pictures and the Blender benchmarks."""

import os
import shutil
import subprocess
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ADDON = os.environ.get("TSK_ADDON") or os.path.join(REPO, "addon")
DIST = os.environ.get("TSK_DIST") or os.path.join(REPO, "dist")


class BlenderUser:
    """A temporary Blender user folder with the add-on linked in (a context manager)."""

    def __enter__(self):
        self.root = tempfile.mkdtemp(prefix="tussock-blender-")
        addons = os.path.join(self.root, "scripts", "addons")
        os.makedirs(addons)
        os.symlink(ADDON, os.path.join(addons, "tussock"))
        self.tmp = os.path.join(self.root, "tmp")
        os.makedirs(self.tmp)
        env = dict(os.environ)
        env["BLENDER_USER_SCRIPTS"] = os.path.join(self.root, "scripts")
        env["BLENDER_USER_CONFIG"] = os.path.join(self.root, "config")
        env["BLENDER_USER_DATAFILES"] = os.path.join(self.root, "datafiles")
        env["BLENDER_USER_EXTENSIONS"] = os.path.join(self.root, "extensions")  # 4.2+
        env["TSK_TEST_TMP"] = self.tmp
        self.env = env
        return self

    def __exit__(self, *exc):
        shutil.rmtree(self.root, ignore_errors=True)


def command(script, args=(), blend=None, window=False):
    """Blender running `script`: in background (`-b`), or with `window` in a real window on
    a virtual X server (Xvfb with Mesa; UI tests, screenshots), where `--enable-event-simulate`
    lets the script send real input events and keeps the machine's own from reaching it."""
    blender = os.environ.get("BLENDER", "blender")
    if window:
        cmd = ["xvfb-run", "-a", "-s", "-screen 0 1600x900x24", blender]
    else:
        cmd = [blender, "-b"]
    if blend:
        cmd.append(blend)
    cmd += ["--factory-startup", "-noaudio", "--python-exit-code", "1"]
    if window:
        cmd += ["--enable-event-simulate"]
    cmd += ["--python", script, "--", *args]
    return cmd


def run(script, args=(), blend=None, timeout=None, capture=True, window=False):
    """Runs script in background Blender (or a real window); returns (exit code, output
    text)."""
    with BlenderUser() as user:
        kw = dict(env=user.env, timeout=timeout, text=True, errors="replace")
        if capture:
            kw.update(stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        proc = subprocess.run(command(script, args, blend, window), **kw)
        return proc.returncode, proc.stdout or ""


def run_worker(blend, expr, addon=True):
    """Runs python `expr` in a background Blender on `blend`, as a farm worker would: with
    Tussock enabled, or with Tussock not installed at all (addon=False). Returns the output;
    raises AssertionError with its end when Blender fails."""
    with BlenderUser() as user:
        if not addon:
            os.unlink(os.path.join(user.root, "scripts", "addons", "tussock"))
        script = os.path.join(user.tmp, "run.py")
        with open(script, "w") as f:
            f.write("import bpy, addon_utils, sys\n")
            if addon:
                f.write("addon_utils.enable('tussock', default_set=True)\n")
            f.write(expr + "\n")
        proc = subprocess.run(command(script, blend=blend), env=user.env, text=True,
                              errors="replace", stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        assert proc.returncode == 0, proc.stdout[-3000:]
        return proc.stdout
