# SPDX-License-Identifier: GPL-3.0-or-later
"""The head template, assembled in fixed stages (thesis 3.1.2 "Building the Reference Head"; staged like
Rigify: each stage runs for every part before the next one starts):

1. *landmarks + skin*: the animatable skin from the canonical face (:mod:`.skin`);
2. *bones*: skull and jaw warped into the skin (:mod:`.skull_fit`); every skin node is attached to the bone
   whose surface is nearest ("the lower part of the face is attached to the mandible");
3. *muscles*: grids from ``presets/face/muscles.json`` placed under the skin; skin nodes in a muscle's zone
   of influence are attached to the closest point on it (:mod:`.muscle_layout`, :mod:`.muscles`);
4. *eyes, teeth, tongue* generated procedurally from landmarks (:mod:`.organs`), lids rigged (:mod:`.kinematics`).

Departures, each explained where it happens: around the mouth the bone is chosen by distance over the skin
to the upper/lower lip margin (the upper teeth sit right behind the lower lip); a left/right symmetric skin
gets symmetrised bones and a hinge axis along X (the skull asset is slightly asymmetric); the skull's own
teeth are seated behind the rendered procedural ones; jaw opening adds the condylar glide.

The spring network is set up from this template by :mod:`.network`. All inputs of the build are plain
arrays (the canonical face, possibly registered onto another head; skull; jaw), so the same code builds the
default head and heads derived from it, and a saved rig can be rebuilt exactly.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from ..errors import UserError
from . import geometry, organs
from .kinematics import LidRig, opening_glide
from .muscle_layout import MUSCLES_JSON, parse_muscle_specs, place_muscle
from .muscles import MuscleSystem
from .skin import EYEBALL_RADIUS, SkinMesh, build_skin
from .skull_fit import PRESETS_DIR, BoneFit, fit_bones, parse_landmarks

__all__ = ["TemplateInputs", "HeadTemplate", "build_template", "default_inputs", "MAX_MUSCLES_PER_NODE"]

MAX_MUSCLES_PER_NODE = 3
SKULL, JAW = 0, 1


@dataclass
class TemplateInputs:
    """Everything the build reads: the canonical face (468 vertices, possibly registered onto another
    head), its faces, contours, skull and jaw meshes, and the preset documents (as text)."""
    canonical_vertices: np.ndarray
    canonical_faces: np.ndarray
    contours: dict[str, np.ndarray]
    skull_vertices: np.ndarray
    skull_faces: np.ndarray
    jaw_vertices: np.ndarray
    jaw_faces: np.ndarray
    landmarks_json: str
    muscles_json: str


def default_inputs() -> TemplateInputs:
    """Inputs for the default head: the committed assets and presets."""
    from .. import assets
    face, skull, jaw = assets.canonical_face(), assets.skull(), assets.jaw()
    return TemplateInputs(face.vertices, face.faces, dict(assets.face_contours().lines), skull.vertices,
                          skull.faces, jaw.vertices, jaw.faces,
                          (PRESETS_DIR / "face" / "landmarks.json").read_text(encoding="utf-8"),
                          MUSCLES_JSON.read_text(encoding="utf-8"))


@dataclass
class HeadTemplate:
    """The assembled head (rest pose, head coordinates). See the module docstring for the stages."""
    resolution: str
    inputs: TemplateInputs
    skin: SkinMesh
    normals: np.ndarray                  # (N, 3) skin node normals
    areas: np.ndarray                    # (N,) barycentric node areas
    bones: BoneFit
    node_bone: np.ndarray                # (N,) 0 skull, 1 jaw (nearest bone surface)
    jaw_weight: np.ndarray               # (N,) smoothed version of node_bone used to carry the skin
    bone_point: np.ndarray               # (N, 3) closest bone point
    bone_normal: np.ndarray              # (N, 3) bone outward normal there
    bone_depth: np.ndarray               # (N,) signed skin thickness over the bone
    muscles: MuscleSystem
    attach_cell: np.ndarray              # (N, K) muscle cell per attachment (-1 = none)
    attach_bary: np.ndarray              # (N, K, 3)
    attach_weight: np.ndarray            # (N, K) influence weights
    eye_centres: dict[str, np.ndarray]
    eye_radius: float
    lids: dict[str, LidRig]
    parts: dict[str, organs.PartMesh]
    tongue_pivot: np.ndarray
    mouth_axes: np.ndarray
    jaw_glide: np.ndarray = field(default_factory=lambda: np.zeros(3))
    mouth_region: np.ndarray | None = None   # (N,) nodes within ~2 cm of the lip margins (over the skin)
    lip_distance: np.ndarray | None = None   # (N,) distance over the skin to the nearest lip margin (m)
    arches: dict = field(default_factory=dict)   # "upper"/"lower" -> (points, normals) labial tooth faces
    wrinkle_regions: dict[str, np.ndarray] = field(default_factory=dict)
    smoothing: object = None             # sparse (N, N) one smoothing pass for muscle displacements
    smoothing_passes: int = 0
    # heads fitted to an artist's mesh (:mod:`.fitted`): nodes driven kinematically to their attachment
    # target instead of simulated (N,) bool, and a precomputed (N, P) muscle attachment map that replaces
    # the one built from ``attach_cell``/``attach_bary``/``attach_weight`` (None: build it as usual)
    kinematic: np.ndarray | None = None
    attachment_matrix: object = None

    @property
    def node_count(self) -> int:
        return self.skin.node_count


def _signed_bone_distance(nodes, normals, verts, faces):
    point, face, bary, dist = geometry.closest_points(verts, faces, nodes)
    bone_normals = geometry.vertex_normals(verts, faces)
    n = np.einsum("ij,ijk->ik", bary, bone_normals[faces[face]])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    outside = np.einsum("ij,ij->i", nodes - point, n) >= 0
    return point, n, np.where(outside, dist, -dist), dist


def _thickness_field(canonical: np.ndarray, landmarks, nodes: np.ndarray) -> np.ndarray:
    """Published tissue depth interpolated over the skin (inverse-distance weights of 4 landmarks)."""
    positions = canonical[[m.index for m in landmarks]]
    depth = np.array([m.depth for m in landmarks])
    dist, idx = cKDTree(positions).query(nodes, k=4)
    w = 1.0 / np.maximum(dist, 1e-4) ** 2
    return (w * depth[idx]).sum(1) / w.sum(1)


def _smooth_on_mesh(values: np.ndarray, faces: np.ndarray, iterations: int) -> np.ndarray:
    edges = geometry.unique_edges(faces)
    n = len(values)
    degree = np.bincount(edges.ravel(), minlength=n).astype(float)
    out = values.astype(float).copy()
    for _ in range(iterations):
        total = np.bincount(edges[:, 0], out[edges[:, 1]], n) + np.bincount(edges[:, 1], out[edges[:, 0]], n)
        out = 0.5 * out + 0.5 * total / np.maximum(degree, 1)
    return out


def build_template(resolution: str = "default", inputs: TemplateInputs | None = None) -> HeadTemplate:
    """Run the four stages (module docstring). Deterministic: same inputs, same arrays."""
    inputs = inputs or default_inputs()
    canonical = np.asarray(inputs.canonical_vertices, np.float64)
    if canonical.shape != (468, 3) or not np.all(np.isfinite(canonical)):
        raise UserError("the face template needs the 468 canonical-face vertices as finite (468, 3) values")
    # -- stage 1: skin -----------------------------------------------------------------------------
    skin = build_skin(canonical, inputs.canonical_faces, inputs.contours, resolution)
    nodes = skin.vertices
    normals = geometry.vertex_normals(nodes, skin.faces)
    areas = geometry.vertex_areas(nodes, skin.faces)
    canonical_normals = geometry.vertex_normals(canonical, np.asarray(inputs.canonical_faces))
    # -- stage 2: bones ----------------------------------------------------------------------------
    landmarks, hints = parse_landmarks(inputs.landmarks_json)
    surface = skin.group("surface")
    eye_far = np.ones(len(nodes), bool)
    for centre in skin.eye_centres.values():
        eye_far &= np.linalg.norm(nodes - centre, axis=1) > EYEBALL_RADIUS + 0.006
    field_depth = _thickness_field(canonical, landmarks, nodes)
    clearance = np.where(surface & eye_far, np.maximum(0.5 * field_depth, 0.0025), 0.0)
    bones = fit_bones(canonical, canonical_normals, inputs.skull_vertices, inputs.skull_faces,
                      inputs.jaw_vertices, inputs.jaw_faces, landmarks, hints, skin_nodes=nodes,
                      skin_faces=skin.faces, skin_normals=normals, clearance=clearance)
    node_mirror = geometry.mirror_map(nodes, tolerance=1e-6)
    symmetric = bool(np.all(node_mirror >= 0))
    if symmetric:
        _symmetrise_bones(bones)
    sp, sn, sd, sdist = _signed_bone_distance(nodes, normals, bones.skull_vertices, bones.skull_faces)
    jp, jn, jd, jdist = _signed_bone_distance(nodes, normals, bones.jaw_vertices, bones.jaw_faces)
    node_bone = np.where(jdist < sdist, JAW, SKULL)
    node_bone, mouth_region, lip_distance = _mouth_bone_override(skin, node_bone)
    # the canonical face is left/right symmetric, the skull asset is not quite: give mirror-image nodes the
    # same bone (the character's right side decides) so mirrored muscles act mirror-symmetrically
    if symmetric:
        left = nodes[:, 0] > 1e-9
        node_bone[left] = node_bone[node_mirror[left]]
    on_jaw = node_bone == JAW
    bone_point = np.where(on_jaw[:, None], jp, sp)
    bone_normal = np.where(on_jaw[:, None], jn, sn)
    bone_depth = np.where(on_jaw, jd, sd)
    if symmetric:      # the skin guard then acts the same on both sides too
        flip = np.array([-1.0, 1.0, 1.0])
        bone_point[left] = bone_point[node_mirror[left]] * flip
        bone_normal[left] = bone_normal[node_mirror[left]] * flip
        bone_depth[left] = bone_depth[node_mirror[left]]
    jaw_weight = np.clip(_smooth_on_mesh(on_jaw.astype(float), skin.faces, 6), 0.0, 1.0)
    if symmetric:
        jaw_weight = 0.5 * (jaw_weight + jaw_weight[node_mirror])
        _symmetrise_tmj(bones)
    jaw_weight[skin.group("upper_lip")] = np.minimum(jaw_weight[skin.group("upper_lip")], 0.0)
    jaw_weight[skin.group("lower_lip")] = 1.0
    # -- stage 3: muscles --------------------------------------------------------------------------
    mirror = geometry.mirror_map(canonical, tolerance=1e-3 * np.ptp(canonical[:, 0]))
    if np.any(mirror < 0):           # a registered (asymmetric) face: the canonical topology's own L/R map
        mirror = _canonical_mirror()
    specs, connections = parse_muscle_specs(inputs.muscles_json, mirror)
    positive_depth = np.maximum(bone_depth, 0.0)
    if symmetric:
        positive_depth = np.minimum(positive_depth, positive_depth[node_mirror])
    placed = [place_muscle(s, canonical, nodes, skin.faces, normals, positive_depth, on_jaw.astype(float))
              for s in specs]
    mouth_axes = _mouth_axes(canonical)
    system = MuscleSystem(placed, connections, mouth_axes)
    system.set_centres([s.centre.evaluate(canonical) if s.centre is not None else None for s in specs])
    attach_cell, attach_bary, attach_weight = _muscle_attachments(system, placed, nodes, skin, node_bone)
    # -- stage 4: eyes, teeth, tongue; lids --------------------------------------------------------
    parts, lids, tongue_pivot, arches = _organs(skin, canonical, bones, nodes)
    template = HeadTemplate(resolution, inputs, skin, normals, areas, bones, node_bone, jaw_weight, bone_point,
                            bone_normal, bone_depth, system, attach_cell, attach_bary, attach_weight,
                            dict(skin.eye_centres), EYEBALL_RADIUS, lids, parts, tongue_pivot, mouth_axes)
    template.wrinkle_regions = _wrinkle_regions(skin, canonical, nodes)
    template.mouth_region, template.arches, template.lip_distance = mouth_region, arches, lip_distance
    _seat_teeth_in_arches(bones, arches)
    incisor = parts["teeth_lower"].vertices[parts["teeth_lower"].vertices[:, 1].argmin()]
    template.jaw_glide = opening_glide(bones.tmj_pivot, bones.tmj_axis, incisor * np.array([0.0, 1.0, 1.0]))
    template.smoothing, template.smoothing_passes = _smoothing_operator(skin)
    return template


def _canonical_mirror() -> np.ndarray:
    """Left/right vertex map of the MediaPipe canonical face (from the symmetric asset): the map belongs to
    the topology, so it also serves a canonical face registered onto an asymmetric head."""
    from .. import assets
    vertices = np.asarray(assets.canonical_face().vertices, np.float64)
    mirror = geometry.mirror_map(vertices, tolerance=1e-3 * np.ptp(vertices[:, 0]))
    if np.any(mirror < 0):
        raise UserError("the canonical face asset is not left/right symmetric; restore the assets")
    return mirror


def _smoothing_operator(skin: SkinMesh, reference_edge: float = 0.0037):
    """One pass ``0.5 x + 0.5 mean(neighbours)`` over the skin edges, as a sparse matrix, and how many
    passes cover the same physical distance at this resolution (~3 passes at 3.7 mm edges). The lip
    margins and the inner lip surface keep their own value, so closing lips still meet exactly."""
    from scipy import sparse
    edges = geometry.unique_edges(skin.faces)
    n = skin.node_count
    adjacency = sparse.csr_matrix((np.ones(2 * len(edges)), (np.r_[edges[:, 0], edges[:, 1]],
                                                             np.r_[edges[:, 1], edges[:, 0]])), shape=(n, n))
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    keep = np.zeros(n, bool)
    for name in ("lips_inner_upper", "lips_inner_lower"):
        keep[skin.contours[name]] = True
    keep |= skin.group("lip_inner")
    mix = np.where(keep, 0.0, 0.5)
    operator = sparse.diags(1.0 - mix) + sparse.diags(mix / np.maximum(degree, 1)) @ adjacency
    length = np.median(np.linalg.norm(skin.vertices[edges[:, 1]] - skin.vertices[edges[:, 0]], axis=1))
    passes = int(max(1, round(3 * (reference_edge / length) ** 2)))
    return operator.tocsr(), passes


def _symmetrise_bones(bones: BoneFit) -> None:
    """Average skull and jaw with their own mirror images (each vertex moves halfway to the closest point of
    the mirrored surface): the skull asset is slightly asymmetric, a symmetric skin deserves symmetric bones."""
    flip = np.array([-1.0, 1.0, 1.0])
    for name in ("skull", "jaw"):
        verts = getattr(bones, f"{name}_vertices")
        faces = getattr(bones, f"{name}_faces")
        mirrored = verts * flip
        point, _, _, _ = geometry.closest_points(mirrored, faces[:, ::-1], verts)
        setattr(bones, f"{name}_vertices", 0.5 * (verts + point))


def _symmetrise_tmj(bones: BoneFit) -> None:
    """For a symmetric head the jaw hinges about the left-right axis in the mid-sagittal plane."""
    bones.tmj_pivot = bones.tmj_pivot * np.array([0.0, 1.0, 1.0])
    bones.tmj_axis = np.array([1.0, 0.0, 0.0])


def _mouth_bone_override(skin: SkinMesh, node_bone: np.ndarray, reach: float = 0.022) -> np.ndarray:
    """Around the mouth the nearest bone is ambiguous (the upper teeth lie right behind the lower lip), so
    there a node belongs to the jaw if it is closer, over the skin, to the lower lip's inner contour than to
    the upper one (geodesic distances along the mesh edges)."""
    from scipy import sparse
    from scipy.sparse.csgraph import dijkstra

    edges = geometry.unique_edges(skin.faces)
    length = np.linalg.norm(skin.vertices[edges[:, 1]] - skin.vertices[edges[:, 0]], axis=1)
    n = skin.node_count
    graph = sparse.csr_matrix((np.r_[length, length], (np.r_[edges[:, 0], edges[:, 1]],
                                                        np.r_[edges[:, 1], edges[:, 0]])), shape=(n, n))
    upper = skin.contours["lips_inner_upper"][1:-1]
    lower = skin.contours["lips_inner_lower"][1:-1]
    d_up = dijkstra(graph, indices=upper, min_only=True, limit=2 * reach)
    d_low = dijkstra(graph, indices=lower, min_only=True, limit=2 * reach)
    out = node_bone.copy()
    near = np.minimum(d_up, d_low) < reach
    out[near] = np.where(d_low[near] < d_up[near], JAW, SKULL)
    out[skin.group("upper_lip")] = SKULL
    out[skin.group("lower_lip")] = JAW
    return out, near, np.minimum(d_up, d_low)


def _mouth_axes(canonical: np.ndarray) -> np.ndarray:
    """Rows: x from the right to the left mouth corner, y = backwards along the protrusion axis (the
    protrusion direction is -y: forward, tilted with the lips), z up."""
    x = canonical[291] - canonical[61]
    x /= np.linalg.norm(x)
    lips_front = 0.5 * (canonical[0] + canonical[17])
    corners = 0.5 * (canonical[61] + canonical[291])
    forward = lips_front - corners
    forward -= x * (forward @ x)
    forward /= np.linalg.norm(forward)
    y = -forward
    z = np.cross(x, y)
    return np.array([x, y, z])


def _muscle_attachments(system: MuscleSystem, placed, nodes: np.ndarray, skin: SkinMesh, node_bone: np.ndarray):
    """Each node follows up to K muscles whose zone of influence contains it (3.1.2: "attaching the skin
    nodes in the muscle's zone of influence to the closest points on the muscle"), with a weight that is 1
    over the muscle and fades to 0 at ``influence`` beyond its edge."""
    n, k = len(nodes), MAX_MUSCLES_PER_NODE
    eligible = ~skin.group("mouth_bag")
    candidates = []
    for index, m in enumerate(placed):
        cells = np.flatnonzero(system.cell_muscle == index)
        tri = system.cells[cells]
        verts = system.rest
        point, face, bary, dist = geometry.closest_points(verts, tri, nodes, candidates=8)
        normal = np.einsum("ij,ijk->ik", bary, system.normal[tri[face]])
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
        offset = nodes - point
        along = np.einsum("ij,ij->i", offset, normal)
        lateral = np.linalg.norm(offset - along[:, None] * normal, axis=1)   # 0 right over the sheet
        depth = np.linalg.norm(m.points - m.skin_points, axis=2).max()
        t = np.clip(1.0 - lateral / m.spec.influence, 0.0, 1.0)
        over = (along > -0.002) & (along < depth + 0.004)                 # on the skin side, not far
        if m.spec.group == "oris":
            # each half of the orbicularis oris moves its own lip only (upper: skull, lower: jaw)
            over &= node_bone == int(np.round(m.row_bone.mean()))
        weight = np.where(eligible & over, t * t * (3 - 2 * t), 0.0)
        candidates.append((weight, cells[face], bary, dist))
    weights = np.stack([c[0] for c in candidates], 1)              # (N, M)
    # strongest influence first; among equals, the muscle closest to the node
    score = weights - 1e-3 * np.minimum(np.stack([c[3] for c in candidates], 1), 0.5)
    order = np.argsort(-score, axis=1, kind="stable")[:, :k]
    rows = np.arange(n)[:, None]
    attach_weight = weights[rows, order]
    attach_cell = np.stack([c[1] for c in candidates], 1)[rows, order]
    attach_bary = np.stack([c[2] for c in candidates], 1)[rows, order]
    attach_cell = np.where(attach_weight > 0, attach_cell, -1)
    return attach_cell, attach_bary, attach_weight


def _organs(skin: SkinMesh, canonical: np.ndarray, bones: BoneFit, nodes: np.ndarray):
    parts = {}
    lids = {}
    for side, centre in skin.eye_centres.items():
        parts[f"eye_{side}"] = organs.eyeball_mesh(centre, EYEBALL_RADIUS, f"eye_{side}")
        upper = nodes[skin.contours[f"eye_{side}_upper"]]
        lower = nodes[skin.contours[f"eye_{side}_lower"]]
        lids[side] = LidRig(centre, nodes, upper, lower, eyeball_radius=EYEBALL_RADIUS,
                            surface=skin.group("surface"))
    # teeth: upper incisal edge 7 mm behind the stomion, 1 mm above it; arch from the mouth width
    stomion = 0.5 * (canonical[13] + canonical[14])
    mouth_width = np.linalg.norm(canonical[291] - canonical[61])
    scale = mouth_width / 0.050
    incisal = stomion + np.array([0.0, 0.0075, 0.0010])
    lower_incisal = incisal + np.array([0.0, 0.0022, 0.0022])
    upper, lower = organs.teeth_meshes(incisal, 0.026 * scale, 0.040 * scale, lower_incisal, scale)
    parts["teeth_upper"], parts["teeth_lower"] = upper, lower
    arches = {"upper": organs.arch_surface(incisal, 0.026 * scale, 0.040 * scale, True),
              "lower": organs.arch_surface(lower_incisal, 0.026 * scale, 0.040 * scale, False)}
    parts["tongue"], tongue_pivot = organs.tongue_in_arch(lower_incisal, 0.026 * scale, 0.040 * scale, scale)
    return parts, lids, tongue_pivot, arches


def _seat_teeth_in_arches(bones: BoneFit, arches: dict, behind: float = 0.001) -> None:
    """Make the skull's and jaw's own teeth agree with the procedural (rendered) teeth: bone vertices in
    front of an arch's labial face, within its height, are moved just behind it, so that "inside the bone"
    and "through the teeth" mean the same thing for the skin."""
    from scipy.spatial import cKDTree
    for key, verts in (("upper", bones.skull_vertices), ("lower", bones.jaw_vertices)):
        points, normals = arches[key]
        dist, idx = cKDTree(points).query(verts)
        height = np.einsum("ij,ij->i", verts - points[idx], normals[idx])
        band = (dist < 0.015) & (height > -behind)
        verts[band] -= normals[idx[band]] * (height[band] + behind)[:, None]


def _wrinkle_regions(skin: SkinMesh, canonical: np.ndarray, nodes: np.ndarray) -> dict[str, np.ndarray]:
    """Per-node masks (0..1) of the expressive-wrinkle regions (3.1.2 "Expressive Wrinkles")."""
    def blob(centre, radius):
        d = np.linalg.norm(nodes - centre, axis=1)
        t = np.clip(1 - d / radius, 0, 1)
        return t * t * (3 - 2 * t)
    forehead = blob(canonical[151], 0.045) * (nodes[:, 2] > canonical[9, 2])
    furrow = blob(0.5 * (canonical[9] + canonical[168]), 0.018)
    nose = blob(canonical[6], 0.015)
    return {"forehead": forehead, "brow_furrow": furrow, "nose_bridge": nose}
