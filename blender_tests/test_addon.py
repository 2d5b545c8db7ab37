"""The add-on registers cleanly: enable/disable cycles leak no handlers or timers, the
sidebar tab and preferences exist, metadata agrees with manifest.toml, compat works, and
a build without the native library still registers with one clear message."""

import os
import shutil
import sys
import tomllib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import test  # noqa: E402

import addon_utils  # noqa: E402
import bpy  # noqa: E402


def handler_counts():
    counts = {}
    for name in dir(bpy.app.handlers):
        value = getattr(bpy.app.handlers, name)
        if isinstance(value, list):
            counts[name] = len(value)
    return counts


def manifest():
    with open(os.path.join(harness.REPO, "manifest.toml"), "rb") as f:
        return tomllib.load(f)


@test
def test_enable_disable_three_times_leaks_nothing():
    before = handler_counts()
    classes_before = len(dir(bpy.types))
    for _ in range(3):
        mod = harness.enable_addon()
        assert hasattr(bpy.types, "TUSSOCK_PT_main")
        # the handler registry really adds and removes: add a frame handler and a timer
        from tussock import handlers

        def probe(*_args):
            pass

        def tick():
            return 1.0
        handlers.add("frame_change_post", probe)
        handlers.add_timer(tick, first_interval=10.0)
        assert probe in bpy.app.handlers.frame_change_post
        assert bpy.app.timers.is_registered(tick)
        harness.disable_addon()
        assert probe not in bpy.app.handlers.frame_change_post
        assert not bpy.app.timers.is_registered(tick)
        assert not hasattr(bpy.types, "TUSSOCK_PT_main")
        assert mod is not None
    assert handler_counts() == before, (before, handler_counts())
    assert len(dir(bpy.types)) == classes_before


@test
def test_preferences_show_version_and_set_threads():
    harness.enable_addon()
    from tussock import native, prefs
    p = prefs.get()
    assert p is not None
    assert native.available(), native.error
    p.threads = 1
    assert native.lib.get_threads() == 1
    p.threads = 2
    assert native.lib.get_threads() == 2
    p.threads = 0
    assert native.lib.get_threads() >= 1
    # draw the preferences and the panel into a fake layout would need a window; at least
    # the text they show must be computable
    assert native.version() == manifest()["version"]


@test
def test_bl_info_agrees_with_manifest():
    import tussock
    m = manifest()
    assert tussock.bl_info["name"] == m["name"]
    assert ".".join(map(str, tussock.bl_info["version"])) == m["version"]
    assert ".".join(map(str, tussock.bl_info["blender"])) == m["blender_version_min"]
    assert tussock.bl_info["description"] == m["tagline"]


@test
def test_compat_node_group_sockets():
    harness.enable_addon()
    from tussock import compat
    ng = bpy.data.node_groups.new("tsk compat", "GeometryNodeTree")
    compat.node_group_add_socket(ng, "INPUT", "NodeSocketGeometry", "Geometry")
    compat.node_group_add_socket(ng, "INPUT", "NodeSocketFloat", "Size")
    compat.node_group_add_socket(ng, "OUTPUT", "NodeSocketGeometry", "Geometry")
    assert compat.node_group_socket_names(ng, "INPUT") == ["Geometry", "Size"]
    assert compat.node_group_socket_names(ng, "OUTPUT") == ["Geometry"]
    bpy.data.node_groups.remove(ng)
    tree = compat.compositor_tree(bpy.context.scene)
    assert tree is not None and tree.bl_idname == "CompositorNodeTree"


@test
def test_compat_mesh_indices_and_face_corners():
    harness.enable_addon()
    import numpy as np
    from tussock import compat, meshes
    # int32 indices are read as uint32 in place; other types are converted
    idx = np.array([[0, 1, 2], [2, 3, 0]], np.int32)
    u = compat.mesh_indices(idx)
    assert u.dtype == np.uint32 and np.shares_memory(u, idx) and u.tolist() == [0, 1, 2, 2, 3, 0]
    w = compat.mesh_indices(np.array([5, 6], np.int64))
    assert w.dtype == np.uint32 and w.tolist() == [5, 6]
    s = compat.mesh_indices(idx[:, ::2])  # not contiguous: copied
    assert not np.shares_memory(s, idx) and s.tolist() == [0, 2, 2, 0]
    for k, faces in ((4, [[0, 1, 2, 3], [1, 4, 5, 2]]), (3, [[0, 1, 2], [2, 1, 4], [4, 5, 2]])):
        mesh = bpy.data.meshes.new(f"tsk corners {k}")
        mesh.vertices.add(6)
        mesh.vertices.foreach_set("co", np.arange(18, dtype=np.float32))
        meshes.set_faces(mesh, np.array(faces))
        mesh.update()
        starts = np.empty(len(faces), np.int32)
        mesh.polygons.foreach_get("loop_start", starts)
        assert starts.tolist() == list(range(0, k * len(faces), k)), starts
        assert [len(p.vertices) for p in mesh.polygons] == [k] * len(faces)
        assert [list(p.vertices) for p in mesh.polygons] == faces
        assert not mesh.validate(), "set_faces made a mesh Blender had to correct"
        bpy.data.meshes.remove(mesh)


