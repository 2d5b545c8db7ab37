"""The mesh writer: the simulated blades of a meadow's Playback into its chunk objects
(blade_objects.py), and the meadow's instances of simulated tiles hidden (tsk_hidden).

The meadow's Viewport display applies to simulated blades as to its instances: the blades of
the chunk instances the viewport shows (build.viewport_off) go into the dynamic meshes shown
in the viewport, the others into render chunks, objects disabled in the viewport (so Blender
does not evaluate them there) that renders show. Every blade is written every frame, so a
render of any frame shows them all. What the writer keeps between frames is its Output,
one per Playback (Playback.output)."""

from types import SimpleNamespace

import bpy
import numpy as np

from .. import compat, meshes, native
from . import blade_objects, build, identity, material, playback

CAPACITY_BLOCK = 256  # a dynamic mesh has room for a whole number of blocks of blades;
                      # it grows by half at least and shrinks below a quarter full, so that
                      # its topology changes seldom while tiles come and go (rebuilding a
                      # chunk costs far more than writing it)
FIT_AFTER_FRAMES = 4  # but every vertex of the room costs Blender each frame, used or not:
                      # once the active tiles have held this many frames, a chunk with more
                      # than an eighth of its room unused is rebuilt to fit (blade_playback:
                      # growth alone can leave much of the room unused, at a cost every frame)
CHUNK_MIN_BLADES = 1024  # fewer blades than this per chunk: fewer chunks are used


class Output:
    """What the writer keeps of one Playback between frames."""

    def __init__(self, pb):
        # the dynamic meshes' fixed texture space: the meadow's ground, a metre high
        origin, size = pb.area
        self.texture_space = (origin, origin + np.array([size[0], size[1], 1.0]))
        self.written = None  # active tiles last written into the dynamic mesh (bytes)
        self.steady = 0  # writes since the active tiles last changed
        self.held = {}  # chunk key -> what its mesh holds: _COLLAPSED, or the room (in
                        # blades) this playback last wrote it with
        self.buf = None  # one chunk's vertex positions, float32; every chunk is written
                         # through it in turn (see _write_chunk)
        self.ribbon = None  # (widths, sides) of the written tiles, one row per blade
        self.rand = None  # colour value of each written blade
        self.hidden = None  # per instance: is its tile simulated
        self.viewport_key = None  # (seed, display, instances) the plan was made for
        self.plan = None  # per chunk object key: the part of the active blades it shows
        self.stats = {}  # active tiles and blades last written (the meadow's properties)


def output_of(pb):
    """The writer's state of Playback `pb`, made at the first call."""
    if pb.output is None:
        pb.output = Output(pb)
    return pb.output


def layout_replaced(pb):
    """The chunks no longer hold what this playback last wrote (a bake's layout was put in):
    the next write sets them afresh."""
    if pb.output is not None:
        pb.output.written = None


def ribbon_topology(mesh, blades, k):
    """(Re)builds `mesh` for `blades` ribbons of k knots: one quad per segment (the same
    diagonal as the instanced blades' triangles when rendered), the point attributes tsk_v
    (knot / (k - 1): 0 at the root, 1 at the tip; the material reads it where instanced
    blades have their UV map's v, since a UV map, one value per face corner, would cost
    Blender about a tenth more work per frame) and tsk_blade_rand. Positions are set
    apart."""
    lib = native.require()
    mesh.clear_geometry()
    tris = np.empty(blades * 6 * (k - 1), np.int32)
    lib.blade_indices(k, blades, tris)
    # triangles (v, v+1, v+3), (v, v+3, v+2) -> quad (v, v+1, v+3, v+2)
    t = tris.reshape(-1, 6)
    quads = np.ascontiguousarray(np.stack([t[:, 0], t[:, 1], t[:, 2], t[:, 5]], axis=1)).ravel()
    mesh.vertices.add(blades * 2 * k)
    meshes.set_faces(mesh, quads.reshape(-1, 4))
    nq = quads.size // 4
    mesh.polygons.foreach_set("use_smooth", np.ones(nq, bool))
    v = np.repeat(np.arange(k, dtype=np.float32) / (k - 1), 2)
    mesh.attributes.new("tsk_v", "FLOAT", "POINT").data.foreach_set("value", np.tile(v, blades))
    mesh.attributes.new("tsk_blade_rand", "FLOAT", "POINT")
    grass = material.grass_material()  # (brought up to date if an older Tussock made it)
    if len(mesh.materials) == 0:
        mesh.materials.append(grass)
    mesh.update()


