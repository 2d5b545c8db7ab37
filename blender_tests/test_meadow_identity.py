"""Which meadow is which (issue 32): a simulated meadow renamed while a ball pushes through
its blades keeps one set of blade objects and one simulation; a deleted meadow's simulation
is freed with its blades objects; blades objects duplicated with their meadow go to the
copy, and duplicated alone become plain meshes; a meadow linked from another file beside a
local meadow of the same name (and the same id) simulates on its own and leaves the local
one's blades as they are without it; re-refined blade models reach both the instances
and the simulation; and a deleted meadow is forgotten once its things are tidied, while an
undo still brings it back whole."""

import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import test, vertices_of  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

harness.enable_addon()
from tussock import bake, native  # noqa: E402
from tussock.meadow import blade_objects as sim_objects  # noqa: E402
from tussock.meadow import build, identity, simulate  # noqa: E402

RADIUS = 0.2
FRAMES = 12
TMP = tempfile.mkdtemp(prefix="tsk_identity_")
SAMPLE = os.path.join(harness.REPO, "samples", "blades", "depth_####.png")


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    simulate.forget()


def meadow_with_ball(offset=(0.0, 0.0, 0.0), name="Meadow", ident=None, **kw):
    """A 3 m meadow over a plane at `offset` and a ball keyframed across it (its collider);
    simulation on. `ident`: the meadow's id (else a new one)."""
    scene = bpy.context.scene
    ox, oy, oz = offset
    bpy.ops.mesh.primitive_plane_add(size=3.0, location=offset)
    opts = dict(tile_size=0.25, blades_per_tile=32, density="UNIFORM", display=1.0)
    opts.update(kw)
    assert bpy.ops.tussock.add_meadow(**opts) == {"FINISHED"}
    meadow = bpy.context.active_object
    meadow.name = name
    if ident is not None:
        meadow[identity.ID] = ident
    bpy.ops.mesh.primitive_uv_sphere_add(radius=RADIUS, location=(ox - 1.2, oy, oz + RADIUS))
    ball = bpy.context.active_object
    ball.name = name + " ball"
    ball.keyframe_insert("location", frame=1)
    ball.location = (ox + 1.2, oy + 0.3, oz + RADIUS)
    ball.keyframe_insert("location", frame=FRAMES)
    coll = bpy.data.collections.new(name + " colliders")
    scene.collection.children.link(coll)
    coll.objects.link(ball)
    scene.collection.objects.unlink(ball)
    meadow.tussock_meadow.colliders = coll
    meadow.tussock_meadow.use_simulation = True
    return meadow


def play(frames=range(1, FRAMES + 1)):
    for f in frames:
        bpy.context.scene.frame_set(f)


def blade_objects():
    """Every object that holds a meadow's simulated blades."""
    return [o for o in bpy.data.objects if "tussock_meadow_name" in o]


def rss_mb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2 ** 20


def drawn_vertices(objs):
    """Ribbon vertices drawn (not collapsed to the origin) in the given blade objects."""
    total = 0
    for o in objs:
        v = np.empty(len(o.data.vertices) * 3, np.float32)
        o.data.vertices.foreach_get("co", v)
        total += int(np.count_nonzero(np.abs(v).reshape(-1, 3).sum(axis=1))) if len(v) else 0
    return total


@test
def test_three_renames_keep_one_set_of_blades_and_one_simulation():
    fresh()
    lib = native.require()
    meadow = meadow_with_ball()
    play()
    first = blade_objects()
    names = sorted(o.name for o in first)
    assert all(n.startswith("Meadow blades") for n in names), names
    drawn = drawn_vertices(first)
    assert meadow["tussock_active_blades"] > 0 and drawn > 0
    patch_objects = len(bpy.data.collections["Meadow patch"].objects)
    native_bytes, rss = lib.allocated_bytes(), rss_mb()
    for i, new in enumerate(("Lawn", "Lawn 2", "Verge")):
        meadow.name = new
        if i == 1:
            bpy.context.view_layer.update()  # as the UI does after an edit (depsgraph handler)
        play(range(1, FRAMES + 1) if i % 2 else range(FRAMES, 0, -1))  # both directions
        play()
        objs = blade_objects()
        # one set: the same objects, renamed; none frozen under an old name
        assert len(objs) == len(first), (new, sorted(o.name for o in objs))
        assert sorted(o.name for o in objs) == sorted(n.replace("Meadow", new, 1) for n in names)
        assert drawn_vertices(objs) == drawn, (new, drawn_vertices(objs), drawn)
        assert simulate.live_count() == 1
        assert simulate.playback_of(meadow) is not None
        patches = [c for c in bpy.data.collections if c.name.endswith(" patch")]
        assert [c.name for c in patches] == [new + " patch"], [c.name for c in patches]
        assert len(patches[0].objects) == patch_objects
        assert all(o.name.startswith(new + " chunk ") for o in patches[0].objects)
        assert lib.allocated_bytes() <= native_bytes * 1.05 + (1 << 20), \
            (new, lib.allocated_bytes(), native_bytes)
    assert rss_mb() < rss + 64, (rss_mb(), rss)
    # a settings change after the renames rebuilds into the same patch collection
    meadow.tussock_meadow.display = 0.5
    assert [c.name for c in bpy.data.collections if c.name.endswith(" patch")] == ["Verge patch"]


