# SPDX-License-Identifier: GPL-3.0-or-later
"""Mouth cues in Rhubarb Lip Sync's formats, for 2D pipelines that read them.

Rhubarb names nine mouth shapes: six basic ones and three extended ones.

====  ==========================================================================================
A     closed mouth: the bilabials P, B, M
B     slightly open, teeth together: most consonants (K, S, T, ...) and the close front vowels (EE)
C     open: EH, AE and other mid vowels
D     wide open: AA
E     slightly rounded: AO, ER
F     puckered: UW, OW, W
G     upper teeth on the lower lip: F, V (extended)
H     tongue raised behind the upper teeth: long L (extended)
X     idle, the mouth at rest: silence (extended)
====  ==========================================================================================

A cue is one shape held from its start to the next cue. The shapes come from the utterance's own timed
phones (the same phone timing that drives the coarticulation, thesis 3.1.4), so every bilabial gets its
own "A" cue however short it is. Two file formats, as Rhubarb writes them: TSV (``start<TAB>shape`` per
line, the last line the end time with the closing shape) and JSON (``metadata`` + ``mouthCues`` with
``start``/``end``/``value``).
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import UserError
from ..core.foreign_files import read_text
from .phonemes import PHONES

SHAPES = ("A", "B", "C", "D", "E", "F", "G", "H", "X")
EXTENDED = ("G", "H", "X")
FORMATS = ("tsv", "json")

#: Shape of each Meta/Oculus viseme; phones that the viseme table groups but Rhubarb tells apart are in
#: :data:`_PHONE_SHAPE`.
_VISEME_SHAPE = {
    "viseme_sil": "X", "viseme_PP": "A", "viseme_FF": "G", "viseme_TH": "B", "viseme_DD": "B",
    "viseme_kk": "B", "viseme_CH": "B", "viseme_SS": "B", "viseme_nn": "B", "viseme_RR": "B",
    "viseme_aa": "D", "viseme_E": "C", "viseme_ih": "B", "viseme_oh": "E", "viseme_ou": "F",
}
_PHONE_SHAPE = {"ae": "C", "ah": "C", "ax": "C", "er": "E", "l": "H", "w": "F", "uh": "F", "ow": "F",
                "q": "X"}
#: extended shape -> basic shape, for ``extended=False``
_BASIC = {"G": "A", "H": "C", "X": "A"}


@dataclass(frozen=True)
class MouthCue:
    start: float
    end: float
    shape: str


def shape_of_phone(phone: str, extended: bool = True) -> str:
    """Rhubarb shape for a unified phone name (``speech.phonemes``)."""
    info = PHONES.get(phone)
    if info is None:
        raise UserError(f"no mouth shape for the phone {phone!r}")
    shape = _PHONE_SHAPE.get(phone, _VISEME_SHAPE[info.viseme])
    return shape if extended or shape not in EXTENDED else _BASIC[shape]


def mouth_cues(phones, duration: float, extended: bool = True) -> list[MouthCue]:
    """Cues for timed phones (objects with ``phone``, ``start``, ``duration``): one cue per run of phones
    with the same shape, silence before the first and after the last phone, covering 0..``duration``
    without gaps or overlaps."""
    rest = "X" if extended else "A"
    cues: list[MouthCue] = []

    def add(start: float, end: float, shape: str) -> None:
        if end <= start + 1e-9:
            return
        if cues and cues[-1].shape == shape and abs(cues[-1].end - start) < 1e-9:
            cues[-1] = MouthCue(cues[-1].start, end, shape)
        elif cues and start < cues[-1].end:
            start = cues[-1].end
            if end > start + 1e-9:
                cues.append(MouthCue(start, end, shape))
        else:
            if cues and start > cues[-1].end + 1e-9:
                add(cues[-1].end, start, rest)
            elif not cues and start > 1e-9:
                cues.append(MouthCue(0.0, start, rest))
            cues.append(MouthCue(start, end, shape))

    for item in sorted(phones, key=lambda p: p.start):
        add(float(item.start), float(item.start + item.duration), shape_of_phone(item.phone, extended))
    if not cues:
        return [MouthCue(0.0, max(duration, 0.0), rest)] if duration > 0 else []
    if duration > cues[-1].end + 1e-9:
        add(cues[-1].end, duration, rest)
    return cues


def cues_text(cues: list[MouthCue], fmt: str, sound_file: str = "", duration: float | None = None,
              extended: bool = True) -> str:
    """The cues as Rhubarb writes them: ``fmt`` ``"tsv"`` or ``"json"``. Times in seconds, 2 decimals
    as Rhubarb prints them (10 ms, finer than any video frame). A TSV line is the start of a shape; a final
    line starts the rest shape at the end, so the last cue's end is in the file (:func:`read_cues`)."""
    if fmt not in FORMATS:
        raise UserError(f"unknown mouth-cue format {fmt!r}: use one of {', '.join(FORMATS)}")
    end = duration if duration is not None else (cues[-1].end if cues else 0.0)
    if fmt == "tsv":
        lines = [f"{cue.start:.2f}\t{cue.shape}" for cue in cues]
        if cues:                      # the end: the rest shape from there on (so the file holds the last cue's end)
            lines.append(f"{end:.2f}\t{'X' if extended else 'A'}")
        return "\n".join(lines) + "\n"
    document = {"metadata": {"soundFile": sound_file, "duration": round(end, 2)},
                "mouthCues": [{"start": round(c.start, 2), "end": round(c.end, 2), "value": c.shape}
                              for c in cues]}
    return json.dumps(document, indent=2) + "\n"


