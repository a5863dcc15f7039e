# SPDX-License-Identifier: GPL-3.0-or-later
"""Flexion creases of the skin, beyond the thesis (its skin, 6.2.1, follows the bones through the mass-spring
network alone).

Each skin node's attachment point is carried by its bones by linear blend skinning. On the palm side of a
flexed joint that folds the skin of the two bones into each other: in a fist the palm-side skin of the
proximal phalanges passed through the skin of the palm (80-120 "pockets": skin edges that pierce the skin a
few edges away). A real finger creases there instead: the two skins press together along the joint.

So, for every finger and thumb joint that flexes (MCP, PIP, DIP; thumb MCP, IP), the attachment points of
the nodes of its two bones near the joint are kept on their own side of the plane that bisects the two bones'
axes through the joint centre: a node may not move further past the plane than it lay at rest, and never
more than ``MARGIN`` past it, so the two sides meet in a crease ``2 MARGIN`` wide. At rest and on the
back of a joint nothing moves; only the palm side of a bent joint is pressed flat. The spring network then
spreads the correction over the skin like any other attachment motion. :class:`FingerSides` does the same
for the facing sides of two neighbouring fingers' proximal phalanges.
"""
from __future__ import annotations

import numpy as np
from scipy import sparse

from .skeleton import Skeleton

__all__ = ["Creases", "FingerSides", "MARGIN", "SIDE_MARGIN", "SIDE_SPAN", "REACH", "bone_radii"]

MARGIN = 0.5e-3          # m: each side stops this far from the bisecting plane
SLACK = 1e-7            # m: rounding, not a crossing
REACH = 2.0              # nodes within this many bone radii of the joint centre take part
JOINTS = ("phalanx-proximal", "phalanx-intermediate", "phalanx-distal")
SIDE_MARGIN = 2e-3       # m: neighbouring proximal phalanges' facing skins stop this far from their midplane
SIDE_SPAN = (-0.1, 0.8)  # the part of a proximal phalanx (fractions of its length) whose facing side takes part
SIDE_REACH = 0.006       # m: nodes this close to the midplane at rest are a facing side