@test
def test_deleting_a_simulated_meadow_frees_its_simulation():
    fresh()
    lib = native.require()
    meadow_with_ball()
    other = meadow_with_ball(offset=(5.0, 0.0, 0.0), name="Other")
    play()
    assert simulate.live_count() == 2
    one = lib.allocated_bytes()
    simulate.forget(other)  # what one meadow's simulation holds, measured
    per_meadow = one - lib.allocated_bytes()
    assert per_meadow > 100_000, per_meadow
    play()
    assert simulate.live_count() == 2
    held = lib.allocated_bytes()  # (within a few hundred bytes of `one`: growth differs)
    for o in bpy.context.selected_objects:
        o.select_set(False)
    other.select_set(True)
    bpy.context.view_layer.objects.active = other
    mine = sorted(o.name for o in blade_objects() if o.name.startswith("Meadow blades"))
    theirs = [o.name for o in blade_objects() if o.name.startswith("Other blades")]
    assert len(mine) == len(theirs) == 2 * sim_objects.CHUNKS, (mine, theirs)
    patch = bpy.data.collections["Other patch"]
    patch_objects = [o.name for o in patch.objects]
    assert bpy.ops.object.delete() == {"FINISHED"}
    bpy.context.view_layer.update()  # the depsgraph handler frees it, without playing
    assert simulate.live_count() == 1, simulate.live_count()
    # and its blades objects (frozen in the scene otherwise), their meshes and its patch go
    # with it; the other meadow's stay
    assert sorted(o.name for o in blade_objects()) == mine, [o.name for o in blade_objects()]
    assert not any(m.name.startswith("Other blades") for m in bpy.data.meshes)
    assert "Other patch" not in bpy.data.collections
    assert not any(n in bpy.data.objects for n in patch_objects)
    assert "Meadow patch" in bpy.data.collections
    freed = held - lib.allocated_bytes()
    assert abs(freed - per_meadow) < 0.01 * per_meadow, (freed, per_meadow)
    play()
    assert simulate.live_count() == 1
    assert abs(held - lib.allocated_bytes() - per_meadow) < 0.01 * per_meadow


@test
def test_deleted_meadows_are_forgotten_once_tidied_and_undo_still_brings_one_back():
    fresh()
    meadow = meadow_with_ball()
    play(range(1, 4))
    k = identity.key(meadow)
    count = len(blade_objects())
    assert count == 2 * sim_objects.CHUNKS, count
    bpy.ops.ed.undo_push(message="played")
    harness.select_objects([meadow])
    assert bpy.ops.object.delete() == {"FINISHED"}
    bpy.context.view_layer.update()
    assert not blade_objects() and "Meadow patch" not in bpy.data.collections
    # tidied: nothing of it is left to look for, so its key is not kept
    assert k not in identity.gone and k not in sim_objects._followed, \
        (identity.gone, sim_objects._followed)
    bpy.ops.ed.undo_push(message="deleted")
    assert bpy.ops.ed.undo() == {"FINISHED"}
    meadow = bpy.data.objects["Meadow"]
    assert identity.key(meadow) == k
    play(range(4, 7))
    assert simulate.live_count() == 1 and len(blade_objects()) == count, \
        (simulate.live_count(), len(blade_objects()))
    harness.select_objects([meadow])
    assert bpy.ops.object.delete() == {"FINISHED"}
    bpy.context.view_layer.update()
    assert not blade_objects() and "Meadow patch" not in bpy.data.collections
    assert simulate.live_count() == 0
    # an afternoon of adding and deleting meadows keeps nothing per meadow
    for _ in range(12):
        meadow = meadow_with_ball(name="Again")
        play(range(1, 3))
        harness.select_objects([o for o in bpy.context.scene.objects
                                if o.name.startswith("Again")])
        assert bpy.ops.object.delete() == {"FINISHED"}
        bpy.context.view_layer.update()
    assert not blade_objects()
    assert len(identity.gone) == 0 and len(sim_objects._followed) == 0, \
        (identity.gone, sim_objects._followed)


