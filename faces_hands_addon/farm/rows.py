# SPDX-License-Identifier: GPL-3.0-or-later
"""What a manifest row means, checked before any work: its action, its options and the files it writes.

Every check is linear in the number of rows: outputs are claimed in a dictionary keyed by their
case-folded path inside the output folder (two rows that write the same file, even spelt ``A.glb`` and
``a.glb``, collide on every file system), inputs are gathered first so an output that is the input of a
later row is found too, folders are resolved once each (a link that leads out of the output folder is
refused), and the checks that cost something (a voice, an emotion word, a style, an audio header) run once
per distinct value. Every output is a path relative to the output folder; an absolute path, ``..``, a
drive or a backslash is refused, so no row can write outside it.
"""
from __future__ import annotations

import math
import os
import posixpath
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ..core.errors import UserError
from ..core.files import FileClaims
from .manifest import Problem, RawRow

__all__ = ["ACTIONS", "OUT_SUFFIXES", "FARM_FOLDER", "SIDECAR_SUFFIX", "REPORT_NAME", "JobRow", "Once", "RowChecks",
           "check_rows", "number_field", "relative_output"]

ACTIONS = ("speak", "lipsync")
OUT_SUFFIXES = (".glb", ".fbx", ".blend")
ANIMATIONS = ("weights", "frames")
LIVE_LINK_SUFFIXES = (".csv",)
CUES_SUFFIXES = (".tsv", ".txt", ".json")
FARM_FOLDER = ".fh-farm"            # staging and chunk reports inside the output folder; never an output
SIDECAR_SUFFIX = ".fhjob.json"      # beside each row's main output: what it was made from
REPORT_NAME = "jobs_report.json"    # the merged report in the output folder
_RESERVED = (FARM_FOLDER, REPORT_NAME)
_ODD = re.compile(r"[\x00-\x1f\x7f\\\\:]")


@dataclass(frozen=True, slots=True)
class JobRow:
    """One checked row. ``out``, ``live_link`` and ``cues`` are relative to the output folder (``/``
    between folders); ``audio`` is an absolute path (relative ones are taken from the manifest's folder)."""
    line: int
    action: str
    out: str
    text: str = ""
    audio: str = ""
    audio_as_given: str = ""
    transcript: str = ""
    voice: str = "en-us"
    rate: float = 175.0
    style: str = ""
    seed: int = 0
    emotion: str = ""
    animation: str = "weights"
    live_link: str = ""
    cues: str = ""

    @property
    def wav(self) -> str:
        return posixpath.splitext(self.out)[0] + ".wav"

    @property
    def sidecar(self) -> str:
        return self.out + SIDECAR_SUFFIX

    def outputs(self) -> tuple[str, ...]:
        """Every file the row writes, main output first (the sidecar is written last, after them)."""
        return tuple(p for p in (self.out, self.wav, self.live_link, self.cues) if p)

    def fields(self) -> dict:
        """The row as plain data (what a worker receives and what its key is made of, line excepted)."""
        return {name: getattr(self, name) for name in self.__slots__}

    @classmethod
    def from_fields(cls, fields: dict) -> "JobRow":
        return cls(**fields)


def number_field(label: str, value, default: float, bounds: tuple[float, float]) -> float:
    """``value`` (text or number; empty: ``default``) as a finite number within ``bounds``."""
    if value is None or (isinstance(value, str) and not value.strip()):
        return float(default)
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise UserError(f"{label} {value!r} is not a number") from None
    if not math.isfinite(number) or not bounds[0] <= number <= bounds[1]:
        raise UserError(f"{label} {value!r} is outside {bounds[0]:g}..{bounds[1]:g}")
    return number


