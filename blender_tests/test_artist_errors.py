"""What artists do to a scene (issue 32): operator arguments out of the stored settings'
limits are refused, never built with one value and stored with another; Tussock objects in
Edit Mode and pictures whose file went missing give a message, not a traceback or black
frames; property update callbacks report any exception."""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import expect_cancel, test  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

harness.enable_addon()
from tussock import native  # noqa: E402
from tussock.meadow import build as meadow_build  # noqa: E402
from tussock.meadow.operators import SETTINGS as MEADOW_SETTINGS  # noqa: E402
from tussock.meadow.props import TussockMeadowSettings  # noqa: E402
from tussock.trees.props import TussockTreeSettings  # noqa: E402
from tussock.wind.props import TussockWindSource  # noqa: E402

lib = native.require()
ops = bpy.ops.tussock
SMALL_MEADOW = dict(size=(2.0, 2.0), patch_blades=256, chunk_blades=16)


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    lib.set_memory_budget(0)


def outside(group_cls, name):
    """Values just outside the stored property's hard limits (those that are not the type's
    own), each with which limit it breaks."""
    p = group_cls.bl_rna.properties[name]
    out = []
    if p.type == "INT":
        if p.hard_min > -2 ** 31:
            out.append(p.hard_min - 1)
        if p.hard_max < 2 ** 31 - 1:
            out.append(p.hard_max + 1)
    else:
        if p.hard_min > -3e38:
            out.append(p.hard_min - max(abs(p.hard_min) * 0.5, 1e-3))
        if p.hard_max < 3e38:
            out.append(p.hard_max + max(abs(p.hard_max) * 0.5, 1e-3))
    return out


def bounded(group_cls, names):
    return [n for n in names if group_cls.bl_rna.properties[n].type in ("INT", "FLOAT")
            and outside(group_cls, n)]


# ---- 1. operator arguments are the stored settings, or refused -----------------------------

@test
def test_meadow_arguments_out_of_the_stored_range_are_refused():
    fresh()
    names = bounded(TussockMeadowSettings, MEADOW_SETTINGS)
    # every bounded meadow setting is tried (the three among them)
    assert {"tile_size", "scale_max", "noise_threshold", "patch_blades"} <= set(names), names
    tried = 0
    for name in names:
        for v in outside(TussockMeadowSettings, name):
            kw = dict(SMALL_MEADOW)
            kw[name] = v
            expect_cancel(ops.add_meadow, name, **kw)
            tried += 1
    assert tried >= 15, tried
    # the example, with the range in the message
    try:
        ops.add_meadow(tile_size=0.005, **SMALL_MEADOW)
    except RuntimeError as exc:
        assert "Tile size (tile_size) must be from 0.01 to 100, got 0.005" in str(exc), exc
    assert not any(o.get("tussock_meadow_object") for o in bpy.data.objects)


@test
def test_meadow_in_range_arguments_are_stored_as_built():
    fresh()
    values = dict(tile_size=0.37, blades_per_tile=48, patch_blades=512, chunk_blades=16,
                  scale_min=0.6, scale_max=1.7, noise_scale=3.5, noise_octaves=4,
                  noise_threshold=0.45, seed=7, display=0.5)
    assert ops.add_meadow(size=(4.0, 3.0), **values) == {"FINISHED"}
    obj = bpy.context.active_object
    s = obj.tussock_meadow
    for name, v in values.items():
        stored = getattr(s, name)
        assert stored == np.float32(v) if isinstance(v, float) else stored == v, \
            (name, stored, v)
    # what the operator built is what the stored settings build
    built = (obj["tussock_blades"], obj["tussock_tiles"], obj["tussock_instances"])
    co = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co)
    assert built[0] > 1000, built
    meadow_build.rebuild(obj)
    again = (obj["tussock_blades"], obj["tussock_tiles"], obj["tussock_instances"])
    co2 = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co2)
    assert built == again, (built, again)
    assert np.array_equal(co, co2)


@test
def test_tree_arguments_out_of_the_stored_range_are_refused():
    fresh()
    preset = lib.tree_presets()[0]
    names = bounded(TussockTreeSettings, ("seed", "smooth_levels"))
    assert names == ["seed", "smooth_levels"], names
    for name in names:
        for v in outside(TussockTreeSettings, name):
            expect_cancel(ops.add_tree, name, preset=preset, **{name: v})
    try:
        ops.add_tree(preset=preset, smooth_levels=4)
    except RuntimeError as exc:
        assert "Smooth (smooth_levels) must be from 0 to 3, got 4" in str(exc), exc
    assert ops.add_tree(preset=preset, seed=11, smooth_levels=1, leaves=False) == {"FINISHED"}
    s = bpy.context.active_object.tussock_tree
    assert (s.seed, s.smooth_levels, s.leaves) == (11, 1, False)


@test
def test_wind_source_arguments_out_of_the_stored_range_are_refused():
    fresh()
    names = bounded(TussockWindSource, ("strength", "radius", "interval"))
    assert names == ["strength", "radius", "interval"], names
    for name in names:
        for v in outside(TussockWindSource, name):
            expect_cancel(ops.add_wind_source, name, **{name: v})
    # 0.0005 was clamped to 0.001 before; now the operator says why
    expect_cancel(ops.add_wind_source, "Radius (radius) must be at least 0.001",
                  radius=0.0005)
    assert ops.add_wind_source(strength=0.3, radius=0.25, interval=2.0) == {"FINISHED"}
    s = bpy.context.active_object.tussock_wind_source
    assert (s.strength, s.radius, s.interval) == (np.float32(0.3), np.float32(0.25), 2.0)


if __name__ == "__main__":
    harness.main()
