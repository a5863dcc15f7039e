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
from .attachment import signed_bone_distance, smoothing_operator
from . import organs as organ_meshes
from .kinematics import LidRig, cornea_bulge, eye_elevation
from .skin import GROUPS, SkinMesh
from .template import HeadTemplate, OrganRecord, SkinRecord
from .transfer import MeshTransfer

__all__ = ["network_template"]

LID_SETUP_RADIUS = 0.025     # m: lid rigs are set up on the vertices this close to the eye (reach: 22 mm)
EYE_CLEARANCE = 0.0005       # m the mesh's lid margins are kept outside the eyeball and cornea (_eye_centres)
LINING_FACING, LINING_REACH = 0.1, 0.004   # cosine towards the eye centre; m beyond the eyeball (_eye_linings)
BROW_SPREAD_PASSES = 3                      # smoothing passes of the muscle field on the mesh (_spread_over_the_brows)
BROW_SPREAD_FROM = (0.02, 0.035)            # m from the lips over which that smoothing fades in
EYE_STEP, EYE_MAX_SHIFT = 0.0001, 0.006     # m: the eyeball moves back in these steps, at most this far
LID_GAP_BORDER = 0.2                        # share of the eye's width at each end left out of the closing gap
OVERLAP_PASSES, OVERLAP_DONE = 8, 1e-4      # _closing_overlap: at most this many passes; rad of gap left = closed


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


def _eye_centres(source: HeadTemplate, transfer: MeshTransfer, skin: SkinMesh) -> dict[str, np.ndarray]:
    """The eyeball centres fitted to the mesh's own eye (thesis 3.1.2 "Eyes, Teeth, Tongue": the lids slide
    over the eyeball). The template places its eyeball by the landmarks; where the mesh's lid margins were
    found (:mod:`..fitting.eye_openings`) and lie inside that eyeball (the MakeHuman lids, up to ~1.1 mm
    inside the eyeball and cornea), the lids closing over it were pushed out and folded: the eyeball is moved
    straight back (+Y), by the least step of ``EYE_STEP``, until every margin vertex lies ``EYE_CLEARANCE``
    outside its sphere and cornea (never forward; eyes without own margins keep the template's centre).
    MakeHuman neutral: 1.9 / 2.0 mm back (L / R)."""
    centres = {}
    radius = source.organs.eye_radius
    for side, centre in source.organs.eye_centres.items():
        centre = np.asarray(centre, np.float64)
        centres[side] = centre
        if f"eye_{side}_upper" not in transfer.eye_margins:
            continue
        ids = np.concatenate([skin.contours[f"eye_{side}_upper"], skin.contours[f"eye_{side}_lower"]])
        margin = skin.vertices[ids]
        for step in np.arange(0.0, EYE_MAX_SHIFT + 1e-9, EYE_STEP):
            moved = margin - (centre + np.array([0.0, step, 0.0]))
            r = np.linalg.norm(moved, axis=1)
            ahead = np.degrees(np.arccos(np.clip(-moved[:, 1] / np.maximum(r, 1e-12), -1.0, 1.0)))
            if np.all(r >= radius * (1.0 + cornea_bulge(ahead)) + EYE_CLEARANCE):
                centres[side] = centre + np.array([0.0, step, 0.0])
                break
    return centres


def _eye_linings(source: HeadTemplate, transfer: MeshTransfer, skin: SkinMesh, normals: np.ndarray) -> None:
    """Skin that faces the eyeball is the lids' lining (the conjunctiva, the template's ``lid_back``): where the
    lids fold back into a socket (MakeHuman) it lies on the eyeball behind the margins. It is regrouped from
    ``surface`` to ``lid_back``, so that closing lids carry it round the eyeball instead of lifting it over
    the cornea and the eye guards pushing it out (which folded the upper lid's underside), as the
    template's own lid backs (thesis 3.1.2 "Eyes, Teeth, Tongue")."""
    for side, centre in skin.eye_centres.items():
        if f"eye_{side}_upper" not in transfer.eye_margins:
            continue
        out = skin.vertices - centre
        distance = np.linalg.norm(out, axis=1)
        facing = np.einsum("ij,ij->i", normals, out) < -LINING_FACING * np.maximum(distance, 1e-12)
        lining = facing & (distance < source.organs.eye_radius + LINING_REACH) & skin.group("surface")
        skin.groups[lining] = (skin.groups[lining] & ~GROUPS["surface"]) | GROUPS["lid_back"]


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
        lids[side] = LidRig(skin.eye_centres[side], nodes, _densify(upper), _densify(lower),
                            eyeball_radius=source.organs.eye_radius, surface=skin.group("surface"),
                            setup_radius=LID_SETUP_RADIUS, fade=weight * open_eye)
        if open_eye and all(f"eye_{side}_{lid}" in skin.contours for lid in ("upper", "lower")):
            _closing_overlap(lids[side], nodes, *(np.asarray(skin.contours[f"eye_{side}_{lid}"])
                                                  for lid in ("upper", "lower")))
    return lids