def relative_output(label: str, value: str, suffixes: tuple[str, ...]) -> str:
    """``value`` as a clean path inside the output folder ('a/b.glb'), or a :class:`UserError` saying why
    it could land elsewhere."""
    odd = _ODD.search(value)
    if odd is not None:
        if odd.group() in "\\:":
            raise UserError(f"{label} {value!r}: use '/' between folders (no '\\', ':' or drive letters)")
        raise UserError(f"{label} {value!r} has a control character")
    if value.startswith(("/", "~")):
        raise UserError(f"{label} {value!r} is an absolute path; give it relative to the output folder")
    parts = [part for part in value.split("/") if part not in ("", ".")]
    if ".." in parts:
        raise UserError(f"{label} {value!r} leads outside the output folder ('..')")
    if not parts:
        raise UserError(f"{label} is empty")
    if parts[0].lower() in _RESERVED:
        raise UserError(f"{label} {value!r}: {parts[0]} is the jobs run's own; choose another name")
    if not parts[-1].lower().endswith(suffixes):
        raise UserError(f"{label} {value!r} must end with {' or '.join(suffixes)}")
    return "/".join(parts)


class Once:
    """Checks run once per distinct value (a voice, an emotion word, a style: the same few values recur in
    thousands of rows); a value's :class:`UserError` is kept and raised again."""

    def __init__(self):
        self._seen: dict[tuple[str, str], object] = {}
        self.folders: dict[str, str] = {}       # resolved folders, for the run's FileClaims

    def __call__(self, kind: str, value: str, check: Callable[[str], object]):
        key = (kind, value)
        if key not in self._seen:
            try:
                self._seen[key] = check(value)
            except UserError as error:
                self._seen[key] = error
        result = self._seen[key]
        if isinstance(result, UserError):
            raise result
        return result


class RowChecks:
    """The per-value checks of a run, each done once per distinct value (``voice_check``: raises for a
    voice the speech engine lacks; ``max_frames``: the most a per-frame bake takes)."""

    def __init__(self, manifest_folder: Path, fps: float, max_frames: int,
                 voice_check: Callable[[str], None] | None = None):
        from ..speech.espeak import RATE_RANGE
        from ..speech.takes import check_text_length, estimated_seconds
        self.rate_range, self.check_text_length, self.estimated_seconds = (RATE_RANGE, check_text_length,
                                                                           estimated_seconds)
        self.folder = manifest_folder
        self.fps, self.max_frames = fps, max_frames
        self._voice_check = voice_check
        self.once = Once()

    def voice(self, voice: str) -> None:
        if self._voice_check is not None:
            self.once("voice", voice, self._voice_check)

    def style(self, style: str) -> None:
        from ..behavior.styles import load_style
        self.once("style", style, load_style)

    def emotion(self, emotion: str) -> str:
        """The emotion as the take reads it: a word of the table (lower case) or 'activation,evaluation'."""
        from ..emotion import parse_emotion

        def normalised(text: str) -> str:
            parsed = parse_emotion(text)
            return ",".join(f"{v:g}" for v in parsed) if isinstance(parsed, tuple) else parsed
        return self.once("emotion", emotion, normalised)

    def audio_seconds(self, audio: str) -> float:
        from ..speech.audio import audio_header
        return self.once("audio", audio, lambda path: audio_header(path).duration)


def _row(raw: RawRow, checks: RowChecks) -> JobRow:
    """The row ``raw`` checked field by field (the first problem raises)."""
    cells = raw.cells
    action = cells.get("action", "").lower()
    if action not in ACTIONS:
        raise UserError(f"unknown action {cells.get('action', '')!r}; use {' or '.join(ACTIONS)}")
    if not cells.get("out"):
        raise UserError("no output: the 'out' cell is empty")
    out = relative_output("output", cells["out"], OUT_SUFFIXES)
    text, audio, transcript = cells.get("text", ""), cells.get("audio", ""), cells.get("transcript", "")
    rate = number_field("rate", cells.get("rate"), 175, checks.rate_range)
    seed = number_field("seed", cells.get("seed"), 0, (0, 2 ** 32 - 1))
    if seed != int(seed):
        raise UserError(f"seed {cells.get('seed')!r} is not a whole number")
    voice = cells.get("voice") or "en-us"
    if action == "speak":
        if audio or transcript:
            raise UserError("a speak row has text, not audio or a transcript (use the lipsync action)")
        if not text:
            raise UserError("a speak row needs text")
        checks.check_text_length(text, rate)
        checks.voice(voice)
        seconds = checks.estimated_seconds(text, rate)
        audio_path = ""
    else:
        if text:
            raise UserError("a lipsync row has audio (+ transcript), not text (use the speak action)")
        if not audio:
            raise UserError("a lipsync row needs audio")
        audio_path = os.path.normpath(os.path.join(checks.folder, os.path.expanduser(audio)))
        seconds = checks.audio_seconds(audio_path)
    animation = (cells.get("animation") or "weights").lower()
    if animation not in ANIMATIONS:
        raise UserError(f"unknown animation {cells.get('animation')!r}; use {' or '.join(ANIMATIONS)}")
    if animation == "frames" and seconds * checks.fps > checks.max_frames:
        raise UserError(f"about {seconds:.0f} s at {checks.fps:g} fps is more than {checks.max_frames} frames, the "
                        "most a per-frame bake takes; use the weights animation (the default)")
    live_link = relative_output("live_link", cells["live_link"], LIVE_LINK_SUFFIXES) if cells.get("live_link") else ""
    if live_link and animation != "weights":
        raise UserError("a Live Link CSV needs the weights animation")
    cues = relative_output("cues", cells["cues"], CUES_SUFFIXES) if cells.get("cues") else ""
    style = cells.get("style", "")
    if style:
        checks.style(style)
    emotion = checks.emotion(cells["emotion"]) if cells.get("emotion") else ""
    return JobRow(raw.line, action, out, text, audio_path, audio, transcript, voice, rate, style, int(seed),
                  emotion, animation, live_link, cues)


