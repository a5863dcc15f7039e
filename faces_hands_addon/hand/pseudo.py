# SPDX-License-Identifier: GPL-3.0-or-later
"""Pseudo muscles (thesis 6.2.2): contraction values -> joint rotations, by anatomy and mechanics.

Per muscle ``i`` with resting fibre length ``l0``, maximum force ``F_max`` and, for every DOF ``k`` it crosses,
a moment arm ``r_ik`` and a direction ``s_ik`` (+1 towards positive angles), Table A.1:

* Eq. 6.1 (Blix curve, active): ``F_contr(l) = [1 - 4 (l/l0 - 1.1)^2] F_max``, largest at ``l = 1.1 l0``;
* Eq. 6.2 (passive stretch): ``F_stretch(l) = 2.77 (l/l0 - 1)^2 F_max`` for ``l >= l0``, else 0;
* the fibre length starts at ``l0`` and changes by the arc length of the rotation at a joint it crosses
  (Eq. 6.7, last line: ``l <- l - dphi r``), kept within ``0.6 l0 <= l <= 1.6 l0`` [BH99]. We keep one such
  length per joint DOF a muscle crosses, ``l_ik = l0_i - s_ik r_ik phi_k``, as in the single-bone derivation
  applied at each joint: summing every joint's arc length into one fibre would shorten the long finger
  flexors past 0.6 l0 in any fist (flexor digitorum profundus: 34 of 66 mm), while 6.2.2 notes that the
  bounds are "usually not reached, since the corresponding joints are constrained in their rotations";
* Eq. 6.3': ``F_i = c_i F_contr(l_i) + F_stretch(l_i)``;
* Eqs. 6.9 / 6.4'': every force acts perpendicular to its moment arm, so the torque about a DOF's axis is
  ``T_k = sum_i s_ik r_ik F_i``, less friction. We read the friction term of Eq. 6.4'' as opposing the
  angular velocity, ``T = T_k - mu omega``: when the muscle torque and the motion share a direction this is
  Eq. 6.4'' exactly; written with the sign of ``T_k`` it would do nothing to a released joint (``T_k = 0``),
  which friction must bring to rest. ``mu = 0.015`` N m s (SI units throughout);
* Eq. 6.7: ``omega_new = omega_old + dt T / J``, ``phi += dt omega_new``, with ``J`` from
  :class:`.inertia.ChainInertia` (Eq. 6.8 and the ``J*`` tables). Because a finger's ``J`` is tiny against
  ``mu dt``, the friction and the stiffness of the muscle torque about the DOF itself are taken at the new
  velocity (backward Euler on those two terms), which keeps every substep stable;
* joint limits (Table 6.4) are always respected: an angle is clamped and its velocity into the limit
  dropped.

Beyond the thesis: a weak restoring torque of the joint capsule and ligaments (6.1.2), ``-k_capsule phi``,
keeps DOFs that Table A.1 moves in one direction only (CMC V opposition, MCP I abduction) from drifting.
Rotation DOFs that follow flexion (``Dof.coupled``) are set from it after every substep.
"""
from __future__ import annotations

import numpy as np

from ..core.errors import UserError
from .inertia import ChainInertia
from .presets import MuscleSpec
from .pseudo_kernel import compiled_substeps
from .skeleton import Skeleton

__all__ = ["MIN_LENGTH", "MAX_LENGTH", "contraction_force", "stretch_force", "PseudoMuscles"]

MIN_LENGTH, MAX_LENGTH = 0.6, 1.6      # fibre length bounds in units of l0 [BH99]
SUBSTEP = 1.0 / 60.0                   # longest substep of the joint simulation (s)
CAPSULE_ABDUCTION = 3.0                # abduction DOFs: stiffer capsule (collateral ligaments)


def contraction_force(length: np.ndarray, rest: np.ndarray, max_force: np.ndarray) -> np.ndarray:
    """Eq. 6.1: ``[1 - 4 (l/l0 - 1.1)^2] F_max``."""
    ratio = np.asarray(length) / rest
    return (1.0 - 4.0 * (ratio - 1.1) ** 2) * max_force


