# SPDX-License-Identifier: GPL-3.0-or-later
"""The eyelids' per-frame rotation (:meth:`.kinematics.LidRig.rotate_lid`, thesis 3.1.2 "Eyes, Teeth,
Tongue": lids that slide over the eyeball) as one compiled loop over the lid's nodes, for the live preview.

In numpy the rotation is ~40 whole-array operations on a few hundred nodes per lid, each costing more in
call overhead than in arithmetic; here it is one pass. The numpy method stays the reference (same formulas,
same order of operations): the margins close to their meeting line, follow the gaze, the levator raises the
upper lid, the orbicularis oculi lifts the lower one, and nodes turned over the cornea are lifted clear of
the eyeball.
"""
from __future__ import annotations

import math

__all__ = ["rotate_lid_nodes"]


def rotate_lid_nodes(lid_rest, centre, theta_u, theta_l, open_share, weight, is_upper, surface, close, gaze, lift,
                     squeeze, follow_upper, follow_lower, raise_rad, squeeze_rad, meeting, overlap, clear_radius,
                     eyeball_radius, cornea_deg, cornea_bulge, out):  # pragma: no cover - compiled
    """Rotated positions (``out``, (n, 3)) of the lid nodes ``lid_rest`` (n, 3) for closure ``close``, gaze
    pitch angle ``gaze`` (rad), levator ``lift`` and orbicularis ``squeeze`` (all clipped by the caller);
    the per-node arrays are the lid's own (``LidRig`` fields taken at its ``index``)."""
    corner = 0.5 * (follow_upper + follow_lower)
    for k in range(lid_rest.shape[0]):
        t = open_share[k]
        upper = theta_u[k] + (follow_upper * t + corner * (1 - t)) * gaze + raise_rad * lift * t
        lower = theta_l[k] + (follow_lower * t + corner * (1 - t)) * gaze + squeeze_rad * squeeze * t
        aperture = max(upper - lower, 0.0)
        meet = lower + meeting * aperture
        if is_upper[k]:
            delta = upper + close * (meet - overlap * t - upper) - theta_u[k]
        else:
            delta = lower + close * (meet - lower) - theta_l[k]
        angle = weight[k] * delta
        dy, dz = lid_rest[k, 1] - centre[1], lid_rest[k, 2] - centre[2]
        c, s = math.cos(angle), math.sin(angle)
        mx = lid_rest[k, 0] - centre[0]
        my = (centre[1] + dy * c + dz * s) - centre[1]
        mz = (centre[2] + dz * c - dy * s) - centre[2]
        radius = math.sqrt(mx * mx + my * my + mz * mz)
        raised = min(max(abs(angle) / 0.06, 0.0), 1.0) * surface[k]
        ahead = math.degrees(math.acos(min(max(-my / max(radius, 1e-12), -1.0), 1.0)))
        bulge = cornea_bulge * math.cos(math.radians(ahead) * 90 / cornea_deg) ** 2 if ahead < cornea_deg else 0.0
        clear = clear_radius + eyeball_radius * bulge
        scale = (radius + raised * max(clear - radius, 0.0)) / max(radius, 1e-12)
        out[k, 0] = centre[0] + mx * scale
        out[k, 1] = centre[1] + my * scale
        out[k, 2] = centre[2] + mz * scale
