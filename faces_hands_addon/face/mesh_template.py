# SPDX-License-Identifier: GPL-3.0-or-later
"""The template of a face rig on the artist's own mesh (thesis 3.1.2 "Creating New Animatable Head Models
from the Template"): the :class:`.template.HeadTemplate` the spring network is built from, over the mesh's
face vertices (simulated) and the ring of vertices just beyond them (driven), with every per-node record
taken over from the template skin by :mod:`.transfer`.
"""
from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.spatial import cKDTree

from ..core import geometry
from .attachment import signed_bone_distance
from .kinematics import LidRig
from .skin import GROUPS, SkinMesh
from .template import HeadTemplate, OrganRecord, SkinRecord
from .transfer import MeshTransfer

__all__ = ["network_template"]

LID_SETUP_RADIUS = 0.025     # m: lid rigs are set up on the vertices this close to the eye (reach: 22 mm)


def _bone_contact(bones, nodes: np.ndarray, node_bone: np.ndarray):
    """Closest point, outward normal and signed skin depth over each node's own bone."""
    point, normal, depth = np.zeros_like(nodes), np.zeros_like(nodes), np.zeros(len(nodes))
    for index, (verts, faces) in enumerate(((bones.skull_vertices, bones.skull_faces),
                                            (bones.jaw_vertices, bones.jaw_faces))):
        select = np.flatnonzero(node_bone == index)
        if len(select):
            point[select], normal[select], depth[select], _ = signed_bone_distance(nodes[select], verts, faces)
    return point, normal, depth


def _densify(polyline: np.ndarray, per_segment: int = 8) -> np.ndarray:
    """Points along a polyline (the lid margin between landmarks, where the mesh's margin vertices lie)."""
    t = np.linspace(0.0, 1.0, per_segment, endpoint=False)[:, None, None]
    out = polyline[:-1][None] * (1 - t) + polyline[1:][None] * t
    return np.vstack([out.transpose(1, 0, 2).reshape(-1, 3), polyline[-1:]])


def _nearest_active(vertices: np.ndarray, active: np.ndarray, points: np.ndarray) -> np.ndarray:
    index = np.flatnonzero(active)
    return index[cKDTree(vertices[index]).query(points)[1]]


def _network_nodes(transfer: MeshTransfer, faces: np.ndarray, n: int):
    """The simulated face vertices, the driven ring around them, and the mesh's triangles among them."""
    active = transfer.face_weight > 0
    edges = transfer.edges
    ring = np.zeros(n, bool)
    ring[edges[active[edges[:, 0]], 1]] = True
    ring[edges[active[edges[:, 1]], 0]] = True
    ring &= ~active
    in_net = active | ring
    nodes_index = np.flatnonzero(in_net)
    local = np.full(n, -1, np.int64)
    local[nodes_index] = np.arange(len(nodes_index))
    sub_faces = local[faces[(local[faces] >= 0).all(axis=1)]]
    return active, ring, nodes_index, np.flatnonzero(~in_net), local, sub_faces


def _outward_normals(nodes: np.ndarray, sub_faces: np.ndarray, expected: np.ndarray, weight: np.ndarray):
    """The mesh's vertex normals, turned outwards if the mesh has them inwards; the template's where the
    mesh has none (isolated vertices)."""
    normals = geometry.vertex_normals(nodes, sub_faces)
    if np.median(np.einsum("ij,ij->i", normals, expected)[weight > 0.5]) < 0:
        normals = -normals                      # the mesh's normals point inwards
    lost = np.linalg.norm(normals, axis=1) < 0.5
    normals[lost] = expected[lost] / np.maximum(np.linalg.norm(expected[lost], axis=1, keepdims=True), 1e-12)
    return normals


