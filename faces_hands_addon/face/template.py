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

from ..core import geometry
from ..core.errors import UserError
from ..core.presets import parse_preset, read_preset_text, resolve
from . import organs
from .attachment import (JAW, AttachmentMap, attach_to_bones, attach_to_muscles, lip_corners, lip_jaw_weight,
                         smoothing_operator)
from .kinematics import LidRig, opening_glide
from .muscle_layout import parse_muscle_specs, place_muscle
from .muscles import MuscleSystem
from .skin import EYEBALL_RADIUS, SkinMesh, build_skin, close_rest_lips
from .skull_fit import BoneFit, fit_bones, parse_landmarks

CLOSED_LIP_COVER = 0.0025    # m the closed lips' line lies above the upper incisal edge (lower lip over the edge)

__all__ = ["TemplateInputs", "SkinRecord", "OrganRecord", "HeadTemplate", "build_template", "default_inputs",
           "canonical_mirror"]


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
    closed_lips: bool = False        # close the canonical face's lips for the skin and muscles (default head)
    incisal_height: float | None = None  # head-space z of the upper incisal edge (a fitted head: its own lips)


@dataclass
class SkinRecord:
    """The skin and what every skin node knows about itself: the mesh (:class:`.skin.SkinMesh`: nodes,
    triangles, groups, contours; its fields read through this record), vertex normals and areas, the mouth
    region, the distance over the skin to the lip margins and the wrinkle-region masks. On a head fitted to
    an artist's mesh, ``kinematic`` marks the ring of nodes driven to their attachment target instead of
    simulated."""
    mesh: SkinMesh
    normals: np.ndarray                  # (N, 3)
    areas: np.ndarray                    # (N,) barycentric node areas
    mouth_region: np.ndarray             # (N,) bool: within ~2 cm of the lip margins, over the skin
    lip_distance: np.ndarray             # (N,) m over the skin to the nearest lip margin
    wrinkle_regions: dict[str, np.ndarray] = field(default_factory=dict)
    kinematic: np.ndarray | None = None

    vertices = property(lambda self: self.mesh.vertices)
    faces = property(lambda self: self.mesh.faces)
    groups = property(lambda self: self.mesh.groups)
    contours = property(lambda self: self.mesh.contours)
    eye_centres = property(lambda self: self.mesh.eye_centres)
    mouth_centre = property(lambda self: self.mesh.mouth_centre)
    node_count = property(lambda self: self.mesh.node_count)

    def group(self, name: str) -> np.ndarray:
        return self.mesh.group(name)

    @property
    def driven(self) -> bool:
        """It has a ring of driven (``kinematic``) nodes (a head fitted to an artist's mesh with more than a
        face: a face-only mesh is simulated to its border and has none)."""
        return self.kinematic is not None and bool(np.any(self.kinematic))

    @property
    def fitted(self) -> bool:
        """A head fitted to an artist's mesh (its record says which nodes are driven, perhaps none), not the
        template's own skin: what the fitted heads' skin-guard rules go by (``face.network._bone_guard``)."""
        return self.kinematic is not None


@dataclass
class OrganRecord:
    """Eyes, lids, teeth and tongue (3.1.2 "Eyes, Teeth, Tongue"): eyeball centres and radius, the lid rigs,
    the rigid part meshes, the tongue's pivot and the labial faces of the dental arches."""
    eye_centres: dict[str, np.ndarray]
    eye_radius: float
    lids: dict[str, LidRig]
    parts: dict[str, organs.PartMesh]
    tongue_pivot: np.ndarray
    arches: dict = field(default_factory=dict)   # "upper"/"lower" -> (points, normals) labial tooth faces


@dataclass
class HeadTemplate:
    """The assembled head (rest pose, head coordinates), one record per stage (module docstring)."""
    resolution: str
    inputs: TemplateInputs
    skin: SkinRecord
    bones: BoneFit
    muscles: MuscleSystem
    attachment: AttachmentMap
    organs: OrganRecord

    @property
    def node_count(self) -> int:
        return self.skin.node_count


