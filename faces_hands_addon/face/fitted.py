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

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..core import geometry
from ..core.blas import one_blas_thread
from ..core.errors import UserError
from ..core.rig import write_rig_archive
from . import FITTED_FACE_RIG_FORMAT
from .mesh_template import network_template
from .network import SkinMaterial, under_ledge
from .persistence import read_saved_rig, restore_state, saved_state
from .rig import FaceRig
from .skull_fit import similarity_transform
from .template import CLOSED_LIP_COVER, HeadTemplate, TemplateInputs, build_template, default_inputs
from .transfer import CARRIERS, MeshTransfer, transfer_to_mesh

__all__ = ["FittedFaceRig", "FittedHead", "build_fitted_rig", "fit_head", "check_mesh", "MAX_VERTICES"]

MAX_VERTICES = 500_000
SYMMETRY_SNAP = 0.0003     # m in head space: landmarks this close to mirror-symmetric are made exactly so
SYMMETRY_OUTLIERS = 8      # ... all but this many (4 pairs) of the 468, which the openings may have moved
LANDMARK_COUNT = 468
INCISAL_SETTLED = 0.0002   # m: an upper incisal edge this near its place on the mesh's own lips is left there


def check_mesh(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """The artist's mesh as (N, 3) float64 vertices and (M, 3) int64 triangles, or a UserError that says
    what is wrong and what to do: the fitter's own checks (``fitting.surface.checked_mesh``: arrays,
    indices, NaN, degenerate), the face rig's size limit, and no non-manifold edges."""
    count = len(np.asarray(vertices).reshape(-1, 3)) if np.asarray(vertices).size else 0
    if count > MAX_VERTICES:
        raise UserError(f"the head mesh has {count:,} vertices; the face rig takes at most "
                        f"{MAX_VERTICES:,}: add a Decimate modifier, apply it and fit again")
    vertices, faces = geometry.checked_mesh(vertices, faces)
    _, counts = geometry.unique_edges(faces[_proper(faces)], return_counts=True)
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


def _flatness(points: np.ndarray) -> float:
    """Smallest over largest principal extent of ``points`` (0 on a plane, a line or a point)."""
    spread = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    return float(spread[2] / spread[0]) if spread[0] > 0 else 0.0


def _check_spread(landmarks: np.ndarray, canonical: np.ndarray) -> None:
    """Refuse landmarks that lie (nearly) on a point, a line or a plane (dragged together by hand, or seen on
    a mesh that is a single triangle, where they land when snapped to its surface): a face has depth, its smallest principal extent at least a
    quarter of the canonical face's share (0.47 of its largest)."""
    if _flatness(landmarks) < 0.25 * _flatness(canonical):
        raise UserError("the landmarks lie (nearly) on a point, a line or a plane, not on a face; place them on "
                        "the face's features (Edit Mode of the landmarks object) or locate them again on a head mesh")


def _symmetric_within(landmarks: np.ndarray, tolerance: float) -> np.ndarray:
    """Head-space landmarks that are mirror images of each other to within ``tolerance`` (m; a symmetric
    head's landmarks, :mod:`..fitting.symmetry`) made exactly so, so that the template built on them is
    (:func:`.template.build_template` symmetrises bones and attachments of a symmetric skin); others as
    they are. All but ``SYMMETRY_OUTLIERS`` of them must be: snapped onto the eye and mouth openings, a few
    lid and inner-lip landmarks of a symmetric head land millimetres off their partners' mirror images
    (population heads: 2 pairs at 2.3-3.4 mm, the 95th percentile 0.12-0.24 mm), and left unsymmetrised,
    the jaw of such a head opened one mouth corner 20 mm further than the other."""
    from .template import canonical_mirror
    mirror = canonical_mirror()
    mirrored = landmarks[mirror] * np.array([-1.0, 1.0, 1.0])
    deviation = np.sort(np.linalg.norm(landmarks - mirrored, axis=1))
    if deviation[-1 - min(SYMMETRY_OUTLIERS, len(deviation) - 1)] > tolerance:
        return landmarks
    return 0.5 * (landmarks + mirrored)


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
             inputs: TemplateInputs | None = None, forward: str | None = None, up: str | None = None) -> FittedHead:
    """Run stages 1-4 plus the network template (module docstring). ``forward``/``up`` name the mesh's
    axes for the automatic landmark location (:func:`..fitting.locate_landmarks`; default: searched).
    On one BLAS thread (:mod:`..core.blas`): the same mesh gives the same rig on any number of cores."""
    with one_blas_thread():
        return _fit_head(vertices, faces, landmarks, seed=seed, progress=progress, resolution=resolution,
                         inputs=inputs, forward=forward, up=up)


