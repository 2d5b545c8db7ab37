"""Blender data of a meadow: the patch split into chunk objects, and the point cloud of
chunk instances that the meadow node group reads. All arrays cross with foreach_set;
the only Python loop is over chunk objects (tens of them), never over blades."""

import bpy
import numpy as np

from .. import compat, meshes


def chunk_object_name(meadow_name, index):
    # zero-padded so the collection's name order is the chunk order (Pick Instance)
    return compat.id_name(meadow_name, f" chunk {index:05d}")


def _mesh_from_arrays(name, positions, tris, uvs, blade_rand, normals=None):
    mesh = bpy.data.meshes.new(name)
    nv, nt = len(positions), len(tris)
    mesh.vertices.add(nv)
    compat.set_positions(mesh, np.ascontiguousarray(positions, np.float32).ravel())
    meshes.set_faces(mesh, np.asarray(tris).reshape(-1, 3))
    uv_layer = mesh.uv_layers.new(name="UVMap")
    uv_layer.data.foreach_set("uv", np.ascontiguousarray(uvs[tris.ravel()], np.float32).ravel())
    rnd = mesh.attributes.new("tsk_blade_rand", "FLOAT", "POINT")
    rnd.data.foreach_set("value", np.ascontiguousarray(blade_rand, np.float32))
    mesh.polygons.foreach_set("use_smooth", np.ones(nt, bool))
    mesh.update()
    return mesh


def build_chunks(collection, meadow_name, positions, tris, uvs, blade_index, blade_rand,
                 blade_count, chunk_blades, material):
    """Fills `collection` with blade_count / chunk_blades chunk objects. positions (V, 3),
    uvs (V, 2), tris (T, 3) describe the expanded patch where blade b owns a contiguous run
    of vertices and triangles; blade_index (V,) says whose vertex it is; blade_rand
    (blade_count,) is a per-blade random value in [0, 1) for colour variation."""
    steps = build_chunks_steps(collection, meadow_name, positions, tris, uvs, blade_index,
                               blade_rand, blade_count, chunk_blades, material)
    for _ in steps:
        pass
    return blade_count // chunk_blades


def build_chunks_steps(collection, meadow_name, positions, tris, uvs, blade_index, blade_rand,
                       blade_count, chunk_blades, material):
    """build_chunks, yielding (chunks made, chunks in all) after each chunk: an interactive
    Add Meadow shows its progress and can stop between chunks."""
    for obj in list(collection.objects):
        meshes.remove_object(obj)
    verts_per_blade = len(positions) // blade_count
    tris_per_blade = len(tris) // blade_count
    chunks = blade_count // chunk_blades
    for c in range(chunks):
        v0, v1 = c * chunk_blades * verts_per_blade, (c + 1) * chunk_blades * verts_per_blade
        t0, t1 = c * chunk_blades * tris_per_blade, (c + 1) * chunk_blades * tris_per_blade
        name = chunk_object_name(meadow_name, c)
        mesh = _mesh_from_arrays(name, positions[v0:v1], tris[t0:t1] - v0, uvs[v0:v1],
                                 blade_rand[blade_index[v0:v1]])
        mesh.materials.append(material)
        obj = bpy.data.objects.new(name, mesh)
        collection.objects.link(obj)
        yield c + 1, chunks


def write_viewport_off(mesh, viewport_off):
    """Sets the boolean point attribute tsk_viewport_off (instances the viewport leaves out;
    the meadow node group reads it), making it if missing."""
    attr = mesh.attributes.get("tsk_viewport_off")
    if attr is None:
        attr = mesh.attributes.new("tsk_viewport_off", "BOOLEAN", "POINT")
    attr.data.foreach_set("value", np.ascontiguousarray(viewport_off, bool))


def write_points(mesh, origins, chunk, viewport_off, hidden=None):
    """Replaces the points of the meadow's instance cloud: one point per chunk instance at
    origins (N, 3) with int attribute tsk_chunk and booleans tsk_viewport_off (N) and
    tsk_hidden."""
    mesh.clear_geometry()
    n = len(chunk)
    mesh.vertices.add(n)
    compat.set_positions(mesh, np.ascontiguousarray(origins, np.float32).ravel())
    for name, kind in (("tsk_chunk", "INT"), ("tsk_hidden", "BOOLEAN"),
                       ("tsk_viewport_off", "BOOLEAN")):
        if name in mesh.attributes:
            mesh.attributes.remove(mesh.attributes[name])
        mesh.attributes.new(name, kind, "POINT")
    mesh.attributes["tsk_chunk"].data.foreach_set("value", np.ascontiguousarray(chunk, np.int32))
    write_viewport_off(mesh, viewport_off)
    if hidden is None:
        hidden = np.zeros(n, bool)
    mesh.attributes["tsk_hidden"].data.foreach_set("value", np.ascontiguousarray(hidden, bool))
    # tells the simulation its hidden instances were reset (writer.set_hidden)
    mesh["tussock_points_serial"] = mesh.get("tussock_points_serial", 0) + 1
    mesh.update()
