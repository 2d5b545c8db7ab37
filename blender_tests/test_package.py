"""./build.sh package output: the legacy zip installs with addon_install and enables in
background Blender; the extension zip carries a valid blender_manifest.toml."""

import os
import sys
import tomllib
import zipfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import test  # noqa: E402

import addon_utils  # noqa: E402
import bpy  # noqa: E402

DIST = os.environ.get("TSK_DIST") or os.path.join(harness.REPO, "dist")


def manifest():
    with open(os.path.join(harness.REPO, "manifest.toml"), "rb") as f:
        return tomllib.load(f)


def zip_path(kind):
    m = manifest()
    path = os.path.join(DIST, f'{m["id"]}-{m["version"]}-{kind}.zip')
    assert os.path.isfile(path), f"{path} missing: run ./build.sh package"
    return path


@test
def test_legacy_zip_installs_and_enables():
    # run.py links the checkout as addons/tussock; remove only that link first.
    link = os.path.join(bpy.utils.script_path_user(), "addons", "tussock")
    if os.path.islink(link):
        os.unlink(link)
    addon_utils.modules_refresh()
    bpy.ops.preferences.addon_install(filepath=zip_path("legacy"), overwrite=True)
    installed = os.path.join(bpy.utils.script_path_user(), "addons", "tussock")
    assert os.path.isfile(os.path.join(installed, "_tussock.abi3.so"))
    reader = os.path.join(installed, "tussock_oni_reader")
    assert os.path.isfile(reader)
    mod = harness.enable_addon("tussock")
    assert os.path.realpath(mod.__file__).startswith(os.path.realpath(installed))
    from tussock import native
    assert native.available(), native.error
    assert native.version() == manifest()["version"]
    assert hasattr(bpy.types, "TUSSOCK_PT_main")
    # the installed recording reader runs: it is executable again after Blender's unzip, and
    # a recording that crashes OpenNI2's player comes back as an error, not a crash
    assert os.access(reader, os.X_OK)
    crash = os.path.join(harness.REPO, "native", "fuzz", "crashes", "oni-segv-libOniFile.oni")
    try:
        native.lib.depth_open_oni(crash)
        raise AssertionError("a recording that crashes OpenNI2 opened")
    except native.Error as exc:
        assert "recording reader crashed" in str(exc), exc
    harness.disable_addon("tussock")


@test
def test_extension_zip_has_valid_manifest():
    m = manifest()
    with zipfile.ZipFile(zip_path("extension")) as z:
        names = set(z.namelist())
        assert {"blender_manifest.toml", "__init__.py", "_tussock.abi3.so",
                "tussock_oni_reader"} <= names, names
        assert (z.getinfo("tussock_oni_reader").external_attr >> 16) & 0o111
        assert not any(n.endswith(".pyc") for n in names)
        bm = tomllib.loads(z.read("blender_manifest.toml").decode())
    for key in ("schema_version", "id", "version", "name", "tagline", "maintainer", "type",
                "blender_version_min", "license", "platforms", "permissions"):
        assert key in bm, key
    assert bm["version"] == m["version"] and bm["id"] == "tussock" and bm["type"] == "add-on"
    assert tuple(map(int, bm["blender_version_min"].split("."))) >= (4, 2, 0)
    assert set(bm["permissions"]) == {"files", "camera"}
    for reason in bm["permissions"].values():
        assert 0 < len(reason) <= 64 and not reason.endswith("."), reason
    assert len(bm["tagline"]) <= 64 and not bm["tagline"].endswith(".")


harness.main()
