"""The objects that hold a meadow's simulated blades: CHUNKS dynamic-mesh objects shown in the
viewport and as many render chunks (disabled in the viewport, rendered), children of the
first, all owned by the meadow (identity.OWNER) and named after it (identity.chunk_name).
They follow the meadow's renames, go to the right meadow when copied with it, and go with
it when it is deleted. What they hold is the mesh writer's (writer.py)."""

import bpy

from .. import compat, meshes
from . import build, identity

CHUNKS = 4  # dynamic-mesh objects the simulated blades are shared among, evenly: Blender
            # evaluates separate objects on separate threads, and re-evaluating one
            # 655,000-vertex mesh per frame was most of a frame (docs/performance.md,
            # blade_playback). They are made together, when simulation is switched on:
            # adding an object mid-playback resets Blender's rigid-body cache, which changes
            # the path of a ball that Bullet rolls.


def _in_the_way(name):
    return ValueError(f"an object named '{name}' that is not this meadow's simulated blades "
                      f"is in the way: rename it")


def _mesh_object(name, meadow, beside):
    """The mesh object `name`, made if missing in the local collections of object `beside`
    (else in the scene's); owned by the meadow (identity.OWNER). (users_collection walks
    every collection: only when made.)"""
    child = bpy.data.objects.get(name)
    made = child is None
    if made:
        child = bpy.data.objects.new(name, bpy.data.meshes.new(name))
        colls = [c for c in beside.users_collection if getattr(c, "library", None) is None]
        for coll in colls or [bpy.context.scene.collection]:
            coll.objects.link(child)
        child[identity.OWNER] = identity.key(meadow)
        child["tussock_meadow_name"] = meadow.name
    elif child.type != "MESH" or not identity.adopt(meadow, child,
                                                    child.get("tussock_meadow_name")):
        raise _in_the_way(name)  # someone else's object: never overwrite it
    return child, made


def role_of(child):
    """The chunk key (see chunk_name) of one of a meadow's simulated-blade objects."""
    if child.get("tussock_simulated_blades"):
        return 0
    if "tussock_blades_render_chunk" in child:
        return ("render", int(child["tussock_blades_render_chunk"]))
    return int(child.get("tussock_blades_chunk", -1))


def follow_name(obj):
    """Renames the meadow's simulated-blade objects (and their meshes) after the meadow, if
    it was renamed since they were named; returns the first chunk, or None if there is none.
    The blades objects are found by their owner (one walk over the file's objects, only
    when the first chunk is not found under the meadow's name)."""
    first = bpy.data.objects.get(identity.chunk_name(obj, 0))
    if first is not None and identity.adopt(obj, first, first.get("tussock_meadow_name")):
        return first
    k = identity.key(obj)
    own = [o for o in bpy.data.objects if o.get(identity.OWNER) == k and role_of(o) != -1]
    if not own:
        if first is not None:
            raise _in_the_way(first.name)
        return None
    wanted = {o: identity.chunk_name(obj, role_of(o)) for o in own}
    for o, name in wanted.items():
        other = bpy.data.objects.get(name)
        if other is not None and other not in wanted:
            raise _in_the_way(name)
    for o in own:  # first out of the way (names may swap among them), then the new names
        o.name = o.name + " (renamed)"
    for o, name in wanted.items():
        o.name = name
        o["tussock_meadow_name"] = obj.name
        if o.data is not None and o.data.users == 1:
            o.data.name = name
    if obj.library is None:
        build.follow_name(obj)  # and the patch collection with its chunk objects
    return next((o for o in own if role_of(o) == 0), None)


def blades_object(obj):
    """The meadow's dynamic mesh of simulated blades (created once): its first chunk, the
    one a bake writes."""
    child = follow_name(obj)
    if child is not None:
        return child
    child, made = _mesh_object(identity.chunk_name(obj, 0), obj, obj)
    if made:
        child["tussock_simulated_blades"] = True
    return child


def find_blades_object(obj):
    """The meadow's first chunk if it exists (after a rename too), else None; makes nothing."""
    return follow_name(obj)


def chunk_object(obj, i):
    """Chunk i of the meadow's simulated blades: 0 is blades_object(); the others are
    children of the first (the outliner groups them; the first stays at the origin), shown
    and rendered as it is."""
    first = blades_object(obj)
    if i == 0:
        return first
    child, made = _mesh_object(identity.chunk_name(obj, i), obj, first)
    if made:
        child.parent = first
        child["tussock_blades_chunk"] = i
    for prop in ("hide_render", "hide_viewport"):
        if getattr(child, prop) != getattr(first, prop):
            setattr(child, prop, getattr(first, prop))
    return child


