# SPDX-License-Identifier: GPL-3.0-or-later
"""One sweep of the finger contact of :mod:`.contact` as a single loop, compiled by numba wherever the physics
kernel is usable (:func:`..physics.kernel.compiled`); :meth:`.contact.FingerContact._rows` in numpy stays the
reference and the fallback (``tests/engine/hand/test_hand_kernels.py`` requires agreement to 1e-12).

Beyond the thesis (its hand has no collisions, 6.2.5). A sweep poses the samples of the four fingers from
their MCP abductions and rotations (``P (R (y - c) + c)``, ``R = F Rx Ry Rz F^T``, :meth:`.Skeleton.
local_rotations`), measures every sample pair's shortfall from lying side by side across the fingers, keeps
each neighbouring pair's worst one and writes its Jacobian row over the MCP abductions and rotations. In numpy
that is some sixty small array operations, each costing more to call than its arithmetic; here one call.
"""
from __future__ import annotations

import math

import numpy as np

from ..physics import kernel

__all__ = ["contact_rows", "resolve_sweeps", "compiled_sweeps"]


def compiled_sweeps():
    """``(contact_rows, resolve_sweeps)`` compiled wherever the physics kernel is usable; ``None`` otherwise
    (the numpy path runs)."""
    rows = kernel.compiled(contact_rows, _pose_fingers, _shortfall)
    if rows is None:
        return None
    kernel.compiled(_turn, _solve_small)
    return rows, kernel.compiled(resolve_sweeps, contact_rows, _turn)


def _pose_fingers(world_flex, frames, offset, centre, abduction, rotation, signs, points, across, axes):
    """Posed samples (F, S, 3), each finger's posed flexion axis (F, 3) and its world MCP abduction and
    rotation axes (F, 2, 3), signed like the DOFs."""
    for f in range(world_flex.shape[0]):
        ca, sa = math.cos(abduction[f] * signs[f, 0]), math.sin(abduction[f] * signs[f, 0])
        cr, sr = math.cos(rotation[f] * signs[f, 1]), math.sin(rotation[f] * signs[f, 1])
        turned = np.empty((3, 3))
        for r in range(3):              # world_flex @ Ry(abduction)
            w0, w1, w2 = world_flex[f, r, 0], world_flex[f, r, 1], world_flex[f, r, 2]
            turned[r, 0] = w0 * ca - w2 * sa
            turned[r, 1] = w1
            turned[r, 2] = w0 * sa + w2 * ca
        posed = np.zeros((3, 3))
        for r in range(3):              # turned @ Rz(rotation) @ F^T
            a0 = turned[r, 0] * cr + turned[r, 1] * sr
            a1 = -turned[r, 0] * sr + turned[r, 1] * cr
            a2 = turned[r, 2]
            for c in range(3):
                posed[r, c] = a0 * frames[f, c, 0] + a1 * frames[f, c, 1] + a2 * frames[f, c, 2]
        for r in range(3):
            across[f, r] = posed[r, 0] * frames[f, 0, 0] + posed[r, 1] * frames[f, 1, 0] + posed[r, 2] * frames[f, 2, 0]
            axes[f, 0, r] = world_flex[f, r, 1] * signs[f, 0]
            axes[f, 1, r] = turned[r, 2] * signs[f, 1]
        for s in range(offset.shape[1]):
            for r in range(3):
                points[f, s, r] = (posed[r, 0] * offset[f, s, 0] + posed[r, 1] * offset[f, s, 1]
                                   + posed[r, 2] * offset[f, s, 2] + centre[f, r])


def _shortfall(points, p, i, j, direction, limit, reach):
    """Shortfall of sample ``i`` of finger ``p`` and sample ``j`` of finger ``p + 1`` from lying ``limit``
    apart on their own sides along ``direction``; -inf when further apart than ``reach`` limits."""
    d0 = points[p + 1, j, 0] - points[p, i, 0]
    d1 = points[p + 1, j, 1] - points[p, i, 1]
    d2 = points[p + 1, j, 2] - points[p, i, 2]
    lateral = d0 * direction[0] + d1 * direction[1] + d2 * direction[2]
    square = d0 * d0 + d1 * d1 + d2 * d2
    if not square < (reach * limit) ** 2:
        return -np.inf
    return math.sqrt(max(limit * limit - (square - lateral * lateral), 0.0)) - lateral


def contact_rows(world_flex, frames, offset, centre, abduction, rotation, signs, ulnar_sign, distance, first,
                 second, n, knuckle_ratio, reach, shorts, rows):
    """Every neighbouring pair's worst shortfall into ``shorts`` (P,) and its Jacobian row over the fingers'
    MCP abductions and rotations into ``rows`` (P, 2 F) (zero for pairs with no sample close): the arithmetic
    of ``FingerContact._shortfalls`` and ``_rows``, first maximum on ties as ``np.argmax``."""
    count, samples = world_flex.shape[0], offset.shape[1]
    points = np.empty((count, samples, 3))
    across = np.empty((count, 3))
    axes = np.empty((count, 2, 3))
    _pose_fingers(world_flex, frames, offset, centre, abduction, rotation, signs, points, across, axes)
    direction = np.empty(3)
    for p in range(count - 1):
        for r in range(3):
            direction[r] = across[p, r] + across[p + 1, r]
        norm = math.sqrt(direction[0] ** 2 + direction[1] ** 2 + direction[2] ** 2)
        for r in range(3):
            direction[r] = direction[r] * ulnar_sign[p] / norm
        best, best_i, best_j = -np.inf, 0, 0
        for i in range(n):
            for j in range(n):
                value = _shortfall(points, p, i, j, direction, distance[p], reach)
                if value > best:
                    best, best_i, best_j = value, i, j
        for q in range(first.shape[0]):
            value = _shortfall(points, p, n + first[q], n + second[q], direction, knuckle_ratio * distance[p], reach)
            if value > best:
                best, best_i, best_j = value, n + first[q], n + second[q]
        shorts[p] = best
        for c in range(rows.shape[1]):
            rows[p, c] = 0.0
        for finger, sign, k in ((p, -1.0, best_i), (p + 1, 1.0, best_j)):
            arm0 = points[finger, k, 0] - centre[finger, 0]
            arm1 = points[finger, k, 1] - centre[finger, 1]
            arm2 = points[finger, k, 2] - centre[finger, 2]
            for d in range(2):
                a0, a1, a2 = axes[finger, d, 0], axes[finger, d, 1], axes[finger, d, 2]
                lever0 = a1 * arm2 - a2 * arm1
                lever1 = a2 * arm0 - a0 * arm2
                lever2 = a0 * arm1 - a1 * arm0
                rows[p, 2 * finger + d] = sign * (lever0 * direction[0] + lever1 * direction[1] + lever2 * direction[2])


