"""Faces into a Blender mesh, complete with their edges, in a few array copies.

Blender 3.4's Mesh.update() derives the edges of a mesh that has none with a hash of every
corner: for a 143,000-quad tree, most of the time of building it. The native library computes
the same edges in first-use order (tsk_mesh_edges), and the indices cross as uint32, the type
of these RNA properties, so foreach_set copies each array in one go (compat.mesh_indices)."""

import bpy
import numpy as np

from . import compat, handlers, native


def remove_object(obj):
    """Removes a mesh object Tussock made, and its mesh when nothing else uses it."""
    mesh = obj.data
    bpy.data.objects.remove(obj)
    if mesh is not None and mesh.users == 0:
        bpy.data.meshes.remove(mesh)


def refuse_edit_mode(obj, doing):
    """Raises ValueError when obj's mesh is in Edit Mode: there its geometry is Blender's
    edit copy (vertices cannot be added, attributes read as empty, and leaving Edit Mode
    writes the edit copy back over whatever was written meanwhile). `doing`: what waits for
    Object Mode, for the message."""
    if in_edit_mode(obj):
        raise ValueError(f"'{obj.name}' is in Edit Mode: {doing} waits for Object Mode "
                         "(press Tab); its mesh is left as it is until then")


def in_edit_mode(obj):
    return bool(getattr(getattr(obj, "data", None), "is_editmode", False))


def select_new(context, objs):
    """Makes objs, which an operator has just added, the selection, the first of them active.
    Leaves Edit Mode first, edits kept, as Blender's own Add operators do (ED_object_add_type):
    an object left in Edit Mode while another is active is a state Blender's interface never
    makes, and joining such an object into another leaks its edit mesh in Blender 4.3 and 5.2
    (soak seed 247497). Call it after everything that can fail."""
    active = context.view_layer.objects.active
    if active is not None and active.mode == "EDIT":
        bpy.ops.object.mode_set(mode="OBJECT")
    for o in context.selected_objects:
        o.select_set(False)
    for o in objs:
        o.select_set(True)
    context.view_layer.objects.active = objs[0]


_waiting = {}  # object name -> work(obj) to redo once the object is out of Edit Mode


def redo_after_edit_mode(obj, work):
    """Runs work(obj) once obj has left Edit Mode (polled by a timer, as Blender has no
    event for it), so that a setting changed in Edit Mode takes effect then."""
    _waiting[obj.name] = work
    handlers.add_timer(_poll_edit_mode, first_interval=0.5)


def _poll_edit_mode():
    for name, work in list(_waiting.items()):
        obj = bpy.data.objects.get(name)
        if obj is not None and in_edit_mode(obj):
            continue
        del _waiting[name]
        if obj is not None:
            work(obj)
    return 0.5 if _waiting else None


def set_faces(mesh, faces, edges=None):
    """Adds `faces` ((F, k) vertex indices, k >= 3, into the mesh's existing vertices) with
    their loops and edges to an empty-topology mesh. Call mesh.update() afterwards. `edges`:
    the faces' edges when the caller knows them, as (edge count, int32 vertex pairs with
    room for 2 F k, int32 edge of each corner), e.g. a tree's closed-form edges
    (tree_mesh_edges); else they are derived here (tsk_mesh_edges)."""
    lib = native.require()
    faces = np.ascontiguousarray(faces, np.int32)
    nf, k = faces.shape
    n = nf * k
    if edges is not None:
        ne, edges, corner_edges = edges
    else:
        edges = np.empty(2 * n, np.int32)
        corner_edges = np.empty(n, np.int32)
        ne = lib.mesh_edges(faces.ravel(), k, len(mesh.vertices), edges, corner_edges)
    mesh.edges.add(ne)
    mesh.edges.foreach_set("vertices", compat.mesh_indices(edges[:2 * ne]))
    mesh.loops.add(n)
    mesh.loops.foreach_set("vertex_index", compat.mesh_indices(faces))
    mesh.loops.foreach_set("edge_index", compat.mesh_indices(corner_edges))
    mesh.polygons.add(nf)
    compat.set_face_corners(mesh.polygons, k)


def fix_texture_space(mesh, lo, hi):
    """Gives `mesh` the fixed texture space lo..hi (world-size box corners) instead of an
    automatic one. Blender recomputes an automatic texture space from every vertex each time
    the mesh changes: for a mesh rewritten every frame (swaying trees, simulated blades)
    that was a whole extra pass over its vertices per frame, and it made Generated texture
    coordinates swim as the mesh moved."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    mesh.use_auto_texspace = False
    mesh.texspace_location = tuple((lo + hi) / 2)
    mesh.texspace_size = tuple(np.maximum((hi - lo) / 2, 1e-4))
