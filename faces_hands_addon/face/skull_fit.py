# SPDX-License-Identifier: GPL-3.0-or-later
"""Stage 2 of the template build: fit skull and jaw inside the skin (thesis 3.1.2 "Building the Reference
Head": "both meshes are interactively equipped with anthropometric landmarks. The bones are then
transformed to fit the skin geometry using these landmarks and a radial basis warping function").

The skin landmarks are MediaPipe vertices (``presets/face/landmarks.json``). Each bone landmark's target
lies the published soft-tissue depth straight under its skin landmark (along the inward normal). The bone
landmarks themselves are found automatically instead of by hand: a similarity transform (scale, rotation,
translation) is fitted to the targets by iterating closest points on the right bone (skull or jaw), and
the final closest points are the bone landmarks. A thin-plate radial-basis warp then carries them
exactly onto their targets, with a ring of far-away skull points held to the similarity so the cranium
behind the face keeps its shape. The same warp moves skull and jaw (they share one frame). Finally, where
bone still comes closer to the skin than a fraction of the published depth (between landmarks), it is
pushed back under the skin (:func:`push_behind_skin`, smoothed over the bone mesh).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.errors import UserError
from ..physics.rbf import RBFWarp
from ..core import geometry
from ..core.geometry import similarity_transform
from ..core.presets import NUMBER, PresetFormat, parse_preset, read_preset_text, register_format, resolve

__all__ = ["Landmark", "BoneFit", "load_landmarks", "parse_landmarks", "fit_bones", "similarity_transform", "FORMAT"]

FORMAT = register_format(PresetFormat("faces_hands.face_landmarks", 1, required=("landmarks",),
                                     shape={"about": str, "landmarks": [{"name": str, "index": NUMBER,
                                                                          "depth_mm": NUMBER, "bone": str}],
                                            "skull_hints": {}}))


@dataclass(frozen=True)
class Landmark:
    name: str
    index: int          # canonical-face vertex
    depth: float        # soft-tissue thickness, m
    bone: str           # "skull" or "jaw"


@dataclass
class BoneFit:
    """Fitted bones in head coordinates plus what the later stages need."""
    skull_vertices: np.ndarray
    skull_faces: np.ndarray
    jaw_vertices: np.ndarray
    jaw_faces: np.ndarray
    landmarks: list[Landmark]
    skin_points: np.ndarray        # (K, 3) skin landmarks
    bone_points: np.ndarray        # (K, 3) their bone counterparts after the fit (= targets)
    similarity: np.ndarray         # 4x4, source bone frame -> head, before the RBF refinement
    tmj_pivot: np.ndarray          # (3,) midpoint of the two condyles
    tmj_axis: np.ndarray           # (3,) unit, from the right condyle to the left one (+X)
    condyles: np.ndarray           # (2, 3) right, left
    jaw_glide: np.ndarray = field(default_factory=lambda: np.zeros(3))   # condylar glide at full opening


def load_landmarks(path: Path | None = None) -> tuple[list[Landmark], dict]:
    """Landmarks and skull hints from ``presets/face/landmarks.json`` (or ``path``)."""
    path = Path(path) if path else resolve("face/landmarks.json")
    return parse_landmarks(read_preset_text(path), str(path), legacy=False)


def parse_landmarks(text: str, where: str = "landmarks.json", legacy: bool = True) -> tuple[list[Landmark], dict]:
    """Landmarks and skull hints from the JSON text of a landmark table (``legacy``: header-less text
    stored in rigs saved before presets had headers is accepted)."""
    path = where
    doc = parse_preset(text, where, FORMAT.name, legacy=legacy)
    try:
        marks = [Landmark(str(r["name"]), int(r["index"]), float(r["depth_mm"]) / 1000.0, str(r["bone"]))
                 for r in doc["landmarks"]]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise UserError(f"{path}: cannot read the landmark table ({exc}); restore the preset") from None
    for mark in marks:
        if mark.bone not in ("skull", "jaw") or not 0 <= mark.depth < 0.05:
            raise UserError(f"{path}: landmark {mark.name} needs bone 'skull'/'jaw' and a depth of 0-50 mm")
    return marks, doc.get("skull_hints", {})


def _apply(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def fit_bones(canonical_vertices: np.ndarray, canonical_normals: np.ndarray, skull_vertices: np.ndarray,
              skull_faces: np.ndarray, jaw_vertices: np.ndarray, jaw_faces: np.ndarray,
              landmarks: list[Landmark], hints: dict, iterations: int = 20,
              skin_nodes: np.ndarray | None = None, skin_faces: np.ndarray | None = None,
              skin_normals: np.ndarray | None = None, clearance: np.ndarray | None = None,
              refinements: int = 4) -> BoneFit:
    """Fit skull and jaw to the skin landmarks (see the module docstring). Deterministic.

    With the skin mesh (``skin_nodes``, ``skin_faces``, ``skin_normals``) and ``clearance`` (minimum skin
    thickness per node, m; 0 = not checked) the warped bones are then pushed under the skin wherever
    they come too close (:func:`push_behind_skin`).
    """
    skin = np.asarray(canonical_vertices, np.float64)
    normals = np.asarray(canonical_normals, np.float64)
    index = np.array([m.index for m in landmarks])
    if index.max() >= len(skin):
        raise UserError("a landmark refers to a vertex the canonical face does not have")
    depth = np.array([m.depth for m in landmarks])
    on_jaw = np.array([m.bone == "jaw" for m in landmarks])
    skin_points = skin[index]
    targets = skin_points - normals[index] * depth[:, None]

    # start: scale/translate the hinted nasion and menton onto their targets
    names = [m.name for m in landmarks]
    try:
        hint_n, hint_m = np.array(hints["nasion"], float), np.array(hints["menton"], float)
        t_n, t_m = targets[names.index("nasion")], targets[names.index("menton")]
    except (KeyError, ValueError):
        raise UserError("landmarks.json needs 'nasion' and 'menton' landmarks and skull_hints") from None
    scale = np.linalg.norm(t_n - t_m) / max(np.linalg.norm(hint_n - hint_m), 1e-9)
    current = np.eye(4)
    current[:3, :3] *= scale
    current[:3, 3] = t_n - scale * hint_n

    bone_source = np.zeros_like(targets)
    for _ in range(iterations):
        inverse = np.linalg.inv(current)
        local_targets = _apply(inverse, targets)
        for mask, verts, faces in ((~on_jaw, skull_vertices, skull_faces), (on_jaw, jaw_vertices, jaw_faces)):
            if np.any(mask):
                point, _, _, _ = geometry.closest_points(verts, faces, local_targets[mask])
                bone_source[mask] = point
        current = similarity_transform(bone_source, targets)

    # far-away skull points keep the similarity (so the cranium behind the face is only scaled)
    centre = skull_vertices.mean(0)
    extent = skull_vertices.max(0) - skull_vertices.min(0)
    far_local = []
    for sx in (-0.25, 0.25):
        for sz in (0.0, 0.5):
            far_local.append(centre + np.array([sx, 0.5, sz]) * extent)      # back of the cranium
    far_local.append(centre + np.array([0.0, 0.0, 0.5]) * extent)            # vertex
    far_local = np.array(far_local)
    source = np.vstack([bone_source, far_local])
    target = np.vstack([targets, _apply(current, far_local)])
    warp = RBFWarp(source, target, kernel="linear")
    skull_out = warp(skull_vertices)
    jaw_out = warp(jaw_vertices)
    if skin_nodes is not None and clearance is not None:
        skull_out = push_behind_skin(skull_out, skull_faces, skin_nodes, skin_faces, skin_normals, clearance,
                                     refinements)
        jaw_out = push_behind_skin(jaw_out, jaw_faces, skin_nodes, skin_faces, skin_normals, clearance,
                                   refinements)
    condyles = _condyles(jaw_out)
    pivot = condyles.mean(0)
    axis = condyles[1] - condyles[0]
    axis /= np.linalg.norm(axis)
    return BoneFit(skull_out, np.asarray(skull_faces, np.int64), jaw_out, np.asarray(jaw_faces, np.int64),
                   list(landmarks), skin_points, warp(bone_source), current, pivot, axis, condyles)


def push_behind_skin(bone: np.ndarray, bone_faces: np.ndarray, skin: np.ndarray, skin_faces: np.ndarray,
                     skin_normals: np.ndarray, clearance: np.ndarray, rounds: int = 4, spread: int = 12,
                     reach: float = 0.03) -> np.ndarray:
    """Move bone vertices that lie closer than ``clearance`` (per skin node, m; 0 = unchecked) under the
    skin, or outside it, back along the inward skin normal; the push is spread over the bone mesh so
    the surface stays smooth. Like the thesis' grid refinement, "so that [it] does not cut through the
    skin"."""
    bone = np.array(bone, np.float64)
    edges = geometry.unique_edges(bone_faces)
    degree = np.bincount(edges.ravel(), minlength=len(bone)).astype(np.float64)
    degree[degree == 0] = 1.0

    def neighbour_mean(values: np.ndarray) -> np.ndarray:
        out = np.zeros_like(values)
        for axis in range(values.shape[1]):
            out[:, axis] = (np.bincount(edges[:, 0], values[edges[:, 1], axis], len(values))
                            + np.bincount(edges[:, 1], values[edges[:, 0], axis], len(values)))
        return out / degree[:, None]

    checked_corner = clearance[skin_faces] > 0
    for _ in range(rounds):
        point, face, bary, dist = geometry.closest_points(skin, skin_faces, bone)
        normal = np.einsum("ij,ijk->ik", bary, skin_normals[skin_faces[face]])
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
        wanted = np.einsum("ij,ij->i", bary, clearance[skin_faces[face]])
        valid = checked_corner[face].all(axis=1) & (dist < reach)
        depth = np.einsum("ij,ij->i", point - bone, normal)
        need = np.where(valid, np.maximum(wanted - depth, 0.0), 0.0)
        if need.max() <= 1e-4:
            break
        push = -normal * need[:, None]
        spread_push = push.copy()
        for _ in range(spread):
            spread_push = 0.5 * spread_push + 0.5 * neighbour_mean(spread_push)
        larger = np.linalg.norm(push, axis=1) > np.linalg.norm(spread_push, axis=1)
        spread_push[larger] = push[larger]
        bone += spread_push
    return bone


def _condyles(jaw: np.ndarray) -> np.ndarray:
    """Condyle heads (right, left): on each side, the highest jaw points in the back half of the ramus
    (the coronoid process, also high, lies further forward)."""
    out = []
    y_mid = np.median(jaw[:, 1])
    for side in (-1.0, 1.0):
        part = jaw[(np.sign(jaw[:, 0]) == side) & (jaw[:, 1] > y_mid)]
        if len(part) < 3:
            raise UserError("the jaw mesh has no recognisable condyles; check the jaw asset")
        top = part[np.argsort(-part[:, 2], kind="stable")[:12]]
        out.append(top.mean(0))
    return np.array(out)
