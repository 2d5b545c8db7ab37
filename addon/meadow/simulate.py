"""Blades that objects touch, frame by frame (seed 000 §4.5 with Han & Harada's solver): on
every frame the meadow's colliders — spheres or capsules fitted to the objects of its collider
collection, rigid bodies included — activate the tiles they touch; those tiles' blades are
simulated natively in the shared wind and written into the meadow's dynamic meshes, and the
instances of those tiles are hidden. Tiles at rest are released and blend back into the
instances.

This module ties the parts together and to Blender's handlers; each part owns its state:
    solver.py         the solver driver (Runner) and collider fitting, no Blender data
    playback.py       each meadow's live simulation: recorded colliders, snapshots
    blade_objects.py  the objects that hold the simulated blades
    writer.py         the blades into those objects' meshes, the instances hidden
    baked.py          a bake's frames shown instead, where it holds them"""

import bpy

from .. import compat, handlers, native
from . import baked, blade_objects, build, identity, playback, writer
from . import colliders as collider_shapes

# what tests and tools read of the live simulation
playback_of = playback.playback_of
live_count = playback.live_count
colliders = playback.colliders


def on_frame(scene, depsgraph=None):
    if playback.suspended:
        return
    sync()
    for obj in scene.objects:  # one simulation per meadow object
        s = compat.settings_of(obj, "tussock_meadow")
        if s is None or not s.is_meadow or not s.use_simulation:
            continue
        try:
            if baked.show_baked(obj, scene, scene.frame_current):
                # the bake's Mesh Cache shows this frame; the colliders are still recorded
                # for live frames after the baked range
                playback.playback(obj, scene).record(
                    scene.frame_current, playback.colliders(scene, s.colliders, depsgraph))
                continue
            pb = playback.simulate_to(obj, scene, scene.frame_current, depsgraph)
            writer.write(obj, pb)
            s.last_error = ""
        except (native.Error, ValueError) as exc:
            s.last_error = str(exc)
    # blade objects made just now (a chunk the artist renamed away is made again) are tidied
    # in this frame change, not by whatever operator next updates the depsgraph (soak seed
    # 515889: a cancelled Apply Preset then seemed to have changed the renamed chunk)
    sync()


def forget(obj=None):
    """Frees the live simulation of meadow object `obj`, or of every meadow."""
    playback.forget(obj)
    writer.forget(obj)
    baked.forget(obj)
    if obj is None:
        blade_objects.forget()
        identity.forget()


def _release_joined(changed=()):
    """Meadows joined with other objects become plain meshes (build.release_joined); True
    when there was one. `changed`: what a depsgraph update lists (build.joined_meadows)."""
    joined = build.joined_meadows(changed)
    texts = [build.release_joined(obj) for obj in joined]
    if joined:
        sync(force=True)
        if not bpy.app.background:  # in the status bar and the Info editor, after the handler
            bpy.app.timers.register(lambda: _report(texts), first_interval=0.0)
    return bool(joined)


def _report(texts):
    wm = bpy.context.window_manager
    if wm.windows:
        with bpy.context.temp_override(window=wm.windows[0]):
            for text in texts:
                bpy.ops.tussock.meadow_joined(message=text)


def sync(force=False):
    """After objects were made or removed: gives duplicated meadows their own ids (and so
    their own simulation and blades objects), and frees the simulations of meadows that are
    gone (deleted, or their file closed); True when objects were made or removed."""
    live = identity.scan(force)
    if live is None:
        return False
    playback.keep_only(live)
    writer.keep_only(live)
    blade_objects.tidy_owned(live)
    return True


@bpy.app.handlers.persistent
def _on_frame_change(scene, depsgraph=None):
    if native.available():
        on_frame(scene, depsgraph)


@bpy.app.handlers.persistent
def _on_load(*_args):
    forget()
    collider_shapes.forget()
    # copies made where Tussock was not enabled (another machine, or the add-on off) are
    # tidied as the file opens, not inside whatever operator next updates the depsgraph
    if native.available():
        sync(force=True)


