"""Faces into a Blender mesh, complete with their edges, in a few array copies.

Blender 3.4's Mesh.update() derives the edges of a mesh that has none with a hash of every
corner: for a 143,000-quad tree, most of the time of building it. The native library computes
the same edges in first-use order (tsk_mesh_edges), and the indices cross as uint32, the type
of these RNA properties, so foreach_set copies each array in one go (compat.mesh_indices)."""

import numpy as np

from . import compat, native


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