def default_inputs() -> TemplateInputs:
    """Inputs for the default head: the committed assets and the face presets (the user's copies where
    there are any), validated here so a broken preset is reported before any work starts."""
    from .. import assets
    texts = {}
    for name in ("landmarks", "muscles"):
        path = resolve(f"face/{name}.json")
        texts[name] = read_preset_text(path)
        parse_preset(texts[name], str(path), f"faces_hands.face_{name}")
    face, skull, jaw = assets.canonical_face(), assets.skull(), assets.jaw()
    return TemplateInputs(face.vertices, face.faces, dict(assets.face_contours().lines), skull.vertices,
                          skull.faces, jaw.vertices, jaw.faces, texts["landmarks"], texts["muscles"], closed_lips=True)


def _skin_stage(canonical: np.ndarray, inputs: TemplateInputs, resolution: str):
    skin = build_skin(canonical, inputs.canonical_faces, inputs.contours, resolution)
    normals = geometry.vertex_normals(skin.vertices, skin.faces)
    return skin, normals, geometry.vertex_areas(skin.vertices, skin.faces)


def _bone_stage(canonical: np.ndarray, inputs: TemplateInputs, skin: SkinMesh, normals: np.ndarray):
    """Skull and jaw warped into the skin (tissue depths from the landmark preset), symmetrised for a
    symmetric skin, and every node attached to its bone."""
    nodes = skin.vertices
    canonical_normals = geometry.vertex_normals(canonical, np.asarray(inputs.canonical_faces))
    landmarks, hints = parse_landmarks(inputs.landmarks_json)
    eye_far = np.ones(len(nodes), bool)
    for centre in skin.eye_centres.values():
        eye_far &= np.linalg.norm(nodes - centre, axis=1) > EYEBALL_RADIUS + 0.006
    field_depth = _thickness_field(canonical, landmarks, nodes)
    clearance = np.where(skin.group("surface") & eye_far, np.maximum(0.5 * field_depth, 0.0025), 0.0)
    bones = fit_bones(canonical, canonical_normals, inputs.skull_vertices, inputs.skull_faces,
                      inputs.jaw_vertices, inputs.jaw_faces, landmarks, hints, skin_nodes=nodes,
                      skin_faces=skin.faces, skin_normals=normals, clearance=clearance)
    node_mirror = geometry.mirror_map(nodes, tolerance=1e-6)
    symmetric = bool(np.all(node_mirror >= 0))
    if symmetric:
        _symmetrise_bones(bones)
    bone_part, mouth_region, lip_distance = attach_to_bones(skin, bones, node_mirror if symmetric else None)
    _sagittal_tmj(bones)
    if symmetric:
        _symmetrise_tmj(bones)
    return bones, bone_part, mouth_region, lip_distance, (node_mirror if symmetric else None)


def _muscle_stage(canonical: np.ndarray, inputs: TemplateInputs, skin: SkinMesh, normals: np.ndarray,
                  bone_part: dict, node_mirror: np.ndarray | None):
    """Muscle grids from the muscle preset placed under the skin (3.1.2 "Building Muscles")."""
    mirror = geometry.mirror_map(canonical, tolerance=1e-3 * np.ptp(canonical[:, 0]))
    if np.any(mirror < 0):           # a registered (asymmetric) face: the canonical topology's own L/R map
        mirror = canonical_mirror()
    specs, connections = parse_muscle_specs(inputs.muscles_json, mirror)
    positive_depth = np.maximum(bone_part["bone_depth"], 0.0)
    if node_mirror is not None:
        positive_depth = np.minimum(positive_depth, positive_depth[node_mirror])
    on_jaw = (bone_part["node_bone"] == JAW).astype(float)
    placed = [place_muscle(s, canonical, skin.vertices, skin.faces, normals, positive_depth, on_jaw,
                           open_lips=not inputs.closed_lips) for s in specs]
    system = MuscleSystem(placed, connections, _mouth_axes(canonical))
    system.set_centres([s.centre.evaluate(canonical) if s.centre is not None else None for s in specs])
    if not inputs.closed_lips:      # the oris closes the parted rest lips the way close_rest_lips would
        oris = np.concatenate([np.full(m.shape[0] * m.shape[1], m.spec.group == "oris") for m in placed])
        points = np.vstack([canonical, system.rest])
        offsets = (close_rest_lips(points, inputs.contours) - points)[len(canonical):]
        system.set_rest_closing(np.where(oris[:, None], offsets, 0.0))
    return system, placed


