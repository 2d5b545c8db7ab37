"""The 4.2+ extension as an artist installs it: the zip that ./build.sh package made for this
Blender installs with `blender --command extension install-file`, is enabled as the
extension bl_ext.user_default.tussock, and in a new Blender (the artist's preferences, not
factory settings) captures blades from the sample depth images, grows a meadow of them and
a tree, saves a tree preset into the extension's own user folder, and opens a recording
through the recording reader - with the installed folder read-only and the reader's
execute bit gone, as a studio's shared install can be. Blender before 4.2 has no
extensions: there, test_package.py installs the legacy zip."""

import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import test  # noqa: E402

import bpy  # noqa: E402

DIST = os.environ.get("TSK_DIST") or os.path.join(harness.REPO, "dist")
PACKAGE = "bl_ext.user_default.tussock"

# Runs in the second Blender; prints one line per check that the test reads back.
WORKER = r'''
import os, sys, bpy
repo, preset_dir_expected = sys.argv[sys.argv.index("--") + 1:]
assert "bl_ext.user_default.tussock" in bpy.context.preferences.addons, \
    [a.module for a in bpy.context.preferences.addons]
import bl_ext.user_default.tussock as ext
from bl_ext.user_default.tussock import native
assert native.available(), native.error
folder = os.path.dirname(ext.__file__)
print("EXT folder", folder, "writable", os.access(folder, os.W_OK))
bpy.ops.wm.read_homefile(use_empty=True)
bpy.ops.tussock.capture_blades(source="FILES", frames=4,
                               filepath=os.path.join(repo, "samples", "blades", "depth_####.png"))
blades = [o for o in bpy.data.collections["Tussock Blades"].objects]
print("EXT blades", len(blades))
for o in blades:
    o.select_set(False)
bpy.context.view_layer.objects.active = None  # a meadow on its own ground, of those blades
bpy.ops.tussock.add_meadow(size=(4.0, 4.0), tile_size=0.25, blades_per_tile=16, chunk_blades=16)
meadow = bpy.context.active_object
print("EXT meadow", meadow["tussock_blades"])
bpy.ops.tussock.add_tree(preset="black_tupelo", seed=2)
tree = bpy.context.active_object
print("EXT tree", len(tree.data.vertices))
bpy.ops.tussock.tree_preset_add(name="ext_check")
from bl_ext.user_default.tussock.trees import presets
print("EXT preset", os.path.isfile(os.path.join(presets.user_dir(), "ext_check.json")),
      os.path.realpath(presets.user_dir()).startswith(os.path.realpath(preset_dir_expected)),
      presets.user_dir(), preset_dir_expected)
crash = os.path.join(repo, "native", "fuzz", "crashes", "oni-segv-libOniFile.oni")
try:
    native.lib.depth_open_oni(crash)
    print("EXT reader opened a crashing recording")
except native.Error as exc:
    print("EXT reader", "crashed" if "recording reader crashed" in str(exc) else str(exc))
'''


def _run(cmd, **kw):
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          errors="replace", **kw)
    assert proc.returncode == 0, f"{cmd[:4]} exited {proc.returncode}:\n{proc.stdout[-4000:]}"
    return proc.stdout


def _read_only(folder, cmd):
    """cmd run while `folder` is read-only: a read-only bind mount in a mount namespace of
    its own for root (whom permission bits do not stop), else the write bits removed."""
    if os.geteuid() == 0:
        return ["unshare", "--mount", "--propagation", "private", "--", "sh", "-ec",
                'mount --bind "$0" "$0"; mount -o remount,bind,ro "$0" "$0"; exec "$@"',
                folder, *cmd]
    subprocess.run(["chmod", "-R", "a-w", folder], check=True)
    return cmd


if bpy.app.version >= (4, 2, 0):
    @test
    def test_extension_installs_and_works_from_a_read_only_folder():
        import tomllib
        with open(os.path.join(harness.REPO, "manifest.toml"), "rb") as f:
            m = tomllib.load(f)
        zip_path = os.path.join(DIST, f'{m["id"]}-{m["version"]}-extension.zip')
        assert os.path.isfile(zip_path), f"{zip_path} missing: run ./build.sh package"
        blender = bpy.app.binary_path
        out = _run([blender, "--command", "extension", "install-file", "--repo", "user_default",
                    "--enable", zip_path])
        assert 'Installed "tussock"' in out, out[-2000:]
        folder = os.path.join(bpy.utils.user_resource("EXTENSIONS"), "user_default", "tussock")
        reader = os.path.join(folder, "tussock_oni_reader")
        assert os.path.isfile(os.path.join(folder, "_tussock.abi3.so")) and os.path.isfile(reader)
        # what some Blender versions' unpacking leaves: no execute bit
        os.chmod(reader, 0o644)
        expected_presets = bpy.utils.extension_path_user(PACKAGE, path="tussock_trees",
                                                         create=True) \
            if hasattr(bpy.utils, "extension_path_user") else ""
        with tempfile.TemporaryDirectory() as tmp:
            script = os.path.join(tmp, "worker.py")
            with open(script, "w") as f:
                f.write(WORKER)
            # no --factory-startup: the preferences that enabled the extension are read
            cmd = [blender, "-b", "-noaudio", "--python-exit-code", "1", "--python", script,
                   "--", harness.REPO, expected_presets]
            try:
                out = _run(_read_only(folder, cmd))
            finally:
                if os.geteuid() != 0:
                    subprocess.run(["chmod", "-R", "u+w", folder], check=False)
        lines = {ln.split()[1]: ln.split()[2:] for ln in out.splitlines()
                 if ln.startswith("EXT ")}
        print("   ", {k: " ".join(v)[:80] for k, v in lines.items()})
        assert lines["folder"][-1] == "False", "the installed folder was writable"
        assert int(lines["blades"][0]) >= 3, lines["blades"]
        assert int(lines["meadow"][0]) > 0, lines["meadow"]
        assert int(lines["tree"][0]) > 1000, lines["tree"]
        assert lines["preset"][:2] == ["True", "True"], lines["preset"]
        assert lines["reader"] == ["crashed"], lines["reader"]
        assert not os.access(reader, os.X_OK), "the test meant the reader to be unexecutable"


harness.main()
