# SPDX-License-Identifier: GPL-3.0-or-later
"""A face rig on the artist's own head mesh (thesis 3.1.2 "Creating New Animatable Head Models from the
Template"): "From the correspondence between the skin landmarks on the source and target geometry, a radial
basis warping function is set up ... The skull landmarks are related to their counterparts on the skin by
an offset ... To transform the muscles, the same deformation function as for the skin is applied to the
muscle grids ... eyes, teeth and tongue can only be positioned and scaled automatically".

The skin is the artist's mesh, vertex for vertex: its topology never changes. Fixed stages (Rigify-like):

1. *landmarks*: the 468 canonical-face landmarks on the mesh, located automatically
   (:func:`..fitting.locate_landmarks`) or as the artist placed them;
2. *normalise*: a similarity (scale, rotation, translation; Umeyama) takes the landmarks onto the default
   canonical face. This "head space" has human proportions in metres, so the published tissue depths, the
   skin material (``spread_mm``), the eyeball size and the stability guard mean the same for a head
   modelled in centimetres or at 100x; ``head_to_mesh`` is its inverse;
3. *template*: :func:`.template.build_template` on the registered canonical face: skull and jaw warped
   with radial basis functions onto the skin landmarks minus the tissue-depth offsets, muscle grids
   evaluated on the registered landmarks (the skin's correspondence) and placed under that skin, eyes,
   teeth and tongue positioned and scaled from the eye and mouth landmarks;
4. *transfer*: every mesh vertex takes over what the template skin has at its closest point
   (:mod:`.transfer`); lids are rigged on the mesh's own vertices around its eye openings;
5. *network*: springs on the mesh's own edges (:mod:`.network`), only over the face: vertices beyond it
   (scalp, ears, neck, shoulders) are not simulated. They stay where they are (the skull does not move)
   except where the mandible is: skin under the chin and on the front and sides of the neck is carried by
   the jaw with the weight of the face's rim next to it, fading to 0 about 8 cm beyond the face, so the
   chin skin goes with the jaw, stretches towards the neck, and the neck, ears and scalp stay put
   (:mod:`.transfer`). The ring of them next to the face is driven (kinematic nodes) and holds the
   simulated face's border. The skull guard keeps each node off its own bone (:class:`OwnBoneGuard`).

Coordinates: every output of :class:`FittedFaceRig` (positions, rest positions, part and bone meshes,
rigid transforms, muscle fibres, landmarks) is in the mesh's own coordinates, ready to be written into a
shape key of the artist's mesh; the simulation runs in head space, ``rig.head_to_mesh`` maps it to the
mesh. Rest positions are the input vertices exactly (displacements are mapped, not positions).
"""
from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy import sparse
from scipy.spatial import cKDTree

from ..errors import UserError
from ..fitting.surface import checked_mesh
from ..physics import BoneHalfSpaceGuard
from . import geometry
from .kinematics import LidRig
from .network import SkinMaterial
from .rig import FaceRig, _attachment_matrix, read_saved_rig
from .skin import GROUPS, SkinMesh
from .skull_fit import similarity_transform
from .template import HeadTemplate, TemplateInputs, build_template, default_inputs
from .transfer import CARRIERS, MeshTransfer, mesh_edges, transfer_to_mesh

__all__ = ["FittedFaceRig", "FittedHead", "build_fitted_rig", "fit_head", "check_mesh", "is_fitted_rig_file",
           "MAX_VERTICES", "FORMAT"]

FORMAT = "faces_hands.fitted_face_rig/1"
MAX_VERTICES = 500_000
LANDMARK_COUNT = 468


