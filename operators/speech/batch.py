# SPDX-License-Identifier: GPL-3.0-or-later
"""Speech takes checked before any work, and jobs CSVs that never lose a file.

Every take (one ``speak``/``lipsync`` line or one CSV row) is checked up front with what is cheap: the
output names (never an input, never another output of the run, a WAV beside the output replaced only when
this extension wrote it or ``--overwrite`` says so), numbers (finite, in range), the audio header (length
limit) and the text length (an estimate of its duration). A jobs CSV runs on past a failing row, names
every failure with its row (spreadsheet numbering: the header is row 1) and ends with a summary and a
non-zero exit code; ``--fail-fast`` stops at the first failure instead. An interrupt says exactly which
rows were written.
"""
from __future__ import annotations

import csv
import io
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.core.files import FileClaims
from ...faces_hands_addon.core.foreign_files import read_text
from ...faces_hands_addon.farm.rows import Once, number_field
from ...faces_hands_addon.speech.audio import audio_header, written_here
from ...faces_hands_addon.speech.espeak import RATE_RANGE
from ...faces_hands_addon.speech.takes import check_text_length, estimated_seconds
from ..adapters.outputs import check_output_path, ledger_mark, refuse_collisions, written, written_since
from ..bases.bake import MAX_FRAMES
from ..cli.interrupts import raise_pending
from ..face.sheet import VIEWS

__all__ = ["OUT_SUFFIXES", "COLUMNS", "checked_spec", "read_jobs", "run_jobs"]

OUT_SUFFIXES = (".glb", ".fbx", ".blend")
COLUMNS = ("out", "text", "audio", "transcript", "voice", "rate", "sheet", "view", "animation", "live_link",
           "cues", "style", "seed", "emotion")
ANIMATIONS = ("weights", "frames")
MAX_JOBS_BYTES = 200_000_000


def _optional_path(spec: dict, key: str, suffixes, folders=None) -> Path | None:
    value = spec.get(key)
    return check_output_path(value, suffixes, folders) if value else None


def _check_wav(wav: Path, overwrite: bool, folders=None) -> None:
    exists = folders.listed(*folders.split(wav)) if folders is not None else wav.exists()
    if exists and not overwrite and not written_here(wav):
        raise UserError(f"{wav} exists and was not written by Faces & Hands, so it is left as it is: choose "
                        "another output name, or pass --overwrite to replace it")


def _nonverbal(spec: dict, once: Once):
    """(style or None, seed, emotion or None) of a take, checked: a style of the styles preset, a whole
    seed >= 0, an emotion word of the table or an activation,evaluation point."""
    from ...faces_hands_addon.behavior.styles import load_style
    from ...faces_hands_addon.emotion import parse_emotion
    style = spec.get("style") or None
    if style is not None:
        once("style", style, load_style)
    seed = number_field("seed", spec.get("seed"), 0, (0, 2 ** 32 - 1))
    if seed != int(seed):
        raise UserError(f"seed {spec.get('seed')!r} is not a whole number")
    emotion = spec.get("emotion")
    return style, int(seed), once("emotion", str(emotion), lambda _: parse_emotion(emotion))