SYNC_EVERY = 0.5  # seconds between looks for meadows gone without an update (see _sync_later)


def _sync_later():
    """Delete in a window frees the object after the last depsgraph update it causes, and a
    script may remove one with none at all: this look, twice a second, finds such a meadow
    gone and frees what it owned, and rebuilds the meadows whose blade models were removed
    (it costs a count of the file's objects while none is made or removed)."""
    # (_release_joined syncs itself when it releases a meadow)
    if native.available() and not playback.suspended and (_release_joined() or sync()):
        _rebuild_stale()  # a blade model among the objects removed
    return SYNC_EVERY


def _rebuild_stale():
    """build.rebuild_stale, then the sync that tidies the patches it left unused (soak seed
    313306: a duplicated meadow, its original gone, was rebuilt when blades were captured;
    its original's patch was removed only at the next object made, inside an operator that
    cancelled)."""
    if build.rebuild_stale():
        sync(force=True)


@bpy.app.handlers.persistent
def _on_depsgraph_update(scene, depsgraph=None):
    if playback.suspended:
        return
    # what changed, read before anything here changes objects: after that depsgraph.updates
    # reads stale items (Blender 5.2 gave an Object where an update was; soak seed 511632)
    global _undone
    # the first update after an undo or redo can list data-blocks of the file state undo
    # replaced: touching them crashed Blender 4.3 (soak seed 583604). Undo restores meadows
    # with their models, so nothing is rebuilt for that update; objects made or removed
    # are still found by sync()
    stale, _undone = _undone, False
    changed = [] if depsgraph is None or stale else [
        (u.id.original if hasattr(u.id, "original") else u.id, u.is_updated_geometry)
        for u in depsgraph.updates]  # the data-blocks changed: a handful
    # Join removes the objects it joined, and one may be a blade model of another meadow:
    # the look for changed models follows (soak seed 720005: that meadow was left stale,
    # then rebuilt inside a cancelled Add Tree)
    made_or_removed = _release_joined(changed) or sync()
    if changed:
        edited = build.models_edited(changed)
        blade_objects.follow_renames(changed)
        if made_or_removed or edited or any(isinstance(idb, bpy.types.Collection)
                                            for idb, _ in changed):
            _rebuild_stale()  # a blade model deleted, moved or edited


classes = ()


_undone = False  # an undo or redo ran since the last depsgraph update


@bpy.app.handlers.persistent
def _on_undo(*_args):
    global _undone
    _undone = True
    writer.forget()  # undo may bring back an older tsk_hidden with the same serial
    build.forget_model_digests()  # the model meshes may be other data-blocks now


def rebuild_stale_models():
    """What changed while nothing watched (the add-on disabled) is settled when it is
    enabled again, not inside whatever operator next updates the depsgraph: meadows joined
    meanwhile are released, copies of blade objects tidied (soak seed 451342 in 4.3: a
    cancelled Apply Preset had stripped an Alt+D copy's tags), and meadows whose blade
    models changed rebuilt (seed 72045 in 5.2: a cancelled Add Tree had rebuilt one)."""
    if not native.available():
        return
    try:
        _release_joined() or sync(force=True)
        _rebuild_stale()
    except AttributeError:  # during register: Blender's data is not readable there
        # (through handlers: disabling the add-on before the timer runs removes it; run
        # without Tussock's properties it raised in 5.2, soak seed 721000)
        handlers.add_timer(rebuild_stale_models)


def register_extra():
    handlers.add("frame_change_post", _on_frame_change)
    handlers.add("load_post", _on_load)
    handlers.add("depsgraph_update_post", _on_depsgraph_update)
    handlers.add_timer(_sync_later, SYNC_EVERY, persistent=True)
    handlers.add("undo_post", _on_undo)
    handlers.add("redo_post", _on_undo)
