# SPDX-License-Identifier: GPL-3.0-or-later
"""The skin of the reference hand (thesis 6.2.1: "a triangle mesh consisting of 3000 triangles"; 6.2.4: the
network has "approximately 1500 nodes"): the WebXR generic right hand, warped onto the skeleton and made
one closed-up surface the spring network can use.

1. *Fit*: the WebXR hand's 25 joints are matched with the skeleton's joint centres and tips, and an RBF warp
   (:class:`..physics.RBFWarp`, biharmonic with an affine part, as in 6.2.3) carries the mesh onto the bones.
   WebXR's tip joints sit in the finger pad, so they go to the same fraction of the distal segment.
2. *Weld*: the asset splits vertices along its UV seams (400 duplicates); they are merged so the skin is one
   sheet (an unwelded seam would open under the springs). UVs are kept per face corner.
3. *Refine*: the longest edges are split (:func:`..core.refine.split_long_edges`) until the network has about
   the thesis' 1500 nodes.
4. *Forearm end*: the asset's flat cap, whose rim zig-zagged, is replaced by a rounded end
   (:mod:`.skin_end`).
5. *Shape*: fingers, thumb and thenar eminence are given rounded sections round their bones
   (:mod:`.skin_shape`); folds left where the asset's webs meet the new sections are smoothed away.
6. *Clearance*: skin that lies closer to a bone than ``CLEARANCE`` is pushed out along its normal, so the
   bones stay inside the hand. On a thin web the normals disagree from node to node, so the push folds it
   (notches that turned into pockets, light through the finger bases, in the spread pose): the folds it left
   are relaxed once more afterwards (the web keeps its clearance; tests/engine/hand/test_hand_webs.py), and
   the facing sides of the middle and ring fingers, which that relax shrank so light showed through their
   web seen from the palm, are brought back out to their sections (:func:`.skin_shape.restore_web_sides`).

The skinning weights (used to carry every skin node's attachment point with the bones) come from the asset
(WebXR joint -> the bone of the same name; tips -> their distal bone), blended for new vertices.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .. import assets
from ..core import geometry, refine
from ..physics import RBFWarp
from .skeleton import TIP_NAMES, Skeleton
from .skin_end import round_forearm_end
from .skin_shape import relax_folds, restore_web_sides, shape_skin, smooth_field, web_membrane

__all__ = ["SkinMesh", "fit_reference_skin", "push_out_of_bones", "TARGET_NODES", "CLEARANCE"]

TARGET_NODES = 1500
CLEARANCE = 0.002          # metres of tissue at least between a bone and the skin


@dataclass
class SkinMesh:
    vertices: np.ndarray       # (N, 3) rest positions
    faces: np.ndarray          # (M, 3)
    corner_uvs: np.ndarray     # (M, 3, 2) UV of every face corner (Blender convention)
    weights: np.ndarray        # (N, B) skinning weights over the skeleton's bones (rows sum to 1)
    boundary: np.ndarray       # (N,) bool: on the open rim at the wrist

    @property
    def normals(self) -> np.ndarray:
        return geometry.vertex_normals(self.vertices, self.faces)


def _joint_targets(hand: assets.SkinnedHand, skeleton: Skeleton) -> tuple[np.ndarray, np.ndarray]:
    """WebXR joint positions and where they go on the skeleton (module docstring, step 1)."""
    source, target = [], []
    world = {name: hand.rest_world[i][:3, 3] for i, name in enumerate(hand.joint_names)}
    vertices = hand.mesh.vertices
    for name, point in world.items():
        if name in TIP_NAMES:
            bone = skeleton.tip_bone(name)
            dip = skeleton.position[bone]
            webxr_dip = world[hand.joint_names[hand.joint_names.index(name) - 1]]
            u = (point - webxr_dip) / np.linalg.norm(point - webxr_dip)
            near = vertices[np.linalg.norm(vertices - point, axis=1) < 0.03]
            skin_end = float(np.max((near - webxr_dip) @ u))
            fraction = float(np.linalg.norm(point - webxr_dip)) / skin_end
            tip = skeleton.tips[name]
            reach = np.linalg.norm(tip - dip) + 0.003
            goal = dip + fraction * reach * (tip - dip) / np.linalg.norm(tip - dip)
        elif name in skeleton.index:
            goal = skeleton.position[skeleton.index[name]]
        else:
            continue
        source.append(point)
        target.append(goal)
    return np.array(source), np.array(target)


def _weld(vertices: np.ndarray, faces: np.ndarray, tolerance: float = 1e-7):
    """Merge vertices at the same place: (kept vertex index per old vertex, kept old indices)."""
    tree = cKDTree(vertices)
    pairs = tree.query_pairs(tolerance, output_type="ndarray")
    representative = np.arange(len(vertices))
    for a, b in sorted(map(tuple, np.sort(pairs, axis=1))):
        representative[b] = representative[a]
    kept = np.unique(representative)
    new_index = np.searchsorted(kept, representative)
    return new_index, kept


def _refined_corner_uvs(new_faces: np.ndarray, matrix, old_faces: np.ndarray, old_corner_uvs: np.ndarray):
    """UVs per corner of the refined faces: every new face lies in one old face whose three vertices are the
    parents of its corners; a corner's UV is the mean of its parents' corner UVs in that face."""
    matrix = matrix.tocsr()
    face_of = {tuple(sorted(f)): k for k, f in enumerate(old_faces.tolist())}
    out = np.zeros((len(new_faces), 3, 2))
    for k, face in enumerate(new_faces):
        parents = [matrix.indices[matrix.indptr[v]:matrix.indptr[v + 1]] for v in face]
        old = face_of[tuple(sorted(set(np.concatenate(parents).tolist())))]
        corner_of = {int(v): c for c, v in enumerate(old_faces[old])}
        for c, parent in enumerate(parents):
            out[k, c] = np.mean([old_corner_uvs[old, corner_of[int(p)]] for p in parent], axis=0)
    return out


def _refine(vertices, faces, corner_uvs, weights, target_nodes: int):
    edges = geometry.unique_edges(faces)
    length = np.linalg.norm(vertices[edges[:, 1]] - vertices[edges[:, 0]], axis=1)
    extra = max(target_nodes - len(vertices), 0)
    if extra == 0:
        return vertices, faces, corner_uvs, weights
    threshold = float(np.sort(length)[-min(extra, len(length) - 1)])
    matrix, new_faces = refine.split_long_edges(vertices, faces, threshold * 0.999)
    uvs = _refined_corner_uvs(new_faces, matrix, faces, corner_uvs)
    return matrix @ vertices, new_faces, uvs, np.asarray(matrix @ weights)


def push_out_of_bones(vertices: np.ndarray, faces: np.ndarray, weights: np.ndarray,
                       skeleton: Skeleton) -> np.ndarray:
    """Move skin vertices that lie within ``CLEARANCE`` of (or inside) one of their own bones (skinning weight
    over 2 %; a neighbouring finger's bone must not push a finger's side into it) out along their normals; the
    push is smoothed over the neighbours, so a thin web is lifted, not folded."""
    names = [n for n in skeleton.names if n != "forearm"]
    trees = [cKDTree(skeleton.mesh_vertices[n][::3]) for n in names]
    columns = [skeleton.index[n] for n in names]
    own = weights[:, columns] > 0.02
    normals = geometry.vertex_normals(vertices, faces)
    out = vertices.copy()
    for _ in range(4):
        distance = np.full(len(out), np.inf)
        height = np.full(len(out), np.inf)
        for k, tree in enumerate(trees):
            d, i = tree.query(out)
            closer = own[:, k] & (d < distance)
            distance[closer] = d[closer]
            h = np.einsum("ij,ij->i", out - tree.data[i], normals)
            height[closer] = h[closer]
        short = np.maximum(CLEARANCE - np.minimum(height, distance), 0.0)
        short[distance > 0.012] = 0.0
        out += smooth_field(normals * short[:, None], faces, 2) + normals * (0.25 * short)[:, None]
    return out


def fit_reference_skin(skeleton: Skeleton, target_nodes: int = TARGET_NODES) -> SkinMesh:
    """The reference skin on ``skeleton`` (module docstring)."""
    hand = assets.webxr_hand("right")
    source, target = _joint_targets(hand, skeleton)
    warp = RBFWarp(source, target)
    vertices = warp(hand.mesh.vertices)
    faces = hand.mesh.faces
    corner_uvs = hand.mesh.uvs[faces]
    weights = np.zeros((len(vertices), len(skeleton.names)))
    for column, joint in enumerate(hand.joint_names):
        bone = skeleton.tip_bone(joint) if joint in TIP_NAMES else skeleton.index[joint]
        mask = hand.skin_joints == column
        np.add.at(weights[:, bone], np.nonzero(mask)[0], hand.skin_weights[mask])
    new_index, kept = _weld(vertices, faces)
    vertices, weights, faces = vertices[kept], weights[kept], new_index[faces]
    vertices, faces, corner_uvs, weights = _refine(vertices, faces, corner_uvs, weights, target_nodes)
    vertices, faces, corner_uvs, weights = round_forearm_end(vertices, faces, corner_uvs, weights, skeleton)
    weights /= weights.sum(axis=1, keepdims=True)
    vertices = web_membrane(shape_skin(vertices, faces, weights, skeleton), faces, weights, skeleton)
    on_fingers = np.isin(weights.argmax(axis=1), [b for b, n in enumerate(skeleton.names) if "phalanx" in n])
    vertices = push_out_of_bones(relax_folds(vertices, faces, on_fingers), faces, weights, skeleton)
    vertices = relax_folds(vertices, faces, on_fingers)          # the folds the push made on the webs
    vertices = restore_web_sides(vertices, weights, skeleton)      # what that relax took off the fingers
    boundary = np.zeros(len(vertices), bool)
    for loop in refine.boundary_loops(faces):
        boundary[loop] = True
    return SkinMesh(vertices, faces, corner_uvs, weights, boundary)