def _fit_head(vertices, faces, landmarks, *, seed: int, progress, resolution: str, inputs: TemplateInputs | None,
              forward: str | None, up: str | None) -> FittedHead:
    """:func:`fit_head` (module docstring, stages 1-4 plus the network template)."""
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
        fit = locate_landmarks(vertices, proper, seed=seed, forward=forward, up=up,
                               progress=lambda f, m: report(0.6 * f, m))
        landmarks, tri_local, bary = fit.positions, fit.triangles, fit.barycentric
        warnings += list(fit.warnings)
    else:
        from ..fitting import project_to_surface
        landmarks = _check_landmarks(landmarks)
        on_surface, tri_local, bary = project_to_surface(landmarks, vertices, proper)
        _check_spread(on_surface, np.asarray((inputs or default_inputs()).canonical_vertices, np.float64))
    landmark_triangles = proper_index[tri_local]
    # -- 2. normalise to head space ------------------------------------------------------------------------
    report(0.6, "building the head template")
    inputs = inputs or default_inputs()
    canonical = np.asarray(inputs.canonical_vertices, np.float64)
    _check_spread(landmarks, canonical)
    to_head = similarity_transform(landmarks, canonical)
    head_to_mesh = np.linalg.inv(to_head)
    head_vertices = _transform(to_head, vertices)
    head_landmarks = _symmetric_within(_transform(to_head, landmarks), SYMMETRY_SNAP)
    # -- 3. template on the registered canonical face -------------------------------------------------------
    registered = replace(inputs, canonical_vertices=head_landmarks, closed_lips=False)
    source = build_template(resolution, registered)
    # -- 4. transfer onto the artist's mesh ------------------------------------------------------------------
    report(0.8, "transferring the rig onto the mesh")
    transfer = transfer_to_mesh(source, head_vertices, proper, head_landmarks)
    height = incisal_height(transfer, head_vertices)
    if height is not None and abs(height - _incisal_edge(source)) > INCISAL_SETTLED:
        source = build_template(resolution, replace(registered, incisal_height=height))
        transfer = transfer_to_mesh(source, head_vertices, proper, head_landmarks)
    warnings += transfer.warnings
    report(0.9, "building the spring network")
    template, network_nodes, passive = network_template(source, transfer, head_vertices, proper, head_landmarks)
    report(1.0, "face rig fitted")
    return FittedHead(vertices, faces, landmarks, landmark_triangles, np.asarray(bary, np.float64), head_to_mesh,
                      head_vertices, source, template, transfer, network_nodes, passive,
                      np.where(transfer.carrier[passive] >= 0, 0.0, transfer.jaw_weight[passive]),
                      transfer.carrier[passive].copy(), inputs, resolution, int(seed), warnings)


def incisal_height(transfer: MeshTransfer, head_vertices: np.ndarray) -> float | None:
    """Head-space height of the upper incisal edge on the artist's mesh (3.1.2 "Eyes, Teeth, Tongue": the
    teeth are placed in the fitted head): ``CLOSED_LIP_COVER`` below the free edge of the mesh's own upper lip
    at the midline (the margin that meets the lower lip, :func:`.transfer._lip_margins`), as on the default
    head, whose closed lips cover the edge by as much. The registered landmarks' stomion, from which the
    template places the teeth, is not the mesh's: on heads modelled with their lips together it lay 1-5 mm
    off the line where the lips meet, which hid the upper teeth behind the upper lip in /f v/ and /a/, or
    showed them through closed lips. None when the mesh has no upper lip margin across the midline."""
    margin = np.asarray(transfer.lip_margins.get("lips_inner_upper", ()), np.int64)
    if len(margin) < 2:
        return None
    x, z = head_vertices[margin, 0], head_vertices[margin, 2]
    if not x.min() < 0.0 < x.max():
        return None
    order = np.argsort(x, kind="stable")
    return float(np.interp(0.0, x[order], z[order])) - CLOSED_LIP_COVER


def _incisal_edge(template: HeadTemplate) -> float:
    """Height of the template's upper incisal edge (its labial arch starts 1 mm above it, organs.arch_surface)."""
    return float(template.organs.arches["upper"][0][:, 2].min()) + 0.001


