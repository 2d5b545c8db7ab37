"""A tree's Blender mesh from its Weber-Penn definition, and its pose at a frame.

The native tree (branches as Bézier segments) is kept per object in a cache keyed by the
definition, so a frame change only bends branches and writes vertex positions. The pose
of a frame depends only on that frame's wind (exact mode of seed 001 §4: children sit on
the moved parent), so scrubbing, jumping and farm frame splits all agree."""

import json
import uuid

import bpy
import numpy as np

from .. import budget, compat, meshes, native
from ..wind import runtime as wind_runtime
from . import materials, params

_cache = {}  # object name -> dict(key, tree, rest_tips, smooth, cage_vertices, ...)


def definition(settings):
    d = params.to_dict(settings.params)
    d["seed"] = int(settings.seed)
    if not settings.leaves:
        d["leaves"] = 0
    return d


def _key(d, settings):
    return json.dumps(d, sort_keys=True) + f"|{settings.smooth_levels}"


def compute(settings):
    """Native work for a tree: generate, mesh topology. No Blender data touched. The rest
    pose is left to rest_positions(): Blender gets the tree posed (write_posed)."""
    d = definition(settings)
    return compute_from(d, settings.smooth_levels, _key(d, settings), rest=False)


def native_tree(d, smooth_levels):
    """The native tree of definition `d`, its mesh checked against the memory budget: what
    makes compute_from fail for `d` fails here, before a mesh or OpenSubdiv is made."""
    lib = native.require()
    tree = lib.tree_create(d)
    nv, nq = lib.tree_mesh_count(tree, leaves=True)
    cage_v, cage_q = lib.tree_mesh_count(tree, leaves=False) if smooth_levels > 0 else (nv, nq)
    budget.check_tree(nv, nq, cage_v, cage_q, smooth_levels)
    return tree


def compute_from(d, smooth_levels, key="", rest=True, tree=None):
    """compute() from plain values (usable off the main thread); `rest`: deform the rest
    pose into data["positions"] now (else on demand, rest_positions()); `tree`: d's tree
    from native_tree(), else made here."""
    lib = native.require()
    if tree is None:
        tree = native_tree(d, smooth_levels)
    counts = lib.tree_counts(tree)
    nv, nq = lib.tree_mesh_count(tree, leaves=True)
    cage_v, cage_q = lib.tree_mesh_count(tree, leaves=False) if smooth_levels > 0 else (nv, nq)
    faces = np.empty(nq * 4, np.int32)
    uvs = np.empty(nq * 8, np.float32)
    lib.tree_mesh_topology(tree, faces, uvs, leaves=True)
    edges, corner_edges = np.empty(nq * 8, np.int32), np.empty(nq * 4, np.int32)
    ne = lib.tree_mesh_edges(tree, edges, corner_edges, leaves=True)
    positions = np.empty(nv * 3, np.float32)
    if rest:
        lib.tree_mesh_deform(tree, positions, leaves=True)
    leaf_quads = counts["leaves"]
    data = dict(key=key, tree=tree, counts=counts, faces=faces.reshape(-1, 4),
                uvs=uvs, positions=positions, leaf_quads=leaf_quads, smooth=None,
                edges=(ne, edges, corner_edges), rest_ready=rest)
    tips = np.empty(counts["branches"] * 3, np.float32)
    lib.tree_tips(tree, tips)
    data["rest_tips"] = tips.reshape(-1, 3)
    if smooth_levels > 0:
        h = lib.subdiv_create(np.ascontiguousarray(faces[:cage_q * 4]), cage_v, smooth_levels)
        sv, sq = lib.subdiv_counts(h)
        sfaces = np.empty(sq * 4, np.int32)
        lib.subdiv_faces(h, sfaces)
        data["smooth"] = dict(handle=h, cage_vertices=cage_v, cage_quads=cage_q,
                              vertices=sv, faces=sfaces.reshape(-1, 4))
    return data


def rest_positions(data):
    """The tree's rest pose, cage vertices (float32, 3 per vertex), deformed on first use."""
    if not data["rest_ready"]:
        lib = native.require()
        lib.tree_reset(data["tree"])
        lib.tree_mesh_deform(data["tree"], data["positions"], leaves=True)
        data["rest_ready"] = True
    return data["positions"]