def bone_radii(skeleton: Skeleton, vertices: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(B,) median distance of each bone's own skin nodes (largest skinning weight) from its axis (m)."""
    owner = weights.argmax(axis=1)
    radii = np.zeros(len(skeleton.names))
    for b in range(len(skeleton.names)):
        points = vertices[owner == b]
        if len(points):
            head, axis = skeleton.position[b], skeleton.tail[b] - skeleton.position[b]
            t = np.clip((points - head) @ axis / max(float(axis @ axis), 1e-12), 0.0, 1.0)
            radii[b] = float(np.median(np.linalg.norm(points - head - t[:, None] * axis, axis=1)))
    return radii


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


class Creases:
    """Keeps the skin of each flexing finger joint on its own side of the joint (module docstring)."""

    def __init__(self, skeleton: Skeleton, vertices: np.ndarray, weights: np.ndarray, radii: np.ndarray):
        owner = weights.argmax(axis=1)
        children = [b for b, name in enumerate(skeleton.names)
                    if any(name.endswith(j) for j in JOINTS) and skeleton.parent[b] >= 0]
        self.child = np.array(children, np.int64)
        self.parent = skeleton.parent[self.child]
        self.centre = skeleton.position[self.child]
        self.parent_axis = _unit(skeleton.tail[self.parent] - skeleton.position[self.parent])
        self.child_axis = _unit(skeleton.tail[self.child] - skeleton.position[self.child])
        normal = _unit(self.parent_axis + self.child_axis)
        nodes, joint, side, bound = [], [], [], []
        for j, (c, p) in enumerate(zip(self.child, self.parent)):
            near = np.linalg.norm(vertices - self.centre[j], axis=1) < REACH * max(radii[c], radii[p])
            near &= (vertices - self.centre[j]) @ self._palmar(skeleton, c) > -0.5 * radii[c]
            rest = (vertices - self.centre[j]) @ normal[j]
            for bone, sign in ((c, 1.0), (p, -1.0)):
                mine = np.flatnonzero(near & (owner == bone))
                nodes.append(mine)
                joint.append(np.full(len(mine), j))
                side.append(np.full(len(mine), sign))
                # sign * distance >= bound: no further past the plane than at rest, nor than MARGIN
                bound.append(np.minimum(sign * rest[mine], MARGIN))
        self.nodes = np.concatenate(nodes)
        self.joint = np.concatenate(joint)
        self.side = np.concatenate(side)
        self.bound = np.concatenate(bound)
        #: (N, entries) sums each entry's push onto its node (a node can sit at two joints)
        self._gather = sparse.csr_matrix((np.ones(len(self.nodes)), (self.nodes, np.arange(len(self.nodes)))),
                                         shape=(len(vertices), len(self.nodes)))

    @staticmethod
    def _palmar(skeleton: Skeleton, bone: int) -> np.ndarray:
        """The side a joint bends towards: where its child's tip goes when it flexes (only that side and the
        flanks can fold into each other; the back of the joint stretches)."""
        angles = np.zeros(skeleton.dof_count)
        angles[skeleton.dof(skeleton.names[bone], "flexion")] = 0.2
        tip = skeleton.posed_points(skeleton.bone_transforms(angles), bone, skeleton.tail[bone])
        return _unit(tip - skeleton.tail[bone])

    def apply(self, target: np.ndarray, transforms: np.ndarray) -> np.ndarray:
        """The attachment points ``target`` (N, 3) with the crease sides kept apart, for the bone
        ``transforms`` (B, 4, 4) of the pose (``target`` itself when no node crossed)."""
        if len(self.nodes) == 0:
            return target
        rotation = transforms[:, :3, :3]
        normal = _unit(np.einsum("jik,jk->ji", rotation[self.parent], self.parent_axis)
                       + np.einsum("jik,jk->ji", rotation[self.child], self.child_axis))
        centre = np.einsum("jik,jk->ji", rotation[self.child], self.centre) + transforms[self.child, :3, 3]
        count = len(self.child)
        offset = np.einsum("ji,ji->j", centre, normal)
        distance = ((target @ normal.T).ravel()[self.nodes * count + self.joint] - offset[self.joint]) * self.side
        push = self.bound - distance
        crossed = push > SLACK
        if not np.any(crossed):
            return target
        push = np.where(crossed, push, 0.0) * self.side
        return target + self._gather @ (normal[self.joint] * push[:, None])


class FingerSides:
    """Keeps the facing sides of neighbouring fingers' proximal phalanges apart, as :class:`Creases` keeps the
    two sides of a joint: the attachment point of a node of a proximal phalanx's side that faces its
    neighbour (within ``SIDE_REACH`` of the plane midway between the two phalanx axes, at the node's fraction
    of its bone) may not come nearer that plane, as posed, than ``SIDE_MARGIN`` or than it lay at rest (so at
    rest nothing moves). When the curled fingers close up (down to the finger contact's distance,
    :mod:`.contact`) the two skins of a web pressed past each other (pockets at the finger bases); now they
    flatten against each other: pockets fist 38 -> 33, point 24 -> 17, thumbs up 32 -> 30, pinch 31 -> 25."""

    def __init__(self, skeleton: Skeleton, vertices: np.ndarray, weights: np.ndarray):
        owner = weights.argmax(axis=1)
        fingers = ("index", "middle", "ring", "pinky")
        nodes, first, second, frac, side, bound = [], [], [], [], [], []
        for fa, fb in zip(fingers, fingers[1:]):
            a, b = (skeleton.index[f"{f}-finger-phalanx-proximal"] for f in (fa, fb))
            for bone, sign in ((a, -1.0), (b, 1.0)):
                axis = skeleton.tail[bone] - skeleton.position[bone]
                s = (vertices - skeleton.position[bone]) @ axis / float(axis @ axis)
                pa, pb = (skeleton.position[k] + s[:, None] * (skeleton.tail[k] - skeleton.position[k]) for k in (a, b))
                d = np.einsum("ij,ij->i", vertices - 0.5 * (pa + pb), _unit(pb - pa))
                near = (s > SIDE_SPAN[0]) & (s < SIDE_SPAN[1]) & (sign * d < SIDE_REACH)
                mine = np.flatnonzero((owner == bone) & near)
                nodes.append(mine)
                first.append(np.full(len(mine), a))
                second.append(np.full(len(mine), b))
                frac.append(s[mine])
                side.append(np.full(len(mine), sign))
                bound.append(np.minimum(sign * d[mine], SIDE_MARGIN))
        self.nodes, self.a, self.b = np.concatenate(nodes), np.concatenate(first), np.concatenate(second)
        self.side, self.bound = np.concatenate(side), np.concatenate(bound)
        f = np.concatenate(frac)[:, None]
        self.at_a = skeleton.position[self.a] + f * (skeleton.tail[self.a] - skeleton.position[self.a])
        self.at_b = skeleton.position[self.b] + f * (skeleton.tail[self.b] - skeleton.position[self.b])

    def apply(self, target: np.ndarray, transforms: np.ndarray) -> np.ndarray:
        """The attachment points ``target`` (N, 3) with the facing sides kept apart for the bone ``transforms``
        (B, 4, 4) (``target`` itself when no node came too near)."""
        if len(self.nodes) == 0:
            return target
        ta, tb = transforms[self.a], transforms[self.b]
        pa = np.einsum("nij,nj->ni", ta[:, :3, :3], self.at_a) + ta[:, :3, 3]
        pb = np.einsum("nij,nj->ni", tb[:, :3, :3], self.at_b) + tb[:, :3, 3]
        normal = _unit(pb - pa)
        push = self.bound - self.side * np.einsum("ij,ij->i", target[self.nodes] - 0.5 * (pa + pb), normal)
        crossed = push > SLACK
        if not np.any(crossed):
            return target
        out = target.copy()
        np.add.at(out, self.nodes[crossed], (self.side * push)[crossed, None] * normal[crossed])
        return out
