# SPDX-License-Identifier: GPL-3.0-or-later
"""Side-by-side contact of neighbouring fingers, beyond the thesis (its hand, 6.2.1-6.2.2, has no collisions;
its future work, 6.2.5, asks for them).

The long flexors cross the MCP joints on the palm side of their abduction axes (Table A.1: the profundus
tendons of the ring and little fingers adduct them with 6 mm moment arms), so a closing hand pulls its fingers
together, as a real one does, until they touch. Without contact the ring and little fingers of a fist were
pulled to their Table 6.4 adduction limits and their phalanx axes came within 3-5 mm of their neighbours'
(a finger is 16-20 mm wide): the curled fingers ran into each other.

After each frame of the pseudo-muscle dynamics (Eq. 6.7), the fingers are kept side by side: along the
direction ``u`` from a finger's MCP joint centre to its ulnar neighbour's (across the palm, as posed), every
sample of a finger's phalanx axes (from ``BASE``
of the proximal phalanx to the tip) must lie at least ``SPACING`` times the distance of the two MCP joint
centres (a finger's width in the reference hand, 15-17 mm; it scales with a warped hand) ulnar of the same
sample (same bone, same fraction) of its radial neighbour, where the two samples are closer than that at
all (a curled finger under a straight one is apart). A signed side-by-side distance, not the distance
of the closest points: a finger that crossed over is pushed back to its own side, not further through.
Where a pair is too close, both fingers' MCP abductions and rotations turn by the smallest amounts that
restore it: the lateral distance changes by ``u . (w x (p - c)) dtheta`` for a finger turned about the DOF's
axis ``w`` through its MCP centre ``c`` (a curled finger's tip lies near its abduction axis, so only the
rotation, which tilts the curl, moves it sideways); within the Table 6.4 limits, a few Gauss-Seidel sweeps
per frame. A finger's abduction speed into the contact is removed (as at a joint limit); the rotation
follows flexion again in the next frame (:mod:`.pseudo`) and is corrected again. Deterministic; no other
DOF moves; ``enabled = False`` leaves the muscles alone (Solve Contractions' checks balance muscles only).
"""
from __future__ import annotations

import numpy as np

from .pseudo import PseudoMuscles
from .skeleton import Skeleton, rotation_matrices

__all__ = ["FingerContact", "SPACING", "BASE", "CONTACT_FINGERS"]

SPACING = 0.98           # neighbouring phalanx axes at least this share of their MCP joints' distance apart
BASE = 0.4               # the proximal phalanx's first 40 % lie in the web, where the MCP spacing decides
CONTACT_FINGERS = ("index", "middle", "ring", "pinky")
SWEEPS = 24
REACH = 1.5              # samples further apart than this many contact distances do not touch
MAX_TURN = np.radians(6.0)   # per sweep, so a deep overlap resolves over a few sweeps without overshooting
PARTS = ("proximal", "intermediate", "distal")


