"""Builds a meadow's Blender data from its settings: the native library makes the patch,
lays out the tiles with the density map and lists the chunk instances; this module puts
them into the chunk collection and the instance point cloud. All native work happens
before any Blender data is touched, so an error leaves the scene as it was."""

import hashlib
import sys

import bpy
import numpy as np
from mathutils import Vector

from .. import budget, compat, meshes, native
from ..capture.blades import COLLECTION as BLADES_COLLECTION
from ..nodes import meadow_nodes
from . import chunks as chunk_data
from . import identity, material

MODIFIER = "Tussock Meadow"
BLADE_RAND_STREAM = 0x636F6C6F72  # "color": per-blade colour variation
DISPLAY_STREAM = 0x76696577  # "view": which chunk instances the viewport shows
MAX_MODELS = 256


def ground_area(ground):
    """(origin xyz, size xy) of a ground object's world-space bounding box."""
    corners = np.array([ground.matrix_world @ Vector(c) for c in ground.bound_box], np.float64)
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    return (float(lo[0]), float(lo[1]), float(hi[2])), (float(hi[0] - lo[0]), float(hi[1] - lo[1]))


MAX_KNOTS = 64  # knots of a blade model (the native patch's limit)
# Each chunk of the patch is a Blender object: Blender adds one object in about a
# millisecond and slows down with every thousand more (65,536 chunks of a 2**20-blade patch
# took minutes, soak), so the patch is cut into at most this many (the default is 1,024).
MAX_CHUNKS = 4096


def blade_models(collection):
    """Knots, widths and knot counts of the blade objects in `collection` (DESIGN.md's
    blade contract: vertices root->tip, point attribute `width`). Returns None for the
    default blade when there are none. Non-blade objects are an error. A blade of more
    knots than a model holds (a capture not refined yet: a whole blade runs to 70-100
    knots) is resampled evenly along its length to MAX_KNOTS, so a meadow can grow straight
    from a capture; Refine chooses the knots by their motion instead."""
    if collection is None:
        collection = bpy.data.collections.get(BLADES_COLLECTION)
    if collection is None or len(collection.objects) == 0:
        return None
    knots, widths, counts = [], [], []
    for obj in collection.objects:  # one entry per model object (not per knot)
        mesh = obj.data if obj.type == "MESH" else None
        if mesh is None or "width" not in mesh.attributes or len(mesh.vertices) < 2:
            raise ValueError(f"'{obj.name}' in '{collection.name}' is not a Tussock blade "
                             "(a mesh of knots with a 'width' attribute)")
        # in Edit Mode its attributes read as empty (foreach_get fails): a message instead
        meshes.refuse_edit_mode(obj, "a meadow grown from it")
        n = len(mesh.vertices)
        co = np.empty(n * 3, np.float32)
        mesh.vertices.foreach_get("co", co)
        w = np.empty(n, np.float32)
        mesh.attributes["width"].data.foreach_get("value", w)
        if n > MAX_KNOTS:
            co_in, w_in = co, w
            n = MAX_KNOTS
            co, w = np.empty(n * 3, np.float32), np.empty(n, np.float32)
            native.require().refine_resample(co_in, w_in, co, w)
        knots.append(co)
        widths.append(w)
        counts.append(n)
        if len(counts) > MAX_MODELS:
            raise ValueError(f"more than {MAX_MODELS} blade models in '{collection.name}'")
    return (np.concatenate(knots), np.concatenate(widths), np.array(counts, np.int32))


_digests = {}  # which objects and meshes the models are, in order -> models_digest
_model_meshes = set()  # session ids of the meshes digested


def _uid(idblock):
    # session_uid is never reused within a session, where a pointer may be
    return getattr(idblock, "session_uid", None) or idblock.as_pointer()


