# SPDX-License-Identifier: GPL-3.0-or-later
"""The pitch tracker's services for commands and operators (plain functions): synthesise a recording,
calibrate its cameras, track a pitch and build the replay."""
from __future__ import annotations

import json
from pathlib import Path

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..adapters.outputs import atomic_output

__all__ = ["synthesise", "calibrate", "track_to_file", "refuse_inside", "track_video_to_file"]


def refuse_inside(path: Path, folder: Path) -> None:
    """An output never lands among (or on) the inputs."""
    if folder.exists() and path.resolve().parent == folder.resolve():
        raise UserError(f"{path} would be written into the input folder {folder}; write it elsewhere")


def synthesise(out: Path, pitch: str, seed: int, calibration: bool, progress, video: bool = True) -> list[Path]:
    from .synth_set import write_synthetic_set
    bpy.ops.wm.read_homefile(use_empty=True)
    return write_synthetic_set(bpy.context.scene, out, pitch, seed, calibration, progress, video)


def calibrate(folder: Path, out: Path, progress) -> str:
    from .photos import calibrate_folder
    calibration, report = calibrate_folder(folder, progress)
    from ...faces_hands_addon.tracking.setup import dump_calibration
    with atomic_output(out) as tmp:
        Path(tmp).write_text(dump_calibration(calibration))
    return report


def track_to_file(photos: Path, calib: Path, out: Path, report: Path | None, progress):
    from .jobs import TrackPitchJob
    from ..bases.jobs import run_job
    bpy.ops.wm.read_homefile(use_empty=True)
    job = TrackPitchJob(photos, calib)
    summary = run_job(job, bpy.context, progress)
    files = []
    from .replay import save_replay
    files.append(save_replay(bpy.context, out))
    if report is not None:
        with atomic_output(report) as tmp:
            Path(tmp).write_text(json.dumps(job.result.document(), indent=1, sort_keys=True))
        files.append(report)
    return files, summary


def track_video_to_file(frames: Path, calib: Path, out: Path, progress):
    from .jobs import TrackVideoJob
    from ..bases.jobs import run_job
    from .replay import save_replay
    bpy.ops.wm.read_homefile(use_empty=True)
    job = TrackVideoJob(frames, calib)
    summary = run_job(job, bpy.context, progress)
    for warning in job.warnings:
        print(f"warning: {warning}")
    return [save_replay(bpy.context, out)], summary