def set_blade_rand(mesh, rand, k):
    """Per-blade colour variation (one value per blade) onto the ribbon vertices."""
    vrand = np.zeros(len(mesh.vertices), np.float32)
    vrand[:len(rand) * 2 * k] = np.repeat(rand, 2 * k)
    mesh.attributes["tsk_blade_rand"].data.foreach_set("value", vrand)


_hidden_written = identity.PerMeadow()  # meadow key -> (points serial, the hidden array written)


def set_hidden(obj, hidden):
    """Sets the meadow's point attribute tsk_hidden (instances not drawn) if it differs.
    The same array already written into the same points (chunks.write_points counts them
    in tussock_points_serial) is not read back: that was a copy of every point per frame."""
    mesh = obj.data
    if mesh.library is not None:
        return  # a linked meadow's points are its library's: Blender ignores writes to them
    which = identity.key(obj)
    serial = mesh.get("tussock_points_serial")
    last = _hidden_written.get(which)
    if serial is not None and last is not None and last[0] == serial and last[1] is hidden:
        return
    attr = mesh.attributes.get("tsk_hidden")
    if attr is None or len(attr.data) != len(hidden):
        return
    current = np.empty(len(hidden), bool)
    attr.data.foreach_get("value", current)
    if not np.array_equal(current, hidden):
        attr.data.foreach_set("value", np.ascontiguousarray(hidden, bool))
        mesh.update()
    _hidden_written[which] = (serial, hidden)


_COLLAPSED = "collapsed"  # Output.held[i] of a chunk whose blades are all collapsed


def left_in_edit_mode(child, out=None, i=None):
    """True when the artist has put chunk `child` (out.held key i) in Edit Mode: it is left
    as it is (vertices cannot be added there, and leaving Edit Mode writes Blender's edit
    copy back over whatever was written meanwhile), and marked so that the first write
    after Edit Mode rebuilds it whole, whatever was done to it there."""
    if not meshes.in_edit_mode(child):
        return False
    if child.data.get("tussock_layout") != "edited":
        child.data["tussock_layout"] = "edited"
    if out is not None:
        out.held.pop(i, None)
    return True


def _collapse(child, out=None, i=None):
    """Shows no blade in a chunk: every vertex at the origin (zero-area quads, which render
    nothing). Its topology stays: clearing a mesh to no vertices mid-playback makes
    Blender's rigid-body world take another path (test_sim's snapshot test)."""
    if out is not None and out.held.get(i) == _COLLAPSED:
        return  # already collapsed by this playback
    if left_in_edit_mode(child, out, i):
        return
    mesh = child.data
    n = len(mesh.vertices) * 3
    if n:
        co = np.empty(n, np.float32)
        compat.get_positions(mesh, co)
        if co.any():
            compat.set_positions(mesh, np.zeros(n, np.float32))
            mesh.update()
    if out is not None:
        out.held[i] = _COLLAPSED  # the next write sets this chunk's blades afresh


def empty_extra_chunks(obj):
    """Leaves only the first chunk with blades (a bake's layout lives there alone)."""
    pb = playback.playback_of(obj)
    out = pb.output if pb is not None else None
    for i, child in enumerate(blade_objects.extra_chunks(obj), start=1):
        _collapse(child, out, i)
    for i, child in enumerate(blade_objects.render_chunks(obj)):
        _collapse(child, out, ("render", i))


