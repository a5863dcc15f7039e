# SPDX-License-Identifier: GPL-3.0-or-later
"""Solve Contractions: the minimal-effort muscle contractions that hold the hand in a pose the artist set by
rotating its bones. The thesis names this as future work (6.2.4: "an optimization process that computes
minimal energy muscle contractions for a given target position of the fingers"; 6.2.5, 7.1.2).

At the target angles every fibre length ``l_ik`` is known (:mod:`.pseudo`), so the torque balance of each
dynamic DOF ``k`` is linear in the contractions:

    sum_i s_ik r_ik [c_i F_contr,i(l_ik) + F_stretch,i(l_ik)] - k_capsule phi_k = 0      (Eqs. 6.3', 6.9)

A DOF held at a Table 6.4 limit only needs its torque to push into the limit. The solver minimises the
effort ``sum c_i^2`` plus a heavily weighted residual of those balances, with ``0 <= c_i <= 1``
(bounded linear least squares), then checks the result by simulating the hand from rest.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import lsq_linear

from ..core.errors import UserError
from .pseudo import PseudoMuscles, contraction_force, stretch_force
from .skeleton import Skeleton

__all__ = ["Solution", "solve_contractions", "angles_from_rotations"]

EFFORT_WEIGHT = 1e-3


@dataclass
class Solution:
    contractions: dict[str, float]
    residual: float                 # largest torque imbalance left (N m)
    reached: np.ndarray | None = None   # simulated angles (radians) when checked
    error_deg: float | None = None      # largest angle error of the check (degrees)


def angles_from_rotations(skeleton: Skeleton, rotations: dict[str, np.ndarray]) -> np.ndarray:
    """DOF angles from each bone's local rotation (3x3, world axes, relative to its parent at rest), decomposed
    in its joint frame as ``Rx(flexion) Ry(abduction) Rz(rotation)``; bones not given stay at 0."""
    angles = np.zeros(skeleton.dof_count)
    for bone, rotation in rotations.items():
        if bone not in skeleton.index:
            raise UserError(f"the hand has no bone {bone!r}")
        b = skeleton.index[bone]
        frame = skeleton.frame[b]
        r = frame.T @ np.asarray(rotation, np.float64) @ frame
        abduction = np.arcsin(np.clip(r[0, 2], -1.0, 1.0))
        flexion = np.arctan2(-r[1, 2], r[2, 2])
        twist = np.arctan2(-r[0, 1], r[0, 0])
        for kind, value in (("flexion", flexion), ("abduction", abduction), ("rotation", twist)):
            k = skeleton.dof_index.get((bone, kind))
            if k is not None:
                angles[k] = value * skeleton.dofs[k].sign
    return angles


def solve_contractions(pseudo: PseudoMuscles, target: np.ndarray, fixed: dict[str, float] | None = None,
                       ) -> Solution:
    """Minimal-effort contractions holding the joints at ``target`` angles (module docstring). ``fixed``
    pins some contractions (name -> value)."""
    target = np.clip(np.asarray(target, np.float64), pseudo.lower, pseudo.upper)
    dyn = pseudo.inertia_dofs
    lengths = pseudo.fibre_lengths(target)[:, dyn]
    rest, top = pseudo.rest[:, None], pseudo.max_force[:, None]
    lever = pseudo.lever[:, dyn]
    a = (lever * contraction_force(lengths, rest, top)).T                     # (K, M): torque per unit c
    b = -np.sum(lever * stretch_force(lengths, rest, top), axis=0) + pseudo.capsule[dyn] * target[dyn]
    span = pseudo.upper[dyn] - pseudo.lower[dyn]
    at_upper = (target[dyn] >= pseudo.upper[dyn] - 1e-6) & (span > 0)
    at_lower = (target[dyn] <= pseudo.lower[dyn] + 1e-6) & (span > 0)
    free = ~(at_upper | at_lower) & (span > 0)
    scale = 1.0 / np.maximum(np.abs(a).max(axis=1), 1e-6)
    lower_c, upper_c = np.zeros(len(pseudo.rest)), np.ones(len(pseudo.rest))
    for name, value in (fixed or {}).items():
        if name not in pseudo.names:
            raise UserError(f"unknown hand muscle {name!r}")
        if not 0.0 <= value <= 1.0:
            raise UserError(f"contraction {name} = {value} is outside [0, 1]")
        i = pseudo.names.index(name)
        lower_c[i], upper_c[i] = value, value + 1e-12
    c = np.zeros(len(pseudo.rest))
    for _ in range(4):                       # limits: keep only balances the solution does not satisfy
        rows = free | (at_upper & (a @ c - b < 0)) | (at_lower & (a @ c - b > 0))
        system = np.vstack([a[rows] * scale[rows, None], np.sqrt(EFFORT_WEIGHT) * np.eye(len(c))])
        rhs = np.concatenate([b[rows] * scale[rows], np.zeros(len(c))])
        c = lsq_linear(system, rhs, bounds=(lower_c, upper_c), method="bvls").x
    imbalance = a @ c - b
    imbalance[at_upper] = np.minimum(imbalance[at_upper], 0.0)
    imbalance[at_lower] = np.maximum(imbalance[at_lower], 0.0)
    c = np.clip(c, 0.0, 1.0)
    return Solution({n: float(round(v, 6)) for n, v in zip(pseudo.names, c)}, float(np.abs(imbalance).max()))