def check_mesh(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """The artist's mesh as (N, 3) float64 vertices and (M, 3) int64 triangles, or a UserError that says
    what is wrong and what to do: the fitter's own checks (``fitting.surface.checked_mesh``: arrays,
    indices, NaN, degenerate), the face rig's size limit, and no non-manifold edges."""
    count = len(np.asarray(vertices).reshape(-1, 3)) if np.asarray(vertices).size else 0
    if count > MAX_VERTICES:
        raise UserError(f"the head mesh has {count:,} vertices; the face rig takes at most "
                        f"{MAX_VERTICES:,}: add a Decimate modifier, apply it and fit again")
    vertices, faces = checked_mesh(vertices, faces)
    _, counts = mesh_edges(faces[_proper(faces)])
    bad = int(np.count_nonzero(counts > 2))
    if bad:
        raise UserError(f"the head mesh has {bad} non-manifold edge{'s' if bad > 1 else ''} (shared by more than "
                        "2 faces); select them (Select > Select All by Trait > Non Manifold) and repair them, "
                        "e.g. with Mesh > Clean Up or by deleting duplicate faces, then fit again")
    return vertices, faces


def _proper(faces: np.ndarray) -> np.ndarray:
    """Indices of the triangles with three different corners (degenerate ones carry no surface)."""
    a, b, c = faces.T
    return np.flatnonzero((a != b) & (b != c) & (a != c))


def _check_landmarks(landmarks) -> np.ndarray:
    try:
        landmarks = np.asarray(landmarks, np.float64)
    except (TypeError, ValueError):
        raise UserError("landmarks must be a numeric (468, 3) array") from None
    if landmarks.shape != (LANDMARK_COUNT, 3) or not np.all(np.isfinite(landmarks)):
        raise UserError(f"landmarks must be {LANDMARK_COUNT} finite 3D points, one per canonical-face vertex "
                        f"(got shape {landmarks.shape}); re-run the landmark fit")
    return landmarks


def _transform(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ matrix[:3, :3].T + matrix[:3, 3]


@dataclass
class FittedHead:
    """Everything the stages produced (module docstring); ``template`` is the network's template over the
    simulated vertices ``network_nodes`` (head space), ``source`` the template on the registered face."""
    mesh_vertices: np.ndarray        # (n, 3) float64, the artist's vertices (mesh coordinates)
    mesh_faces: np.ndarray           # (m, 3) int64, as given
    landmarks: np.ndarray            # (468, 3) mesh coordinates
    landmark_triangles: np.ndarray   # (468,) triangle of ``mesh_faces`` each landmark lies on
    landmark_barycentric: np.ndarray # (468, 3)
    head_to_mesh: np.ndarray         # 4x4 similarity
    head_vertices: np.ndarray        # (n, 3) the vertices in head space
    source: HeadTemplate
    template: HeadTemplate
    transfer: MeshTransfer
    network_nodes: np.ndarray        # vertex ids of the network's nodes (simulated + driven ring)
    passive: np.ndarray              # vertex ids outside the network
    passive_jaw: np.ndarray          # how far each passive vertex is carried by the jaw
    passive_carrier: np.ndarray      # the rigid part (index into transfer.CARRIERS) a passive vertex rides, -1
    inputs: TemplateInputs           # template inputs, canonical face = the normalisation target
    resolution: str
    seed: int
    warnings: list[str] = field(default_factory=list)


def fit_head(vertices, faces, landmarks=None, *, seed: int = 0, progress=None, resolution: str = "default",
             inputs: TemplateInputs | None = None) -> FittedHead:
    """Run stages 1-4 plus the network template (module docstring)."""
    def report(fraction: float, message: str) -> None:
        if progress is not None:
            progress(float(fraction), message)

    vertices, faces = check_mesh(vertices, faces)
    proper_index = _proper(faces)
    proper = faces[proper_index]
    warnings: list[str] = []
    # -- 1. landmarks --------------------------------------------------------------------------------------
    if landmarks is None:
        from ..fitting import locate_landmarks
        fit = locate_landmarks(vertices, proper, seed=seed,
                               progress=lambda f, m: report(0.6 * f, m))
        landmarks, tri_local, bary = fit.positions, fit.triangles, fit.barycentric
        warnings += list(fit.warnings)
    else:
        from ..fitting import project_to_surface
        landmarks = _check_landmarks(landmarks)
        _, tri_local, bary = project_to_surface(landmarks, vertices, proper)
    landmark_triangles = proper_index[tri_local]
    # -- 2. normalise to head space ------------------------------------------------------------------------
    report(0.6, "building the head template")
    inputs = inputs or default_inputs()
    canonical = np.asarray(inputs.canonical_vertices, np.float64)
    to_head = similarity_transform(landmarks, canonical)
    head_to_mesh = np.linalg.inv(to_head)
    head_vertices = _transform(to_head, vertices)
    head_landmarks = _transform(to_head, landmarks)
    # -- 3. template on the registered canonical face -------------------------------------------------------
    source = build_template(resolution, replace(inputs, canonical_vertices=head_landmarks))
    # -- 4. transfer onto the artist's mesh ------------------------------------------------------------------
    report(0.8, "transferring the rig onto the mesh")
    transfer = transfer_to_mesh(source, head_vertices, proper, head_landmarks)
    warnings += transfer.warnings
    report(0.9, "building the spring network")
    template, network_nodes, passive = _network_template(source, transfer, head_vertices, proper, head_landmarks)
    report(1.0, "face rig fitted")
    return FittedHead(vertices, faces, landmarks, landmark_triangles, np.asarray(bary, np.float64), head_to_mesh,
                      head_vertices, source, template, transfer, network_nodes, passive,
                      np.where(transfer.carrier[passive] >= 0, 0.0, transfer.jaw_weight[passive]),
                      transfer.carrier[passive].copy(), inputs, resolution, int(seed), warnings)


def _bone_contact(bones, nodes: np.ndarray, node_bone: np.ndarray):
    """Closest point, outward normal and signed skin depth over each node's own bone."""
    point, normal, depth = np.zeros_like(nodes), np.zeros_like(nodes), np.zeros(len(nodes))
    for index, (verts, faces) in enumerate(((bones.skull_vertices, bones.skull_faces),
                                            (bones.jaw_vertices, bones.jaw_faces))):
        select = np.flatnonzero(node_bone == index)
        if len(select) == 0:
            continue
        p, face, bary, dist = geometry.closest_points(verts, faces, nodes[select])
        n = np.einsum("ij,ijk->ik", bary, geometry.vertex_normals(verts, faces)[faces[face]])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
        outside = np.einsum("ij,ij->i", nodes[select] - p, n) >= 0
        point[select], normal[select], depth[select] = p, n, np.where(outside, dist, -dist)
    return point, normal, depth


def _network_template(source: HeadTemplate, transfer: MeshTransfer, vertices: np.ndarray, faces: np.ndarray,
                      landmarks: np.ndarray):
    """The template the spring network is built from: the mesh's face vertices (simulated) and the ring of
    vertices just beyond them (driven), with everything the network and the rig read per node."""
    n = len(vertices)
    active = transfer.face_weight > 0
    edges = transfer.edges
    ring = np.zeros(n, bool)
    ring[edges[active[edges[:, 0]], 1]] = True
    ring[edges[active[edges[:, 1]], 0]] = True
    ring &= ~active
    in_net = active | ring
    nodes_index = np.flatnonzero(in_net)
    passive = np.flatnonzero(~in_net)
    local = np.full(n, -1, np.int64)
    local[nodes_index] = np.arange(len(nodes_index))
    sub_faces = local[faces[(local[faces] >= 0).all(axis=1)]]
    nodes = vertices[nodes_index]
    kinematic = ring[nodes_index]
    weight = transfer.face_weight[nodes_index]
    interpolation = transfer.interpolation[nodes_index]

    normals = geometry.vertex_normals(nodes, sub_faces)
    expected = interpolation @ source.normals
    if np.median(np.einsum("ij,ij->i", normals, expected)[weight > 0.5]) < 0:
        normals = -normals                      # the mesh's normals point inwards
    lost = np.linalg.norm(normals, axis=1) < 0.5
    normals[lost] = expected[lost] / np.maximum(np.linalg.norm(expected[lost], axis=1, keepdims=True), 1e-12)
    areas = geometry.vertex_areas(nodes, sub_faces)

    groups = transfer.groups[nodes_index].copy()
    groups[kinematic] = GROUPS["boundary"]      # driven, not guarded
    contours = {name: local[ids] for name, ids in transfer.lip_margins.items()}
    for name in ("eye_L_upper", "eye_L_lower", "eye_R_upper", "eye_R_lower", "lips_outer_upper",
                 "lips_outer_lower", "eyebrow_L_upper", "eyebrow_R_upper"):
        if name in source.inputs.contours:
            nearest = local[_nearest_active(vertices, active, landmarks[source.inputs.contours[name]])]
            contours[name] = nearest[np.sort(np.unique(nearest, return_index=True)[1])]
    skin = SkinMesh(nodes, sub_faces, sparse.identity(len(nodes), format="csr"), nodes, sub_faces, groups,
                    contours, dict(source.eye_centres), source.skin.mouth_centre)
    node_bone = transfer.node_bone[nodes_index]
    bone_point, bone_normal, bone_depth = _bone_contact(source.bones, nodes, node_bone)

    surface = skin.group("surface")
    lids = {}
    for side in ("L", "R"):
        upper = landmarks[source.inputs.contours[f"eye_{side}_upper"]]
        lower = landmarks[source.inputs.contours[f"eye_{side}_lower"]]
        open_eye = float(transfer.openings.get(f"eye_{side}", True))
        lids[side] = _lid_rig(source.eye_centres[side], nodes, upper, lower, source.eye_radius, surface,
                              weight * open_eye)

    field = _attachment_matrix(source)
    for _ in range(source.smoothing_passes):      # the template's own spreading of the muscles' pull
        field = source.smoothing @ field
    attachment = (sparse.diags(weight) @ interpolation @ field).tocsr()
    attachment.eliminate_zeros()
    empty = np.zeros((len(nodes), 0))
    template = HeadTemplate(
        source.resolution, source.inputs, skin, normals, areas, source.bones, node_bone,
        transfer.jaw_weight[nodes_index], bone_point, bone_normal, bone_depth, source.muscles,
        empty.astype(np.int64), np.zeros((len(nodes), 0, 3)), empty, dict(source.eye_centres), source.eye_radius,
        lids, dict(source.parts), source.tongue_pivot, source.mouth_axes, jaw_glide=source.jaw_glide,
        mouth_region=transfer.mouth_region[nodes_index], lip_distance=transfer.lip_distance[nodes_index],
        arches=source.arches, wrinkle_regions={k: v[nodes_index] for k, v in transfer.wrinkles.items()},
        smoothing=None, smoothing_passes=0, kinematic=kinematic, attachment_matrix=attachment)
    return template, nodes_index, passive


def _densify(polyline: np.ndarray, per_segment: int = 8) -> np.ndarray:
    """Points along a polyline (the lid margin between landmarks, where the mesh's margin vertices lie)."""
    t = np.linspace(0.0, 1.0, per_segment, endpoint=False)[:, None, None]
    out = polyline[:-1][None] * (1 - t) + polyline[1:][None] * t
    return np.vstack([out.transpose(1, 0, 2).reshape(-1, 3), polyline[-1:]])


def _lid_rig(centre: np.ndarray, nodes: np.ndarray, upper: np.ndarray, lower: np.ndarray, eyeball_radius: float,
             surface: np.ndarray, weight: np.ndarray) -> LidRig:
    """:class:`.kinematics.LidRig` on the mesh's own vertices around one eye: the margins are the landmark
    contours (densified, so vertices between landmarks are on the margin too), set up on the vertices near
    the eye only (the rig's reach is 22 mm) and spread back to all nodes; ``weight`` fades it off the face."""
    near = np.flatnonzero(np.linalg.norm(nodes - centre, axis=1) < 0.025)
    local = LidRig(centre, nodes[near], _densify(upper), _densify(lower), eyeball_radius=eyeball_radius,
                   surface=surface[near])
    lid = LidRig.__new__(LidRig)          # the same rig with its per-node arrays over all nodes
    lid.__dict__.update(local.__dict__)
    lid.surface = np.asarray(surface, bool)
    for name, fill in (("theta_u", 0.0), ("theta_l", 0.0), ("is_upper", False), ("weight", 0.0)):
        full = np.full(len(nodes), fill, dtype=np.asarray(getattr(local, name)).dtype)
        full[near] = getattr(local, name)
        setattr(lid, name, full)
    lid.weight = lid.weight * weight
    lid.index = np.flatnonzero(lid.weight > 0)
    return lid


def _nearest_active(vertices: np.ndarray, active: np.ndarray, points: np.ndarray) -> np.ndarray:
    index = np.flatnonzero(active)
    return index[cKDTree(vertices[index]).query(points)[1]]


def build_fitted_rig(vertices, faces, landmarks=None, *, seed: int = 0, progress=None,
                     material: SkinMaterial | None = None, resolution: str = "default",
                     inputs: TemplateInputs | None = None) -> "FittedFaceRig":
    """A face rig whose skin is the artist's mesh (module docstring).

    ``vertices`` (n, 3) and ``faces`` (m, 3) triangles in the mesh's coordinates (the head facing -Y,
    Z up, any scale and position); ``landmarks`` the 468 canonical landmarks on it (mesh coordinates) as
    the artist edited them, else they are located automatically (seeded by ``seed``). ``progress(fraction,
    message)`` is called now and then. Raises :class:`UserError` for unusable meshes; problems that still
    leave a usable rig (no mouth opening, closed eyes) are listed in ``rig.warnings``.
    """
    head = fit_head(vertices, faces, landmarks, seed=seed, progress=progress, resolution=resolution,
                    inputs=inputs)
    return FittedFaceRig(head, material)


class OwnBoneGuard(BoneHalfSpaceGuard):
    """The skull guard of a fitted head (thesis 3.1.2 "Mass Spring Network": the mirrored attachments keep
    the skin off the bone "except for very violent movements"; the guard covers those): each node is
    guarded against its *own* bone only, and its tangent plane is re-anchored (on the exact closest point
    of that bone) only when the node has slid over the bone, measured in the bone's own frame.

    The default head's guard re-anchors a node on the nearest vertex of whichever bone is nearest once the
    node has moved 1.5 mm in the world. On fitted heads of other proportions that misfires twice: chin skin
    swinging down and back with the opening jaw passes within reach of the upper teeth and is held by their
    plane (the chin crumples), and a node carried by the jaw, moving with it, is re-anchored every frame on
    a nearest bone *vertex* whose plane can cut through the node's own rest place at the mandible's lower
    border (held by millimetres). Skin carried by a bone cannot reach the other bone from outside, and its
    rest plane stays valid while it rides with its bone; the lips, where both bones matter, are left to the
    teeth guard as on the default head. A new plane must leave the node's own rest place outside (a node
    lagging behind its bone over a concave part of it would otherwise get a plane across its way back).
    ``_last`` holds the node positions in their bone's frame.
    """

    @classmethod
    def from_guard(cls, guard: BoneHalfSpaceGuard) -> "OwnBoneGuard":
        out = cls.__new__(cls)
        out.__dict__.update(guard.__dict__)
        out.own = guard.bone.copy()
        return out

    def refresh(self, positions: np.ndarray, everything: bool = False) -> None:
        """Re-anchor the planes of the nodes that slid ``_moved`` metres over their own bone."""
        if not self._surfaces or self._exact is None:
            return
        all_x = positions[:, self.nodes]
        local = np.empty_like(all_x)
        for bone, matrix in enumerate(self._transforms):
            mine = self.own == bone
            local[:, mine] = matrix[:3, :3].T @ (all_x[:, mine] - matrix[:3, 3:4])    # into the bone's frame
        if self._last is None or everything:
            active = np.arange(len(self.nodes))
        else:
            step = local - self._last
            active = np.flatnonzero(np.einsum("ij,ij->j", step, step) > self._moved ** 2)
        for bone, matrix in enumerate(self._transforms):
            mine = active[self.own[active] == bone]
            if not len(mine):
                continue
            point, normal = self._exact(bone, local[:, mine].T)
            # a plane that would push the node's own rest place (its target when nothing pulls it) into the
            # bone is the wrong one (a node lagging behind its bone over a concave part of it)
            ok = np.einsum("ij,ij->i", self._rest[:, mine].T - point, normal) >= self.clearance[mine]
            if self._facing is not None:
                ok &= np.einsum("ij,ij->i", normal @ matrix[:3, :3].T, self._facing[:, mine].T) > 0.2
            self.local_point[:, mine[ok]], self.local_normal[:, mine[ok]] = point[ok].T, normal[ok].T
        if self._last is not None and len(active):
            self._last[:, active] = local[:, active]
        self._pose(active)


class FittedFaceRig(FaceRig):
    """:class:`.rig.FaceRig` on the artist's mesh: same controls and simulation, outputs in mesh coordinates
    for all ``n`` vertices of the mesh (module docstring)."""

    def __init__(self, head: FittedHead, material: SkinMaterial | None = None) -> None:
        super().__init__(head.template, material)
        self.face.bone_guard = OwnBoneGuard.from_guard(self.face.bone_guard)
        self.fitted = head
        self.head_to_mesh = head.head_to_mesh.copy()
        self.warnings = list(head.warnings)
        self._linear = head.head_to_mesh[:3, :3].copy()
        self._passive_rest = head.head_vertices[head.passive]
        self._passive_offset = np.zeros_like(self._passive_rest)
        self._stepping = False

    # -- mesh coordinates ---------------------------------------------------------------------------------
    @property
    def faces(self) -> np.ndarray:
        """The mesh's own triangles (m, 3) int32."""
        return self.fitted.mesh_faces.astype(np.int32)

    @property
    def rest_positions(self) -> np.ndarray:
        """The mesh's vertices (n, 3) float32, exactly as given (mesh coordinates)."""
        return self.fitted.mesh_vertices.astype(np.float32)

    @property
    def positions(self) -> np.ndarray:
        """Current positions of all n mesh vertices (n, 3) float32, mesh coordinates: the rest vertices
        plus the head-space displacement mapped by ``head_to_mesh`` (exactly the rest vertices at rest)."""
        if self._stepping:           # inside step_frame: the passive part is not updated yet, nobody reads it
            return None
        head = self.fitted
        offset = np.zeros_like(head.mesh_vertices)
        offset[head.network_nodes] = self.face.network.positions.T - self._rest
        offset[head.passive] = self._passive_offset
        return np.ascontiguousarray(head.mesh_vertices + offset @ self._linear.T, dtype=np.float32)

    @property
    def landmarks(self) -> np.ndarray:
        """The 468 landmarks the rig was fitted to (468, 3), mesh coordinates, at rest."""
        return self.fitted.landmarks.copy()

    def to_mesh(self, points: np.ndarray) -> np.ndarray:
        """Head-space points (k, 3) -> mesh coordinates."""
        return _transform(self.head_to_mesh, np.asarray(points, np.float64))

    def landmark_positions(self, positions: np.ndarray | None = None) -> np.ndarray:
        """The 468 landmarks (468, 3) on the current (or given) skin positions, mesh coordinates."""
        positions = self.positions if positions is None else np.asarray(positions)
        corners = positions[self.fitted.mesh_faces[self.fitted.landmark_triangles]].astype(np.float64)
        return np.einsum("ij,ijk->ik", self.fitted.landmark_barycentric, corners)

    def part_meshes(self) -> dict:
        return {name: replace(part, vertices=self.to_mesh(part.vertices))
                for name, part in super().part_meshes().items()}

    def bone_meshes(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        return {name: (self.to_mesh(v), f) for name, (v, f) in super().bone_meshes().items()}

    def rigid_transforms(self) -> dict[str, np.ndarray]:
        """4x4 matrices in mesh coordinates, applied to the (mesh-coordinate) rest meshes of the parts."""
        forward, back = self.head_to_mesh, np.linalg.inv(self.head_to_mesh)
        return {name: np.eye(4) if np.array_equal(m, np.eye(4)) else forward @ m @ back
                for name, m in super().rigid_transforms().items()}

    def muscle_fibres(self) -> list[tuple[str, np.ndarray, float]]:
        return [(name, self.to_mesh(line).astype(np.float32), value)
                for name, line, value in super().muscle_fibres()]

    def wrinkle_masks(self) -> dict[str, np.ndarray]:
        """Per-vertex weights (n,) float32 of each wrinkle region over the whole mesh."""
        return {name: mask.astype(np.float32) for name, mask in self.fitted.transfer.wrinkles.items()}

    # -- simulation ---------------------------------------------------------------------------------------
    def reset_state(self) -> None:
        super().reset_state()
        self._passive_offset = np.zeros_like(self._passive_rest)

    def step_frame(self, dt: float = 1 / 24) -> np.ndarray:
        """One frame (see :meth:`.rig.FaceRig.step_frame`); vertices beyond the face follow the jaw by their
        weight. Returns the positions of all mesh vertices (mesh coordinates)."""
        self._stepping = True
        try:
            FaceRig.step_frame(self, dt)
        finally:
            self._stepping = False
        self._passive_offset = self._passive_motion()
        return self.positions

    def _passive_motion(self) -> np.ndarray:
        """Head-space offsets of the vertices outside the network: carried by the jaw by their weight, or
        rigidly by the part (eye, teeth, tongue) a separate piece of the mesh lies on."""
        jaw, rest, head = self._jaw_now, self._passive_rest, self.fitted
        offset = head.passive_jaw[:, None] * (rest @ jaw[:3, :3].T + jaw[:3, 3] - rest)
        if np.any(head.passive_carrier >= 0):
            transforms = FaceRig.rigid_transforms(self)
            for index, name in enumerate(CARRIERS):
                select = np.flatnonzero(head.passive_carrier == index)
                if len(select):
                    matrix = transforms[name]
                    offset[select] = rest[select] @ matrix[:3, :3].T + matrix[:3, 3] - rest[select]
        return offset

    # -- persistence --------------------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write the rig (.npz, no pickle): the mesh and landmarks it was fitted to, the template inputs,
        material, controls and simulation state. :meth:`load` refits from them (deterministic)."""
        head = self.fitted
        meta, arrays = self._saved_state(head.inputs)  # the inputs the fit started from, not the warped ones
        meta.update(format=FORMAT, resolution=head.resolution, seed=head.seed, warnings=self.warnings)
        arrays.update(mesh_vertices=head.mesh_vertices, mesh_faces=head.mesh_faces.astype(np.int32),
                      landmarks=head.landmarks, passive_offset=self._passive_offset)
        self._write(path, meta, arrays)

    @classmethod
    def load(cls, path: str | Path) -> "FittedFaceRig":
        """Read a rig written by :meth:`save` (never unpickles anything); refits deterministically."""
        saved = read_saved_rig(path, FORMAT, "fitted face rig",
                               extra=("mesh_vertices", "mesh_faces", "landmarks", "passive_offset"))
        mesh = (saved.arrays["mesh_vertices"], saved.arrays["mesh_faces"], saved.arrays["landmarks"])
        head = fit_head(*mesh, seed=int(saved.meta["seed"]), resolution=saved.meta["resolution"],
                        inputs=saved.inputs)
        rig = cls(head, SkinMaterial(**saved.meta["material"]))
        rig.warnings = list(saved.meta.get("warnings", rig.warnings))
        if saved.arrays["positions"].shape != rig.face.network.positions.shape:
            raise UserError(f"{path}: the saved state does not match the refitted rig; fit the rig again")
        rig._restore_state(saved)
        rig._passive_offset = np.array(saved.arrays["passive_offset"], np.float64)
        return rig


def is_fitted_rig_file(path: str | Path) -> bool:
    """Does ``path`` hold a rig written by :meth:`FittedFaceRig.save`? (False for anything unreadable.)"""
    try:
        with np.load(Path(path), allow_pickle=False) as data:
            return json.loads(bytes(data["meta_json"]).decode("utf-8")).get("format") == FORMAT
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):   # not ours: FaceRig.load reports it
        return False