def checked_spec(raw: dict, fps: float, rig_path=None, jobs_path=None, overwrite: bool = False,
                 once: Once | None = None) -> dict:
    """The take ``raw`` (out, text or audio, ...) checked and normalised, before any expensive work;
    ``once``: the checks of a jobs CSV's values, kept from row to row."""
    spec = {k: (v.strip() if isinstance(v, str) else v) for k, v in raw.items() if k}
    one_line = once is None             # a jobs CSV checks every row's files at once (_check_rows)
    if not spec.get("out"):
        raise UserError("no output: the 'out' column (--out) is empty")
    folders = once.folders if once is not None else None
    out = check_output_path(spec["out"], OUT_SUFFIXES, folders)
    text, audio = spec.get("text") or "", spec.get("audio") or ""
    if text and audio:
        raise UserError("give text or audio, not both")
    if not text and not audio:
        raise UserError("give text (speak) or audio (lipsync)")
    if spec.get("transcript") and not audio:
        raise UserError("a transcript goes with recorded audio, not with text")
    animation = spec.get("animation") or "weights"
    if animation not in ANIMATIONS:
        raise UserError(f"unknown animation {animation!r}; use one of {', '.join(ANIMATIONS)}")
    view = spec.get("view") or "front"
    if view not in VIEWS:
        raise UserError(f"unknown sheet view {view!r}; use one of {', '.join(VIEWS)}")
    live_link = _optional_path(spec, "live_link", (".csv",), folders)
    if live_link is not None and animation != "weights":
        raise UserError("a Live Link CSV needs the weights animation (leave out --animation frames)")
    cues = _optional_path(spec, "cues", (".tsv", ".txt", ".json"), folders)
    rate = number_field("rate", spec.get("rate"), 175, RATE_RANGE)
    once = once or Once()
    style, seed, emotion = _nonverbal(spec, once)
    if spec.get("voice"):                  # a language the recording's transcript is read in, or the TTS voice
        from ...faces_hands_addon.speech.espeak import check_voice
        once("voice", spec["voice"], check_voice)
    if audio:
        seconds = audio_header(audio).duration          # exists, readable, within the length limit
    else:
        check_text_length(text, rate)
        seconds = estimated_seconds(text, rate)
    if animation == "frames" and seconds * fps > MAX_FRAMES:
        raise UserError(f"about {seconds:.0f} s at {fps:g} fps is more than {MAX_FRAMES} frames, the most a per-frame "
                        "cache bakes; use the weights animation (the default), which has no frame limit")
    wav = out.with_suffix(".wav")
    outputs = {"the output": out, "the WAV beside the output": wav,
               "the sheet": _optional_path(spec, "sheet", (".png",), folders), "the Live Link CSV": live_link,
               "the mouth cues": cues}
    if one_line:
        refuse_collisions(outputs, {"audio": Path(audio) if audio else None,
                                    "rig": Path(rig_path) if rig_path else None,
                                    "jobs file": Path(jobs_path) if jobs_path else None})
    _check_wav(wav, overwrite, folders)
    spec.update(out=str(out), text=text, audio=audio or None, rate=rate, animation=animation, view=view,
                live_link=live_link, cues=cues, style=style, seed=seed, emotion=emotion, outputs=[p for p in outputs.values() if p is not None])
    return spec


def read_jobs(path: str) -> list[dict]:
    """The rows of a jobs CSV (file-level problems raise; row problems are the rows' own, ``run_jobs``)."""
    jobs_file = Path(path)
    text = read_text(jobs_file, "the jobs file", MAX_JOBS_BYTES)     # NUL bytes, size, encoding, path problems
    try:
        reader = csv.DictReader(io.StringIO(text, newline=""))
        rows = list(reader)
        header = reader.fieldnames or []
    except csv.Error as error:
        raise UserError(f"{jobs_file} is not a readable UTF-8 CSV file ({error})") from None
    if "out" not in header:
        raise UserError(f"{jobs_file} has no 'out' column (columns: {', '.join(COLUMNS)})")
    unknown = [name for name in header if name and name not in COLUMNS]
    if unknown:
        raise UserError(f"{jobs_file}: unknown column(s) {', '.join(unknown)}; the columns are {', '.join(COLUMNS)}")
    if not rows:
        raise UserError(f"{jobs_file} has no job rows (a header row plus one row per take)")
    return rows