class FingerContact:
    """Keeps neighbouring fingers side by side by their MCP abduction and rotation (module docstring);
    ``distance`` (m) overrides the per-pair distances."""

    def __init__(self, skeleton: Skeleton, pseudo: PseudoMuscles, distance: float | None = None, samples: int = 6):
        self.skeleton, self.pseudo = skeleton, pseudo
        self.enabled = True
        self.bones = [[skeleton.index[f"{f}-finger-phalanx-{p}"] for p in PARTS] for f in CONTACT_FINGERS]
        mcp = skeleton.position[[bones[0] for bones in self.bones]]
        spacing = np.linalg.norm(np.diff(mcp, axis=0), axis=1)
        self.distance = SPACING * spacing if distance is None else np.full(len(spacing), float(distance))
        self.dofs = [[skeleton.dof(f"{f}-finger-phalanx-proximal", kind) for kind in ("abduction", "rotation")]
                     for f in CONTACT_FINGERS]
        self.flexion = [skeleton.dof(f"{f}-finger-phalanx-proximal", "flexion") for f in CONTACT_FINGERS]
        s = np.linspace(0.0, 1.0, samples)[:, None]
        rest, owner = [], []
        for bones in self.bones:
            points = [skeleton.position[b] + f * (skeleton.tail[b] - skeleton.position[b])
                      for b, f in zip(bones, (BASE + (1.0 - BASE) * s, s, s))]
            rest.append(np.concatenate(points))
            owner.append(np.repeat(bones, samples))
        self.rest = np.array(rest)                      # (fingers, samples, 3) on the rest axes
        self.owner = np.array(owner)                    # (fingers, samples) bone of each sample
        self.mcp = np.array([bones[0] for bones in self.bones])
        self.parents = skeleton.parent[self.mcp]
        self.frames = skeleton.frame[self.mcp]
        flat = np.array(self.dofs)
        self.signs = np.array([[skeleton.dofs[k].sign for k in row] for row in flat])
        self.flexion_sign = np.array([skeleton.dofs[k].sign for k in self.flexion])
        self._flat_dofs = flat

    def _axes(self, transforms: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World axes (fingers, 2, 3) of the MCP abduction and rotation (signed like the DOFs; the joint
        turns ``F Rx Ry Rz F^T``, :mod:`.skeleton`) and the MCP centres (fingers, 3)."""
        count = len(self.mcp)
        flex = rotation_matrices(np.tile([1.0, 0.0, 0.0], (count, 1)), angles[self.flexion] * self.flexion_sign)
        abd = rotation_matrices(np.tile([0.0, 1.0, 0.0], (count, 1)), angles[self._flat_dofs[:, 0]] * self.signs[:, 0])
        world = transforms[self.parents][:, :3, :3] @ self.frames
        abduction = (world @ flex)[:, :, 1] * self.signs[:, :1]
        rotation = (world @ flex @ abd)[:, :, 2] * self.signs[:, 1:]
        centre = np.einsum("fij,fj->fi", transforms[self.parents][:, :3, :3], self.skeleton.position[self.mcp]) \
            + transforms[self.parents][:, :3, 3]
        return np.stack([abduction, rotation], axis=1), centre

    def _sides(self, angles: np.ndarray):
        transforms = self.skeleton.bone_transforms(angles)
        m = transforms[self.owner]
        points = np.einsum("fsij,fsj->fsi", m[..., :3, :3], self.rest) + m[..., :3, 3]
        m = transforms[self.mcp]
        centres = np.einsum("fij,fj->fi", m[:, :3, :3], self.skeleton.position[self.mcp]) + m[:, :3, 3]
        across = np.diff(centres, axis=0)
        return transforms, points, across / np.linalg.norm(across, axis=1, keepdims=True)

    def gaps(self, angles: np.ndarray) -> np.ndarray:
        """Smallest side-by-side distance (m, module docstring) of each neighbouring pair."""
        _, points, ulnar = self._sides(angles)
        out = []
        for f in range(len(points) - 1):
            between = points[f + 1] - points[f]
            lateral = between @ ulnar[f]
            out.append(np.min(np.where(np.linalg.norm(between, axis=1) < REACH * self.distance[f], lateral, np.inf)))
        return np.minimum(np.array(out), self.distance)

    def resolve(self) -> bool:
        """Push touching fingers apart (module docstring); True if any joint was turned."""
        pseudo, moved, angles = self.pseudo, False, self.pseudo.angles
        for _ in range(SWEEPS if self.enabled else 0):
            transforms, points, ulnar = self._sides(angles)
            axes, centres = None, None
            turned = False
            for a in range(len(points) - 1):
                between = points[a + 1] - points[a]             # matching samples: same bone, same fraction
                lateral = between @ ulnar[a]
                lateral[np.linalg.norm(between, axis=1) >= REACH * self.distance[a]] = np.inf   # apart (palm-wards)
                i = int(np.argmin(lateral))
                short = self.distance[a] - lateral[i]
                if short <= 1e-5:
                    continue
                if axes is None:
                    axes, centres = self._axes(transforms, angles)
                rows = []
                for finger, sign in ((a, -1.0), (a + 1, 1.0)):
                    rows.extend(sign * (np.cross(axes[finger], points[finger][i] - centres[finger]) @ ulnar[a]))
                jac = np.array(rows)
                norm = float(jac @ jac)
                if norm < 1e-8:
                    continue
                step = np.clip(jac * short / norm, -MAX_TURN, MAX_TURN)
                for k, turn in zip(self.dofs[a] + self.dofs[a + 1], step):
                    new = float(np.clip(angles[k] + turn, pseudo.lower[k], pseudo.upper[k]))
                    if new != angles[k]:
                        if pseudo.velocity[k] * turn < 0:
                            pseudo.velocity[k] = 0.0
                        angles[k] = new
                        turned = moved = True
            if not turned:
                break
        return moved
