# SPDX-License-Identifier: GPL-3.0-or-later
"""Pitch tracker operators: track a pitch from multi-exposure photos and build its replay (modal, with a
progress bar; Esc cancels and leaves the scene as it was)."""
from __future__ import annotations

from pathlib import Path

import bpy

from ..common.jobs import Job
from ..common.modal import JobOperator
from .jobs import TrackPitchJob


class FH_OT_track_pitch(JobOperator, bpy.types.Operator):
    """Track the ball and the pitcher's hand in multi-exposure photos (one per calibrated camera) and build the replay: spinning ball, measured and reference trajectories, hand in slow motion, cameras with their photos"""

    bl_idname = "faces_hands.track_pitch"
    bl_label = "Track Pitch"
    bl_options = {"REGISTER", "UNDO"}

    directory: bpy.props.StringProperty(subtype="DIR_PATH", description="Folder with one photo per camera, named like the cameras")
    calibration: bpy.props.StringProperty(subtype="FILE_PATH", description="Calibration file written by calibrate-pitch (.json)")

    def make_job(self, context) -> Job:
        return TrackPitchJob(Path(bpy.path.abspath(self.directory)), Path(bpy.path.abspath(self.calibration)))


CLASSES = [FH_OT_track_pitch]