def _skin_mesh(source: HeadTemplate, transfer: MeshTransfer, vertices, landmarks, nodes_index, local, sub_faces,
               active, kinematic) -> SkinMesh:
    nodes = vertices[nodes_index]
    groups = transfer.groups[nodes_index].copy()
    groups[kinematic] = GROUPS["boundary"]      # driven, not guarded
    contours = {name: local[ids] for name, ids in transfer.lip_margins.items()}
    for name in ("eye_L_upper", "eye_L_lower", "eye_R_upper", "eye_R_lower", "lips_outer_upper",
                 "lips_outer_lower", "eyebrow_L_upper", "eyebrow_R_upper"):
        if name in source.inputs.contours:
            points = transfer.eye_margins.get(name, landmarks[source.inputs.contours[name]])
            nearest = local[_nearest_active(vertices, active, points)]
            contours[name] = nearest[np.sort(np.unique(nearest, return_index=True)[1])]
    return SkinMesh(nodes, sub_faces, sparse.identity(len(nodes), format="csr"), nodes, sub_faces, groups,
                    contours, dict(source.organs.eye_centres), source.skin.mouth_centre)


def _lid_rigs(source: HeadTemplate, transfer: MeshTransfer, nodes, landmarks, skin: SkinMesh,
              weight) -> dict[str, LidRig]:
    """:class:`.kinematics.LidRig` on the mesh's own vertices around each eye: the margins are the landmark
    contours (densified, so vertices between landmarks are on the margin too), set up on the vertices near
    the eye only; faded off the face by ``weight``, and off entirely for an eye the mesh has no opening for.
    Where the mesh's own opening was found (:mod:`..fitting.eye_openings`), the margins are the mesh's
    vertices along its edges (the skin's lid contours), so that the margins meet exactly when closed."""
    lids = {}
    for side in ("L", "R"):
        own = f"eye_{side}_upper" in transfer.eye_margins
        upper, lower = (nodes[skin.contours[f"eye_{side}_{lid}"]] if own
                        else landmarks[source.inputs.contours[f"eye_{side}_{lid}"]] for lid in ("upper", "lower"))
        open_eye = float(transfer.openings.get(f"eye_{side}", True))
        lids[side] = LidRig(source.organs.eye_centres[side], nodes, _densify(upper), _densify(lower),
                            eyeball_radius=source.organs.eye_radius, surface=skin.group("surface"),
                            setup_radius=LID_SETUP_RADIUS, fade=weight * open_eye)
    return lids


def network_template(source: HeadTemplate, transfer: MeshTransfer, vertices: np.ndarray, faces: np.ndarray,
                     landmarks: np.ndarray):
    """The template the spring network is built from (module docstring), the mesh vertex ids of its nodes
    and the ids of the vertices outside it (passive)."""
    active, ring, nodes_index, passive, local, sub_faces = _network_nodes(transfer, faces, len(vertices))
    nodes = vertices[nodes_index]
    kinematic = ring[nodes_index]
    weight = transfer.face_weight[nodes_index]
    interpolation = transfer.interpolation[nodes_index]
    normals = _outward_normals(nodes, sub_faces, interpolation @ source.skin.normals, weight)
    skin = _skin_mesh(source, transfer, vertices, landmarks, nodes_index, local, sub_faces, active, kinematic)
    node_bone = transfer.node_bone[nodes_index]
    attachment = source.attachment.transferred(interpolation, weight, node_bone, transfer.jaw_weight[nodes_index],
                                               _bone_contact(source.bones, nodes, node_bone))
    record = SkinRecord(skin, normals, geometry.vertex_areas(nodes, sub_faces), transfer.mouth_region[nodes_index],
                        transfer.lip_distance[nodes_index],
                        {k: v[nodes_index] for k, v in transfer.wrinkles.items()}, kinematic)
    organs = OrganRecord(dict(source.organs.eye_centres), source.organs.eye_radius,
                         _lid_rigs(source, transfer, nodes, landmarks, skin, weight),
                         dict(source.organs.parts), source.organs.tongue_pivot, source.organs.arches)
    template = HeadTemplate(source.resolution, source.inputs, record, source.bones, source.muscles, attachment,
                            organs)
    return template, nodes_index, passive