def _knots(meadow):
    r = simulate.playback_of(meadow).runner
    return r.knots().copy()


@test
def test_a_duplicated_meadow_gets_its_own_id_simulation_and_blades():
    fresh()
    meadow = meadow_with_ball()
    reference = {}
    for f in range(1, FRAMES + 1):
        bpy.context.scene.frame_set(f)
        reference[f] = _knots(meadow)
    fresh()
    meadow = meadow_with_ball()
    ident = meadow[identity.ID]
    play(range(1, 5))
    mine = sim_objects.blades_object(meadow)
    for o in bpy.context.selected_objects:
        o.select_set(False)
    meadow.select_set(True)
    bpy.context.view_layer.objects.active = meadow
    assert bpy.ops.object.duplicate() == {"FINISHED"}  # Shift+D
    dup = bpy.context.active_object
    assert dup is not meadow and identity.ID in dup  # custom properties are copied (the
    # depsgraph handler may have given it its own id already)
    for f in range(1, FRAMES + 1):
        bpy.context.scene.frame_set(f)
        assert np.array_equal(_knots(meadow), reference[f]), f
        assert np.array_equal(_knots(dup), reference[f]), f  # the same ground and ball
    assert meadow[identity.ID] == ident and dup[identity.ID] != ident  # the copy is renamed
    assert simulate.live_count() == 2
    assert simulate.playback_of(dup) is not simulate.playback_of(meadow)
    assert sim_objects.blades_object(meadow) == mine and mine.name == "Meadow blades"
    theirs = sim_objects.blades_object(dup)
    assert theirs.name == f"{dup.name} blades" and theirs.get(identity.OWNER) == dup[identity.ID]
    # its own patch once it is rebuilt; the original's stays as it is
    chunks = sorted(o.name for o in bpy.data.collections["Meadow patch"].objects)
    dup.tussock_meadow.seed = 7
    assert sorted(o.name for o in bpy.data.collections["Meadow patch"].objects) == chunks
    assert len(bpy.data.collections[f"{dup.name} patch"].objects) == len(chunks)


def select(objs):
    for o in bpy.context.selected_objects:
        o.select_set(False)
    for o in objs:
        o.select_set(True)
    bpy.context.view_layer.objects.active = objs[0]


@test
def test_blades_duplicated_with_their_meadow_go_to_the_copy_and_alone_become_plain():
    fresh()
    meadow = meadow_with_ball()
    play(range(1, 7))
    own = sorted(blade_objects(), key=lambda o: o.name)
    assert len(own) == 2 * sim_objects.CHUNKS
    # Shift+D of the meadow with its blades objects (a box selection of the lot)
    select([meadow] + own)
    assert bpy.ops.object.duplicate() == {"FINISHED"}
    dup = next(o for o in bpy.context.selected_objects if o.get("tussock_meadow_object"))
    bpy.context.view_layer.update()
    play()
    dup_name = dup.name
    objs = blade_objects()
    # two sets, each named after its meadow and owned by it: nothing frozen, nothing extra
    # (the render chunks are disabled in the viewport, so Shift+D leaves them, and the copy
    # makes its own when its Viewport display leaves blades out)
    copied = [o for o in own if not o.hide_viewport]
    assert len(copied) == sim_objects.CHUNKS
    assert len(objs) == len(own) + len(copied), sorted(o.name for o in objs)
    for m, names in ((meadow, [o.name for o in own]),
                     (dup, [o.name.replace("Meadow", dup_name, 1) for o in copied])):
        mine = [o for o in objs if o.get(identity.OWNER) == m[identity.ID]]
        assert sorted(o.name for o in mine) == sorted(names), sorted(o.name for o in mine)
        assert drawn_vertices(mine) > 0
    assert dup_name.startswith("Meadow.") and simulate.live_count() == 2
    first_dup = sim_objects.blades_object(dup)
    assert first_dup in bpy.context.selected_objects  # a copy, not a blades object made anew
    # the copy plays its own simulation: its blades move with the ball as the original's
    assert np.array_equal(vertices_of(first_dup), vertices_of(sim_objects.blades_object(meadow)))
    # Shift+D of blades alone, and Alt+D: the artist's still copies, never written again
    first = sim_objects.blades_object(meadow)
    select([first])
    assert bpy.ops.object.duplicate() == {"FINISHED"}
    still = bpy.context.active_object
    select([first])
    assert bpy.ops.object.duplicate(linked=True) == {"FINISHED"}
    shared = bpy.context.active_object
    assert shared.data == first.data
    bpy.context.view_layer.update()
    for o in (still, shared):
        assert not any(tag in o for tag in sim_objects.OWN_TAGS), o.keys()
    kept = vertices_of(still)
    play(range(FRAMES, 0, -1))
    assert np.array_equal(vertices_of(still), kept)  # frozen on purpose: a copy of a moment
    assert np.array_equal(vertices_of(shared), vertices_of(first))  # shows the live mesh
    assert len([o for o in blade_objects() if o.get(identity.OWNER)]) == len(objs)
    # the original is renamed afterwards: its set follows, the copies do not get in the way
    meadow.name = "Lawn"
    play(range(1, 4))
    assert sorted(o.name for o in blade_objects() if o.get(identity.OWNER) == meadow[identity.ID]) \
        == sorted(o.name.replace("Meadow", "Lawn", 1) for o in own)
    assert meadow.tussock_meadow.last_error == "" and dup.tussock_meadow.last_error == ""


