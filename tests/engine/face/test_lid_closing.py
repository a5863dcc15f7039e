# SPDX-License-Identifier: GPL-3.0-or-later
"""A blink closes the eye whatever the lids' node spacing (thesis 3.1.2 "Eyes, Teeth, Tongue": the lids are
skin that closes over the eyeball). Every margin node turns to the meeting line at its own x, but a margin
is straight between its nodes: an upper lid with few nodes (a decimated artist's mesh) closed as a chord
that passed above the lower lid's nodes, leaving the eye open by the curvature of the meeting line
between them. ``mesh_template._closing_overlap`` measures that gap on the head and closes the upper lid
past the meeting line by as much."""
from __future__ import annotations

import numpy as np

from faces_hands_addon.face.kinematics import LidRig
from faces_hands_addon.face.mesh_template import _closing_overlap

RADIUS = 0.0135          # m from the eye's centre to the lid skin
HALF_WIDTH = 0.011       # m from the eye's middle to either canthus


def _on_eye(x, elevation):
    """Points on the lid sphere at ``x`` and elevation (rad above forward, -Y)."""
    r = np.sqrt(RADIUS ** 2 - x ** 2)
    return np.stack([x, -r * np.cos(elevation), r * np.sin(elevation)], 1)


def _eye(upper_x):
    """An eye whose lower margin has a node every 1 mm and whose upper margin has nodes at ``upper_x`` only;
    the margins' elevations are parabolas meeting at the canthi (upper 0.5 rad, lower 0.6 rad at the middle)."""
    lower_x = np.linspace(-HALF_WIDTH, HALF_WIDTH, 23)
    shape = lambda x: 1.0 - (x / HALF_WIDTH) ** 2  # noqa: E731
    upper = _on_eye(upper_x, 0.5 * shape(upper_x))
    lower = _on_eye(lower_x, -0.6 * shape(lower_x))
    nodes = np.vstack([upper, lower])
    fine = np.linspace(-HALF_WIDTH, HALF_WIDTH, 201)         # the margin curves the rig interpolates
    lid = LidRig(np.zeros(3), nodes, _on_eye(fine, 0.5 * shape(fine)), _on_eye(fine, -0.6 * shape(fine)),
                 eyeball_radius=0.012, side=np.r_[np.ones(len(upper)), -np.ones(len(lower))].astype(int))
    return lid, nodes, np.arange(len(upper)), len(upper) + np.arange(len(lower))


def _closed_gap_mm(lid, nodes, upper, lower):
    """The audit's lid gap (face/audit.py): the largest height of the opening between the closed margins
    over the middle 60 % of the eye."""
    closed = lid.rotate(nodes, 1.0, 0.0)
    xs = np.linspace(-0.6 * HALF_WIDTH, 0.6 * HALF_WIDTH, 25)
    zu = np.interp(xs, closed[upper, 0], closed[upper, 2])
    zl = np.interp(xs, closed[lower, 0], closed[lower, 2])
    return float(max(0.0, np.max(zu - zl)) * 1000.0)


def test_a_coarse_upper_lid_closes_the_eye():
    """Upper margin nodes at the canthi and the middle only: closed to the meeting line (the fixed overlap)
    its chords leave the eye open (> 0.5 mm); with the measured overlap it closes (<= 0.05 mm)."""
    lid, nodes, upper, lower = _eye(np.array([-HALF_WIDTH, 0.0, HALF_WIDTH]))
    assert lid.overlap == LidRig.OVERLAP
    assert _closed_gap_mm(lid, nodes, upper, lower) > 0.5
    overlap = _closing_overlap(lid, nodes, upper, lower)
    assert lid.overlap == overlap > LidRig.OVERLAP
    assert _closed_gap_mm(lid, nodes, upper, lower) <= 0.05


def test_a_fine_upper_lid_keeps_the_fixed_overlap():
    """Margins with nodes every millimetre already close at the meeting line: nothing is added."""
    lid, nodes, upper, lower = _eye(np.linspace(-HALF_WIDTH, HALF_WIDTH, 23))
    assert _closed_gap_mm(lid, nodes, upper, lower) <= 0.05
    assert _closing_overlap(lid, nodes, upper, lower) == LidRig.OVERLAP
