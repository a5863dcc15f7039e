# SPDX-License-Identifier: GPL-3.0-or-later
"""Pitch tracker operators: track a pitch from multi-exposure photos and build its replay (modal, with a
progress bar; Esc cancels and leaves the scene as it was)."""
from __future__ import annotations

from pathlib import Path

import bpy

from ..bases.jobs import Job
from ..bases.modal import JobOperator
from .jobs import TrackPitchJob


class FH_OT_track_pitch(JobOperator, bpy.types.Operator):
    """Track the ball and the pitcher's hand in multi-exposure photos (one per calibrated camera) and build the replay: spinning ball, measured and reference trajectories, hand in slow motion, cameras with their photos"""

    bl_idname = "faces_hands.track_pitch"
    bl_label = "Track Pitch"
    bl_options = {"REGISTER", "UNDO"}

    filepath: bpy.props.StringProperty(subtype="FILE_PATH", description="Calibration file written by calibrate-pitch (.json)")
    filter_glob: bpy.props.StringProperty(default="*.json", options={"HIDDEN"}, description="Show calibration files only")
    photos: bpy.props.StringProperty(name="Photos", subtype="DIR_PATH", default="",
                                     description="Folder with one multi-exposure photo per camera, named like the cameras "
                                                 "(default: the folder 'photos' beside the calibration file)")

    def make_job(self, context) -> Job:
        calibration = Path(bpy.path.abspath(self.filepath))
        photos = Path(bpy.path.abspath(self.photos)) if self.photos else calibration.parent / "photos"
        return TrackPitchJob(photos, calibration)

    def invoke(self, context, event):
        if not self.filepath and context.window is not None:
            context.window_manager.fileselect_add(self)          # choose the calibration file first
            return {"RUNNING_MODAL"}
        return super().invoke(context, event)

    def execute(self, context):
        if context.window is not None and self._job is None:      # back from the file browser: run modally
            return super().invoke(context, None)
        return super().execute(context)


CLASSES = [FH_OT_track_pitch]