def _topology(data):
    """(quads (Q, 4), uvs per corner or None, edges for meshes.set_faces or None) of the
    mesh, with the smoothed branches when the tree is smooth."""
    if data["smooth"] is None:
        return data["faces"], data["uvs"], data["edges"]
    s = data["smooth"]
    leaf_faces = data["faces"][s["cage_quads"]:] - s["cage_vertices"] + s["vertices"]
    return np.concatenate([s["faces"], leaf_faces]), None, None


def _vertices(data, positions):
    """Mesh vertex positions (V, 3) for cage `positions`, refined when the tree is smooth."""
    if data["smooth"] is None:
        return positions.reshape(-1, 3)
    lib = native.require()
    s = data["smooth"]
    cage = np.ascontiguousarray(positions[:s["cage_vertices"] * 3])
    refined = np.empty(s["vertices"] * 3, np.float32)
    lib.subdiv_apply(s["handle"], cage, refined)
    leaves_pos = positions[s["cage_vertices"] * 3:].reshape(-1, 3)
    return np.concatenate([refined.reshape(-1, 3), leaves_pos])


NOT_OWNED = ("the tree's mesh was changed outside Tussock (joined with another object, "
             "edited, or another mesh given to the tree): Tussock leaves it as it is and no "
             "longer animates it. Undo that change to animate the tree again, or add a new "
             "tree")


def owns_mesh(obj):
    """True when obj's mesh is the one Tussock last wrote for this tree, so that writing it
    loses nothing of the artist's: a new empty mesh, or one carrying the tree's stamp
    (`tussock_tree` on the mesh equal to the object's `tussock_tree_id`; a mesh given by
    another object has another or none) with the vertex count Tussock wrote (joining a rock
    into the tree or adding geometry in Edit Mode changes it). Trees saved before the stamp
    existed are recognised by their vertex count alone."""
    mesh = obj.data
    if mesh is None:
        return False
    count = len(mesh.vertices)
    if count == 0 and len(mesh.polygons) == 0:
        return True
    if count != obj.get("tussock_vertices", -1):
        return False
    token = obj.get("tussock_tree_id")
    return mesh.get("tussock_tree") == token if token else "tussock_tree" not in mesh


def write(obj, data, positions=None, by_operator=False):
    """Replaces the object's mesh with the tree's (materials: bark 0, leaves 1), its vertices
    at `positions` (mesh vertices from posed_vertices) or else at rest. `by_operator`: the
    caller is an operator or a property update, not a frame handler (compat.shade_smooth).
    Raises ValueError (NOT_OWNED) and writes nothing when the mesh is not Tussock's to
    write (owns_mesh)."""
    meshes.refuse_edit_mode(obj, "growing the tree")
    if not owns_mesh(obj):
        raise ValueError(NOT_OWNED)
    quads, uvs, edges = _topology(data)
    verts = positions if positions is not None else _vertices(data, rest_positions(data))
    mesh = obj.data
    mesh.clear_geometry()
    mesh.vertices.add(len(verts))
    flat = np.ascontiguousarray(verts, np.float32).ravel()  # one float32 copy at most
    compat.set_positions(mesh, flat)
    nq = len(quads)
    meshes.set_faces(mesh, quads, edges)
    index = np.zeros(nq, np.int32)
    if data["leaf_quads"]:
        index[nq - data["leaf_quads"]:] = 1
        # the generic attribute (Blender >= 3.4) takes the array in one copy; the polygon
        # property goes face by face. Without leaves every face is bark, material 0, which
        # is what a mesh without the attribute means: no layer to fill and copy.
        attr = mesh.attributes.get("material_index")
        if attr is None:
            attr = mesh.attributes.new("material_index", "INT", "FACE")
        attr.data.foreach_set("value", index)
    # every face smooth: bark is round, and a leaf card is flat with four vertices of its
    # own, so its smooth normals are its face normal
    compat.shade_smooth(obj, by_operator)
    if uvs is not None:
        layer = mesh.uv_layers.new(name="UVMap", do_init=False)  # all set just below
        layer.data.foreach_set("uv", uvs)
    if len(verts):  # (numpy's min(axis=0) of (n, 3) took 9 ms for 250,000 vertices)
        try:
            lo, hi = native.require().vec3_bounds(flat)
            meshes.fix_texture_space(mesh, lo, hi)  # not redone per frame
        except native.Error:
            mesh.use_auto_texspace = True  # a non-finite vertex: never half a mesh for it
    mesh.update()
    if len(mesh.materials) == 0:
        mesh.materials.append(materials.bark())
        mesh.materials.append(materials.leaf())
    _cache[obj.name] = data
    obj["tussock_branches"] = int(data["counts"]["branches"])
    obj["tussock_leaves"] = int(data["counts"]["leaves"])
    obj["tussock_vertices"] = len(verts)
    token = obj.get("tussock_tree_id") or uuid.uuid4().hex  # survives renames and copies
    obj["tussock_tree_id"] = mesh["tussock_tree"] = token


