# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands synth-pitch | calibrate-pitch | track-pitch``: the pitch tracker in batch (thesis 6.3)."""
from __future__ import annotations

from pathlib import Path

import bpy

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.tracking.setup import PITCH_TYPES
from ..adapters.outputs import check_output_dir, check_output_path, written
from . import services


class SynthPitch:
    NAME = "synth-pitch"
    HELP = "render a synthetic multi-exposure recording of a pitch (ball, marker glove, calibration) with its ground truth"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--pitch", required=True, choices=PITCH_TYPES, help="the pitch type")
        parser.add_argument("--seed", type=int, default=0, help="random seed (cameras, pitch, hand; default 0)")
        parser.add_argument("--out", required=True, help="output folder (photos/, calibration/, truth.json)")
        parser.add_argument("--no-calibration", action="store_true",
                            help="skip the calibration photos (another set with the same seed has them)")
        parser.add_argument("--no-video", action="store_true", help="skip the high-speed video (markerless replay)")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_dir(args.out)
        if out.exists() and any(out.iterdir()):
            raise UserError(f"output folder {out} is not empty; give a new folder")
        if not 0 <= args.seed < 2 ** 31:
            raise UserError("--seed must be between 0 and 2^31 - 1")
        files = services.synthesise(out, args.pitch, args.seed, not args.no_calibration, progress, not args.no_video)
        print(f"wrote {len(files)} files into {out} ({sum(f.stat().st_size for f in files) / 1e6:.1f} MB)")
        return 0


class CalibratePitch:
    NAME = "calibrate-pitch"
    HELP = "calibrate the cameras of a pitch recording from its checkerboard and calibration-object photos"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--photos", required=True, help="folder with setup.json and the calibration photos")
        parser.add_argument("--out", required=True, help="output calibration .json")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_path(args.out, (".json",))
        folder = Path(args.photos)
        services.refuse_inside(out, folder)
        report = services.calibrate(folder, out, progress)
        print(report)
        print(written([out]))
        return 0


class TrackPitch:
    NAME = "track-pitch"
    HELP = "track ball and hand in multi-exposure photos of a pitch and build its replay (.blend or .glb)"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--photos", required=True, help="folder with one multi-exposure photo per camera")
        parser.add_argument("--calib", required=True, help="calibration .json (from calibrate-pitch)")
        parser.add_argument("--out", required=True, help="output .blend or .glb (the replay)")
        parser.add_argument("--report", help="also write the measurements (Table 6.6) as .json")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_path(args.out, (".blend", ".glb"))
        report = check_output_path(args.report, (".json",)) if args.report else None
        for path in (out, report):
            if path is not None:
                services.refuse_inside(path, Path(args.photos))
                if Path(args.calib).resolve() == path.resolve():
                    raise UserError("the output must not overwrite the calibration file")
        files, summary = services.track_to_file(Path(args.photos), Path(args.calib), out, report, progress)
        print(summary)
        print(written(files))
        return 0


class TrackVideo:
    NAME = "track-video"
    HELP = "the markerless replay: hand landmarks and ball from an ordinary high-speed video of a throw (.blend or .glb)"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--frames", required=True, help="folder with the frames and video.json (camera, fps)")
        parser.add_argument("--calib", required=True, help="calibration .json naming the video camera")
        parser.add_argument("--out", required=True, help="output .blend or .glb (the replay)")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_path(args.out, (".blend", ".glb"))
        services.refuse_inside(out, Path(args.frames))
        files, summary = services.track_video_to_file(Path(args.frames), Path(args.calib), out, progress)
        print(summary)
        print(written(files))
        return 0


COMMANDS = [SynthPitch, CalibratePitch, TrackPitch, TrackVideo]
