# SPDX-License-Identifier: GPL-3.0-or-later
"""The muscles' per-frame deformation (:meth:`.muscles.MuscleSystem.deform`, thesis 3.1.2 "Muscles",
"Properties", "Muscle Deformation") as compiled loops over the few hundred control points, for the live
preview.

In numpy each of the five steps (linear contraction along the rest polyline, pushes, sphincter contraction,
connections restored and spread, bulging) is tens of whole-array operations on a few hundred points, each
costing more in call overhead than in arithmetic; here every step is one pass. The numpy methods stay the
reference (same formulas, same order of operations; see :mod:`.muscles` for what each step means).
"""
from __future__ import annotations

import math

__all__ = ["deform_points", "HELPERS"]

CONNECTION_GAIN = 8.0        # as muscles.CONNECTION_GAIN
RETRACTED_OUTER = 0.5        # as muscles.RETRACTED_OUTER


def contract_linear(contraction, rotation, translation, rest, jaw_carry, muscle_of_point, which, column, row, rows,
                    arclength, grid, shortening, points, own_length):  # pragma: no cover - compiled
    """Step 1 for the linear muscles' points (``MuscleSystem._contract_linear``): each point to its shortened
    arc length along its column's rest polyline, then its share of the way with the jaw (in place)."""
    for k in range(which.shape[0]):
        muscle = muscle_of_point[which[k]]
        if not contraction[muscle] > 0:
            continue
        ratio = 1.0 - contraction[muscle] * shortening[muscle]
        c = column[k]
        target = arclength[c, row[k]] * ratio
        count = 0
        for r in range(arclength.shape[1]):
            if arclength[c, r] <= target:
                count += 1
        seg = min(max(count - 1, 0), rows[k] - 2)
        s0, s1 = arclength[c, seg], arclength[c, seg + 1]
        t = min(max((target - s0) / max(s1 - s0, 1e-12), 0.0), 1.0)
        i0, i1, p = grid[c, seg], grid[c, seg + 1], which[k]
        x = rest[i0, 0] * (1 - t) + rest[i1, 0] * t
        y = rest[i0, 1] * (1 - t) + rest[i1, 1] * t
        z = rest[i0, 2] * (1 - t) + rest[i1, 2] * t
        xyz = (x, y, z)
        for a in range(3):
            moved = (x * rotation[a, 0] + y * rotation[a, 1] + z * rotation[a, 2]) + translation[a]
            points[p, a] = xyz[a] + jaw_carry[p] * (moved - xyz[a])
        own_length[p] = ratio


def push(push_sources, source_start, push_targets, target_start, push_weight, push_axes, points,
         carried):  # pragma: no cover - compiled
    """Pushes (``MuscleSystem._push``): each target point moves by the mean displacement of its push's source
    points along the push's axes, faded by its weight (in place)."""
    for g in range(push_axes.shape[0]):
        first, last = source_start[g], source_start[g + 1]
        mean = [0.0, 0.0, 0.0]
        for a in range(3):
            total = 0.0
            for k in range(first, last):
                total += points[push_sources[k], a] - carried[push_sources[k], a]
            mean[a] = total / (last - first) * push_axes[g, a]
        if mean[0] == 0.0 and mean[1] == 0.0 and mean[2] == 0.0:
            continue
        for k in range(target_start[g], target_start[g + 1]):
            for a in range(3):
                points[push_targets[k], a] += push_weight[k] * mean[a]


def contract_sphincters(contraction, protrusion, rotation, translation, which, muscle, squeeze, inner, oris, forward,
                        backward, centres, axes, rest_closing, points, own_length):  # pragma: no cover - compiled
    """Step 1 for the sphincters' points (``MuscleSystem._contract_sphincters``): towards the centre (the
    oris' halfway carried by the jaw, in the mouth frame ``axes``), squeezed per fibre, the oris with
    protrusion and rounding (in place)."""
    ahead = max(protrusion, 0.0)
    for k in range(which.shape[0]):
        c, m, p = contraction[muscle[k]], muscle[k], which[k]
        centre = [centres[m, 0], centres[m, 1], centres[m, 2]]
        if oris[k]:
            x, y, z = centre[0], centre[1], centre[2]
            centre = [0.5 * (centre[a] + ((x * rotation[a, 0] + y * rotation[a, 1] + z * rotation[a, 2])
                                          + translation[a])) for a in range(3)]
        d = [points[p, 0] - centre[0], points[p, 1] - centre[1], points[p, 2] - centre[2]]
        local = d
        if oris[k]:
            local = [d[0] * axes[a, 0] + d[1] * axes[a, 1] + d[2] * axes[a, 2] for a in range(3)]
        rounding = c * ahead if oris[k] else 0.0
        sx = 1.0 - c * squeeze[0, k] - rounding * squeeze[2, k]
        sz = (1.0 - c * squeeze[1, k]) * min(max(1.0 - rounding * squeeze[3, k], 0.0), 1.0)
        local[0] *= sx
        local[2] *= sz
        if protrusion != 0.0 and oris[k]:
            travel = forward[k] if protrusion > 0 else backward[k]
            weight = inner[k] if protrusion > 0 else RETRACTED_OUTER + (1.0 - RETRACTED_OUTER) * inner[k]
            local[1] -= protrusion * travel * weight
        if oris[k]:
            local = [local[0] * axes[0, a] + local[1] * axes[1, a] + local[2] * axes[2, a] for a in range(3)]
        shut = min(max(1.0 - sz, 0.0), 1.0)
        early = (min(2.0 * shut, 1.0) - shut) * (1.0 - ahead)
        for a in range(3):
            points[p, a] = local[a] + centre[a] + early * rest_closing[p, a]
        own_length[p] = 0.5 * (sx + sz)