def models_digest(collection):
    """A digest of the blade models of `collection` (see blade_models): their knots, widths
    and order, so that a re-refined or edited blade counts as another model whatever its
    name. Reading 256 models costs about 3 ms, and the simulation asks every frame: the
    digest is kept for the same objects and meshes (about 1 ms to tell for 256 in Blender
    3.4) until one of those meshes is edited (models_edited)."""
    coll = collection or bpy.data.collections.get(BLADES_COLLECTION)
    if coll is None:
        return None
    which = tuple((_uid(o), _uid(o.data) if o.data is not None else 0) for o in coll.objects)
    digest = _digests.get(which)
    if digest is None:
        # watched before they are read: a model that cannot be read now (in Edit Mode) is
        # read again when its mesh changes (leaving Edit Mode writes it)
        _model_meshes.update(m for _, m in which)
        models = blade_models(coll)
        if models is None:
            return None
        h = hashlib.sha256()
        for a in models:
            h.update(np.ascontiguousarray(a).tobytes())
        digest = h.hexdigest()[:32]
        if len(_digests) > 64:  # (one entry per set of models seen: they seldom change)
            _digests.clear()
        _digests[which] = digest
    return digest


def forget_model_digests():
    _digests.clear()
    _model_meshes.clear()


def models_edited(changed):
    """Forgets the digests of blade models whose meshes a depsgraph update changed (`changed`:
    (original data-block, geometry updated) of each of its updates); True when there was
    one."""
    if not _model_meshes:
        return False
    for idblock, geometry in changed:
        try:
            edited = (isinstance(idblock, bpy.types.Mesh) and geometry
                      and _uid(idblock) in _model_meshes)
        except ReferenceError:  # removed since the update
            continue
        if edited:
            forget_model_digests()
            return True
    return False


def patch_key(settings):
    """What the patch depends on; the chunk meshes are rebuilt only when it changes."""
    return repr((settings.patch_blades, round(settings.scale_min, 6), round(settings.scale_max, 6),
                 settings.seed, round(settings.tile_size, 6), settings.chunk_blades,
                 models_digest(settings.models)))


def make_patch(settings):
    """The native patch of a meadow's settings."""
    lib = native.require()
    models = blade_models(settings.models)
    kw = dict(blade_count=settings.patch_blades, scale_min=settings.scale_min,
              scale_max=settings.scale_max, seed=settings.seed)
    if models is not None:
        kw.update(knots=models[0], widths=models[1], knot_counts=models[2])
    try:
        patch = lib.patch_create(**kw)
    except lib.Error as exc:  # name the setting the artist knows
        raise lib.Error(f"patch ({settings.patch_blades} blades): {exc}") from None
    chunks = settings.patch_blades // max(settings.chunk_blades, 1)
    if chunks > MAX_CHUNKS:
        raise ValueError(
            f"chunk_blades: a patch of {settings.patch_blades} blades (Patch size) in chunks "
            f"of {settings.chunk_blades} makes {chunks} chunk objects, more than "
            f"{MAX_CHUNKS}: raise Chunk to at least {-(-settings.patch_blades // MAX_CHUNKS)}")
    return patch


def compute_patch(settings):
    """The patch expanded into one mesh in tile-local metres, as plain arrays."""
    lib = native.require()
    patch = make_patch(settings)
    pinfo = lib.patch_info(patch)
    nv, nt = pinfo["vertex_count"], pinfo["triangle_count"]
    positions = np.empty(nv * 3, np.float32)
    uvs = np.empty(nv * 2, np.float32)
    tris = np.empty(nt * 3, np.int32)
    blade_index = np.empty(nv, np.int32)
    lib.patch_expand(patch, settings.tile_size, positions, None, uvs, tris, blade_index)
    blade_rand = np.empty(pinfo["blade_count"], np.float32)
    lib.rand_fill(settings.seed, BLADE_RAND_STREAM, blade_rand)
    return dict(positions=positions.reshape(-1, 3), uvs=uvs.reshape(-1, 2),
                tris=tris.reshape(-1, 3), blade_index=blade_index, blade_rand=blade_rand,
                blade_count=pinfo["blade_count"])


def density_image_values(settings):
    img = settings.density_image
    if img is None or img.size[0] == 0 or img.size[1] == 0:
        raise ValueError("density image: choose an image with pixels")
    iw, ih = img.size
    px = np.empty(iw * ih * 4, np.float32)
    img.pixels.foreach_get(px)
    return np.ascontiguousarray(px.reshape(-1, 4)[:, :3].mean(axis=1), np.float32), iw, ih


