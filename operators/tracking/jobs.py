# SPDX-License-Identifier: GPL-3.0-or-later
"""Tracking a pitch as a job (``common.jobs``): the engine's pipeline steps one by one, then the replay is built
in ``commit``; cancelling before that leaves the scene as it was."""
from __future__ import annotations

from pathlib import Path

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.tracking.ball_model import ball_model
from ...faces_hands_addon.tracking.pipeline import PitchTracker
from ...faces_hands_addon.tracking.setup import read_calibration
from ..bases.jobs import Job
from .photos import load_photo, photo_files

__all__ = ["TrackPitchJob", "TrackVideoJob"]


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


class TrackVideoJob(Job):
    """The markerless replay: hand landmarks and ball from an ordinary high-speed video of one calibrated camera
    (``video.json`` beside the frames names the camera and the frame rate)."""

    label = "Tracking the video"

    def __init__(self, frames_folder: Path, calib: Path):
        import json
        self.calibration = read_calibration(calib)
        description = Path(frames_folder) / "video.json"
        if not description.is_file():
            raise UserError(f"{frames_folder} has no video.json naming the camera and the frame rate")
        doc = json.loads(description.read_text())
        self.camera = self.calibration.cameras.get(doc.get("camera"))
        if self.camera is None:
            raise UserError(f"camera {doc.get('camera')!r} of video.json is not in the calibration")
        self.fps = float(doc.get("fps", 0))
        if not 10.0 <= self.fps <= 100000.0:
            raise UserError("video.json: fps must be a frame rate between 10 and 100000")
        files = sorted(p for p in Path(frames_folder).iterdir() if p.suffix.lower() in (".png", ".jpg", ".jpeg"))
        if len(files) < 2:
            raise UserError(f"{frames_folder}: a video needs at least two frames (frame_0000.png, ...)")
        self.frames = [load_photo(p) for p in files]
        sizes = {f.shape[:2] for f in self.frames}
        if len(sizes) != 1 or (self.frames[0].shape[1], self.frames[0].shape[0]) != tuple(self.camera.size):
            raise UserError("the video's frames must all have the calibrated camera's size "
                            f"{self.camera.size[0]}x{self.camera.size[1]}")
        self.model = ball_model()
        self._rig = None
        self.video = None
        self.result = None
        self._done = False

    def _hand_rig(self):
        if self._rig is None:
            from ...faces_hands_addon.hand.rig import build_hand_rig
            self._rig = build_hand_rig("right", (self.calibration.hand or {}).get("photo"))
        return self._rig

    def step(self) -> float:
        from ...faces_hands_addon.tracking.markerless import as_pitch_result, track_video
        if self._done:
            return 1.0
        self.video = track_video(self.frames, self.fps, self.camera, self._hand_rig().skeleton, self.model.radius)
        self.result = as_pitch_result(self.video)
        self._done = True
        return 1.0

    @property
    def warnings(self):
        return tuple(self.video.warnings) if self.video else ()

    def commit(self, context) -> str:
        from .replay import build_replay
        build_replay(context, self.result, self.calibration, {}, self._rig, self.model)
        return f"video: {len(self.video.hands)} hand poses in {len(self.frames)} frames, ball in {len(self.video.ball)}"