def build_template(resolution: str = "default", inputs: TemplateInputs | None = None) -> HeadTemplate:
    """Run the four stages (module docstring). Deterministic: same inputs, same arrays."""
    inputs = inputs or default_inputs()
    canonical = np.asarray(inputs.canonical_vertices, np.float64)
    if canonical.shape != (468, 3) or not np.all(np.isfinite(canonical)):
        raise UserError("the face template needs the 468 canonical-face vertices as finite (468, 3) values")
    # soft tissue (skin, muscles) from the closed-lip face; skeleton and teeth from the face as given
    soft = close_rest_lips(canonical, inputs.contours) if inputs.closed_lips else canonical
    skin, normals, areas = _skin_stage(soft, inputs, resolution)
    bones, bone_part, mouth_region, lip_distance, node_mirror = _bone_stage(canonical, inputs, skin, normals)
    system, placed = _muscle_stage(soft, inputs, skin, normals, bone_part, node_mirror)
    muscle_matrix = attach_to_muscles(system, placed, skin, bone_part["node_bone"])
    _carry_lips(system, placed, skin)
    parts, lids, tongue_pivot, arches = _organs(skin, canonical, bones, skin.vertices,
                                                closed=soft if inputs.closed_lips else None,
                                                incisal_height=inputs.incisal_height)
    _seat_teeth_in_arches(bones, arches)
    incisor = parts["teeth_lower"].vertices[parts["teeth_lower"].vertices[:, 1].argmin()]
    bones.jaw_glide = opening_glide(bones.tmj_pivot, bones.tmj_axis, incisor * np.array([0.0, 1.0, 1.0]))
    smoothing, passes = smoothing_operator(skin)
    record = SkinRecord(skin, normals, areas, mouth_region, lip_distance,
                        _wrinkle_regions(skin, soft, skin.vertices))
    return HeadTemplate(resolution, inputs, record, bones, system,
                        AttachmentMap(**bone_part, muscle_matrix=muscle_matrix, smoothing=smoothing,
                                      smoothing_passes=passes),
                        OrganRecord(dict(skin.eye_centres), EYEBALL_RADIUS, lids, parts, tongue_pivot, arches))


def _carry_lips(system: MuscleSystem, placed: list, skin: SkinMesh) -> None:
    """The orbicularis oris halves are carried by the jaw like the lip skin over them (:func:`.attachment.
    lip_jaw_weight`: the upper half stays, the lower goes with the jaw, both half way at the corners)."""
    carry = system.jaw_carry.copy()
    corners = lip_corners(skin)
    for index, m in enumerate(placed):
        if m.spec.group != "oris":
            continue
        lower = bool(np.round(m.row_bone.mean()))
        margin = skin.vertices[skin.contours["lips_inner_lower" if lower else "lips_inner_upper"]]
        points = m.skin_points.reshape(-1, 3)
        distance, _ = cKDTree(margin).query(points)
        carry[system.slice(index)] = lip_jaw_weight(points[:, 0], np.full(len(points), lower), distance,
                                                    np.full(len(points), float(lower)), corners)
    system.set_jaw_carry(carry)