def make_meadow(settings, origin, size):
    """The native meadow layout of a meadow's settings."""
    lib = native.require()
    density = settings.density.lower()
    image, iw, ih = (None, 0, 0)
    if density == "image":
        image, iw, ih = density_image_values(settings)
    return lib.meadow_create(
        origin=origin, size=size, tile_size=settings.tile_size,
        blades_per_tile=settings.blades_per_tile, patch_blades=settings.patch_blades,
        chunk_blades=settings.chunk_blades, seed=settings.seed, density=density,
        noise_scale=settings.noise_scale, noise_octaves=settings.noise_octaves,
        noise_threshold=settings.noise_threshold, image=image, image_width=iw,
        image_height=ih)


def compute_layout(settings, origin, size):
    """Tiles, density map and chunk instances of the meadow, as plain arrays."""
    lib = native.require()
    meadow = make_meadow(settings, origin, size)
    info = lib.meadow_info(meadow)
    n = info["chunk_instances"]
    memory = budget.check_meadow(info["tile_count"], n, info["blade_count"])  # Blender's too
    origins = np.empty(n * 3, np.float32)
    chunk = np.empty(n, np.int32)
    lib.meadow_chunk_instances(meadow, origins, chunk)
    return dict(info=info, origins=origins.reshape(-1, 3), chunk=chunk, memory=memory)


PATCH_SUFFIX = " patch"


def patch_name(obj):
    return compat.id_name(obj.name, PATCH_SUFFIX)


def _owned_patch(obj):
    """The meadow's patch collection if it has one (owned by its key: a duplicated meadow's
    modifier still instances its original's), else None."""
    mod = obj.modifiers.get(MODIFIER)
    coll = None
    if mod is not None and mod.node_group is not None:
        try:
            coll = compat.get_modifier_input(mod, "Chunks")
        except KeyError:  # not Tussock's node group
            coll = None
    if coll is None:
        coll = bpy.data.collections.get(patch_name(obj))
    if coll is None:
        return None
    old = coll.name[:-len(PATCH_SUFFIX)] if coll.name.endswith(PATCH_SUFFIX) else None
    return coll if identity.adopt(obj, coll, old) else None


def follow_name(obj):
    """Renames the meadow's patch collection and its chunk objects after the meadow if it
    was renamed; returns the collection, or None if the meadow has none."""
    coll = _owned_patch(obj)
    name = patch_name(obj)
    if coll is None or coll.name == name or bpy.data.collections.get(name) is not None:
        return coll  # (a name someone else's collection has: kept as it is)
    coll.name = name
    for o in coll.objects:  # one rename per chunk object (the patch's blades / chunk_blades)
        index = o.name.rpartition(" chunk ")[2][:5]
        if index.isdigit():
            o.name = chunk_data.chunk_object_name(obj.name, int(index))
            if o.data is not None and o.data.users == 1:
                o.data.name = o.name
    return coll


def patch_collection(obj):
    """The meadow's patch collection (see follow_name), made if it has none."""
    coll = follow_name(obj)
    if coll is None:
        coll = bpy.data.collections.new(patch_name(obj))
        coll[identity.OWNER] = identity.key(obj)
    return coll


def compute(settings, origin, size, obj=None):
    """Native work of a meadow (patch only when `obj` has none for these settings)."""
    key = patch_key(settings)
    coll = _owned_patch(obj) if obj is not None else None
    patch = None
    if coll is None or obj.get("tussock_patch_key") != key or len(coll.objects) == 0:
        patch = compute_patch(settings)
    layout = compute_layout(settings, origin, size)
    return key, patch, layout


def viewport_off(settings, count):
    """Per chunk instance (count of them, in the meadow's order), whether the viewport leaves
    it out: all but a fraction `display` of them, drawn by the counter-based generator from
    the meadow's seed, so the simulated blades of a tile show in the viewport as its
    instances do (writer.write)."""
    r = np.empty(count, np.float32)
    if count:
        native.require().rand_fill(settings.seed, DISPLAY_STREAM, r)
    return r >= np.float32(settings.display)