def stretch_force(length: np.ndarray, rest: np.ndarray, max_force: np.ndarray) -> np.ndarray:
    """Eq. 6.2: ``2.77 (l/l0 - 1)^2 F_max`` when stretched (``l >= l0``), else 0."""
    over = np.maximum(np.asarray(length) / rest - 1.0, 0.0)
    return 2.77 * over * over * max_force


class PseudoMuscles:
    """All pseudo muscles of a hand as flat arrays, and the joint state they drive (module docstring)."""

    def __init__(self, skeleton: Skeleton, specs: list[MuscleSpec], inertia_masses: np.ndarray,
                 friction: float = 0.015, capsule: float = 0.0):
        self.skeleton = skeleton
        self.names = [m.name for m in specs]
        self.groups = [m.group for m in specs]
        self.rest = np.array([m.rest_length for m in specs])
        self.max_force = np.array([m.max_force for m in specs])
        muscle, dof, sign, arm = [], [], [], []
        for i, spec in enumerate(specs):
            for row in spec.rows:
                if row.bone not in skeleton.index:
                    raise UserError(f"hand muscle {spec.name!r} crosses {row.bone!r}, which the hand does not have")
                key = (row.bone, row.dof)
                if key not in skeleton.dof_index:
                    raise UserError(f"hand muscle {spec.name!r} moves the {row.dof} of {row.bone!r}, a DOF that "
                                    "joint has not (presets/hand/joints.json)")
                muscle.append(i)
                dof.append(skeleton.dof_index[key])
                sign.append(row.sign)
                arm.append(row.arm)
        count = skeleton.dof_count
        #: (muscles, DOFs) signed moment arms s_ik r_ik (m); its square for the stiffness
        self.lever = np.zeros((len(specs), count))
        np.add.at(self.lever, (np.array(muscle, np.int64), np.array(dof, np.int64)), np.array(sign) * np.array(arm))
        self.lever2 = self.lever ** 2
        self._min, self._max = MIN_LENGTH * self.rest, MAX_LENGTH * self.rest
        self._force_per_length = self.max_force / self.rest
        self.coupled = np.array([d.coupled is not None for d in skeleton.dofs])
        self.dynamic = ~self.coupled
        self.coupled_to = np.array([skeleton.dof_index.get((skeleton.names[d.bone], "flexion"), k)
                                    for k, d in enumerate(skeleton.dofs)], np.int64)
        self.coupling = np.array([d.coupled or 0.0 for d in skeleton.dofs])
        self.lower, self.upper = skeleton.lower, skeleton.upper
        self.friction = float(friction)
        #: capsule stiffness per DOF (N m / rad); abduction DOFs are held by the collateral ligaments
        self.capsule = np.array([capsule * (CAPSULE_ABDUCTION if d.kind == "abduction" else 1.0)
                                 for d in skeleton.dofs])
        self.inertia = ChainInertia(skeleton, inertia_masses, self.dynamic)
        #: "auto": the compiled substeps (:mod:`.pseudo_kernel`) wherever numba is usable; "numpy": never
        self.backend = "auto"
        self.inertia_dofs = self.inertia.dofs
        self.angles = np.zeros(count)
        self.velocity = np.zeros(count)
        self._count = count

    # -- Eqs. 6.1-6.3', 6.9 ----------------------------------------------------------------------
    def fibre_lengths(self, angles: np.ndarray) -> np.ndarray:
        """(muscles, DOFs) fibre lengths ``l_ik = l0_i - s_ik r_ik phi_k`` within ``[0.6, 1.6] l0`` (module
        docstring); entries of DOFs a muscle does not cross hold ``l0``."""
        return np.clip(self.rest[:, None] - self.lever * angles[None, :], self._min[:, None], self._max[:, None])

    def forces(self, contraction: np.ndarray, lengths: np.ndarray) -> np.ndarray:
        """Eq. 6.3': ``F = c F_contr(l) + F_stretch(l)`` (N), for lengths of shape (muscles,) or (muscles, DOFs)."""
        shape = (-1,) + (1,) * (np.ndim(lengths) - 1)
        rest, top = self.rest.reshape(shape), self.max_force.reshape(shape)
        return (np.reshape(contraction, shape) * contraction_force(lengths, rest, top)
                + stretch_force(lengths, rest, top))

    def torques(self, contraction: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """Eq. 6.9: muscle torque about every DOF (N m), before friction and capsule."""
        return np.sum(self.lever * self.forces(contraction, self.fibre_lengths(angles)), axis=0)

    # -- Eq. 6.7 ---------------------------------------------------------------------------------
    def _couple(self, angles: np.ndarray) -> None:
        c = self.coupled
        angles[c] = np.clip(self.coupling[c] * angles[self.coupled_to[c]], self.lower[c], self.upper[c])

    def step(self, contraction: np.ndarray, dt: float) -> None:
        """Advance the joints by ``dt`` seconds (substeps of at most ``SUBSTEP``); the moments of inertia are
        looked up once per call (they change with the pose, slowly)."""
        contraction = np.asarray(contraction, np.float64)
        if contraction.shape != self.rest.shape or np.any((contraction < 0) | (contraction > 1)):
            raise UserError("pseudo-muscle contractions must be one value in [0, 1] per muscle")
        substeps = max(1, int(np.ceil(dt / SUBSTEP - 1e-9)))
        h = dt / substeps
        dyn = self.inertia_dofs
        lever, lever2 = self.lever[:, dyn], self.lever2[:, dyn]
        rest, low_l, high_l = self.rest[:, None], self._min[:, None], self._max[:, None]
        active = (contraction * self.max_force)[:, None]
        passive = 2.77 * self.max_force[:, None]
        slope_active = (contraction * -8.0 * self._force_per_length)[:, None]
        slope_passive = 5.54 * self._force_per_length[:, None]
        inverse_inertia = 1.0 / self.inertia(self.angles)
        friction, capsule = h * self.friction * inverse_inertia, self.capsule[dyn]
        low, high = self.lower[dyn], self.upper[dyn]
        q, w = self.angles[dyn], self.velocity[dyn]
        compiled = None if self.backend == "numpy" else compiled_substeps()
        if compiled is not None:
            compiled(q, w, np.ascontiguousarray(lever), np.ascontiguousarray(lever2), self.rest, self._min,
                     self._max, active[:, 0], passive[:, 0], slope_active[:, 0], slope_passive[:, 0],
                     np.ascontiguousarray(inverse_inertia), np.ascontiguousarray(friction),
                     np.ascontiguousarray(capsule), low, high, h, substeps)
            substeps = 0
        for _ in range(substeps):
            raw = rest - lever * q
            lengths = np.clip(raw, low_l, high_l)
            ratio = lengths / rest
            over = np.maximum(ratio - 1.0, 0.0)
            force = active * (1.0 - 4.0 * (ratio - 1.1) ** 2) + passive * over * over
            slope = (slope_active * (ratio - 1.1) + slope_passive * over) * (raw == lengths)
            torque = np.sum(lever * force, axis=0) - capsule * q
            stiffness = np.maximum(np.sum(lever2 * slope, axis=0), 0.0) + capsule
            w = (w + h * torque * inverse_inertia) / (1.0 + friction + h * h * stiffness * inverse_inertia)
            q_new = q + h * w
            q = np.clip(q_new, low, high)
            w = np.where(((q_new < low) & (w < 0)) | ((q_new > high) & (w > 0)), 0.0, w)
        self.angles[dyn], self.velocity[dyn] = q, w
        self._couple(self.angles)

    def reset(self) -> None:
        self.angles[:] = 0.0
        self.velocity[:] = 0.0

    def set_angles(self, angles: np.ndarray) -> None:
        """Put the joints at ``angles`` (clamped to the limits, rotations coupled), at rest."""
        self.angles[:] = np.clip(angles, self.lower, self.upper)
        self._couple(self.angles)
        self.velocity[:] = 0.0

    def speed(self) -> float:
        return float(np.abs(self.velocity).max()) if self._count else 0.0
