"""A meadow's bake as the live meadow shows it (baking.py makes the bake): the baked
layout — the rest ribbons of every tile the colliders touch over the range — in the first
blades object, the meadow's instances of those tiles hidden, and the Mesh Cache playing the
baked frames. Shown whenever the cache holds the current frame and is up to date."""

import hashlib
import weakref

import numpy as np

from .. import cache, compat, native
from ..wind import runtime as wind_runtime
from . import blade_objects, identity, playback, writer

# meadow key -> (weakref to its Playback, bake layout digest, per instance: is its tile baked)
_hidden = identity.PerMeadow()


def inputs_key(meadow, scene):
    """A digest of what a meadow's baked frames depend on, checked whenever a frame is
    shown: meadow, solver and wind settings, first frame, frame rate and collider
    collection. How the colliders move is checked only when baking (the manifest): after
    changing their animation, bake again."""
    s = meadow.tussock_meadow
    parts = [playback.layout_key(meadow, scene), wind_runtime.settings_key(scene),
             wind_runtime.fps_of(scene), s.colliders.name if s.colliders else None]
    return hashlib.sha256(repr(parts).encode()).hexdigest()


def meadow_of(child, scene):
    """The meadow object whose simulated blades `child` holds, or None."""
    return identity.meadow_of(child, scene)


def blades_inputs_key(child, scene):
    meadow = meadow_of(child, scene)
    return inputs_key(meadow, scene) if meadow is not None else None


def rest_layout(runner, tiles):
    """The baked mesh's blades at rest: counts per tile, ribbon positions (float32, 2K
    vertices per blade) and per-blade colour values, tiles in the given order."""
    lib = native.require()
    k = runner.K
    counts, ribbons, rands = [], [], []
    for t in tiles:  # one native call per tile of the layout
        knots, widths, sides, rand = runner.rest_blades(int(t))
        ribbon = np.empty(len(rand) * 2 * k * 3, np.float32)
        if len(rand):
            lib.blades_expand(knots, widths, sides, k, ribbon, None, None)
        counts.append(len(rand))
        ribbons.append(ribbon)
        rands.append(rand)
    rest = np.concatenate(ribbons) if ribbons else np.zeros(0, np.float32)
    rand = np.concatenate(rands) if rands else np.zeros(0, np.float32)
    return dict(counts=np.array(counts, np.int32), rest=rest, rand=rand)


def apply_layout(meadow, child, tiles, layout, k, instance_tile, digest):
    """Puts the baked layout into Blender: the ribbons of every baked blade at rest, their
    colour values, and the meadow's instances of those tiles hidden."""
    mesh = child.data
    writer.ribbon_topology(mesh, int(layout["counts"].sum()), k)
    compat.set_positions(mesh, layout["rest"])
    writer.set_blade_rand(mesh, layout["rand"], k)
    mesh.update()
    mesh["tussock_layout"] = "baked:" + digest
    if "tussock_capacity" in mesh:
        del mesh["tussock_capacity"]
    writer.empty_extra_chunks(meadow)  # live chunks beyond the first hold no baked blade
    writer.set_hidden(meadow, np.isin(instance_tile, tiles))


def show_baked(meadow, scene, frame):
    """True when the meadow's bake shows `frame`. Then the baked layout is put back if live
    frames (outside the baked range, or while the cache was out of date) replaced it."""
    child = blade_objects.find_blades_object(meadow)
    if child is None or child.modifiers.get(cache.MODIFIER) is None:
        return False
    if not cache.baked_frame(child, scene, frame, lambda _c, scene: inputs_key(meadow, scene)):
        return False
    restore_layout(child, scene, meadow)
    return True


def restore_layout(child, scene, meadow=None):
    """Puts a bake's layout back into the blades object and the meadow's hidden instances
    if live frames replaced them."""
    meadow = meadow or meadow_of(child, scene)
    if meadow is None:
        return
    digest = child.get("tussock_bake_layout")
    tiles = np.array(child.get("tussock_baked_tiles", []), np.int32)
    pb = playback.playback(meadow, scene)
    if writer.left_in_edit_mode(child):
        pass  # the baked layout is put back after Edit Mode
    elif child.data.get("tussock_layout") != "baked:" + str(digest):
        layout = rest_layout(pb.runner, tiles)
        apply_layout(meadow, child, tiles, layout, pb.runner.K, pb.instance_tile, digest)
        writer.layout_replaced(pb)  # the live frames' layout is gone
    # the hidden instances too (checked every frame: rebuilding the meadow clears them)
    which = identity.key(meadow)
    known = _hidden.get(which)
    if known is None or known[0]() is not pb or known[1] != digest:
        known = _hidden[which] = (weakref.ref(pb), digest, np.isin(pb.instance_tile, tiles))
    writer.set_hidden(meadow, known[2])


forget = _hidden.forget  # (obj=None)