def _give_viewport_off(skip):
    """Meadows made before tsk_viewport_off existed get it (the node group now reads it)."""
    for obj in bpy.data.objects:
        s = compat.settings_of(obj, "tussock_meadow")
        if (obj is skip or s is None or not s.is_meadow or obj.type != "MESH"
                or "tsk_viewport_off" in obj.data.attributes):
            continue
        chunk_data.write_viewport_off(obj.data, viewport_off(s, len(obj.data.vertices)))
        obj.data.update()


def write(obj, settings, key, patch, layout):
    """Writes computed meadow data into the object, its patch collection and modifier."""
    steps = write_steps(obj, settings, key, patch, layout)
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value


def write_steps(obj, settings, key, patch, layout):
    """write(), yielding (chunks made, chunks in all) while it builds the patch's chunk
    objects, the long part of a large meadow; returns the layout's info."""
    meshes.refuse_edit_mode(obj, "rebuilding the meadow")
    if patch is not None:
        # the collection the chunks go into is the one the modifier gets: a duplicated
        # meadow's modifier still instances its original's patch, so looking it up again
        # would not find this new one and would make another, empty (its blades vanished)
        coll = patch_collection(obj)
        yield from chunk_data.build_chunks_steps(
            coll, obj.name, patch["positions"], patch["tris"], patch["uvs"],
            patch["blade_index"], patch["blade_rand"], patch["blade_count"],
            settings.chunk_blades, material.grass_material())
        obj["tussock_patch_key"] = key
    else:
        coll = patch_collection(obj)
    chunk_data.write_points(obj.data, layout["origins"], layout["chunk"],
                            viewport_off(settings, len(layout["chunk"])))
    mod = obj.modifiers.get(MODIFIER)
    if mod is None:
        mod = obj.modifiers.new(MODIFIER, "NODES")
    group = meadow_nodes.meadow_group()
    if mod.node_group is not group:
        mod.node_group = group
    compat.set_modifier_input(mod, "Chunks", coll)
    _give_viewport_off(obj)
    info = layout["info"]
    obj["tussock_blades"] = int(info["blade_count"])
    obj["tussock_tiles"] = int(info["tile_count"])
    obj["tussock_instances"] = int(info["chunk_instances"])
    obj.update_tag()
    return info


_objects_seen = None  # the number of objects at the last look for joined meadows


def joined_meadows(changed=()):
    """Meadows whose mesh holds geometry that is not the meadow's own instance points: Join
    (Ctrl+J) with the meadow active puts the other objects' vertices, edges and faces into
    its mesh, and the meadow's modifier would then put a chunk of blades on every vertex (a
    leafy tree: millions of blades, 17 to 40 s a frame in a window). Looked at are the
    meadows whose geometry changed, of the data-blocks `changed` that a depsgraph update
    lists as (data-block, geometry changed), and all of them when the number of objects
    changed (a look with no update to read). The count alone misses a Join whose other
    object lives on, unlinked, because something still uses it: a meadow's ground, which
    its settings point to (soak seed 261014: that meadow was released only later, inside
    a cancelled Add Tree)."""
    global _objects_seen
    count = len(bpy.data.objects)
    geometry = {idb.as_pointer() for idb, geom in changed if geom}
    if count == _objects_seen and not geometry:
        return []
    everything = count != _objects_seen
    _objects_seen = count
    found = []
    for obj in identity.meadows():  # one per meadow object
        if obj.type != "MESH" or obj.library is not None or obj.mode == "EDIT" \
                or obj.modifiers.get(MODIFIER) is None:
            continue
        if not everything and obj.as_pointer() not in geometry \
                and obj.data.as_pointer() not in geometry:
            continue
        mesh = obj.data
        # (fewer points than instances is a meadow whose points were deleted in Edit Mode)
        if len(mesh.polygons) or len(mesh.edges) \
                or len(mesh.vertices) > obj.get("tussock_instances", len(mesh.vertices)):
            found.append(obj)
    return found