def check_rows(raws: list[RawRow], checks: RowChecks, out_dir: Path, inputs: dict[str, str],
               problems: list[Problem]) -> list[JobRow]:
    """Every row of ``raws`` checked; a bad row adds a :class:`Problem` (at its line) and is left out.
    ``inputs``: the run's own input files (label -> path: the manifest, a rig), never to be written."""
    rows = []
    for raw in raws:
        try:
            rows.append(_row(raw, checks))
        except UserError as error:
            problems.append(Problem(raw.line, str(error)))
    guard = _OutputGuard(out_dir, inputs, rows)
    kept = []
    for row in rows:
        try:
            guard.claim(row)
            kept.append(row)
        except UserError as error:
            problems.append(Problem(row.line, str(error)))
    return kept


class _OutputGuard:
    """Claims of output files, linear: a dictionary by case-folded relative path; each folder resolved and
    listed once, so only outputs that already exist are looked up among the inputs (:class:`FileClaims`)."""

    def __init__(self, out_dir: Path, inputs: dict[str, str], rows: list[JobRow]):
        self.root = os.path.realpath(out_dir)
        self.claimed: dict[str, int] = {}
        self.inputs = FileClaims()
        self.folders: dict[str, tuple[str, set[str]]] = {}
        for label, path in inputs.items():
            self.inputs.add(path, label)
        for row in rows:
            if row.audio:
                self.inputs.add(row.audio, f"the audio of line {row.line}")

    def _folder(self, relative_folder: str) -> tuple[str, set[str]]:
        """(resolved folder, case-folded names in it) of a folder inside the output folder."""
        known = self.folders.get(relative_folder)
        if known is None:
            real = os.path.realpath(os.path.join(self.root, relative_folder))
            if os.path.commonpath([real, self.root]) != self.root:
                raise UserError(f"the folder {relative_folder!r} leads outside the output folder (a link)")
            if os.path.exists(real) and not os.path.isdir(real):
                raise UserError(f"{relative_folder!r} is a file, not a folder")
            names = {name.casefold() for name in os.listdir(real)} if os.path.isdir(real) else set()
            known = self.folders[relative_folder] = (real, names)
        return known

    def claim(self, row: JobRow) -> None:
        paths = row.outputs() + (row.sidecar,)
        keys = [path.casefold() for path in paths]
        for path, key in zip(paths, keys):
            owner = self.claimed.get(key)
            if owner is not None:
                raise UserError(f"writes {path!r}, which line {owner} writes too")
            slash = key.rfind("/")
            real, names = self._folder(path[:slash] if slash >= 0 else "")
            if key[slash + 1:] in names:
                full = os.path.join(real, path[slash + 1:])
                if os.path.isdir(full):
                    raise UserError(f"{path!r} is a folder")
                label = self.inputs.owner(full)
                if label is not None:
                    raise UserError(f"writes {path!r}, which is {label}; never an input is written")
        for key in keys:
            self.claimed[key] = row.line

