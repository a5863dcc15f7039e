# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands speak | lipsync``: lip-synced talking heads in batch, one line or a CSV of many.

Each line: a speech take (espeak-ng text-to-speech, or recorded audio aligned with pocketsphinx) is put
on the face rig's speech layer, the face is simulated frame by frame over the take (the exact result,
per-frame shape keys), and the head is written as .glb/.fbx (or .blend) with the speech as a WAV beside
it. Animation and audio come from the same phone timing and both start at time 0 (thesis 3.1.4).
"""
from __future__ import annotations

import csv
import math
import tempfile
from pathlib import Path

import bpy

from ..faces_hands_addon.errors import UserError
from . import bl_export, bl_sheet, bl_speech
from .cmd_face import build_default, find_rig, open_blend, save_blend
from .jobs import run_job
from .outputs import atomic_output, check_output_path, written

OUT_SUFFIXES = (".glb", ".fbx", ".blend")


def _common_arguments(parser) -> None:
    parser.add_argument("--rig", help="a .blend with a face rig (default: the default head)")
    parser.add_argument("--fps", type=float, default=30.0, help="frame rate of the animation (default 30)")
    parser.add_argument("--sheet", help="also write a contact sheet of the frames at phoneme centres (.png)")
    parser.add_argument("--view", choices=tuple(bl_sheet.VIEWS), default="front",
                        help="camera of the contact sheet (default front; side shows lip protrusion)")
    parser.add_argument("--jobs", help="CSV with one line per take (columns: out, and text or audio "
                                       "[+ transcript], optional voice); replaces the single-line options")


def _prepare_rig(rig_path: str | None, fps: float, progress):
    if not (1.0 <= fps <= 240.0):
        raise UserError(f"--fps {fps} is outside 1..240")
    if rig_path:
        open_blend(rig_path)
        rig_obj = find_rig()
    else:
        _, rig_obj = build_default(progress)
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = _fps_fraction(fps)
    return rig_obj


def _fps_fraction(fps: float) -> tuple[int, float]:
    """29.97 -> (30000, 1.001) style pairs Blender understands; integers stay integers."""
    if abs(fps - round(fps)) < 1e-6:
        return int(round(fps)), 1.0
    rounded = math.ceil(fps)
    return rounded, rounded / fps


def _bake_take(rig_obj, take, progress) -> None:
    """Put the take on the rig, then simulate every frame of it (exact per-frame shape keys)."""
    from .ops_face import BakeJob
    scene = bpy.context.scene
    scene.frame_start = 0
    report = bl_speech.apply_take(scene, rig_obj, take, start_frame=0)
    scene.frame_end = max(1, int(math.ceil(take.duration * bl_speech.scene_fps(scene))))
    print(report)
    run_job(BakeJob(bpy.context, rig_obj, "ANIMATION", "all"), bpy.context, progress)


def phoneme_cells(take, limit: int = 40) -> list:
    """(label, controls) at the centre of each spoken phone, for a contact sheet."""
    cells = []
    for phone in take.utterance.phones:
        if phone.is_pause:
            continue
        centre = phone.start + phone.duration / 2
        word = take.utterance.words[phone.word].text if phone.word is not None and phone.word >= 0 else ""
        controls = {track.name: float(track.sample(centre)) for track in take.tracks}
        cells.append((f"/{phone.phone}/ {word}".strip(), controls))
    return cells[:limit]


def _write_outputs(rig_obj, take, out: Path, sheet: Path | None, progress, source_audio=None,
                   view: str = "front", extra_sheets=()) -> list[Path]:
    from ..faces_hands_addon.speech import load_audio, save_wav
    paths = []
    wav = out.with_suffix(".wav")
    if out.suffix.lower() == ".blend":
        save_blend(out)
    else:
        bl_export.export_rig(bpy.context, rig_obj, str(out))
    paths.append(out)
    with atomic_output(wav) as tmp:
        if source_audio is not None:
            samples, rate = load_audio(source_audio)
            save_wav(tmp, samples, rate)
        else:
            save_wav(tmp, take.utterance.samples, take.utterance.sample_rate)
    paths.append(wav)
    for sheet_path, sheet_view in ([(sheet, view)] if sheet is not None else []) + list(extra_sheets):
        with atomic_output(sheet_path) as tmp:
            bl_sheet.render_sheet(bpy.context, rig_obj, phoneme_cells(take), tmp, columns=8, progress=progress,
                                  view=sheet_view)
        paths.append(Path(sheet_path))
    return paths


def run_line(spec: dict, rig_path, fps, progress) -> list[Path]:
    """One take: ``spec`` has out and text (+voice, rate) or audio (+transcript, language)."""
    from ..faces_hands_addon.speech.takes import take_from_audio, take_from_text
    out = check_output_path(spec["out"], OUT_SUFFIXES)
    sheet = check_output_path(spec["sheet"], (".png",)) if spec.get("sheet") else None
    view = spec.get("view") or "front"
    if view not in bl_sheet.VIEWS:
        raise UserError(f"unknown sheet view {view!r}; use one of {', '.join(bl_sheet.VIEWS)}")
    if spec.get("audio"):
        audio = Path(spec["audio"])
        if not audio.is_file():
            raise UserError(f"audio file {audio} does not exist")
        take = take_from_audio(audio, spec.get("transcript") or None, fps=fps, target="muscles",
                               language=spec.get("voice") or "en-us", progress=progress)
        for warning in take.utterance.warnings:
            print(f"warning: {warning}")
    else:
        take = take_from_text(spec.get("text", ""), voice=spec.get("voice") or "en-us",
                              rate=float(spec.get("rate") or 175), fps=fps, target="muscles", progress=progress)
    rig_obj = _prepare_rig(rig_path, fps, progress)
    _bake_take(rig_obj, take, progress)
    return _write_outputs(rig_obj, take, out, sheet, progress, spec.get("audio"), view,
                          spec.get("extra_sheets", ()))


def read_jobs(path: str) -> list[dict]:
    jobs_file = Path(path)
    if not jobs_file.is_file():
        raise UserError(f"jobs file {jobs_file} does not exist")
    try:
        with open(jobs_file, newline="", encoding="utf-8") as handle:
            rows = list(csv.DictReader(handle))
    except (UnicodeDecodeError, csv.Error) as error:
        raise UserError(f"{jobs_file} is not a readable UTF-8 CSV file ({error})") from None
    if not rows:
        raise UserError(f"{jobs_file} has no job lines (a header row plus one line per take)")
    for number, row in enumerate(rows, start=2):
        if not (row.get("out") or "").strip():
            raise UserError(f"{jobs_file} line {number}: the 'out' column is empty")
        if not ((row.get("text") or "").strip() or (row.get("audio") or "").strip()):
            raise UserError(f"{jobs_file} line {number}: give 'text' or 'audio'")
        check_output_path(row["out"], OUT_SUFFIXES)
    return [{k: (v or "").strip() for k, v in row.items() if k} for row in rows]


def run_jobs(rows: list[dict], rig_path, fps, progress) -> int:
    """Bake every line; a failing line is reported and the others still run (exit code 1 then)."""
    failures = 0
    with tempfile.TemporaryDirectory(prefix="fh-jobs-") as tmp:
        if rig_path is None:  # build the default head once, reuse it for every line
            _prepare_rig(None, fps, progress)
            rig_path = str(Path(tmp) / "rig.blend")
            bpy.ops.wm.save_as_mainfile(filepath=rig_path, copy=True, check_existing=False)
        for number, row in enumerate(rows, start=1):
            print(f"== job {number}/{len(rows)}: {row['out']}")
            try:
                print(written(run_line(row, rig_path, fps, progress)))
            except UserError as error:
                failures += 1
                print(f"faces_hands: error: job {number} ({row['out']}): {error}")
    return 1 if failures else 0


class Speak:
    NAME = "speak"
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
        if args.jobs:
            return run_jobs(read_jobs(args.jobs), args.rig, args.fps, progress)
        if args.text is None or args.out is None:
            raise UserError("give --text and --out (or --jobs FILE.csv)")
        spec = {"text": args.text, "voice": args.voice, "rate": args.rate, "out": args.out, "sheet": args.sheet,
                "view": args.view}
        print(written(run_line(spec, args.rig, args.fps, progress)))
        return 0


class LipSync:
    NAME = "lipsync"
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
        if args.jobs:
            return run_jobs(read_jobs(args.jobs), args.rig, args.fps, progress)
        if args.audio is None or args.out is None:
            raise UserError("give --audio and --out (or --jobs FILE.csv)")
        spec = {"audio": args.audio, "transcript": args.transcript, "voice": args.language, "out": args.out,
                "sheet": args.sheet, "view": args.view}
        print(written(run_line(spec, args.rig, args.fps, progress)))
        return 0