def chunk_ranges(nb):
    """The active blades of each chunk, as ranges in order: nearly equal parts over as many
    chunks as have CHUNK_MIN_BLADES each (at least one), empty ranges for the rest."""
    chunks = blade_objects.CHUNKS
    used = max(1, min(chunks, nb // CHUNK_MIN_BLADES))
    return [range(i * nb // used, (i + 1) * nb // used) if i < used else range(nb, nb)
            for i in range(chunks)]


def active_ribbons(obj):
    """Ribbon vertex positions of the active simulated blades, in the solver's order, read
    back from the chunks that show them in the viewport and the render chunks (float32,
    2 * K * 3 per blade); each chunk's spare room must be zero."""
    pb = playback.playback_of(obj)
    state = pb.output if pb is not None else None
    nb = int(state.stats.get("tussock_active_blades", 0)) if state is not None else 0
    if nb == 0 or not state.plan:
        return np.zeros(0, np.float32)
    per = 2 * pb.runner.K * 3
    out = np.zeros((nb, per), np.float32)
    got = np.zeros(nb, np.int32)
    for key, part in state.plan.items():
        child = bpy.data.objects.get(identity.chunk_name(obj, key))
        v = np.zeros(0, np.float32)
        if child is not None:
            v = np.empty(len(child.data.vertices) * 3, np.float32)
            compat.get_positions(child.data, v)
        n = len(part.index) * per
        if len(v) < n or v[n:].any():
            raise AssertionError(
                f"{key}: the chunk does not hold exactly its {len(part.index)} blades")
        out[part.index] = v[:n].reshape(-1, per)
        got[part.index] += 1
    if not np.all(got == 1):
        raise AssertionError("the chunks do not hold every active blade exactly once")
    return out.ravel()


def viewport_shown(pb, tiles, counts, viewport_off):
    """Per active blade (the solver's order): is it shown in the viewport, i.e. is its chunk
    instance (tsk_meadow_chunk_instances: tile by tile, a tile's blades C at a time) one
    that the viewport shows."""
    c = pb.chunk_blades
    per_tile = counts // c
    first = np.searchsorted(pb.instance_tile, tiles)  # each active tile's first instance
    instance = (np.repeat(first - (np.cumsum(per_tile) - per_tile), per_tile)
                + np.arange(int(per_tile.sum())))
    return np.repeat(~viewport_off[instance], c)


def _part(out, index):
    """What a chunk object holds: the active blades `index` (ascending) as runs for
    blade_sim_ribbon_runs, with their widths, sides and colour values."""
    index = np.asarray(index, np.int64)
    if len(index):
        breaks = np.flatnonzero(np.diff(index) != 1) + 1
        starts = index[np.concatenate(([0], breaks))]
        ends = index[np.concatenate((breaks - 1, [len(index) - 1]))] + 1
    else:
        starts = ends = np.zeros(0, np.int64)
    return SimpleNamespace(index=index, starts=np.ascontiguousarray(starts),
                           counts=np.ascontiguousarray(ends - starts),
                           widths=np.ascontiguousarray(out.ribbon[0][index]).ravel(),
                           sides=np.ascontiguousarray(out.ribbon[1][index]).ravel(),
                           rand=out.rand[index])


def make_plan(out, shown):
    """Chunk object key -> part: the blades shown in the viewport shared evenly among the
    CHUNKS chunk objects (keys 0 ..), the others among as many render chunks (keys
    ("render", i)). With every blade shown, chunk i holds chunk_ranges(nb)[i]."""
    plan = {}
    for which, seq in ((None, np.flatnonzero(shown)), ("render", np.flatnonzero(~shown))):
        for i, r in enumerate(chunk_ranges(len(seq))):
            key = i if which is None else (which, i)
            if which is None or len(r):
                plan[key] = _part(out, seq[r.start:r.stop])
    return plan


def chunk_capacity(capacity, nb, fit=False):
    """Room (in blades) of a chunk's mesh holding nb blades, given its room now: whole
    CAPACITY_BLOCKs, grown by half at least when too small, shrunk to fit when under a
    quarter full, and when `fit` (the active tiles have held FIT_AFTER_FRAMES) to fit if
    more than an eighth of it is unused."""
    def blocks(n):
        return max(1, -(-n // CAPACITY_BLOCK)) * CAPACITY_BLOCK
    if not capacity or nb > capacity:
        return blocks(max(nb, capacity * 3 // 2))
    if nb < capacity // 4 or (fit and blocks(nb) < capacity - capacity // 8):
        return blocks(nb)
    return capacity


def _write_chunk(child, pb, out, i, part, k, layout_changed, fit=False):
    """Writes the active blades of `part` (make_plan) into chunk `child` (out.held key i);
    `fit`: see chunk_capacity."""
    if left_in_edit_mode(child, out, i):
        return
    mesh = child.data
    nb = len(part.index) if part is not None else 0
    if nb == 0 and mesh.get("tussock_layout") == "live":
        _collapse(child, out, i)  # written once: an unchanged mesh costs Blender nothing
        return
    capacity = chunk_capacity(mesh.get("tussock_capacity") or 0, nb, fit)
    fresh = (mesh.get("tussock_layout") != "live" or mesh.get("tussock_capacity") != capacity
             or len(mesh.vertices) != capacity * 2 * k)
    if fresh:
        ribbon_topology(mesh, capacity, k)
        mesh["tussock_layout"] = "live"
        mesh["tussock_capacity"] = capacity
    if fresh or layout_changed or out.held.get(i) != capacity:
        # (a new Playback, e.g. after the meadow's ground moved, brings its own box)
        meshes.fix_texture_space(mesh, *out.texture_space)
        set_blade_rand(mesh, part.rand if nb else np.zeros(0, np.float32), k)
        out.held[i] = capacity
    # The chunks share one buffer: it is still in the cache when the next chunk is written,
    # where a buffer per chunk comes back from memory every frame, since Blender's evaluation
    # of the meshes in between goes through far more memory than the cache holds
    # (docs/performance.md, "Blade playback in Blender").
    n, used = capacity * 2 * k * 3, nb * 2 * k * 3
    if out.buf is None or len(out.buf) < n:
        out.buf = np.empty(n, np.float32)
    pos = out.buf[:n]
    if nb:
        pb.runner.lib.blade_sim_ribbon_runs(pb.runner.sim, part.starts, part.counts,
                                            part.widths, part.sides, pos[:used])
    pos[used:] = 0.0  # the chunk's unused room: zero-area quads at the origin
    compat.set_positions(mesh, pos)
    mesh.update()


def write(obj, pb):
    """Writes the simulated blades into the meadow's dynamic meshes and hides the instances
    of their tiles. The blades the meadow's Viewport display shows are shared evenly among
    CHUNKS objects, which Blender evaluates in parallel; the others go into render chunks
    (see the module's docstring). Per frame only vertex positions change; a chunk's
    topology, the per-blade colour and the hidden instances change only when the set of
    active tiles, or the viewport's share, does. Unused blade slots collapse to zero-area
    quads."""
    r = pb.runner
    out = output_of(pb)
    k = r.K
    s = obj.tussock_meadow
    tiles, counts = r.active()
    nb = int(counts.sum())
    layout = tiles.tobytes()
    layout_changed = out.written != layout
    out.steady = 0 if layout_changed else out.steady + 1
    if layout_changed:
        out.written = layout
        out.hidden = np.isin(pb.instance_tile, tiles)
        out.rand = r.per_blade(tiles, 2)
        out.ribbon = tuple(np.ascontiguousarray(r.per_blade(tiles, w).reshape(nb, -1))
                           if nb else r.per_blade(tiles, w).reshape(0, k if w == 0 else 3)
                           for w in (0, 1))
    viewport_key = (s.seed, float(s.display), len(pb.instance_tile))
    if layout_changed or out.viewport_key != viewport_key or out.plan is None:
        off = build.viewport_off(s, len(pb.instance_tile))
        out.plan = make_plan(out, viewport_shown(pb, tiles, counts, off))
        out.viewport_key = viewport_key
        layout_changed = True  # chunks hold other blades: their colours too
    set_hidden(obj, out.hidden)  # (checked every frame: rebuilding the meadow clears it)
    fit = out.steady == FIT_AFTER_FRAMES
    chunks = blade_objects.CHUNKS
    for i in range(chunks):
        _write_chunk(blade_objects.chunk_object(obj, i), pb, out, i, out.plan.get(i), k,
                     layout_changed, fit)
    made = len(blade_objects.render_chunks(obj))
    for i in range(max(chunks, made)):
        part = out.plan.get(("render", i))
        if part is None and i >= made:
            continue  # render chunks are made only when there is something to show
        child = blade_objects.render_chunk_object(obj, i)
        if i >= chunks:
            _collapse(child, out, ("render", i))  # of a larger CHUNKS: unused
        else:
            _write_chunk(child, pb, out, ("render", i), part, k, layout_changed, fit)
    for i, child in enumerate(blade_objects.extra_chunks(obj)[chunks - 1:], start=chunks):
        _collapse(child, out, i)  # chunks of a larger CHUNKS: unused
    out.stats = dict(tussock_active_tiles=len(tiles), tussock_active_blades=nb,
                     tussock_viewport_blades=int(sum(len(p.index) for key, p in out.plan.items()
                                                     if not isinstance(key, tuple))))
    if obj.library is None:  # (a linked meadow's properties are its library's)
        for name, value in out.stats.items():
            obj[name] = value


forget = _hidden_written.forget  # (obj=None): what was written into tsk_hidden, of obj or all
keep_only = _hidden_written.keep_only