@test
def test_every_operator_and_setting_has_a_tooltip():
    """Blender shows an operator's description in its tooltip and in F3 search, and a
    property's in its tooltip: every Tussock operator and every setting an artist can see
    has one."""
    harness.enable_addon()
    missing, checked = [], 0
    for name, module in list(sys.modules.items()):
        if not name.startswith("tussock"):
            continue
        for cls in list(vars(module).values()):
            if not isinstance(cls, type) or "bl_rna" not in cls.__dict__:
                continue  # not a class Blender registered
            if issubclass(cls, bpy.types.Operator):
                category, op = cls.bl_idname.split(".")
                rna = getattr(getattr(bpy.ops, category), op).get_rna_type()
                checked += 1
                if not rna.description:
                    missing.append(cls.bl_idname)
            elif issubclass(cls, (bpy.types.PropertyGroup, bpy.types.AddonPreferences)):
                rna = cls.bl_rna
            else:
                continue
            for prop in rna.properties:
                if prop.identifier in ("rna_type", "name", "bl_idname") or prop.is_hidden:
                    continue
                checked += 1
                if not prop.description:
                    missing.append(f"{cls.__name__}.{prop.identifier}")
    assert checked > 150, checked
    assert not missing, f"{len(missing)} without a tooltip: {missing}"


@test
def test_add_menu_offers_tussock_objects_and_leaves_with_the_addon():
    """Shift+A › Tussock holds Add Meadow, Add Tree and Add Wind Source; disabling the
    add-on takes the entry away again."""
    def ours():
        funcs = getattr(bpy.types.VIEW3D_MT_add.draw, "_draw_funcs", None) or ()
        return [f for f in funcs if (getattr(f, "__module__", "") or "").startswith("tussock")]
    harness.enable_addon()
    assert len(ours()) == 1, ours()
    menu = bpy.types.TUSSOCK_MT_add
    import inspect
    source = inspect.getsource(menu.draw)
    for op in ("tussock.add_meadow", "tussock.add_tree", "tussock.add_wind_source"):
        assert op in source, op
        category, name = op.split(".")
        assert getattr(getattr(bpy.ops, category), name).get_rna_type().description
    harness.disable_addon()
    assert ours() == [] and not hasattr(bpy.types, "TUSSOCK_MT_add")
    harness.enable_addon()


@test
def test_missing_native_library_still_registers_with_clear_message():
    # A copy of the add-on without _tussock*.so, under another name: installed, not in a
    # source checkout, so the message sends the artist to the self-contained zip.
    import tussock
    src = os.path.dirname(os.path.realpath(tussock.__file__))
    dst = os.path.join(bpy.utils.script_path_user(), "addons", "tussock_nonative")
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("_tussock*", "__pycache__"))
    addon_utils.modules_refresh()
    mod = harness.enable_addon("tussock_nonative")
    try:
        assert not mod.native.available()
        assert "linux_x64.zip" in mod.native.error and "ImportError" in mod.native.error
        assert "./build.sh" not in mod.native.error
        assert hasattr(bpy.types, "TUSSOCK_PT_main")
        try:
            mod.native.require()
        except mod.native.NativeMissing as exc:
            assert "linux_x64.zip" in str(exc)
        else:
            raise AssertionError("require() did not raise")
        # an operator's error path reports instead of raising
        reports = []

        class FakeOp:
            def report(self, kind, msg):
                reports.append((kind, msg))
        import importlib
        errors = importlib.import_module("tussock_nonative.errors")
        result = errors.run(FakeOp(), lambda: mod.native.require() and {"FINISHED"})
        assert result == {"CANCELLED"}
        assert reports and reports[0][0] == {"ERROR"} and "linux_x64.zip" in reports[0][1]
    finally:
        harness.disable_addon("tussock_nonative")
        shutil.rmtree(dst)


harness.main()
