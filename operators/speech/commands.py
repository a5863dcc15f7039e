# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands speak | lipsync``: lip-synced talking heads in batch, one line or a CSV of many
(``services``: the work; here: the command-line arguments)."""
from __future__ import annotations

from ...faces_hands_addon.core.errors import UserError
from ..adapters.outputs import written
from ..face.sheet import VIEWS
from .batch import checked_spec, read_jobs, run_jobs
from .services import MASK, rig_file, run_line, shared_default_rig


def _common_arguments(parser) -> None:
    parser.add_argument("--rig", help="a .blend with a face rig or a character (default: the default character; "
                                      "'mask' for the face-only default head)")
    parser.add_argument("--fps", type=float, default=30.0, help="frame rate of the animation (default 30)")
    parser.add_argument("--sheet", help="also write a contact sheet of the frames at phoneme centres (.png)")
    parser.add_argument("--view", choices=tuple(VIEWS), default="front",
                        help="camera of the contact sheet (default front; side shows lip protrusion)")
    parser.add_argument("--animation", default="weights", choices=("weights", "frames"),
                        help="engine-ready weights of the ARKit/viseme/emotion targets (default), or the exact "
                             "per-frame cache (frames: one shape key per frame, for offline renders)")
    parser.add_argument("--live-link", help="also write the ARKit weights as a Live Link Face CSV (.csv)")
    parser.add_argument("--cues", help="also write the mouth cues in Rhubarb Lip Sync's format (shapes A-H, X): "
                                       ".tsv or .json")
    parser.add_argument("--style", help="also animate non-verbal behaviour (blinks, brows, gaze, thinking) in this "
                                        "character style: neutral, nodder, brow_raiser, reserved, expressive")
    parser.add_argument("--seed", type=int, default=0, help="seed of the behaviour's random choices (default 0)")
    parser.add_argument("--emotion", help="an emotion for the whole take, in face and voice: a word (joy, fear, "
                                          "anxiety, ...) or activation,evaluation such as 50,-20 (a point that "
                                          "starts with a minus sign needs '=': --emotion=-50,-20)")
    parser.add_argument("--jobs", help="CSV with one row per take (columns: out, and text or audio "
                                       "[+ transcript]; optional voice, rate, sheet, view, animation, live_link, "
                                       "cues, style, seed, emotion); "
                                       "replaces the single-line options")
    parser.add_argument("--fail-fast", action="store_true",
                        help="with --jobs: stop at the first failing row (default: report it and go on)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an existing WAV beside the output even when another program wrote it")


def _run(args, spec: dict, progress) -> int:
    if args.jobs:
        return run_jobs(read_jobs(args.jobs), rig_file(args.rig), args.fps, progress, run_line,
                        jobs_path=args.jobs, fail_fast=args.fail_fast, overwrite=args.overwrite,
                        prepare_rig=lambda folder: shared_default_rig(folder, args.fps, progress, args.rig))
    spec = checked_spec(spec, args.fps, rig_file(args.rig), overwrite=args.overwrite)
    print(written(run_line(spec, args.rig, args.fps, progress)))
    return 0


class Speak:
    NAME = "speak"
    INPUTS = ("rig", "jobs")
    INPUT_WORDS = {"rig": (MASK,)}
    HELP = "speak text with espeak-ng on a face rig; writes .glb/.fbx/.blend plus the .wav beside it"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--text", help="what to say (emoticons like :-) become emotion tags)")
        parser.add_argument("--voice", default="en-us", help="espeak-ng voice, e.g. en-us, de, fr (default en-us)")
        parser.add_argument("--rate", type=float, default=175, help="words per minute (80..450, default 175)")
        parser.add_argument("--out", help="output .glb, .fbx or .blend (the .wav goes beside it)")
        _common_arguments(parser)

    @staticmethod
    def run(args, progress) -> int:
        if not args.jobs and (args.text is None or args.out is None):
            raise UserError("give --text and --out (or --jobs FILE.csv)")
        return _run(args, {"text": args.text, "voice": args.voice, "rate": args.rate, "out": args.out,
                           "sheet": args.sheet, "view": args.view, "animation": args.animation,
                           "live_link": args.live_link, "cues": args.cues,
                           "style": args.style, "seed": args.seed, "emotion": args.emotion}, progress)


class LipSync:
    NAME = "lipsync"
    INPUTS = ("audio", "rig", "jobs")
    INPUT_WORDS = {"rig": (MASK,)}
    HELP = "lip-sync a face rig to recorded speech (WAV/FLAC/OGG) with its transcript"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--audio", help="recorded speech: WAV, FLAC or OGG")
        parser.add_argument("--transcript", help="what is said (without it phones are recognised, less accurately)")
        parser.add_argument("--language", default="en-us", help="language of the recording (default en-us)")
        parser.add_argument("--out", help="output .glb, .fbx or .blend (a .wav copy goes beside it)")
        _common_arguments(parser)

    @staticmethod
    def run(args, progress) -> int:
        if not args.jobs and (args.audio is None or args.out is None):
            raise UserError("give --audio and --out (or --jobs FILE.csv)")
        return _run(args, {"audio": args.audio, "transcript": args.transcript, "voice": args.language,
                           "out": args.out, "sheet": args.sheet, "view": args.view, "animation": args.animation,
                           "live_link": args.live_link, "cues": args.cues,
                           "style": args.style, "seed": args.seed, "emotion": args.emotion}, progress)


COMMANDS = [Speak, LipSync]