def _instanced(coll):
    """True when a meadow's modifier instances the collection (a copy shares its original's
    patch until it has one of its own)."""
    for obj in identity.meadows():  # one look per meadow
        mod = obj.modifiers.get(MODIFIER)
        if mod is not None and mod.node_group is not None:
            try:
                if compat.get_modifier_input(mod, "Chunks") == coll:
                    return True
            except KeyError:  # not Tussock's node group
                pass
    return False


def release_joined(obj):
    """A meadow joined with other objects becomes the plain mesh that Join made: no blades
    on its vertices, no simulation. The message says why and how to get the meadow back
    (Undo): printed here, and returned for the caller to report."""
    patch = _owned_patch(obj)
    mod = obj.modifiers.get(MODIFIER)
    if mod is not None:
        obj.modifiers.remove(mod)
    if patch is not None and not _instanced(patch):
        # removed here rather than left to the sync's tidy, which waits for a collection
        # with no users: Blender 5.2 still counts one after the modifier is removed
        for o in list(patch.objects):
            if len(o.users_collection) == 1:
                meshes.remove_object(o)
        bpy.data.collections.remove(patch)
    obj.tussock_meadow.is_meadow = False
    for key in ("tussock_blades", "tussock_tiles", "tussock_instances"):
        if key in obj:
            del obj[key]
    text = (f"Tussock: '{obj.name}' is no longer a meadow: it was joined with other objects, "
            "and its blades would grow on each of their vertices. Undo (Ctrl+Z) brings the "
            "meadow back; to place objects on a meadow, keep them separate objects")
    print(text, file=sys.stderr)
    return text


def rebuild_stale():
    """Rebuilds the local meadows whose blade models are no longer the ones they were built
    from (a model deleted, added, moved to another collection or edited), at once: a meadow
    left stale would be rebuilt by whatever next asked for its patch (a frame of its
    simulation, a bake), which then changed the scene as a side effect, even when it
    failed (soak seed 363588). Runs when objects were made or removed, a collection
    changed, or a model's mesh was edited; a meadow still being made has no patch key yet.
    True when a meadow was rebuilt: its old patch may now be its original's, unused, which
    the caller's sync then tidies at once rather than at the next object made or removed."""
    rebuilt = False
    for obj in identity.meadows():  # one check per meadow (its models' digest is kept)
        key = obj.get("tussock_patch_key")
        if obj.library is not None or key is None:
            continue
        s = obj.tussock_meadow
        try:
            if key == patch_key(s):  # (raises while a model is in Edit Mode)
                continue
            rebuild(obj)
            rebuilt = True
            error = ""
        except (native.Error, ValueError) as exc:
            error = str(exc)
        if s.last_error != error:  # (each write is one more depsgraph update)
            s.last_error = error
    return rebuilt


def rebuild_growing(blades):
    """Rebuilds the local meadows that grow any of the blade objects `blades` (after Refine
    changed their models), so that their instances and simulation use the new models; a
    meadow that cannot be rebuilt keeps its last good state and shows why."""
    changed = {o.as_pointer() for o in blades}
    for obj in identity.meadows():  # one check per meadow
        if obj.library is not None:
            continue
        s = obj.tussock_meadow
        coll = s.models or bpy.data.collections.get(BLADES_COLLECTION)
        if coll is None or not any(o.as_pointer() in changed for o in coll.objects):
            continue
        try:
            rebuild(obj)
        except (native.Error, ValueError) as exc:
            s.last_error = str(exc)
        else:
            s.last_error = ""


def area_of(obj, settings):
    if settings.ground is not None:
        return ground_area(settings.ground)
    return tuple(obj["tussock_origin"]), tuple(obj["tussock_size"])


def rebuild(obj):
    """Recomputes the meadow of `obj` from its settings and writes it into Blender; the
    native work raises before anything in the scene changes."""
    settings = obj.tussock_meadow
    meshes.refuse_edit_mode(obj, "rebuilding the meadow")  # before the native work
    origin, size = area_of(obj, settings)
    key, patch, layout = compute(settings, origin, size, obj)
    return write(obj, settings, key, patch, layout)