def _closing_overlap(lid: LidRig, nodes: np.ndarray, upper: np.ndarray, lower: np.ndarray) -> float:
    """How far past the meeting line (rad) the upper margin must close so that the closed margins leave no
    gap (3.1.2: "eyes together with the animatable eyelids"; a blink closes the eye). Each margin node
    rotates to the meeting line at its own x, but the margins are straight between their nodes: where one lid
    has few nodes (a decimated mesh: 4-5 mm apart) its chord passes above the other lid's nodes by the
    curvature of the meeting line between them (up to 2 mm by an eye's outer corner). The closed margins are
    posed as the rig will pose them (node weights, canthus ties) and the largest gap between the two
    polylines over the middle ``1 - 2 LID_GAP_BORDER`` of the eye is added to the overlap until none is left
    (nodes held by a canthus close less than the overlap, so once may not do): measured on the head, not
    chosen per head. ``lid.overlap`` is left at the result."""
    overlap = LidRig.OVERLAP
    for _ in range(OVERLAP_PASSES):
        lid.overlap = overlap
        closed = []
        for ids in (upper, lower):
            elevation = eye_elevation(nodes[ids], lid.centre) + lid.rotations(1.0, 0.0, nodes=ids)
            order = np.argsort(nodes[ids, 0], kind="stable")
            closed.append((nodes[ids, 0][order], elevation[order]))
        lo = min(closed[0][0][0], closed[1][0][0])
        hi = max(closed[0][0][-1], closed[1][0][-1])
        xs = np.linspace(lo + LID_GAP_BORDER * (hi - lo), hi - LID_GAP_BORDER * (hi - lo), 49)
        gap = float((np.interp(xs, *closed[0]) - np.interp(xs, *closed[1])).max())
        if gap <= OVERLAP_DONE:
            break
        overlap += gap
    lid.overlap = overlap
    return overlap


def _spread_over_the_brows(attachment, skin: SkinMesh, lip_distance: np.ndarray) -> None:
    """The muscle field interpolated from the template keeps the template's own spread (its skin layer's
    smoothing passes, thesis 3.1.2 Fig. 3.4), which is steep for an artist's finer mesh at the brow's lower
    edge: on SOMA neighbouring nodes ~4 mm apart were pulled 1.0 and 4.7 mm by browDown, which
    folded the skin between brow and lid. ``BROW_SPREAD_PASSES`` passes of the skin layer's smoothing on
    the mesh itself spread it there; the lips keep their field (the smoothing fades in from
    ``BROW_SPREAD_FROM[0]`` to ``[1]`` away from the lips: their margins must meet and protrude)."""
    operator, _ = smoothing_operator(skin)
    low, high = BROW_SPREAD_FROM
    share = np.clip((lip_distance - low) / (high - low), 0.0, 1.0)
    attachment.smoothing = (sparse.diags(share) @ operator + sparse.diags(1.0 - share)).tocsr()
    attachment.smoothing_passes = BROW_SPREAD_PASSES


def _inner_lip_gap(points: np.ndarray, upper: np.ndarray, lower: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Height of the opening between two inner lip contours (node ids into ``points``) at each ``x``."""
    upper, lower = upper[np.argsort(points[upper, 0])], lower[np.argsort(points[lower, 0])]
    return np.interp(x, points[upper, 0], points[upper, 2]) - np.interp(x, points[lower, 0], points[lower, 2])


def _rest_closing_of_the_mesh(muscles, skin: SkinMesh, landmarks: np.ndarray, contours: dict) -> None:
    """The orbicularis oris closes the mesh's own rest opening first, not the landmarks' (3.1.2: the rest
    lips are the artist's): ``rest_closing`` was set from the landmarks' inner lip contours, which keep the
    canonical face's parted lips (~5 mm) where an artist models them together (MakeHuman: 0.8 mm apart),
    so the oris pressed the lips into each other. Each point's closing is scaled by the mesh's opening
    over the landmarks' at its x (at most 1)."""
    names = ("lips_inner_upper", "lips_inner_lower")
    if not np.any(muscles.rest_closing) or not all(len(skin.contours.get(k, ())) for k in names):
        return                             # no inner lip contour found on the mesh: the landmarks' closing
    x = muscles.rest[:, 0]
    said = _inner_lip_gap(landmarks, *(np.asarray(contours[k]) for k in names), x)
    real = _inner_lip_gap(skin.vertices, *(np.asarray(skin.contours[k]) for k in names), x)
    scale = np.where(said > 1e-4, np.clip(real / np.maximum(said, 1e-4), 0.0, 1.0), 1.0)
    muscles.set_rest_closing(muscles.rest_closing * scale[:, None])


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
    skin.eye_centres = _eye_centres(source, transfer, skin)
    _eye_linings(source, transfer, skin, normals)
    parts = dict(source.organs.parts)
    for side, centre in skin.eye_centres.items():
        parts[f"eye_{side}"] = organ_meshes.eyeball_mesh(centre, source.organs.eye_radius, f"eye_{side}")
    node_bone = transfer.node_bone[nodes_index]
    attachment = source.attachment.transferred(interpolation, weight, node_bone, transfer.jaw_weight[nodes_index],
                                               _bone_contact(source.bones, nodes, node_bone))
    _spread_over_the_brows(attachment, skin, transfer.lip_distance[nodes_index])
    record = SkinRecord(skin, normals, geometry.vertex_areas(nodes, sub_faces), transfer.mouth_region[nodes_index],
                        transfer.lip_distance[nodes_index],
                        {k: v[nodes_index] for k, v in transfer.wrinkles.items()}, kinematic)
    organs = OrganRecord(dict(skin.eye_centres), source.organs.eye_radius,
                         _lid_rigs(source, transfer, nodes, landmarks, skin, weight), parts,
                         source.organs.tongue_pivot, source.organs.arches)
    _rest_closing_of_the_mesh(source.muscles, skin, landmarks, source.inputs.contours)
    template = HeadTemplate(source.resolution, source.inputs, record, source.bones, source.muscles, attachment,
                            organs)
    return template, nodes_index, passive