def build_fitted_rig(vertices, faces, landmarks=None, *, seed: int = 0, progress=None,
                     material: SkinMaterial | None = None, resolution: str = "default",
                     inputs: TemplateInputs | None = None, forward: str | None = None,
                     up: str | None = None) -> "FittedFaceRig":
    """A face rig whose skin is the artist's mesh (module docstring).

    ``vertices`` (n, 3) and ``faces`` (m, 3) triangles in the mesh's coordinates (any axis orientation,
    found automatically unless ``forward``/``up`` name it; any scale and position); ``landmarks`` the 468 canonical landmarks on it (mesh coordinates) as
    the artist edited them, else they are located automatically (seeded by ``seed``). ``progress(fraction,
    message)`` is called now and then. Raises :class:`UserError` for unusable meshes; problems that still
    leave a usable rig (no mouth opening, closed eyes) are listed in ``rig.warnings``.
    """
    head = fit_head(vertices, faces, landmarks, seed=seed, progress=progress, resolution=resolution,
                    inputs=inputs, forward=forward, up=up)
    return FittedFaceRig(head, material)


class FittedFaceRig(FaceRig):
    """:class:`.rig.FaceRig` on the artist's mesh: same controls and simulation, outputs in mesh coordinates
    for all ``n`` vertices of the mesh (module docstring)."""

    def __init__(self, head: FittedHead, material: SkinMaterial | None = None) -> None:
        super().__init__(head.template, material)
        self.face.bone_guard.keep_own_bones(refuse=under_ledge)
        self.fitted = head
        self.head_to_mesh = head.head_to_mesh.copy()
        self._mesh_to_head = np.linalg.inv(self.head_to_mesh)      # once: LAPACK's 4x4 inverse cost ~1 ms a tick
        self.warnings = list(head.warnings)
        self._linear = head.head_to_mesh[:3, :3].copy()
        self._passive_rest = head.head_vertices[head.passive]
        self._passive_offset = np.zeros_like(self._passive_rest)

    @classmethod
    def _copy_of(cls, rig: "FittedFaceRig") -> "FittedFaceRig":
        return cls(rig.fitted, rig.material)

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
        forward, back = self.head_to_mesh, self._mesh_to_head
        return {name: np.eye(4) if np.array_equal(m, np.eye(4)) else forward @ m @ back
                for name, m in super().rigid_transforms().items()}

    def _display_points(self, points: np.ndarray) -> np.ndarray:
        return self.to_mesh(points).astype(np.float32)

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

    def _advance(self, dt: float) -> None:
        """One frame of the state (see :meth:`.rig.FaceRig._advance`); vertices beyond the face follow the jaw
        by their weight. ``step_frame`` returns the positions of all mesh vertices (mesh coordinates)."""
        super()._advance(dt)
        self._passive_offset = self._passive_motion()

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
        meta, arrays = saved_state(self, head.inputs)  # the inputs the fit started from, not the warped ones
        meta.update(format=FITTED_FACE_RIG_FORMAT, resolution=head.resolution, seed=head.seed,
                    warnings=self.warnings)
        arrays.update(mesh_vertices=head.mesh_vertices, mesh_faces=head.mesh_faces.astype(np.int32),
                      landmarks=head.landmarks, passive_offset=self._passive_offset)
        write_rig_archive(path, meta, arrays)

    @classmethod
    def load(cls, path: str | Path) -> "FittedFaceRig":
        """Read a rig written by :meth:`save` (never unpickles anything); refits deterministically."""
        saved = read_saved_rig(path, FITTED_FACE_RIG_FORMAT, "fitted face rig",
                               extra=("mesh_vertices", "mesh_faces", "landmarks", "passive_offset"))
        mesh = (saved.arrays["mesh_vertices"], saved.arrays["mesh_faces"], saved.arrays["landmarks"])
        head = fit_head(*mesh, seed=int(saved.meta["seed"]), resolution=saved.meta["resolution"],
                        inputs=saved.inputs)
        rig = cls(head, SkinMaterial(**saved.meta["material"]))
        rig.warnings = list(saved.meta.get("warnings", rig.warnings))
        if saved.arrays["positions"].shape != rig.face.network.positions.shape:
            raise UserError(f"{path}: the saved state does not match the refitted rig; fit the rig again")
        restore_state(rig, saved)
        rig._passive_offset = np.array(saved.arrays["passive_offset"], np.float64)
        return rig

