"""Captured blades into Blender, following DESIGN.md's contract: one mesh object per blade
in the collection 'Tussock Blades', vertices = knots root -> tip joined by edges, a float
point attribute `width` (full width, metres), a float-vector point attribute `camera_co`
(the knot in the camera frame, OpenCV convention) and provenance in custom properties.
The cluster stands upright at the 3D cursor as it stood in front of the camera."""

import bpy
import numpy as np

from .. import compat
from ..nodes import blade_nodes

COLLECTION = "Tussock Blades"

# camera frame (x right, y down, z forward) -> Blender (X right, Y away, Z up)
CAMERA_TO_WORLD = np.array([[1.0, 0.0, 0.0],
                            [0.0, 0.0, 1.0],
                            [0.0, -1.0, 0.0]], np.float64)


def blade_collection(scene):
    coll = bpy.data.collections.get(COLLECTION)
    if coll is None:
        coll = bpy.data.collections.new(COLLECTION)
    children = scene.collection.children
    if coll.name not in children and children.get(coll.name) is None:
        scene.collection.children.link(coll)
    return coll


def blade_mesh(name, local_co, widths, camera_co):
    """A mesh of a polyline: vertices local_co (n, 3) joined by n-1 edges, with `width` and
    `camera_co` point attributes. Arrays are float32; no Python loop over knots."""
    n = len(local_co)
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(n)
    mesh.vertices.foreach_set("co", np.ascontiguousarray(local_co, np.float32).ravel())
    edges = np.stack([np.arange(n - 1), np.arange(1, n)], axis=1).astype(np.int32)
    mesh.edges.add(n - 1)
    mesh.edges.foreach_set("vertices", compat.mesh_indices(edges))
    w = mesh.attributes.new("width", "FLOAT", "POINT")
    w.data.foreach_set("value", np.ascontiguousarray(widths, np.float32))
    c = mesh.attributes.new("camera_co", "FLOAT_VECTOR", "POINT")
    c.data.foreach_set("vector", np.ascontiguousarray(camera_co, np.float32).ravel())
    mesh.update()
    return mesh


def create_blades(scene, knot_counts, camera_xyz, widths, flags, provenance, cursor):
    """Creates one object per captured blade. knot_counts (B,) int; camera_xyz (K, 3)
    and widths (K,) float32 for all knots, blade after blade; flags (B,) uint32.
    Returns the new objects. Nothing is created when there are no blades."""
    knot_counts = np.asarray(knot_counts, np.int64)
    if len(knot_counts) == 0:
        return []
    starts = np.concatenate([[0], np.cumsum(knot_counts)[:-1]])
    camera_xyz = np.asarray(camera_xyz, np.float64).reshape(-1, 3)
    roots = camera_xyz[starts]
    base = roots.mean(axis=0)
    world = camera_xyz @ CAMERA_TO_WORLD.T
    world_base = base @ CAMERA_TO_WORLD.T
    coll = blade_collection(scene)
    objects = []
    for b, (start, count) in enumerate(zip(starts, knot_counts)):  # one object per blade
        pts = world[start:start + count]
        mesh = blade_mesh(f"Blade {b + 1}", pts - pts[0], widths[start:start + count],
                          camera_xyz[start:start + count])
        obj = bpy.data.objects.new(mesh.name, mesh)
        obj.location = np.asarray(cursor, np.float64) + (pts[0] - world_base)
        for key, value in provenance.items():
            obj[f"tussock_{key}"] = value
        obj["tussock_blade"] = b
        obj["tussock_flags"] = int(flags[b])
        obj["tussock_cut_by_border"] = bool(int(flags[b]) & 1)
        coll.objects.link(obj)
        blade_nodes.show_ribbon(obj)
        objects.append(obj)
    return objects
