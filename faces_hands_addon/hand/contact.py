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
rotation, which tilts the curl, moves it sideways); within the Table 6.4 limits, all pairs at once, a few
linearised sweeps per frame. A finger's abduction speed into the contact is removed (as at a joint limit); the rotation
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
SWEEPS = 6
TOLERANCE = 2e-4         # m of shortfall left alone (a fifth of a millimetre)
SETTLED = 1e-3           # m: after a first sweep, shortfalls below a millimetre wait for the next frame
REACH = 1.5              # samples further apart than this many contact distances do not touch
MAX_TURN = np.radians(6.0)   # per sweep: a deep overlap resolves over a few sweeps, the linearisation holds
PARTS = ("proximal", "intermediate", "distal")


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` for (..., 3) arrays (``np.cross`` costs more than the arithmetic for a handful of vectors)."""
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1], a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


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
        self._last = None

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

    def transforms(self, angles: np.ndarray) -> np.ndarray:
        """The bone transforms of ``angles``: the ones the last contact check computed when the joints have not
        moved since (usually the case after :meth:`resolve`), else forward kinematics."""
        if self._last is not None and np.array_equal(self._last[0], angles):
            return self._last[1]
        return self.skeleton.bone_transforms(angles)

    def _sides(self, angles: np.ndarray):
        transforms = self.skeleton.bone_transforms(angles)
        self._last = (angles.copy(), transforms)
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

    def _rows(self, angles: np.ndarray):
        """The pairs that are too close: (shortfalls (P,), Jacobian (P, 2 x fingers) of their side-by-side
        distances over every finger's MCP abduction and rotation)."""
        transforms, points, ulnar = self._sides(angles)
        between = points[1:] - points[:-1]                   # matching samples: same bone, same fraction
        lateral = np.einsum("psi,pi->ps", between, ulnar)
        lateral[np.einsum("psi,psi->ps", between, between) >= (REACH * self.distance[:, None]) ** 2] = np.inf
        worst = np.argmin(lateral, axis=1)
        pairs = np.arange(len(between))
        shorts = self.distance - lateral[pairs, worst]
        close = np.flatnonzero(shorts > TOLERANCE)
        if len(close) == 0:
            return shorts[close], np.zeros((0, 2 * len(points)))
        axes, centres = self._axes(transforms, angles)
        rows = np.zeros((len(close), 2 * len(points)))
        for r, a in enumerate(close):
            for finger, sign in ((a, -1.0), (a + 1, 1.0)):
                lever = _cross(axes[finger], points[finger][worst[a]] - centres[finger])
                rows[r, 2 * finger:2 * finger + 2] = sign * (lever @ ulnar[a])
        return shorts[close], rows

    def resolve(self) -> bool:
        """Push touching fingers apart (module docstring); True if any joint was turned. Each sweep solves
        the linearised contacts of all pairs at once: the smallest turn ``J^T lambda`` with ``lambda >= 0``
        that restores every shortfall, DOFs held at a limit taken out."""
        pseudo, moved, angles, dofs = self.pseudo, False, self.pseudo.angles, self._flat_dofs.ravel()
        for _ in range(SWEEPS if self.enabled else 0):
            shorts, jac = self._rows(angles)
            if len(shorts) == 0 or (moved and shorts.max() < SETTLED):
                break
            free = np.ones(len(dofs), bool)
            for _ in range(3):          # drop DOFs a turn would push past their limits, then solve again
                j = jac * free
                gram = j @ j.T + 1e-9 * np.eye(len(shorts))
                lam = np.maximum(np.linalg.solve(gram, shorts), 0.0)
                step = np.clip(j.T @ lam, -MAX_TURN, MAX_TURN)
                target = angles[dofs] + step
                blocked = ((target < pseudo.lower[dofs]) & (step < 0)) | ((target > pseudo.upper[dofs]) & (step > 0))
                if not np.any(blocked & free):
                    break
                free &= ~blocked
            new = np.clip(angles[dofs] + step, pseudo.lower[dofs], pseudo.upper[dofs])
            turn = new - angles[dofs]
            if np.abs(turn).max() < 1e-7:
                break
            stop = pseudo.velocity[dofs] * turn < 0
            pseudo.velocity[dofs[stop]] = 0.0
            angles[dofs] = new
            moved = True
        return moved
