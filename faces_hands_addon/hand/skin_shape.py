# SPDX-License-Identifier: GPL-3.0-or-later
"""Rounded fingers, thumb and thenar eminence for the reference skin (thesis 6.2.1: the skin surface around
the 29 bones, Fig. 6.13; the thenar eminence it must show so the geometric muscles of Fig. 6.18 can swell it).

The WebXR hand warped onto the myo-sim bones (:mod:`.skin`, step 1) keeps its own finger sections where its
joints were, not where the bones are: the thumb came out a cone (33 mm round its metacarpal, 5 mm off its
distal bone on one side), the ring and little finger bases flat-sided boxes. So every phalanx (and the thumb
metacarpal) gets a *target section*: a capsule round the bone axis whose section is an ellipse of half-width
``a`` (across the finger, along the flexion axis x) and half-depths ``dorsal``/``palmar`` (the palm side is -y,
where flexion moves the tip; the finger pads are thicker than the back), growing linearly from the bone's
head to its tail (values in :data:`SECTIONS`, millimetres, from adult hand anthropometry: finger breadths at
the joints about 15-22 mm, depths about 0.85 of the breadth; the thumb metacarpal's palmar half-depth is the
thenar eminence). Distal bones end in a round cap ``TIP_PAD`` past the bone.

A skin node moves towards the targets of its finger's bones by its skinning weights on them, faded in over
``WEB`` of a proximal phalanx's length from its base; a node's blend of its targets is smoothed over the mesh,
so no seam shows where a target fades out. The finger bases themselves (web and knuckles, where the asset
folds once its fingers sit on the bones) become a Laplace membrane between palm and finger
(:func:`web_membrane`), and what folds remain on the fingers is relaxed (:func:`relax_folds`).
"""
from __future__ import annotations

import numpy as np
from scipy import sparse
import scipy.sparse.linalg  # noqa: F401  (sparse.linalg)

from ..core import geometry
from .skeleton import Skeleton

__all__ = ["SECTIONS", "FINGER_SCALE", "TIP_PAD", "WEB", "WEB_SIDES", "shape_skin", "section_radius", "relax_folds",
           "smooth_field", "web_membrane", "fold_vertices", "restore_web_sides"]

#: bone-name suffix -> (a, dorsal, palmar) at the bone's head and at its tail, mm
SECTIONS = {
    "phalanx-proximal": ((10.0, 7.5, 10.0), (8.8, 6.5, 8.8)),
    "phalanx-intermediate": ((8.8, 6.5, 8.8), (8.0, 5.8, 8.0)),
    "phalanx-distal": ((8.0, 5.8, 8.0), (7.2, 5.0, 7.4)),
}
THUMB_SECTIONS = {
    "metacarpal": ((14.0, 9.0, 17.0), (11.5, 8.0, 12.5)),
    "phalanx-proximal": ((11.0, 8.0, 10.5), (10.0, 7.0, 9.5)),
    "phalanx-distal": ((10.0, 7.0, 9.5), (9.0, 6.0, 8.5)),
}
FINGER_SCALE = {"index": 1.0, "middle": 1.03, "ring": 0.96, "pinky": 0.9}
#: bone-name suffix -> mm of fat pad added to the palmar half-depth at the bone's head and at its tail (the
#: palm side of a phalanx carries the pulp, the back is thin), so a curled finger's inside is filled, not
#: hollow. The proximal phalanges keep theirs in the web (a pad there folds the web into the neighbour's
#: crease in the curled poses), except the little finger's, whose curl showed light through it
PADS = {"phalanx-proximal": (0.0, 0.0), "phalanx-intermediate": (3.0, 3.0), "phalanx-distal": (2.0, 2.0)}
PINKY_PROXIMAL_PAD = (3.0, 3.0)
TIP_PAD = 0.002       # m of pulp past the tip of a distal bone
WEB = (0.12, 0.45)     # fade-in of a proximal phalanx's target over this part of its length
THUMB_BASE = (0.05, 0.35)   # the same for the thumb metacarpal (the carpus keeps its shape)
SMOOTHING = 4          # umbrella iterations on the blend strength
#: finger -> (its neighbour, share of its target section restored) for :func:`restore_web_sides`
WEB_SIDES = {"middle": ("ring", 1.02), "ring": ("middle", 0.95)}
WEB_SIDE_SPAN = (0.3, 0.5)     # restored from 0.3 of the proximal phalanx, fully from 0.5
WEB_SIDE_FACING = (0.2, 0.6)   # ... on the side facing the neighbour: cosine to it from 0.2, fully from 0.6


def _sections(name: str):
    parts = name.split("-")
    finger = parts[0]
    suffix = "-".join(parts[1:]) if finger == "thumb" else "-".join(parts[2:])
    if finger == "thumb":
        return THUMB_SECTIONS.get(suffix), 1.0
    if finger in FINGER_SCALE and suffix in SECTIONS:
        pad = PINKY_PROXIMAL_PAD if (finger, suffix) == ("pinky", "phalanx-proximal") else PADS[suffix]
        (a0, d0, p0), (a1, d1, p1) = SECTIONS[suffix]
        return ((a0, d0, p0 + pad[0]), (a1, d1, p1 + pad[1])), FINGER_SCALE[finger]
    return None, 1.0