def connect(contraction, muscle_of_point, rest, members, group_of, count, spreads, indptr, indices, data, points,
            out):  # pragma: no cover - compiled
    """Steps 3 and 4 (``MuscleSystem._connect``): each connection group's original distances to its
    weighted centre restored, the corrections spread into the muscles by the propagation matrix (CSR
    ``indptr``, ``indices``, ``data``); ``out`` = the connected points."""
    total = [0.0] * count
    now = [[0.0, 0.0, 0.0] for _ in range(count)]
    was = [[0.0, 0.0, 0.0] for _ in range(count)]
    for k in range(members.shape[0]):
        g, p = group_of[k], members[k]
        weight = 1.0 + CONNECTION_GAIN * contraction[muscle_of_point[p]]
        total[g] += weight
        for a in range(3):
            now[g][a] += weight * points[p, a]
            was[g][a] += weight * rest[p, a]
    correction = 0.0 * points
    for k in range(members.shape[0]):
        g, p = group_of[k], members[k]
        if spreads[p]:
            for a in range(3):
                correction[p, a] = now[g][a] / total[g] + (rest[p, a] - was[g][a] / total[g]) - points[p, a]
    for i in range(points.shape[0]):
        for a in range(3):
            spread = 0.0
            for k in range(indptr[i], indptr[i + 1]):
                spread += data[k] * correction[indices[k], a]
            out[i, a] = points[i, a] + spread


def bulge(contraction, muscle_of_point, points, own_length, column, start, following, fibre_length, bulge_of, along,
          linear, thickness_rest, thickness):  # pragma: no cover - compiled
    """Thickness per point (step 5, ``MuscleSystem._bulge``): thicker with contraction (linear: most
    mid-belly, sphincter: evenly), thinner when stretched beyond its own contraction's length."""
    fibres = fibre_length.shape[0]
    length, own, size = [0.0] * fibres, [0.0] * fibres, [0.0] * fibres
    for k in range(start.shape[0]):
        i, j = start[k], following[k]
        dx, dy, dz = points[j, 0] - points[i, 0], points[j, 1] - points[i, 1], points[j, 2] - points[i, 2]
        length[column[i]] += math.sqrt(dx * dx + dy * dy + dz * dz)
    for p in range(column.shape[0]):
        own[column[p]] += own_length[p]
        size[column[p]] += 1.0
    for p in range(column.shape[0]):
        f = column[p]
        expected = fibre_length[f] * (own[f] / size[f])
        stretch = min(max(max(length[f], 1e-9) / max(expected, 1e-9), 0.25), 4.0)
        profile = math.sin(math.pi * along[p]) if linear[p] else 1.0
        grow = 1.0 + bulge_of[p] * contraction[muscle_of_point[p]] * profile
        thickness[p] = thickness_rest[p] * grow / math.sqrt(stretch)


def deform_points(contraction, protrusion, rotation, translation, rest, normal, jaw_carry, muscle_of_point,
                  linear_tables, push_tables, sphincter_tables, connect_tables, bulge_tables, rest_closing,
                  thickness_rest, surface, carried, thickness):  # pragma: no cover - compiled
    """:meth:`.muscles.MuscleSystem.deform` (module docstring): ``surface`` (P, 3) the deformed control
    points (bulge included), ``carried`` (P, 3) their bone-carried rest positions, ``thickness`` (P,);
    ``contraction`` and ``protrusion`` already clipped, the ``*_tables`` as ``MuscleSystem`` packs them."""
    n = rest.shape[0]
    points = rest.copy()
    own_length = 1.0 + 0.0 * thickness_rest
    for p in range(n):
        x, y, z = rest[p, 0], rest[p, 1], rest[p, 2]
        for a in range(3):
            moved = (x * rotation[a, 0] + y * rotation[a, 1] + z * rotation[a, 2]) + translation[a]
            carried[p, a] = rest[p, a] + jaw_carry[p] * (moved - rest[p, a])
            points[p, a] = carried[p, a]
    which, column, row, rows, arclength, grid, shortening = linear_tables
    contract_linear(contraction, rotation, translation, rest, jaw_carry, muscle_of_point, which, column, row, rows,
                    arclength, grid, shortening, points, own_length)
    push(*push_tables, points, carried)
    (s_which, s_muscle, squeeze, inner, oris, forward, backward, centres, axes, enabled) = sphincter_tables
    if enabled:
        contract_sphincters(contraction, protrusion, rotation, translation, s_which, s_muscle, squeeze, inner, oris,
                            forward, backward, centres, axes, rest_closing, points, own_length)
    members, group_of, count, spreads, indptr, indices, data = connect_tables
    connected = points.copy()
    if count:
        connect(contraction, muscle_of_point, rest, members, group_of, count, spreads, indptr, indices, data, points,
                connected)
    b_column, start, following, fibre_length, bulge_of, along, linear = bulge_tables
    bulge(contraction, muscle_of_point, connected, own_length, b_column, start, following, fibre_length, bulge_of,
          along, linear, thickness_rest, thickness)
    for p in range(n):
        on_jaw = jaw_carry[p] > 0.5
        for a in range(3):
            turned = normal[p, a]
            if on_jaw:
                turned = normal[p, 0] * rotation[a, 0] + normal[p, 1] * rotation[a, 1] + normal[p, 2] * rotation[a, 2]
            surface[p, a] = connected[p, a] + turned * (thickness[p] - thickness_rest[p])


#: the module-level functions :func:`deform_points` calls, compiled with it (``kernel.compiled``)
HELPERS = (contract_linear, push, contract_sphincters, connect, bulge)