def render_chunk_object(obj, i):
    """Render chunk i of the meadow's simulated blades: a child of the first chunk that is
    disabled in the viewport (Blender does not evaluate it there) and rendered as the first
    chunk is; it holds blades the meadow's Viewport display leaves out."""
    first = blades_object(obj)
    child, made = _mesh_object(identity.chunk_name(obj, ("render", i)), obj, first)
    if made:
        child.parent = first
        child["tussock_blades_render_chunk"] = i
    if not child.hide_viewport:
        child.hide_viewport = True
    if child.hide_render != first.hide_render:
        child.hide_render = first.hide_render
    return child


def render_chunks(obj):
    """The meadow's render chunk objects that exist, in order."""
    found = []
    while (child := bpy.data.objects.get(
            identity.chunk_name(obj, ("render", len(found))))) is not None:
        found.append(child)
    return found


def ensure_chunks(obj):
    """Makes every chunk object of the meadow now (see CHUNKS: not during playback)."""
    for i in range(CHUNKS):
        chunk_object(obj, i)
        render_chunk_object(obj, i)


def extra_chunks(obj):
    """The meadow's chunk objects after the first, in order."""
    found = []
    i = 1
    while (child := bpy.data.objects.get(identity.chunk_name(obj, i))) is not None:
        found.append(child)
        i += 1
    return found


OWN_TAGS = (identity.OWNER, "tussock_meadow_name", "tussock_simulated_blades",
            "tussock_blades_chunk", "tussock_blades_render_chunk")


def tidy_owned(live):
    """What meadows owned outlives them otherwise, frozen in the scene: the simulated-blade
    objects of a deleted meadow (identity.gone: one that was there, not one being made by
    Add Meadow) are removed, with its patch once nothing instances it. Copies
    of blade objects (Shift+D of a meadow with its blades) go to the meadow copied with them,
    one copy per chunk, renamed after it at the next frame; copies of blades alone (or
    sharing their mesh, Alt+D) become the artist's plain meshes, which Tussock never writes.
    Runs when objects were made or removed (one walk over the file's objects)."""
    groups = {}
    for o in bpy.data.objects:
        k = o.get(identity.OWNER)
        if k is not None and o.library is None and (role := role_of(o)) != -1:
            groups.setdefault((k, role), []).append(o)
    heirs = {}
    for fresh, old in identity.born.items():
        heirs.setdefault(old, []).append(fresh)
    taken = set(groups)
    for (k, role), objs in groups.items():
        if k not in live:
            if k in identity.gone:
                for o in objs:
                    meshes.remove_object(o)
            continue
        if len(objs) == 1:
            continue
        meadow = identity.find(k)
        name = identity.chunk_name(meadow, role) if meadow is not None else None
        objs.sort(key=lambda o: (o.name != name, o.name))  # the original holds the name
        for o in objs[1:]:
            heir = next((h for h in sorted(heirs.get(k, ()))
                         if (h, role) not in taken), None)
            if heir is not None and o.data is not None and o.data.users == 1:
                o[identity.OWNER] = heir
                taken.add((heir, role))
            else:
                for tag in OWN_TAGS:
                    if tag in o:
                        del o[tag]
    held = set()
    for coll in list(bpy.data.collections):
        k = coll.get(identity.OWNER)
        if k in identity.gone and coll.users == 0 and coll.library is None:
            for o in list(coll.objects):
                if len(o.users_collection) == 1:
                    meshes.remove_object(o)
            bpy.data.collections.remove(coll)
        elif k is not None:
            held.add(k)
    # a deleted meadow whose things are all removed needs no remembering (an undo that
    # brings it back brings its key back to the next scan); an artist who adds and deletes
    # meadows all day would otherwise grow this set without end
    identity.gone.intersection_update(held)
    for k in [k for k in _followed if k not in live]:
        del _followed[k]


_followed = {}  # meadow key -> the name its objects were last renamed after


def follow_renames(changed):
    """The simulated-blade objects and patch collections of renamed meadows take the new
    names (a rename updates the depsgraph, so this runs right after it; `changed`: (original
    data-block, geometry updated) of each of its updates)."""
    for obj, _geometry in changed:
        try:
            if not isinstance(obj, bpy.types.Object) or obj.library is not None:
                continue
        except ReferenceError:  # removed since the update
            continue
        s = compat.settings_of(obj, "tussock_meadow")
        if s is None or not s.is_meadow or obj.get(identity.ID) is None:
            continue
        which = identity.key(obj)
        if _followed.get(which) == obj.name:
            continue  # not renamed (a move, a setting): nothing to look for
        _followed[which] = obj.name
        try:
            follow_name(obj)
            build.follow_name(obj)
        except ValueError as exc:  # a name in the way: the panel says which
            if s.last_error != str(exc):  # (each write is one more depsgraph update)
                s.last_error = str(exc)


def forget():
    """Forgets which names the meadows' objects follow (a new file)."""
    _followed.clear()