def section_radius(u: np.ndarray, frame: np.ndarray, a: np.ndarray, dorsal: np.ndarray,
                   palmar: np.ndarray) -> np.ndarray:
    """Distance from the axis to the target ellipse (capsule) in unit directions ``u`` (N, 3)."""
    ux, uy, uz = u @ frame[:, 0], u @ frame[:, 1], u @ frame[:, 2]
    depth = np.where(uy > 0, dorsal, palmar)
    return 1.0 / np.sqrt((ux / a) ** 2 + (uy / depth) ** 2 + (uz / a) ** 2)


def _target(vertices: np.ndarray, skeleton: Skeleton, b: int, sections, scale: float):
    """(target points (N, 3), fade (N,)) of bone ``b``'s capsule for every vertex."""
    head, tail = skeleton.position[b], skeleton.tail[b]
    z = tail - head
    length = float(np.linalg.norm(z))
    z = z / length
    distal = skeleton.names[b].endswith("distal")
    (a0, d0, p0), (a1, d1, p1) = (np.array(s) * scale / 1000.0 for s in sections)
    end = length + (TIP_PAD - a1 if distal else 0.0)
    raw = (vertices - head) @ z
    along = np.clip(raw, 0.0, end)
    s = along / length
    centre = head + along[:, None] * z
    d = vertices - centre
    u = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)
    radius = section_radius(u, skeleton.frame[b], a0 + s * (a1 - a0), d0 + s * (d1 - d0), p0 + s * (p1 - p0))
    low, high = THUMB_BASE if skeleton.names[b] == "thumb-metacarpal" else (
        WEB if skeleton.names[b].endswith("proximal") else (-1.0, -0.5))
    fade = np.clip((raw / length - low) / (high - low), 0.0, 1.0)
    return centre + u * radius[:, None], fade


def smooth_field(field: np.ndarray, faces: np.ndarray, iterations: int) -> np.ndarray:
    """``field`` (N, K) on the mesh's vertices, averaged half-and-half with its neighbours ``iterations`` times."""
    edges = geometry.unique_edges(faces)
    n = len(field)
    adjacency = sparse.coo_matrix((np.ones(2 * len(edges)), (np.r_[edges[:, 0], edges[:, 1]],
                                                              np.r_[edges[:, 1], edges[:, 0]])), (n, n)).tocsr()
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    for _ in range(iterations):
        field = 0.5 * field + 0.5 * (adjacency @ field) / np.maximum(degree, 1)[:, None]
    return field


