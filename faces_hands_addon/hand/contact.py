# SPDX-License-Identifier: GPL-3.0-or-later
"""Side-by-side contact of neighbouring fingers, beyond the thesis (its hand, 6.2.1-6.2.2, has no collisions;
its future work, 6.2.5, asks for them).

The long flexors cross the MCP joints on the palm side of their abduction axes (Table A.1: the profundus
tendons of the ring and little fingers adduct them with 6 mm moment arms), so a closing hand pulls its fingers
together, as a real one does, until they touch. Without contact the ring and little fingers of a fist were
pulled to their Table 6.4 adduction limits and their phalanx axes came within 3-5 mm of their neighbours'
(a finger is 16-20 mm wide): the curled fingers ran into each other.

After each frame of the pseudo-muscle dynamics (Eq. 6.7), the fingers are kept side by side. Every sample of
a finger's phalanx axes (from ``BASE`` of the proximal phalanx to the tip) and every sample of its ulnar
neighbour's that are closer than ``REACH`` contact distances must lie at least the contact distance apart
(``SPACING`` times the distance of the two MCP joint centres: a finger's width in the reference hand, 15-17
mm; it scales with a warped hand), and the ulnar one on its own side: their offset across the fingers (along
``u``, the mean of the two proximal phalanges' posed flexion axes, towards the ulnar finger) must be at least
``sqrt(d^2 - a^2)``, ``a`` being the rest of the offset (along the fingers and through the palm). A signed
distance: a finger that crossed over is pushed back to its own side, not further through; two samples apart
along the fingers (a little finger curled inside the ring finger's curl) need little offset across them. In
the web the same holds, with ``KNUCKLE`` instead of ``SPACING``, between the radial finger's proximal
phalanx, from the MCP joint on, and its neighbour's matching samples and MCP centre (the little finger's MCP
lies 9 mm nearer the palm than the ring finger's, under the flexed ring finger's base).

Before, the offset was measured along the line between the two MCP centres, of matching samples only (same
bone, same fraction): at rest that line runs 47 degrees off the two flexion axes for the ring and little
fingers (22 for the middle and ring, 7.5 for the index and middle), so a curled little finger counted as
crossing the ring finger and was turned out of the fist to its rotation limit (a loop beside the fist, its tip
24 mm from the ring finger's in the fist, point and thumbs up; now 15-16 mm, beside the ring finger).

Where a pair is too close, both fingers' MCP abductions and rotations turn by the smallest amounts that
restore it: the offset changes by ``u . (w x (p - c)) dtheta`` for a finger turned about the DOF's axis ``w``
through its MCP centre ``c`` (a curled finger's tip lies near its abduction axis, so only the rotation, which
tilts the curl, moves it sideways); within the Table 6.4 limits, all pairs at once, a few linearised sweeps per
frame. A finger's abduction speed into the contact is removed (as at a joint limit); the rotation follows
flexion again in the next frame (:mod:`.pseudo`) and is corrected again. Deterministic; no other DOF moves;
``enabled = False`` leaves the muscles alone (Solve Contractions' checks balance muscles only).
"""
from __future__ import annotations

import numpy as np

from .contact_kernel import compiled_sweeps
from .pseudo import PseudoMuscles
from .skeleton import Skeleton, rotation_matrices

__all__ = ["FingerContact", "SPACING", "KNUCKLE", "BASE", "CONTACT_FINGERS", "turn_apart"]

