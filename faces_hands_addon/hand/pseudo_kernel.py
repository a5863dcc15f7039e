# SPDX-License-Identifier: GPL-3.0-or-later
"""The pseudo muscles' joint substeps (thesis 6.2.2, Eqs. 6.1-6.3', 6.7, 6.9) as one loop, compiled by numba
wherever the physics kernel is usable (:func:`..physics.kernel.compiled`); the numpy substeps of
:meth:`.pseudo.PseudoMuscles.step` stay the reference and the fallback
(``tests/engine/hand/test_hand_kernels.py`` requires agreement to 1e-12 rad).

Per substep of length ``h`` and per dynamic DOF ``k`` (the DOFs are independent within a substep: a fibre's
length ``l_ik = l0_i - s_ik r_ik phi_k`` depends on its own DOF only): the Blix force-length curve (Eq. 6.1)
and the passive stretch (Eq. 6.2) of every muscle at its bounded length, their torque (Eq. 6.9) less the joint
capsule, and the semi-implicit velocity update of Eq. 6.7 with friction (Eq. 6.4'') and the force-length
slope as stiffness; the joint stops at its Table 6.4 limits. In numpy that is some twenty array operations per
substep on (muscles x DOFs) arrays; here one call.
"""
from __future__ import annotations

from ..physics import kernel

__all__ = ["joint_substeps", "compiled_substeps"]


def compiled_substeps():
    """:func:`joint_substeps` compiled wherever the physics kernel is usable; else ``None``."""
    return kernel.compiled(joint_substeps)


def joint_substeps(q, w, lever, lever2, rest, low_length, high_length, active, passive, slope_active,
                   slope_passive, inverse_inertia, friction, capsule, low, high, h, substeps):
    """``substeps`` substeps of ``h`` seconds; ``q``, ``w`` (dynamic DOFs' angles and speeds) change in place.
    ``lever``/``lever2`` (muscles, DOFs), per-muscle ``rest``, length bounds, ``active`` = c F_max,
    ``passive`` = 2.77 F_max and the two slope factors; per-DOF ``inverse_inertia``, ``friction`` (h mu / I),
    ``capsule`` and the limits: the arithmetic of :meth:`.pseudo.PseudoMuscles.step`."""
    muscles, dofs = lever.shape
    for _ in range(substeps):
        for k in range(dofs):
            torque, stiffness = 0.0, 0.0
            for i in range(muscles):
                raw = rest[i] - lever[i, k] * q[k]
                length = min(max(raw, low_length[i]), high_length[i])
                ratio = length / rest[i]
                over = max(ratio - 1.0, 0.0)
                force = active[i] * (1.0 - 4.0 * (ratio - 1.1) ** 2) + passive[i] * over * over
                torque += lever[i, k] * force
                if raw == length:
                    stiffness += lever2[i, k] * (slope_active[i] * (ratio - 1.1) + slope_passive[i] * over)
            torque -= capsule[k] * q[k]
            stiffness = max(stiffness, 0.0) + capsule[k]
            speed = (w[k] + h * torque * inverse_inertia[k]) / (1.0 + friction[k] + h * h * stiffness * inverse_inertia[k])
            moved = q[k] + h * speed
            if (moved < low[k] and speed < 0.0) or (moved > high[k] and speed > 0.0):
                speed = 0.0
            q[k] = min(max(moved, low[k]), high[k])
            w[k] = speed