def shape_skin(vertices: np.ndarray, faces: np.ndarray, weights: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """The skin ``vertices`` moved onto the target sections of the fingers and thumb (module docstring).
    A node follows the targets of one finger only, the one it is weighted to most (an average of two
    fingers' targets would lie between them)."""
    shaped = [(b, *_sections(name)) for b, name in enumerate(skeleton.names) if _sections(name)[0] is not None]
    finger = {b: skeleton.names[b].split("-")[0] for b, _, _ in shaped}
    fingers = sorted(set(finger.values()))
    per_finger = np.stack([sum(weights[:, b] for b, _, _ in shaped if finger[b] == f) for f in fingers], axis=1)
    own = np.array(fingers)[np.argmax(per_finger, axis=1)]
    pull = np.zeros_like(vertices)
    strength = np.zeros(len(vertices))
    for b, sections, scale in shaped:
        target, fade = _target(vertices, skeleton, b, sections, scale)
        w = weights[:, b] * fade * (own == finger[b])
        pull += w[:, None] * target
        strength += w
    target = np.where(strength[:, None] > 1e-9, pull / np.maximum(strength, 1e-12)[:, None], vertices)
    strength = smooth_field(np.clip(strength, 0.0, 1.0)[:, None], faces, SMOOTHING)[:, 0]
    return vertices + strength[:, None] * (target - vertices)


def fold_vertices(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Vertices on edges whose two faces meet at more than 90 degrees (a fold or a flap)."""
    normals = geometry.face_normals(vertices, faces)
    corners = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    owner = np.tile(np.arange(len(faces)), 3)
    key = np.sort(corners, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    key, owner = key[order], owner[order]
    same = np.all(key[1:] == key[:-1], axis=1)
    a, b = owner[:-1][same], owner[1:][same]
    folded = np.einsum("ij,ij->i", normals[a], normals[b]) < 0.0
    return np.unique(key[:-1][same][folded])


def relax_folds(vertices: np.ndarray, faces: np.ndarray, movable: np.ndarray, rounds: int = 8, rings: int = 2,
                iterations: int = 12) -> np.ndarray:
    """Smooth the skin only round its folds (edges sharper than 90 degrees, left where the asset's web met
    a finger's new section), ``rings`` edges wide, until none is left or ``rounds`` are done. Only ``movable``
    nodes (N,) bool move: smoothing the folds of the asset's wrist rim would pinch the forearm."""
    edges = geometry.unique_edges(faces)
    n = len(vertices)
    adjacency = sparse.coo_matrix((np.ones(2 * len(edges)), (np.r_[edges[:, 0], edges[:, 1]],
                                                              np.r_[edges[:, 1], edges[:, 0]])), (n, n)).tocsr()
    degree = np.maximum(np.asarray(adjacency.sum(axis=1)).ravel(), 1)
    out = vertices.copy()
    for _ in range(rounds):
        sharp = fold_vertices(out, faces)
        if len(sharp) == 0:
            break
        region = np.zeros(n, bool)
        region[sharp] = True
        for _ in range(rings):
            region |= np.asarray(adjacency @ region.astype(float)).ravel() > 0
        region &= movable
        for _ in range(iterations):
            mean = (adjacency @ out) / degree[:, None]
            out[region] += 0.5 * (mean[region] - out[region])
    return out


def web_membrane(vertices: np.ndarray, faces: np.ndarray, weights: np.ndarray, skeleton: Skeleton,
                 span: tuple[float, float] = (-0.05, 0.4)) -> np.ndarray:
    """The finger bases as a membrane: the skin nodes of the four fingers' proximal phalanges from ``span[0]``
    to ``span[1]`` of the bone's length (the web and the knuckles, where the asset's surface folds once its
    fingers sit on the bones) are placed by the discrete Laplace equation, fixed by the palm round them and
    the rounded finger beyond: a smooth sheet from palm to finger, the web between two fingers."""
    owner = weights.argmax(axis=1)
    free = np.zeros(len(vertices), bool)
    for finger in ("index", "middle", "ring", "pinky"):
        b = skeleton.index[f"{finger}-finger-phalanx-proximal"]
        head, tail = skeleton.position[b], skeleton.tail[b]
        s = (vertices - head) @ (tail - head) / float(np.dot(tail - head, tail - head))
        free |= (owner == b) & (s > span[0]) & (s < span[1])
    edges = geometry.unique_edges(faces)
    n = len(vertices)
    adjacency = sparse.coo_matrix((np.ones(2 * len(edges)), (np.r_[edges[:, 0], edges[:, 1]],
                                                              np.r_[edges[:, 1], edges[:, 0]])), (n, n)).tocsr()
    laplacian = sparse.diags(np.asarray(adjacency.sum(axis=1)).ravel()) - adjacency
    idx, fixed = np.flatnonzero(free), np.flatnonzero(~free)
    if len(idx) == 0:
        return vertices
    system = laplacian[idx][:, idx].tocsc()
    rhs = -(laplacian[idx][:, fixed] @ vertices[fixed])
    out = vertices.copy()
    out[idx] = sparse.linalg.spsolve(system, rhs).reshape(len(idx), 3)
    return out


def restore_web_sides(vertices: np.ndarray, weights: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """The facing sides of the middle and ring fingers' proximal phalanges brought back out to their target
    sections (:data:`WEB_SIDES`; 6.2.1, Fig. 6.13: the fingers touch above the web). Relaxing the folds of the
    asset's web shrinks the finger round it to 0.7-0.8 of its section from 0.4 to 0.65 of the bone, and the
    web between these two, whose commissure reaches only 0.45-0.57, then showed light through it seen from the
    palm (16-21 mm^2). Only outward: a node already outside its section stays; the share below 1 on the ring
    finger keeps its side off the web's triangles when the two fingers curl differently."""
    owner = weights.argmax(axis=1)
    out = vertices.copy()
    for finger, (other, share) in WEB_SIDES.items():
        b, o = (skeleton.index[f"{f}-finger-phalanx-proximal"] for f in (finger, other))
        sections, scale = _sections(skeleton.names[b])
        head, tail = skeleton.position[b], skeleton.tail[b]
        length = float(np.linalg.norm(tail - head))
        z = (tail - head) / length
        s = (vertices - head) @ z / length
        mine = np.flatnonzero((owner == b) & (s > WEB_SIDE_SPAN[0]))
        target, _ = _target(vertices[mine], skeleton, b, sections, scale)
        centre = head + np.outer((vertices[mine] - head) @ z, z)
        offset = vertices[mine] - centre
        r = np.linalg.norm(offset, axis=1)
        u = offset / np.maximum(r, 1e-12)[:, None]
        toward = skeleton.position[o] - head
        toward -= (toward @ z) * z
        toward /= np.linalg.norm(toward)
        w = np.clip((s[mine] - WEB_SIDE_SPAN[0]) / (WEB_SIDE_SPAN[1] - WEB_SIDE_SPAN[0]), 0.0, 1.0)
        w *= np.clip((u @ toward - WEB_SIDE_FACING[0]) / (WEB_SIDE_FACING[1] - WEB_SIDE_FACING[0]), 0.0, 1.0)
        grow = np.maximum(share * np.linalg.norm(target - centre, axis=1) - r, 0.0) * w
        out[mine] += u * grow[:, None]
    return out
