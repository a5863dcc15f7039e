# SPDX-License-Identifier: GPL-3.0-or-later
"""Thin conversions between engine arrays and Blender meshes (foreach_get/set, no vertex loops)."""
from __future__ import annotations

import bpy
import numpy as np


def mesh_from_arrays(name: str, vertices, faces, uvs=None, smooth: bool = True) -> bpy.types.Mesh:
    """A new mesh datablock from (N,3) vertices, (M,3|4) faces and optional per-vertex (N,2) UVs."""
    vertices = np.ascontiguousarray(vertices, dtype=np.float32).reshape(-1, 3)
    faces = np.ascontiguousarray(faces, dtype=np.int32)
    corners = faces.shape[1]
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(vertices))
    mesh.vertices.foreach_set("co", vertices.ravel())
    mesh.loops.add(faces.size)
    mesh.loops.foreach_set("vertex_index", faces.ravel())
    mesh.polygons.add(len(faces))
    mesh.polygons.foreach_set("loop_start", np.arange(0, faces.size, corners, dtype=np.int32))
    mesh.polygons.foreach_set("use_smooth", np.full(len(faces), smooth, dtype=bool))
    if uvs is not None:
        uv_layer = mesh.uv_layers.new(name="UVMap")
        per_corner = np.asarray(uvs, dtype=np.float32)[faces.ravel()]
        uv_layer.data.foreach_set("uv", per_corner.ravel())
    mesh.update(calc_edges=True)
    mesh.validate(clean_customdata=False)
    return mesh


def mesh_vertices(mesh: bpy.types.Mesh) -> np.ndarray:
    out = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", out)
    return out.reshape(-1, 3)


def mesh_triangles(mesh: bpy.types.Mesh) -> np.ndarray:
    """Triangulated faces (loop triangles) as an (M,3) int array of vertex indices."""
    mesh.calc_loop_triangles()
    out = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", out)
    return out.reshape(-1, 3)


def object_from_mesh(mesh: bpy.types.Mesh, collection: bpy.types.Collection, name: str | None = None):
    obj = bpy.data.objects.new(name or mesh.name, mesh)
    collection.objects.link(obj)
    return obj