def cue_format(path: str | Path) -> str:
    """``tsv`` or ``json`` from the file name (``.tsv``/``.txt`` or ``.json``)."""
    suffix = Path(path).suffix.lower()
    if suffix in (".tsv", ".txt"):
        return "tsv"
    if suffix == ".json":
        return "json"
    raise UserError(f"--cues {path}: name a .tsv (or .txt) or .json file")


#: the viseme that plays each shape when cues drive a character (:func:`cue_weights`): the shapes' own
#: viseme of :data:`_VISEME_SHAPE`, the most common where several share one
SHAPE_VISEME = {"A": "viseme_PP", "B": "viseme_kk", "C": "viseme_E", "D": "viseme_aa", "E": "viseme_oh",
                "F": "viseme_ou", "G": "viseme_FF", "H": "viseme_nn", "X": "viseme_sil"}
MAX_CUE_BYTES = 50_000_000


def _cue(start, end, shape, where: str) -> MouthCue:
    try:
        start, end = float(start), float(end)
    except (TypeError, ValueError):
        raise UserError(f"{where}: the time is not a number") from None
    if not (np.isfinite(start) and np.isfinite(end)) or start < 0 or end < start:
        raise UserError(f"{where}: times {start}..{end} are not a span from 0 on")
    if shape not in SHAPES:
        raise UserError(f"{where}: {shape!r} is not a mouth shape ({', '.join(SHAPES)})")
    return MouthCue(start, end, shape)


def read_cues(path: str | Path) -> list[MouthCue]:
    """The mouth cues of a Rhubarb Lip Sync file as :func:`cues_text` writes it (and Rhubarb does): TSV
    (``start<TAB>shape`` lines, each cue ending where the next starts; the last line is the end, where the
    rest shape holds on) or JSON (``mouthCues`` with ``start``/``end``/``value``); cues in time order
    without overlaps. What :func:`cues_text` wrote reads back as its cues at the file's 10 ms."""
    fmt = cue_format(path)
    text = read_text(path, "the mouth-cue file", MAX_CUE_BYTES)
    if fmt == "json":
        try:
            cues = [_cue(c["start"], c["end"], c["value"], f"{path} cue {k + 1}")
                    for k, c in enumerate(json.loads(text)["mouthCues"])]
        except (ValueError, KeyError, TypeError) as error:
            raise UserError(f"{path} is not Rhubarb's JSON (mouthCues with start, end, value): {error}") from None
    else:
        rows = [line.split("\t") for line in text.splitlines() if line.strip()]
        if any(len(row) != 2 for row in rows):
            raise UserError(f"{path}: every line must be start<TAB>shape")
        cues = [_cue(rows[k][0], rows[k + 1][0], rows[k][1], f"{path} line {k + 1}") for k in range(len(rows) - 1)]
    if any(b.start < a.end - 1e-9 for a, b in zip(cues, cues[1:])):
        raise UserError(f"{path}: the cues overlap or are not in time order")
    return cues


def cue_weights(cues: list[MouthCue], fps: float) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Frames (from 0) and per-viseme weights (:data:`SHAPE_VISEME`) that hold each cue's shape from its
    start to the next: what a 2D pipeline's mouth chart shows, on a character's viseme keys."""
    end = max((c.end for c in cues), default=0.0)
    frames = np.arange(0, int(np.floor(end * fps + 1e-6)) + 1, dtype=np.float64)
    starts = np.array([c.start for c in cues])
    index = np.clip(np.searchsorted(starts, frames / fps + 1e-9, side="right") - 1, 0, max(len(cues) - 1, 0))
    weights = {viseme: np.zeros(len(frames)) for viseme in SHAPE_VISEME.values()}
    for row, k in enumerate(index):
        if cues:
            weights[SHAPE_VISEME[cues[k].shape]][row] = 1.0
    return frames, weights