def rebuild(obj):
    """Regrows the tree after a change in the panel or a preset (not from a frame handler)."""
    data = compute(obj.tussock_tree)
    write_posed(obj, data, bpy.context.scene, bpy.context.scene.frame_current, by_operator=True)


def _data(obj):
    """The cached native tree of obj, rebuilt after a file load or a change."""
    s = obj.tussock_tree
    data = _cache.get(obj.name)
    if data is None or data["key"] != _key(definition(s), s):
        data = compute(s)
        _cache[obj.name] = data
    return data


def posed_vertices(data, matrix_world, strength, wind_sample, out=None):
    """Vertex positions (V, 3) of the tree bent by the wind: `wind_sample(world_xyz)` gives
    the wind (m/s) at world points; the pose depends on nothing else (exact mode), so it is
    the same whatever frames came before. Pure: usable by a bake worker thread. `out`: a
    float32 buffer of len(data["positions"]) to deform into (the result may be a view of
    it), else a new one."""
    lib = native.require()
    tree = data["tree"]
    lib.tree_reset(tree)
    if strength > 0.0:
        # the wind at the rest tips, in world space, turned into the tree's local frame
        m = np.asarray(matrix_world, np.float64)
        tips_world = data["rest_tips"] @ m[:3, :3].T + m[:3, 3]
        vel = wind_sample(tips_world)
        force = np.ascontiguousarray(vel @ np.linalg.inv(m[:3, :3]).T, np.float32)
        lib.tree_wind_step(tree, force.ravel(), mode=1, strength=float(strength))
    positions = out if out is not None else np.empty(len(data["positions"]), np.float32)
    lib.tree_mesh_deform(tree, positions, leaves=True)
    return _vertices(data, positions)


def _posed(obj, data, scene, frame, matrix_world):
    s = obj.tussock_tree
    # one buffer per tree, reused every frame (no fresh pages to fault in)
    buffer = data.get("pose_buffer")
    if buffer is None:
        buffer = data["pose_buffer"] = np.empty(len(data["positions"]), np.float32)
    return posed_vertices(data, matrix_world, s.wind_strength,
                          lambda xyz: wind_runtime.sample(scene, frame, xyz), out=buffer)


def pose(obj, scene, frame):
    """Bends the tree by the scene's wind at `frame` and writes the vertex positions."""
    meshes.refuse_edit_mode(obj, "the tree's swaying")
    if not owns_mesh(obj):
        raise ValueError(NOT_OWNED)
    data = _data(obj)
    verts = _posed(obj, data, scene, frame, obj.matrix_world)
    mesh = obj.data
    if len(mesh.vertices) != len(verts):  # the tree itself changed (its settings)
        write(obj, data, verts)
        return
    compat.set_positions(mesh, verts.ravel() if verts.dtype == np.float32
                         and verts.flags.c_contiguous else
                         np.ascontiguousarray(verts, np.float32).ravel())
    mesh.update()


def write_posed(obj, data, scene, frame, matrix_world=None, by_operator=False):
    """Writes the tree's mesh already bent by the wind at `frame`: one deform and one copy
    of the vertices, not a rest mesh then a pose. `matrix_world`: where the tree stands
    when the object is not evaluated yet (a new object: its matrix_basis); else its
    evaluated matrix_world."""
    m = obj.matrix_world if matrix_world is None else matrix_world
    write(obj, data, _posed(obj, data, scene, frame, m), by_operator)


def forget(name=None):
    if name is None:
        _cache.clear()
    else:
        _cache.pop(name, None)