@dataclass
class BatchReport:
    """What happened to every row: written files, or the error that stopped it."""
    total: int
    done: dict[int, list[Path]] = field(default_factory=dict)
    failed: dict[int, str] = field(default_factory=dict)

    def fail(self, number: int, out: str, message: str) -> None:
        self.failed[number] = f"row {number} ({out or 'no output'}): {message}"
        print(f"faces_hands: error: {self.failed[number]}")

    def summary(self) -> str:
        if not self.failed:
            return f"all {self.total} rows written"
        return f"{len(self.failed)} of {self.total} rows failed: " + "; ".join(self.failed.values())

    def interrupted(self, number: int, partial: list[Path], rows: list[int]) -> str:
        done = ", ".join(str(n) for n in self.done) or "none"
        later = [n for n in rows if n > number]
        rest = f"; rows {later[0]}-{later[-1]} did not run" if later else ""
        if number in self.done:
            return f"interrupted after row {number}: rows written completely: {done}{rest}"
        part = ", ".join(str(p) for p in partial)
        return (f"interrupted in row {number}: rows written completely: {done}; row {number} "
                + (f"wrote only {part}" if partial else "wrote nothing") + rest)


def _check_rows(rows: list[dict], fps, rig_path, jobs_path, overwrite, report: BatchReport) -> dict[int, dict]:
    """Check every row before any work; a row that writes what an earlier row writes or reads fails (linear
    in the rows: files are claimed in ``FileClaims``, the jobs manifests' check)."""
    once = Once()
    inputs = FileClaims(once.folders)
    for path, what in ((jobs_path, "the jobs file"), (rig_path, "the rig")):
        if path:
            inputs.add(path, what)
    for number, row in enumerate(rows, start=2):
        if (row.get("audio") or "").strip():
            inputs.add(row["audio"].strip(), f"the audio input of row {number}")
    specs, claimed = {}, FileClaims(once.folders)
    for number, row in enumerate(rows, start=2):
        try:
            spec = checked_spec(row, fps, rig_path, jobs_path, overwrite, once)
            places = [once.folders.split(path) for path in spec["outputs"]]
            if len(set(places)) < len(places):
                raise UserError("writes one file twice (two of its outputs are the same file)")
            for path, place in zip(spec["outputs"], places):
                owner, reader = claimed.owner_at(*place), inputs.owner_at(*place)
                if owner is not None:
                    raise UserError(f"writes {path}, which row {owner} writes too")
                if reader is not None:
                    raise UserError(f"writes {path}, which is {reader}")
            for place in places:
                claimed.add_at(*place, number)
            specs[number] = spec
        except UserError as error:
            report.fail(number, (row.get("out") or "").strip(), str(error))
    return specs


def run_jobs(rows: list[dict], rig_path, fps, progress, run_line, *, jobs_path=None, fail_fast: bool = False,
             overwrite: bool = False, prepare_rig=None) -> int:
    """Bake every row with ``run_line(spec, rig_path, fps, progress)``; returns the exit code (1 if a row
    failed). ``prepare_rig(tmp_folder)`` builds a shared rig once and returns its path (no ``--rig``)."""
    report = BatchReport(total=len(rows))
    specs = _check_rows(rows, fps, rig_path, jobs_path, overwrite, report)
    if fail_fast and report.failed:
        print(f"faces_hands: {report.summary()} (--fail-fast: nothing was run)")
        return 1
    with tempfile.TemporaryDirectory(prefix="fh-jobs-") as tmp:
        if rig_path is None and specs and prepare_rig is not None:
            rig_path = prepare_rig(tmp)
        for number, spec in specs.items():
            print(f"== row {number} ({len(report.done) + len(report.failed) + 1}/{len(rows)}): {spec['out']}")
            mark = ledger_mark()
            try:
                raise_pending()
                report.done[number] = run_line(spec, rig_path, fps, progress)
                raise_pending()
                print(written(report.done[number]))
            except UserError as error:
                report.fail(number, spec["out"], str(error))
            except KeyboardInterrupt:
                partial = written_since(mark)
                if {Path(p) for p in spec["outputs"]} <= {Path(p) for p in partial}:
                    report.done[number] = partial        # all its files were on disk when the interrupt came
                print(f"faces_hands: {report.interrupted(number, partial, list(specs))}")
                raise
            except Exception as error:  # a bug in one row must not cost the other rows
                report.fail(number, spec["out"], f"internal error: {type(error).__name__}: {error}")
            if fail_fast and report.failed:
                break
    print(f"faces_hands: {report.summary()}")
    return 1 if report.failed else 0
