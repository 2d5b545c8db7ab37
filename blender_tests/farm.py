"""Helpers of the bake tests (test_bake.py, test_bake_picture.py): background Blenders run as
farm workers would, killed bakes, the cache files of a folder, small tmpfs mounts."""

import filecmp
import os
import signal
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                "tools"))
import blender_env  # noqa: E402


def bake_refused_in(cache_parent, needle, unmount=False, after=None):
    """Bakes with the cache in `cache_parent`/tussock_cache: the bake is refused with a
    message containing `needle` (the scene unchanged is the operator's own promise, checked
    by expect_cancel). `after()` runs before the cache folder is given back; `unmount`
    unmounts `cache_parent` (a tmpfs) at the end."""
    import bpy
    from harness import expect_cancel
    from tussock import cache
    cache.CACHE_DIR_OVERRIDE = os.path.join(cache_parent, "tussock_cache")
    try:
        expect_cancel(bpy.ops.tussock.bake, needle)
        if after is not None:
            after()
    finally:
        cache.CACHE_DIR_OVERRIDE = None
        if unmount:
            subprocess.run(["umount", cache_parent])


def blender(blend, expr, addon=True):
    """Runs background Blender on a .blend with a python expression (a farm worker)."""
    return blender_env.run_worker(blend, expr, addon)


def cache_files(folder):
    """Paths of every file under folder/tussock_cache, relative to it, sorted."""
    root = os.path.join(folder, "tussock_cache")
    out = []
    for dirpath, _, files in os.walk(root):
        out += [os.path.relpath(os.path.join(dirpath, f), root) for f in files]
    return sorted(out)


def bake_killed(blend, done, timeout):
    """Starts `bpy.ops.tussock.bake()` in a background Blender on `blend` and kills it with
    SIGKILL as soon as done() is true (or after `timeout` seconds)."""
    with blender_env.BlenderUser() as user:
        script = os.path.join(user.tmp, "run.py")
        with open(script, "w") as f:
            f.write("import bpy, addon_utils\naddon_utils.enable('tussock')\n"
                    "bpy.ops.tussock.bake()\n")
        proc = subprocess.Popen(blender_env.command(script, blend=blend), env=user.env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.time() + timeout
        while time.time() < deadline and not done():
            time.sleep(0.01)
        proc.send_signal(signal.SIGKILL)
        proc.wait()


def assert_same_caches(ref_dir, other_dir):
    """Both folders' tussock_cache hold the same files with the same bytes."""
    a, b = cache_files(ref_dir), cache_files(other_dir)
    assert a == b, (len(a), len(b), sorted(set(a) ^ set(b)))
    for rel in a:
        assert filecmp.cmp(os.path.join(ref_dir, "tussock_cache", rel),
                           os.path.join(other_dir, "tussock_cache", rel), shallow=False), rel


def mount_tmpfs(where, options):
    """Mounts a tmpfs (needs root); False when it cannot."""
    os.makedirs(where, exist_ok=True)
    return subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", where],
                          stderr=subprocess.DEVNULL).returncode == 0
