# SPDX-License-Identifier: GPL-3.0-or-later
"""Template -> new head in Blender (thesis 3.1.2): landmark markers on the artist's mesh, then a rig
whose skin is that very mesh (topology, UVs, materials and shape keys untouched).

Coordinates: the engine fits in *world* space (so the object's own rotation and scale count: the face's
direction and up axis are searched among the 24 axis orientations as seen in the viewport, or given as
world axes with ``forward``/``up``) and a fitted rig answers in the coordinates it was given
(its internal human-scale head space stays inside the engine). The rig remembers the world matrix ``M0``
of the moment it was built; its outputs map to the object's local space by ``inv(M0)``.
"""
from __future__ import annotations

import json
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix

from ...faces_hands_addon.core.errors import UserError
from ..adapters.foreign_import import import_foreign
from ..adapters.meshes import mesh_triangles, mesh_vertices
from ..adapters.outputs import atomic_output, same_file
from ..adapters.rig_store import OUTPUT_TO_LOCAL, PART_ROLE, parts
from .objects import create_rig_objects
from ...names import RIG_WARNINGS

LANDMARKS_ROLE = "landmarks"


def world_geometry(obj) -> tuple[np.ndarray, np.ndarray]:
    """The object's base mesh (no modifiers, no shape keys) in world coordinates, and its triangles."""
    if obj is None or obj.type != "MESH":
        raise UserError("select the head mesh (a mesh object) first")
    mesh = obj.data
    if len(mesh.polygons) == 0:
        raise UserError(f"'{obj.name}' has no faces; the head must be a surface mesh, not only vertices/edges")
    vertices = mesh_vertices(mesh).astype(np.float64)
    matrix = np.array(obj.matrix_world, dtype=np.float64)
    world = vertices @ matrix[:3, :3].T + matrix[:3, 3]
    return world, mesh_triangles(mesh).astype(np.int64)


# ------------------------------------------------------------------------------ markers
def landmark_object(head):
    for child in head.children:
        if child.get(PART_ROLE) == LANDMARKS_ROLE:
            return child
    return None


def _contour_edges() -> list[tuple[int, int]]:
    from ...faces_hands_addon.assets import face_contours
    contours = face_contours()
    edges = set()
    for name, line in contours.lines.items():
        points = [int(i) for i in line]
        if contours.closed.get(name):
            points.append(points[0])
        edges.update(tuple(sorted(pair)) for pair in zip(points[:-1], points[1:]) if pair[0] != pair[1])
    return sorted(edges)


def create_markers(context, head, positions_world: np.ndarray):
    """An editable landmark mesh (468 vertices, contour edges) parented to the head: the artist drags
    vertices in Edit Mode (face snapping keeps them on the surface) before fitting."""
    old = landmark_object(head)
    if old is not None:
        mesh = old.data
        bpy.data.objects.remove(old)
        bpy.data.meshes.remove(mesh)
    inverse = np.linalg.inv(np.array(head.matrix_world, dtype=np.float64))
    local = positions_world @ inverse[:3, :3].T + inverse[:3, 3]
    mesh = bpy.data.meshes.new(f"{head.name} Landmarks")
    mesh.from_pydata(local.tolist(), _contour_edges(), [])
    markers = bpy.data.objects.new(f"{head.name} Landmarks", mesh)
    for collection in head.users_collection:
        collection.objects.link(markers)
    markers.parent = head
    markers[PART_ROLE] = LANDMARKS_ROLE
    markers.show_in_front = True
    markers.display_type = "WIRE"
    return markers


def marker_positions_world(head) -> np.ndarray | None:
    markers = landmark_object(head)
    if markers is None:
        return None
    if markers.mode == "EDIT":
        markers.update_from_editmode()
    local = mesh_vertices(markers.data).astype(np.float64)
    if len(local) != 468:
        raise UserError(f"'{markers.name}' must keep its 468 vertices (it has {len(local)}); "
                        "delete it and locate the landmarks again")
    matrix = np.array(markers.matrix_world, dtype=np.float64)
    return local @ matrix[:3, :3].T + matrix[:3, 3]


# ------------------------------------------------------------------------------ refused fits
AXIS_ITEMS = [("AUTO", "Automatic", "Search the 24 axis orientations for the face (forward and up both Automatic)")] + [
    (axis, axis, f"the face looks along world {axis} / the top of the head points along world {axis}")
    for axis in ("-Y", "+Y", "+X", "-X", "+Z", "-Z")]


def axes_argument(forward: str | None, up: str | None) -> tuple[str | None, str | None]:
    """Operator/CLI axis choices as the engine's ``forward``/``up`` (None = searched)."""
    forward = None if forward in (None, "", "AUTO") else forward
    up = None if up in (None, "", "AUTO") else up
    if (forward is None) != (up is None):
        raise UserError("set both the forward and the up axis of the head (e.g. forward -Y, up +Z), or neither "
                        "(Automatic)")
    return forward, up


def preview_path(out: Path, inputs=()) -> Path:
    """``<out>.fit-preview.png`` beside ``out``; another name if that would be one of the ``inputs``."""
    out = Path(out)
    candidate = out.with_name(f"{out.stem}.fit-preview.png")
    number = 2
    while any(same_file(candidate, source) for source in inputs if source is not None):
        candidate = out.with_name(f"{out.stem}.fit-preview-{number}.png")
        number += 1
    return candidate


def default_preview_path(head_name: str) -> Path:
    """Where the operators put the preview of a refused fit: Blender's temporary folder."""
    import tempfile
    safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in head_name) or "head"
    return Path(bpy.app.tempdir or tempfile.gettempdir()) / f"{safe}.fit-preview.png"


def refuse_with_preview(error, path: Path) -> UserError:
    """The refusal of ``error`` (a ``fitting.quality.FitRefused``) with its preview written to ``path``."""
    from ...faces_hands_addon.fitting.preview import png_bytes
    try:
        data = png_bytes(error.preview())
        with atomic_output(path) as tmp:
            tmp.write_bytes(data)
    except OSError as problem:
        return UserError(f"{error} (the preview could not be written to {path}: {problem})")
    return UserError(f"{error}. Preview of where the face was looked for: {path}")


# ------------------------------------------------------------------------------ the fitted rig
def attach_rig(context, head, rig, world_matrix: np.ndarray, name: str | None = None):
    """Turn ``head`` into a rig object: parts, controls and engine state (its mesh is not changed)."""
    to_local = np.linalg.inv(world_matrix)
    head[OUTPUT_TO_LOCAL] = [float(v) for v in to_local.ravel()]
    obj = create_rig_objects(context, rig, name or f"FH {head.name}", skin_obj=head)
    for part in parts(obj).values():
        part.matrix_parent_inverse = Matrix(to_local.tolist())
    warnings = list(getattr(rig, "warnings", []) or [])
    if warnings:
        obj[RIG_WARNINGS] = json.dumps(warnings)
    return obj


def import_meshes(path: str, what: str = "the mesh file") -> list:
    """Import a mesh file with Blender's own importer (default axis conversion), checked and run in a child
    process (``adapters.foreign_import``); returns the new meshes."""
    meshes = [o for o in import_foreign(path, what).objects if o.type == "MESH"]
    if not meshes:
        raise UserError(f"{path} contains no mesh")
    return meshes


def import_head(path: str):
    """Import a head mesh (see :func:`import_meshes`); the biggest mesh wins."""
    return max(import_meshes(path), key=lambda o: len(o.data.vertices))
