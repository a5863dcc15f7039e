# SPDX-License-Identifier: GPL-3.0-or-later
"""The standalone hand on the MPFB2 base mesh's hand (CC0; the character's hands, :mod:`..character.mpfb2`),
the reference hand's skeleton, joint limits and muscles fitted into it (thesis 6.2.1 and 6.2.3). The
character package registers it with the hand as the skin ``mpfb2`` (:func:`..hand.register_hand_mesh`).

1. *Cut*: the base mesh's right hand (``body`` faces only: knuckles, nail plates, creases, thenar and
   hypothenar eminences as MakeHuman modelled them) up to a wrist ring on the forearm: every face with a
   vertex that MPFB2's hand bones move (any weight of ``wrist`` or a finger bone) is kept, so the ring is the
   next loop of vertices up the forearm, which only the forearm moves: the cut joins a forearm unchanged
   (measured on the base mesh: the wrist bone's weights reach about a quarter of the way to the elbow). Quads are split along their
   shorter diagonal; UVs are kept per face corner. The left hand is its mirror image (the base mesh is
   symmetric, ``hm08.mirror``), which the rig's ``side="left"`` gives.
2. *Frame*: the cut hand is turned (rotation only, a least-squares fit of its landmarks, Kabsch) into the
   reference hand's frame: wrist at the origin, fingers along -Z, the palm facing +X.
3. *Landmarks*: the joint centres of MPFB2's ``default`` skeleton (elbow, wrist, the thumb's CMC, MCP and IP,
   every finger's MCP, PIP and DIP, and the distal bones' tails as fingertips) are paired with the reference
   skeleton's joint centres and tips.
4. *Warp*: the biharmonic RBF warp of 6.2.3 (``f(x) = sum_i c_i ||x - s_i|| + affine part``,
   :class:`..physics.RBFWarp`) takes the reference skeleton onto those landmarks and carries everything else
   the template holds (bone meshes, carpal-metacarpal joints, geometric-muscle grids) with it
   (:func:`..hand.template.warped_template`); the joint frames are re-oriented along the new bones, the DOFs and
   limits of Table 6.4 and the pseudo muscles of Table A.1 are kept.
5. *Weights*: MPFB2's own skin weights for those bones (metacarpal1-4 -> the index..little metacarpals,
   finger1-* -> the thumb, fingerN-* -> the phalanges, wrist.R -> the wrist, the forearm bones -> the
   forearm), renormalised to sum 1, then widened over the mesh (:func:`widened`) so that each joint's blend
   zone is as long as the finger is thick there: MPFB2 blends a finger joint over about one ring of
   vertices, and the thesis' joint rotations (Table 6.4, up to 90-110 degrees) stretched the skin over the
   knuckle to 2.7 times its rest length with those weights alone. Each vertex keeps its four largest
   weights (renormalised), so the simulated hand is skinned exactly as every export plays it.
6. *Clearance*: skin closer than :data:`..hand.skin.CLEARANCE` to one of its own bones is pushed out (the warp
   puts the bones' centres on MPFB2's joints, not their surfaces inside MPFB2's fingers).

Masses and feature points (Table 6.5) are recomputed on the new skin.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components

from ..core import geometry, refine
from ..core.skinning import limit_influences
from ..hand.features import feature_points
from ..hand.inertia import segment_masses
from ..hand.skeleton import TIP_NAMES, Skeleton
from ..hand.skin import SkinMesh, push_out_of_bones
from ..hand.template import HandTemplate, warped_template
from ..physics import RBFWarp
from . import mpfb2

__all__ = ["mpfb2_hand_template", "hand_landmarks", "cut_hand", "mpfb2_weights", "widened", "SOURCE_SKELETON"]

SOURCE_SKELETON = "default"       # MPFB2's skeleton with metacarpal bones (game_engine has none)

#: reference bone (its head) -> MPFB2 bone (its head), right side
_HEADS = {"forearm": "lowerarm01", "wrist": "wrist", "thumb-metacarpal": "finger1-1",
          "thumb-phalanx-proximal": "finger1-2", "thumb-phalanx-distal": "finger1-3"}
for _k, _finger in enumerate(("index", "middle", "ring", "pinky"), start=2):
    for _j, _part in enumerate(("proximal", "intermediate", "distal"), start=1):
        _HEADS[f"{_finger}-finger-phalanx-{_part}"] = f"finger{_k}-{_j}"
#: reference tip -> MPFB2 bone whose tail is that fingertip
_TIPS = {tip: f"finger{k}-3" for k, tip in enumerate(TIP_NAMES, start=1)}
#: MPFB2 bone -> reference bone for the skin weights (anything else in the cut: the forearm)
_BONES_WEIGHTED = {"wrist": "wrist", "finger1-1": "thumb-metacarpal", "finger1-2": "thumb-phalanx-proximal",
                 "finger1-3": "thumb-phalanx-distal"}
for _k, _finger in enumerate(("index", "middle", "ring", "pinky"), start=1):
    _BONES_WEIGHTED[f"metacarpal{_k}"] = f"{_finger}-finger-metacarpal"
    for _j, _part in enumerate(("proximal", "intermediate", "distal"), start=1):
        _BONES_WEIGHTED[f"finger{_k + 1}-{_j}"] = f"{_finger}-finger-phalanx-{_part}"


def hand_landmarks(skeleton: Skeleton, side: str = "R") -> tuple[np.ndarray, np.ndarray]:
    """(reference points (K, 3), MPFB2 points (K, 3) in metres, this project's axes): joint centres and tips
    (module docstring, step 3)."""
    bones = {b.name: b for b in mpfb2.read_skeleton(SOURCE_SKELETON).bones}
    source, target = [], []
    for ours, theirs in _HEADS.items():
        source.append(skeleton.position[skeleton.index[ours]])
        target.append(bones[f"{theirs}.{side}"].head)
    for tip, theirs in _TIPS.items():
        source.append(skeleton.tips[tip])
        target.append(bones[f"{theirs}.{side}"].tail)
    return np.array(source), mpfb2.to_fh(np.array(target))


def _kabsch(moving: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """The rotation R (3x3, det +1) minimising ``sum |R (m - mean m) - (f - mean f)|^2``."""
    a, b = moving - moving.mean(axis=0), fixed - fixed.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    return vt.T @ np.diag([1.0, 1.0, d]) @ u.T


def cut_hand(elbow: np.ndarray, wrist: np.ndarray, side: str = "R"):
    """The base mesh's hand beyond the wrist ring (module docstring, step 1), MPFB2 vertex ids and metres:
    (vertex ids (N,), triangles (M, 3) into them, corner UVs (M, 3, 2))."""
    mesh = mpfb2.base_mesh()
    points = mpfb2.to_fh(mesh.vertices)
    table = mpfb2.read_weights(SOURCE_SKELETON)
    moved = np.zeros(len(points), bool)
    for bone in _BONES_WEIGHTED:
        vertex, value = table[f"{bone}.{side}"]
        moved[vertex[value > 0]] = True
    axis = (wrist - elbow) / np.linalg.norm(wrist - elbow)
    beyond = moved & ((points - elbow) @ axis > 0.0)        # the hand's side of the elbow
    sided = points[:, 0] < 0.0 if side == "R" else points[:, 0] > 0.0      # MakeHuman +X: the character's left
    body = mesh.faces_in("body")
    quads = mesh.quads[body]
    keep = np.any(beyond[quads], axis=1) & np.all(sided[quads], axis=1)
    quads, quad_uvs = quads[keep], mesh.quad_uvs[body][keep]
    d02 = np.linalg.norm(points[quads[:, 0]] - points[quads[:, 2]], axis=1)
    d13 = np.linalg.norm(points[quads[:, 1]] - points[quads[:, 3]], axis=1)
    split = np.where((d02 <= d13)[:, None], [[0, 1, 2, 0, 2, 3]], [[0, 1, 3, 1, 2, 3]])
    tris = np.take_along_axis(quads, split, axis=1).reshape(-1, 3)
    tri_uvs = np.take_along_axis(quad_uvs, split, axis=1).reshape(-1, 3)
    # one piece: the one holding the moved vertex nearest the wrist (a stray face elsewhere never counts)
    _, label = connected_components(sparse.coo_matrix(
        (np.ones(tris.size), (tris.ravel(), tris[:, [1, 2, 0]].ravel())),
        shape=(len(points), len(points))), directed=False)
    inside = np.flatnonzero(beyond & sided & np.isin(np.arange(len(points)), tris))
    seed = inside[np.argmin(np.linalg.norm(points[inside] - wrist, axis=1))]
    hand = label[tris[:, 0]] == label[seed]
    tris, tri_uvs = tris[hand], tri_uvs[hand]
    ids, local = np.unique(tris, return_inverse=True)
    return ids, local.reshape(-1, 3), mesh.uvs[tri_uvs]


def mpfb2_weights(ids: np.ndarray, skeleton: Skeleton, side: str = "R") -> np.ndarray:
    """MPFB2's skin weights of the base-mesh vertices ``ids`` over ``skeleton``'s bones (module docstring,
    step 5), rows summing to 1."""
    table = mpfb2.read_weights(SOURCE_SKELETON)
    weights = np.zeros((len(ids), len(skeleton.names)))
    position = np.full(mpfb2.VERTEX_COUNT, -1)
    position[ids] = np.arange(len(ids))
    forearm = skeleton.index["forearm"]
    for bone, (vertex, value) in table.items():
        if not bone.endswith(f".{side}"):
            continue
        rows = position[vertex]
        hit = rows >= 0
        column = skeleton.index.get(_BONES_WEIGHTED.get(bone[:-2], ""), forearm)
        np.add.at(weights[:, column], rows[hit], value[hit])
    empty = weights.sum(axis=1) <= 0
    weights[empty, forearm] = 1.0
    return weights / weights.sum(axis=1, keepdims=True)


def widened(weights: np.ndarray, vertices: np.ndarray, faces: np.ndarray,
            skeleton: Skeleton) -> tuple[np.ndarray, int]:
    """``weights`` diffused over the mesh (``W <- (W + mean of the neighbours' W) / 2``, ``k`` times) until the
    blend zone's spread is the phalanges' skin radius ``r`` (median of :func:`..hand.crease.bone_radii`): each step
    spreads a weight by a variance of about ``h^2 / 4`` along the surface (``h`` the median edge length),
    so ``k = round(4 r^2 / h^2)``. The forearm ring keeps its forearm weight (it joins the forearm). Returns
    (weights, k)."""
    from ..hand.crease import bone_radii
    edges = geometry.unique_edges(np.asarray(faces, np.int64))
    h = float(np.median(np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)))
    radii = bone_radii(skeleton, vertices, weights)
    r = float(np.median([radii[b] for b, n in enumerate(skeleton.names) if "phalanx" in n]))
    steps = int(round(4.0 * r * r / (h * h)))
    n = len(vertices)
    adjacency = sparse.coo_matrix((np.ones(2 * len(edges)), (np.r_[edges[:, 0], edges[:, 1]],
                                   np.r_[edges[:, 1], edges[:, 0]])), shape=(n, n)).tocsr()
    mean = sparse.diags(1.0 / np.asarray(adjacency.sum(axis=1)).ravel()) @ adjacency
    out = weights.copy()
    ring = _rim(faces, n)
    for _ in range(steps):
        out = 0.5 * out + 0.5 * (mean @ out)
        out[ring] = weights[ring]
    return out / out.sum(axis=1, keepdims=True), steps


def _rim(faces: np.ndarray, count: int) -> np.ndarray:
    """(count,) bool: the vertices on the mesh's open rims."""
    out = np.zeros(count, bool)
    for loop in refine.boundary_loops(faces):
        out[loop] = True
    return out


def mpfb2_hand_template(reference: HandTemplate) -> HandTemplate:
    """``reference`` (the thesis' reference hand) fitted into the MPFB2 hand (module docstring)."""
    source, target = hand_landmarks(reference.skeleton)
    rotation = _kabsch(target, source)
    w_ref, w_mpfb = source[list(_HEADS).index("wrist")], target[list(_HEADS).index("wrist")]
    place = lambda p: (p - w_mpfb) @ rotation.T + w_ref                      # noqa: E731
    warped = warped_template(reference, RBFWarp(source, place(target)))
    skeleton = warped.skeleton
    ids, faces, corner_uvs = cut_hand(target[list(_HEADS).index("forearm")], w_mpfb)
    vertices = place(mpfb2.to_fh(mpfb2.base_mesh().vertices[ids]))
    weights = limit_influences(widened(mpfb2_weights(ids, skeleton), vertices, faces, skeleton)[0])
    vertices = push_out_of_bones(vertices, faces, weights, skeleton)
    boundary = _rim(faces, len(vertices))
    skin = SkinMesh(vertices, faces, corner_uvs, weights, boundary)
    return replace(warped, skin=skin, masses=segment_masses(skeleton, vertices, weights),
                   features=feature_points(skeleton, vertices))
