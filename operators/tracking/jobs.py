# SPDX-License-Identifier: GPL-3.0-or-later
"""Tracking a pitch as a job (``common.jobs``): the engine's pipeline steps one by one, then the replay is built
in ``commit``; cancelling before that leaves the scene as it was."""
from __future__ import annotations

from pathlib import Path

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.tracking.ball_model import ball_model
from ...faces_hands_addon.tracking.pipeline import PitchTracker
from ...faces_hands_addon.tracking.setup import read_calibration
from ..common.jobs import Job
from .photos import load_photo, photo_files

__all__ = ["TrackPitchJob"]


class TrackPitchJob(Job):
    label = "Tracking the pitch"

    def __init__(self, photos: Path, calib: Path):
        self.calibration = read_calibration(calib)
        files = photo_files(Path(photos))
        self.files = {n: p for n, p in files.items() if n in self.calibration.cameras}
        if not self.files:
            raise UserError(f"no photo in {photos} is named like a calibrated camera ("
                            + ", ".join(sorted(self.calibration.cameras)) + ")")
        images = {n: load_photo(p) for n, p in self.files.items()}
        self.model = ball_model()
        self._rig = None
        self.tracker = PitchTracker(self.calibration, images, self._hand_rig, self.model)
        self._steps = self.tracker.steps()
        self.result = self.tracker.result

    def _hand_rig(self):
        if self._rig is None:
            from ...faces_hands_addon.hand.rig import build_hand_rig
            photo = (self.calibration.hand or {}).get("photo")
            self._rig = build_hand_rig("right", photo)
        return self._rig

    def step(self) -> float:
        try:
            fraction, self.label = next(self._steps)
        except StopIteration:
            return 1.0
        return min(fraction, 0.999) if fraction < 1.0 else 1.0

    @property
    def warnings(self):
        return tuple(self.result.warnings)

    def summary(self) -> str:
        r = self.result
        lines = [f"ball: {len(r.front)} front and {len(r.back)} back positions; markers per ball "
                 f"{r.markers_per_ball}"]
        if r.table:
            t = r.table
            lines.append(f"reference: {t['v0_ref_mph']:.1f} mph, {t['spin_ref_rpm']:.0f} rpm; eps avg {t['eps_avg_mm']:.1f} "
                         f"mm, max {t['eps_max_mm']:.1f} mm; v0 {t['v0_angle_deg']:.2f} deg / {t['v0_diff_mph']:.2f} mph; "
                         f"spin axis {t['axis_angle_deg']:.2f} deg / {t['spin_diff_rpm']:.0f} rpm (Table 6.6)")
        lines.append(f"hand: {len(r.hands)} poses")
        return "\n".join(lines)

    def commit(self, context) -> str:
        from .replay import build_replay
        build_replay(context, self.result, self.calibration, self.files, self._rig, self.model)
        return self.summary()