def _solve_small(matrix, rhs, size):
    """``matrix[:size, :size] x = rhs[:size]`` by Gaussian elimination with partial pivoting (the LU that
    ``np.linalg.solve`` uses), in place; returns x."""
    a = matrix[:size, :size].copy()
    x = rhs[:size].copy()
    for col in range(size):
        pivot = col
        for r in range(col + 1, size):
            if abs(a[r, col]) > abs(a[pivot, col]):
                pivot = r
        if pivot != col:
            for c in range(size):
                a[col, c], a[pivot, c] = a[pivot, c], a[col, c]
            x[col], x[pivot] = x[pivot], x[col]
        for r in range(col + 1, size):
            factor = a[r, col] / a[col, col]
            for c in range(col, size):
                a[r, c] -= factor * a[col, c]
            x[r] -= factor * x[col]
    for r in range(size - 1, -1, -1):
        total = x[r]
        for c in range(r + 1, size):
            total -= a[r, c] * x[c]
        x[r] = total / a[r, r]
    return x


def _turn(jac, shorts, close, angles, dofs, lower, upper, max_turn, weights):
    """The smallest turn ``W J^T lambda`` (``lambda >= 0``, ``W`` the DOFs' ``weights``) of the free DOFs
    that restores the ``close`` pairs' shortfalls, DOFs a turn would push past their limits taken out (up to
    three solves): the numpy ``FingerContact.resolve`` sweep."""
    size, width = close.shape[0], jac.shape[1]
    free = np.ones(width, np.bool_)
    step = np.zeros(width)
    gram, rhs = np.empty((size, size)), np.empty(size)
    for _ in range(3):
        for r in range(size):
            rhs[r] = shorts[close[r]]
            for s in range(size):
                total = 0.0
                for c in range(width):
                    if free[c]:
                        total += jac[close[r], c] * jac[close[s], c] * weights[c]
                gram[r, s] = total + (1e-9 if r == s else 0.0)
        lam = _solve_small(gram, rhs, size)
        any_blocked = False
        for c in range(width):
            total = 0.0
            if free[c]:
                for r in range(size):
                    total += jac[close[r], c] * max(lam[r], 0.0)
            step[c] = min(max(total * weights[c], -max_turn), max_turn)
            target = angles[dofs[c]] + step[c]
            if free[c] and ((target < lower[dofs[c]] and step[c] < 0) or (target > upper[dofs[c]] and step[c] > 0)):
                any_blocked = True
        if not any_blocked:
            break
        for c in range(width):
            target = angles[dofs[c]] + step[c]
            if (target < lower[dofs[c]] and step[c] < 0) or (target > upper[dofs[c]] and step[c] > 0):
                free[c] = False
    return step


def resolve_sweeps(world_flex, frames, offset, centre, signs, ulnar_sign, distance, first, second, n,
                   knuckle_ratio, reach, angles, velocity, dofs, lower, upper, sweeps, tolerance, settled,
                   max_turn, weights):
    """Every sweep of ``FingerContact.resolve`` (:mod:`.contact`) in one call: pairs too close, their
    linearised turn, the DOFs clamped to their limits, the speed into the contact removed; ``angles`` and
    ``velocity`` change in place. Returns whether any joint turned."""
    count = world_flex.shape[0]
    shorts, rows = np.empty(count - 1), np.empty((count - 1, 2 * count))
    abduction, rotation = np.empty(count), np.empty(count)
    moved = False
    for _ in range(sweeps):
        for f in range(count):
            abduction[f], rotation[f] = angles[dofs[2 * f]], angles[dofs[2 * f + 1]]
        contact_rows(world_flex, frames, offset, centre, abduction, rotation, signs, ulnar_sign, distance,
                     first, second, n, knuckle_ratio, reach, shorts, rows)
        close = np.flatnonzero(shorts > tolerance)
        if close.shape[0] == 0:
            break
        if moved and shorts[close].max() < settled:
            break
        step = _turn(rows, shorts, close, angles, dofs, lower, upper, max_turn, weights)
        largest = 0.0
        new = np.empty(dofs.shape[0])
        for c in range(dofs.shape[0]):
            new[c] = min(max(angles[dofs[c]] + step[c], lower[dofs[c]]), upper[dofs[c]])
            largest = max(largest, abs(new[c] - angles[dofs[c]]))
        if largest < 1e-7:
            break
        for c in range(dofs.shape[0]):
            if velocity[dofs[c]] * (new[c] - angles[dofs[c]]) < 0:
                velocity[dofs[c]] = 0.0
            angles[dofs[c]] = new[c]
        moved = True
    return moved
