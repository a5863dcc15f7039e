# SPDX-License-Identifier: GPL-3.0-or-later
"""Lip closures of the exact per-frame bake, simulated ahead (anim.closure_drive, thesis 3.1.3).

A closure after an open vowel needs more frames than the fixed lead gives; the drive finds the shortest lead
whose simulation has the lips shut at the closure's first frame, and the poses it yields are exactly those
of a plain simulation fed that table."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.anim.closure_drive import CLOSED_GAP_M, ClosureDrive
from faces_hands_addon.anim.layers import BASE_LAYER, LayerTable
from faces_hands_addon.face.expressions import expression_controls, load_expressions
from faces_hands_addon.face.rig import build_default_rig

DT = 1 / 30


class FirstOrderLips:
    """A stand-in rig: the lip gap (mm) moves halfway to its target (control ``gap``) every frame."""
    template = None

    def __init__(self) -> None:
        self.gap_mm = 0.0

    def settled(self, values, settle_time, dt):
        self.gap_mm = values[BASE_LAYER]["gap"]
        return self.gap_mm

    def step(self, values, dt):
        self.gap_mm += 0.5 * (values[BASE_LAYER]["gap"] - self.gap_mm)
        return self.gap_mm

    def lip_gap(self) -> float:
        return self.gap_mm / 1000.0


def _tables(open_rows: np.ndarray, closed_value: float):
    frames = np.arange(len(open_rows), dtype=np.float64)
    table = LayerTable(frames, ("gap",), {BASE_LAYER: open_rows[:, None].astype(np.float64)})
    closed = LayerTable(frames, ("gap",), {BASE_LAYER: np.full((len(frames), 1), closed_value)})
    return table, closed


def _plain(rig, table, closed, fed):
    out = []
    for row in range(len(table)):
        values = closed.at(row) if fed[row] else table.at(row)
        out.append(rig.settled(values, 1.0, DT) if row == 0 else rig.step(values, DT))
    return out


def test_a_closure_after_an_open_mouth_gets_the_lead_it_needs_and_nothing_else_changes():
    table, closed = _tables(np.full(24, 20.0), -1.0)
    drive = ClosureDrive(closed, [(8, 10, 10)], max_lead=6)
    rig = FirstOrderLips()
    poses = list(drive.poses(rig, table, DT, 1.0))
    assert drive.leads == [3] and drive.retries == 1          # 2 rows were not enough, 3 are
    fed = np.zeros(24, bool)
    fed[7:11] = True
    assert poses == _plain(FirstOrderLips(), table, closed, fed)
    assert poses[10] <= CLOSED_GAP_M * 1000 < poses[9]
    fixed = np.zeros(24, bool)
    fixed[8:11] = True
    assert _plain(FirstOrderLips(), table, closed, fixed)[10] > 1.0   # the fixed lead leaves the lips apart


def test_nearly_shut_lips_keep_the_fixed_lead_and_a_far_closure_stops_at_the_longest_lead():
    table, closed = _tables(np.full(30, 0.4), -1.0)
    drive = ClosureDrive(closed, [(8, 10, 11)], max_lead=6)
    list(drive.poses(FirstOrderLips(), table, DT, 1.0))
    assert drive.leads == [2] and drive.retries == 0
    table, closed = _tables(np.full(30, 400.0), -1.0)
    drive = ClosureDrive(closed, [(8, 10, 11), (20, 22, 22)], max_lead=3)
    list(drive.poses(FirstOrderLips(), table, DT, 1.0))
    assert drive.leads == [3, 3]                             # capped; the bake goes on


@pytest.fixture(scope="module")
def rig_tables():
    rig = build_default_rig()
    specs = rig.control_specs()
    visemes = load_expressions("visemes")
    names = tuple(specs)
    vowel = expression_controls(visemes["viseme_aa"], specs)
    bilabial = expression_controls(visemes["viseme_PP"], specs)
    rows = np.array([[vowel[n] for n in names]] * 24)
    frames = np.arange(24, dtype=np.float64)
    table = LayerTable(frames, names, {BASE_LAYER: rows})
    closed = LayerTable(frames, names, {BASE_LAYER: np.array([[bilabial[n] for n in names]] * 24)})
    return rig, table, closed


def _pose_gap(pose) -> float:
    """Inner lip gap at the mouth centre (canonical nodes 13 over 14), m."""
    skin = pose.positions["skin"]
    return float(skin[13, 2] - skin[14, 2])


def test_the_default_head_shuts_a_one_frame_bilabial_after_an_open_vowel(rig_tables):
    rig, table, closed = rig_tables
    fixed = np.zeros(len(table), bool)
    fixed[14:17] = True                       # the closure at row 16, fed from 2 rows before it
    assert _pose_gap(_plain(rig, table, closed, fixed)[16]) > 0.001     # the fixed lead: more than 1 mm apart
    drive = ClosureDrive(closed, [(14, 16, 16)], max_lead=6)
    poses = list(drive.poses(rig, table, DT, 1.0))
    assert _pose_gap(poses[16]) <= CLOSED_GAP_M and drive.leads[0] > 2