def _thickness_field(canonical: np.ndarray, landmarks, nodes: np.ndarray) -> np.ndarray:
    """Published tissue depth interpolated over the skin (inverse-distance weights of 4 landmarks)."""
    positions = canonical[[m.index for m in landmarks]]
    depth = np.array([m.depth for m in landmarks])
    dist, idx = cKDTree(positions).query(nodes, k=4)
    w = 1.0 / np.maximum(dist, 1e-4) ** 2
    return (w * depth[idx]).sum(1) / w.sum(1)


def canonical_mirror() -> np.ndarray:
    """Left/right vertex map of the MediaPipe canonical face (from the symmetric asset): the map belongs to
    the topology, so it also serves a canonical face registered onto an asymmetric head."""
    from .. import assets
    vertices = np.asarray(assets.canonical_face().vertices, np.float64)
    mirror = geometry.mirror_map(vertices, tolerance=1e-3 * np.ptp(vertices[:, 0]))
    if np.any(mirror < 0):
        raise UserError("the canonical face asset is not left/right symmetric; restore the assets")
    return mirror


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
    """For a symmetric head the jaw's hinge (left-right, :func:`_sagittal_tmj`) lies in the mid-sagittal plane."""
    bones.tmj_pivot = bones.tmj_pivot * np.array([0.0, 1.0, 1.0])


def _sagittal_tmj(bones: BoneFit) -> None:
    """Any head opens its jaw in the mid-sagittal plane (3.1.1: the jaw's rotation about the condyles, plus
    their forward glide): the hinge axis runs left-right (head-space X, the canonical face's) through the
    condyles' midpoint (the glide, computed from it, then has no sideways part). The condyles lie far
    behind the face landmarks the skull is warped by, so their fitted positions amplify a head's asymmetry:
    a population head whose skin is mirror-symmetric to 0.55 mm got condyles 6.6 mm apart in depth, a hinge
    yawed 3.8 degrees and a 2.2 mm sideways glide, and jawOpen moved one jaw angle 3.5 mm further than the
    other."""
    bones.tmj_axis = np.array([1.0, 0.0, 0.0])


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


def _organs(skin: SkinMesh, canonical: np.ndarray, bones: BoneFit, nodes: np.ndarray,
            closed: np.ndarray | None = None, incisal_height: float | None = None):
    parts = {}
    lids = {}
    for side, centre in skin.eye_centres.items():
        parts[f"eye_{side}"] = organs.eyeball_mesh(centre, EYEBALL_RADIUS, f"eye_{side}")
        upper = nodes[skin.contours[f"eye_{side}_upper"]]
        lower = nodes[skin.contours[f"eye_{side}_lower"]]
        is_up, is_low = skin.group(f"lid_upper_{side}"), skin.group(f"lid_lower_{side}")
        lids[side] = LidRig(centre, nodes, upper, lower, eyeball_radius=EYEBALL_RADIUS,
                            surface=skin.group("surface"), side=is_up.astype(int) - is_low.astype(int))
    # teeth: upper incisal edge 7.5 mm behind the stomion, 1 mm above it (lips parted, as a fitted head's
    # mesh has them), or CLOSED_LIP_COVER below it (lips closed at rest: the lower lip covers the edge),
    # or at ``incisal_height`` when given (a fitted head: from its own lips, fitted.incisal_height);
    # arch from the mouth width
    stomion = 0.5 * (canonical[13] + canonical[14])
    mouth_width = np.linalg.norm(canonical[291] - canonical[61])
    scale = mouth_width / 0.050
    incisal = stomion + np.array([0.0, 0.0075, 0.0010])
    if closed is not None:
        incisal = 0.5 * (closed[13] + closed[14]) + np.array([0.0, 0.0075, -CLOSED_LIP_COVER])
    if incisal_height is not None:
        incisal[2] = incisal_height
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