@test
def test_linked_meadow_of_the_same_name_simulates_on_its_own():
    # the library: a meadow named "Meadow" elsewhere, its own ball
    fresh()
    ident = meadow_with_ball(offset=(6.0, 0.0, 0.0))[identity.ID]
    path = os.path.join(TMP, "library.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    # the local scene alone: the reference
    fresh()
    local = meadow_with_ball()
    reference = {}
    for f in range(1, FRAMES + 1):
        bpy.context.scene.frame_set(f)
        reference[f] = _knots(local)
    assert max(len(k) for k in reference.values()) > 0
    # the same scene with the library's meadow linked beside it
    fresh()
    local = meadow_with_ball(ident=ident)  # as if the library was once a copy of this file
    with bpy.data.libraries.load(path, link=True) as (src, dst):
        dst.objects = ["Meadow", "Plane"]
        dst.collections = ["Meadow colliders"]
    linked, linked_colliders = dst.objects[0], dst.collections[0]
    scene = bpy.context.scene
    # the ground too: from Blender 4.1 on, an object's world matrix is known only where it
    # is evaluated (the meadow's area comes from its ground)
    for obj in dst.objects:
        scene.collection.objects.link(obj)
    scene.collection.children.link(linked_colliders)
    assert linked.library is not None and linked.name == local.name == "Meadow"
    assert local[identity.ID] == linked[identity.ID]
    for f in range(1, FRAMES + 1):
        scene.frame_set(f)
        assert np.array_equal(_knots(local), reference[f]), f
    assert simulate.live_count() == 2
    pl, pk = simulate.playback_of(local), simulate.playback_of(linked)
    assert pl is not pk
    assert pl.output.stats["tussock_active_blades"] > 0
    assert pk.output.stats["tussock_active_blades"] > 0
    # the linked meadow's blades are where its ball went (x about 6), in objects of its own
    roots = pk.runner.knots().reshape(-1, pk.runner.K, 3)[:, 0]
    assert roots[:, 0].min() > 4.0, roots[:, 0].min()
    mine, theirs = sim_objects.blades_object(local), sim_objects.blades_object(linked)
    assert mine is not theirs and theirs.name == "Meadow [library.blend] blades", theirs.name
    assert mine.name == "Meadow blades"
    drawn = drawn_vertices([theirs] + sim_objects.extra_chunks(linked))  # ribbon vertices
    assert drawn == pk.output.stats["tussock_active_blades"] * 2 * pk.runner.K, drawn


@test
def test_a_meadow_made_before_ids_keeps_its_blades_and_patch():
    fresh()
    meadow = meadow_with_ball()
    play()
    blades = sorted(o.name for o in blade_objects())
    patch = bpy.data.collections["Meadow patch"]
    for thing in blade_objects() + [patch]:  # as an older Tussock left them: names only
        del thing[identity.OWNER]
    del meadow[identity.ID]
    simulate.forget()  # as after opening the file
    play()
    assert meadow.tussock_meadow.last_error == ""
    assert sorted(o.name for o in blade_objects()) == blades
    k = identity.key(meadow)
    assert all(o[identity.OWNER] == k for o in blade_objects())
    meadow.tussock_meadow.display = 0.5  # a rebuild keeps its patch collection
    assert patch[identity.OWNER] == k
    assert [c.name for c in bpy.data.collections if c.name.endswith(" patch")] == ["Meadow patch"]
    meadow.name = "Lawn"
    play(range(1, 3))
    assert sorted(o.name for o in blade_objects()) == [n.replace("Meadow", "Lawn") for n in blades]


@test
def test_a_baked_meadow_renamed_plays_its_bake_and_frees_its_files():
    fresh()
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, FRAMES
    meadow = meadow_with_ball()
    folder = os.path.join(TMP, "baked")
    os.makedirs(folder, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(folder, "scene.blend"))
    assert bpy.ops.tussock.bake() == {"FINISHED"}
    cache = os.path.join(folder, "tussock_cache")
    written = sorted(set(os.listdir(cache)) - {bake.RECORD})
    assert written == ["Meadow_blades", "Meadow_blades.layout.json", "Meadow_blades.pc2"], written
    meadow.name = "Lawn"
    scene.frame_set(FRAMES // 2)
    child = bpy.data.objects["Lawn blades"]  # the baked blades, renamed
    pc2 = os.path.join(cache, "Meadow_blades.pc2")
    out = np.empty(native.require().pc2_info(pc2)["points"] * 3, np.float32)
    native.require().pc2_read_sample(pc2, FRAMES // 2 - 1, out)
    ev = child.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    co = np.empty(len(ev.vertices) * 3, np.float32)
    ev.vertices.foreach_get("co", co)
    assert np.allclose(co, out, atol=1e-6)  # its Mesh Cache still plays the bake
    child.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh_clear()
    assert bpy.ops.tussock.free_bake() == {"FINISHED"}
    assert os.listdir(cache) == [], os.listdir(cache)  # the files it was baked under
    play()
    assert meadow["tussock_active_blades"] > 0 and not child.modifiers


def _patch_positions(coll):
    chunks = sorted(coll.objects, key=lambda o: o.name)
    parts = []
    for o in chunks:
        v = np.empty(len(o.data.vertices) * 3, np.float32)
        o.data.vertices.foreach_get("co", v)
        parts.append(v)
    return np.concatenate(parts)


def _sim_patch_positions(meadow):
    """The patch the live simulation grows its waking tiles from, expanded as the instances
    are."""
    lib = native.require()
    s = meadow.tussock_meadow
    patch = simulate.playback_of(meadow).runner.patch
    info = lib.patch_info(patch)
    pos = np.empty(info["vertex_count"] * 3, np.float32)
    uvs = np.empty(info["vertex_count"] * 2, np.float32)
    tris = np.empty(info["triangle_count"] * 3, np.int32)
    index = np.empty(info["vertex_count"], np.int32)
    lib.patch_expand(patch, s.tile_size, pos, None, uvs, tris, index)
    return pos


@test
def test_rerefined_models_reach_instances_and_simulation():
    fresh()
    assert bpy.ops.tussock.capture_blades(source="FILES", filepath=SAMPLE) == {"FINISHED"}
    assert bpy.ops.tussock.refine_blades(knots="16", movement="SIMULATED", frames=6) == {"FINISHED"}
    meadow = meadow_with_ball(patch_blades=2048)
    play()
    coll = bpy.data.collections["Meadow patch"]
    before = _patch_positions(coll)
    assert np.array_equal(before, _sim_patch_positions(meadow))
    blades = list(bpy.data.collections["Tussock Blades"].objects)
    for o in bpy.context.selected_objects:
        o.select_set(False)
    for o in blades:
        o.select_set(True)
    assert bpy.ops.tussock.refine_blades(knots="8", movement="SIMULATED", frames=6) == {"FINISHED"}
    expected = build.compute_patch(meadow.tussock_meadow)["positions"].ravel()
    now = _patch_positions(coll)
    assert len(now) != len(before)  # 8 knots a blade now
    assert np.array_equal(now, expected)  # the instances grow the new models
    play(range(1, 4))  # playing on: the simulation too
    assert simulate.playback_of(meadow).runner.K == 8
    assert np.array_equal(_sim_patch_positions(meadow), expected)
    simulate.forget()  # as after reopening the file
    play(range(1, 4))
    assert np.array_equal(_sim_patch_positions(meadow), _patch_positions(coll))


harness.main()