SPACING = 0.98           # neighbouring phalanx axes at least this share of their MCP joints' distance apart
KNUCKLE = 0.87            # in the web: the radial proximal phalanx and its neighbour's MCP centre (module docstring)
BASE = 0.4               # the proximal phalanx's first 40 % lie in the web, where the MCP spacing decides
CONTACT_FINGERS = ("index", "middle", "ring", "pinky")
SWEEPS = 6
TOLERANCE = 2e-4         # m of shortfall left alone (a fifth of a millimetre)
SETTLED = 5e-4           # m: after a first sweep, shortfalls below half a millimetre wait for the next frame
REACH = 1.5              # samples further apart than this many contact distances do not touch
MAX_TURN = np.radians(6.0)   # per sweep: a deep overlap resolves over a few sweeps, the linearisation holds
#: the share of a turn that a curled finger's MCP abduction takes against its rotation (1): the little finger's
#: curled tip lies near its abduction axis, so clearing the ring finger's tip by abduction swung its proximal
#: phalanx out of the fist (a hook); the rotation, which tilts the curl, moves the tip without swinging it
ABDUCTION_WEIGHT = {"pinky": 0.05}
CURL = (np.radians(90.0), np.radians(180.0))   # the weight applies from none to all between these summed flexions
PARTS = ("proximal", "intermediate", "distal")


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` for (..., 3) arrays (``np.cross`` costs more than the arithmetic for a handful of vectors)."""
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1], a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def turn_apart(pseudo: PseudoMuscles, dofs: np.ndarray, shorts: np.ndarray, jac: np.ndarray,
               max_turn: float, weights: np.ndarray | None = None) -> bool:
    """One linearised contact sweep: the smallest turn ``W J^T lambda`` (``lambda >= 0``; the least
    ``sum(turn^2 / w)``, ``W`` the DOFs' ``weights``, all 1 when None) of the joint DOFs ``dofs`` that
    restores the ``shorts`` (m) with Jacobian ``jac`` (rows, DOFs), at most ``max_turn`` per DOF, DOFs a
    turn would push past their Table 6.4 limits taken out (up to three solves); the joints' speed into the
    contact is removed (as at a joint limit). Changes ``pseudo.angles`` and ``pseudo.velocity`` in place; False
    when the turn is below 1e-7 rad (nothing moved)."""
    angles = pseudo.angles
    free = np.ones(len(dofs), bool)
    weights = np.ones(len(dofs)) if weights is None else weights
    for _ in range(3):          # drop DOFs a turn would push past their limits, then solve again
        j = jac * free
        gram = (j * weights) @ j.T + 1e-9 * np.eye(len(shorts))
        lam = np.maximum(np.linalg.solve(gram, shorts), 0.0)
        step = np.clip(weights * (j.T @ lam), -max_turn, max_turn)
        target = angles[dofs] + step
        blocked = ((target < pseudo.lower[dofs]) & (step < 0)) | ((target > pseudo.upper[dofs]) & (step > 0))
        if not np.any(blocked & free):
            break
        free &= ~blocked
    new = np.clip(angles[dofs] + step, pseudo.lower[dofs], pseudo.upper[dofs])
    turn = new - angles[dofs]
    if np.abs(turn).max() < 1e-7:
        return False
    stop = pseudo.velocity[dofs] * turn < 0
    pseudo.velocity[dofs[stop]] = 0.0
    angles[dofs] = new
    return True


class FingerContact:
    """Keeps neighbouring fingers side by side by their MCP abduction and rotation (module docstring);
    ``distance`` (m) overrides the per-pair distances."""

    def __init__(self, skeleton: Skeleton, pseudo: PseudoMuscles, distance: float | None = None, samples: int = 6):
        self.skeleton, self.pseudo = skeleton, pseudo
        self.enabled = True
        #: "auto": the compiled sweep (:mod:`.contact_kernel`) wherever numba is usable; "numpy": never
        self.backend = "auto"
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
        knuckle = [skeleton.position[b[0]] + s * (skeleton.tail[b[0]] - skeleton.position[b[0]]) for b in self.bones]
        self.knuckle_rest = np.array(knuckle)           # (fingers, samples, 3) along the whole proximal phalanx
        k = np.arange(samples)
        self.knuckle_pairs = (np.r_[k, k[1:]], np.r_[k, np.zeros(samples - 1, int)])
        self.owner = np.array(owner)                    # (fingers, samples) bone of each sample
        self.mcp = np.array([bones[0] for bones in self.bones])
        self.parents = skeleton.parent[self.mcp]
        self.frames = skeleton.frame[self.mcp]
        flat = np.array(self.dofs)
        self.signs = np.array([[skeleton.dofs[k].sign for k in row] for row in flat])
        self.flexion_sign = np.array([skeleton.dofs[k].sign for k in self.flexion])
        self._flat_dofs = flat
        self.curl_dofs = np.array([[skeleton.dof(f"{f}-finger-phalanx-{p}", "flexion") for p in PARTS]
                                   for f in CONTACT_FINGERS])
        self.least_weight = np.array([ABDUCTION_WEIGHT.get(f, 1.0) for f in CONTACT_FINGERS])
        self._last = None
        self._frozen: dict = {}
        axes = self.frames[:, :, 0]
        self.ulnar_sign = np.sign(np.einsum("pi,pi->p", axes[1:] + axes[:-1], np.diff(mcp, axis=0)))

    def weights(self, angles: np.ndarray) -> np.ndarray:
        """Each contact DOF's weight in the turn (fingers x (abduction, rotation), flattened): 1, but a curled
        finger's abduction :data:`ABDUCTION_WEIGHT`, reached as its MCP, PIP and DIP flexions sum from
        ``CURL[0]`` to ``CURL[1]`` (a straight finger's tip moves sideways by abduction as well as any)."""
        curl = np.clip((angles[self.curl_dofs].sum(axis=1) - CURL[0]) / (CURL[1] - CURL[0]), 0.0, 1.0)
        abduction = 1.0 + (self.least_weight - 1.0) * curl
        return np.stack([abduction, np.ones_like(abduction)], axis=1).ravel()

    def transforms(self, angles: np.ndarray) -> np.ndarray:
        """The bone transforms of ``angles``: the ones the last contact check computed when the joints have not
        moved since, else forward kinematics."""
        if self._last is not None and np.array_equal(self._last[0], angles):
            return self._last[1]
        transforms = self.skeleton.bone_transforms(angles)
        self._last = (np.array(angles, np.float64), transforms)
        return transforms

    def keep(self, angles: np.ndarray, transforms: np.ndarray) -> None:
        """Remember ``transforms`` as those of ``angles`` (so :meth:`transforms` need not compute them again)."""
        self._last = (np.array(angles, np.float64), transforms)

    def _freeze(self, angles: np.ndarray) -> None:
        """What stays fixed while only the MCP abductions and rotations turn (one forward kinematics per
        :meth:`resolve`, not one per sweep): each finger's parent transform ``P``, its MCP centre ``c``, the
        flexion turn, and every sample in its proximal phalanx's rest coordinates ``y`` (the intermediate and
        distal phalanges ride on the proximal one), so a sweep poses the samples as ``P (R (y - c) + c)``
        with ``R = F Rx Ry Rz F^T`` the MCP joint's rotation (:meth:`.Skeleton.local_rotations`)."""
        transforms = self.transforms(angles)
        m = transforms[self.owner]
        points = np.einsum("fsij,fsj->fsi", m[..., :3, :3], self.rest) + m[..., :3, 3]
        proximal = transforms[self.mcp]
        rest = np.einsum("fji,fsj->fsi", proximal[:, :3, :3], points - proximal[:, None, :3, 3])
        centre = self.skeleton.position[self.mcp]
        parent = transforms[self.parents]
        flex = rotation_matrices(np.tile([1.0, 0.0, 0.0], (len(self.mcp), 1)), angles[self.flexion] * self.flexion_sign)
        world = parent[:, :3, :3] @ self.frames
        self._frozen = {
            "offset": np.concatenate([rest, self.knuckle_rest], axis=1) - centre[:, None, :],
            "world_flex": world @ flex,
            "centre": np.einsum("fij,fj->fi", parent[:, :3, :3], centre) + parent[:, :3, 3],
            "held": np.delete(angles, self._flat_dofs.ravel())}

    def _posed(self, angles: np.ndarray):
        """Posed samples (fingers, samples + knuckle samples, 3), each pair's direction across the fingers
        (pairs, 3): the mean of the two proximal phalanges' posed flexion axes, towards the ulnar finger; the
        world axes (fingers, 2, 3) of the MCP abduction and rotation (signed like the DOFs) and the MCP centres
        (fingers, 3). Uses the :meth:`_freeze` of the same angles but the MCP abductions and rotations."""
        frozen = self._frozen
        count = len(self.mcp)
        abd = rotation_matrices(np.tile([0.0, 1.0, 0.0], (count, 1)), angles[self._flat_dofs[:, 0]] * self.signs[:, 0])
        rot = rotation_matrices(np.tile([0.0, 0.0, 1.0], (count, 1)), angles[self._flat_dofs[:, 1]] * self.signs[:, 1])
        turned = frozen["world_flex"] @ abd
        posed = turned @ rot @ np.transpose(self.frames, (0, 2, 1))          # P R: the proximal phalanx's rotation
        points = np.einsum("fij,fsj->fsi", posed, frozen["offset"]) + frozen["centre"][:, None, :]
        across = np.einsum("fij,fj->fi", posed, self.frames[:, :, 0])
        across = across[1:] + across[:-1]
        axes = np.stack([frozen["world_flex"][:, :, 1] * self.signs[:, :1], turned[:, :, 2] * self.signs[:, 1:]], axis=1)
        across = across * (self.ulnar_sign / np.linalg.norm(across, axis=1))[:, None]
        return points, across, axes, frozen["centre"]

    def _shortfalls(self, angles: np.ndarray):
        """Samples, directions across, MCP axes and centres (:meth:`_posed`) and the shortfalls (pairs,
        S x S + K) from side by side (module docstring): every sample of a finger against every sample of its
        ulnar neighbour, then the ``K`` knuckle pairs (the radial proximal phalanx against its neighbour's
        matching samples and MCP centre); -inf where samples are far apart."""
        self._frozen_for(angles)
        points, across, axes, centres = self._posed(angles)
        n, first, second = self.rest.shape[1], *self.knuckle_pairs
        between = points[1:, None, :n, :] - points[:-1, :n, None, :]
        short = self._short(between.reshape(len(between), -1, 3), across, self.distance)
        base = points[1:, n + second] - points[:-1, n + first]
        knuckle = self._short(base, across, KNUCKLE / SPACING * self.distance)
        return points, across, axes, centres, np.concatenate([short, knuckle], axis=1)

    @staticmethod
    def _short(between: np.ndarray, across: np.ndarray, distance: np.ndarray) -> np.ndarray:
        """Shortfall (pairs, K) of sample offsets ``between`` (pairs, K, 3) from lying ``distance`` (pairs,)
        apart on their own sides across the fingers; -inf where they are far apart."""
        limit = distance[:, None]
        lateral = np.einsum("pkj,pj->pk", between, across)
        square = np.einsum("pkj,pkj->pk", between, between)
        needed = np.sqrt(np.maximum(limit ** 2 - (square - lateral ** 2), 0.0))
        return np.where(square < (REACH * limit) ** 2, needed - lateral, -np.inf)

    def gaps(self, angles: np.ndarray) -> np.ndarray:
        """Each neighbouring pair's contact distance less its largest shortfall (m): at least the distance when
        the pair is side by side (module docstring)."""
        short = self._shortfalls(angles)[4]
        return self.distance - np.maximum(short.max(axis=1), 0.0)

    def _compiled(self):
        """``(contact_rows, resolve_sweeps)`` of :mod:`.contact_kernel` compiled, wherever numba is usable
        and ``backend`` allows it; else ``None`` (numpy)."""
        return None if self.backend == "numpy" else compiled_sweeps()

    def _frozen_for(self, angles: np.ndarray) -> dict:
        """:meth:`_freeze` unless it holds for ``angles`` already."""
        if not np.array_equal(self._frozen.get("held"), np.delete(angles, self._flat_dofs.ravel())):
            self._freeze(angles)
        return self._frozen

    def _rows(self, angles: np.ndarray):
        """The pairs that are too close: (shortfalls (P,), Jacobian (P, 2 x fingers) of their worst samples'
        offset across the fingers over every finger's MCP abduction and rotation)."""
        compiled = self._compiled()
        if compiled is not None:
            frozen, count = self._frozen_for(angles), len(self.mcp)
            shorts, rows = np.empty(count - 1), np.empty((count - 1, 2 * count))
            compiled[0](frozen["world_flex"], self.frames, frozen["offset"], frozen["centre"],
                     angles[self._flat_dofs[:, 0]], angles[self._flat_dofs[:, 1]], self.signs, self.ulnar_sign,
                     self.distance, self.knuckle_pairs[0], self.knuckle_pairs[1], self.rest.shape[1],
                     KNUCKLE / SPACING, REACH, shorts, rows)
            close = np.flatnonzero(shorts > TOLERANCE)
            return shorts[close], rows[close]
        points, across, axes, centres, short = self._shortfalls(angles)
        worst = np.argmax(short, axis=1)
        pairs = np.arange(len(short))
        shorts = short[pairs, worst]
        close = np.flatnonzero(shorts > TOLERANCE)
        if len(close) == 0:
            return shorts[close], np.zeros((0, 2 * len(points)))
        rows = np.zeros((len(close), 2 * len(points)))
        n = self.rest.shape[1]
        for r, a in enumerate(close):
            w = int(worst[a])
            if w < n * n:
                i, j = divmod(w, n)
            else:
                i, j = (n + v[w - n * n] for v in self.knuckle_pairs)
            for finger, sign, k in ((a, -1.0, i), (a + 1, 1.0, j)):
                lever = _cross(axes[finger], points[finger][k] - centres[finger])
                rows[r, 2 * finger:2 * finger + 2] = sign * (lever @ across[a])
        return shorts[close], rows

    def resolve(self) -> bool:
        """Push touching fingers apart (module docstring); True if any joint was turned. Each sweep solves
        the linearised contacts of all pairs at once: the smallest weighted turn ``W J^T lambda`` with
        ``lambda >= 0`` (:meth:`weights`: a curled little finger clears by rotation more than by abduction)
        that restores every shortfall, DOFs held at a limit taken out."""
        pseudo, moved, angles, dofs = self.pseudo, False, self.pseudo.angles, self._flat_dofs.ravel()
        weights = self.weights(angles)              # the flexions do not change while the contact turns
        compiled = self._compiled() if self.enabled else None
        if compiled is not None:
            frozen = self._frozen_for(angles)
            return bool(compiled[1](frozen["world_flex"], self.frames, frozen["offset"], frozen["centre"], self.signs,
                                    self.ulnar_sign, self.distance, self.knuckle_pairs[0], self.knuckle_pairs[1],
                                    self.rest.shape[1], KNUCKLE / SPACING, REACH, angles, pseudo.velocity, dofs,
                                    pseudo.lower, pseudo.upper, SWEEPS, TOLERANCE, SETTLED, MAX_TURN, weights))
        for _ in range(SWEEPS if self.enabled else 0):
            shorts, jac = self._rows(angles)
            if len(shorts) == 0 or (moved and shorts.max() < SETTLED):
                break
            if not turn_apart(pseudo, dofs, shorts, jac, MAX_TURN, weights):
                break
            moved = True
        return moved
