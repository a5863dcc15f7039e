# SPDX-License-Identifier: GPL-3.0-or-later
"""A speech *take*: an utterance plus the coarticulated tracks that animate a face with it.

This is the whole lip-sync pipeline of thesis 4.3.4 (text analysis -> phonemes with durations ->
coarticulated control values) minus the part that writes Blender data. Audio and animation come from
the same phone timing, so they stay in sync (3.1.4): track times are seconds from the first audio sample.

Two targets:

* ``"muscles"``: the speech parameters of the muscle face rig (3.1.3 "Muscles"), from
  ``presets/speech/articulation.json``;
* ``"visemes"``: weights of the 15 Meta/Oculus viseme shape keys (``viseme_sil`` ...), from
  ``presets/speech/visemes.json``, for characters that have viseme shape keys but no muscle rig.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Callable

from ..anim import TrackSet
from ..anim.timing import check_fps
from ..core.errors import UserError
from .align import align_audio
from .audio import MAX_TAKE_SECONDS, audio_header
from .articulation import TargetSet, load_articulation, load_viseme_targets
from .coarticulation import coarticulate
from .tts import synthesize
from .utterance import Utterance

TARGETS = ("muscles", "visemes")
MAX_TEXT_CHARS = 400_000

Progress = Callable[[float, str], None]


@dataclass
class SpeechTake:
    """One line of speech ready to be put on a character: ``tracks`` for the speech layer, ``layers``
    (``"behavior"``, ``"emotion"``; see :mod:`.performance`) for the other layers of a face rig, and
    ``head`` (``head.pitch``/``head.yaw``/``head.roll`` in radians) for the head's rotation."""

    utterance: Utterance
    tracks: TrackSet
    target: str
    fps: float
    ranges: dict[str, tuple[float, float]]
    layers: dict[str, TrackSet] = field(default_factory=dict)
    head: TrackSet = field(default_factory=TrackSet)

    @property
    def duration(self) -> float:
        return float(self.utterance.duration)


def target_set(target: str, preset_path: str | os.PathLike | None = None) -> TargetSet:
    if target not in TARGETS:
        raise UserError(f"unknown lip-sync target {target!r}; use one of {', '.join(TARGETS)}")
    return load_articulation(preset_path) if target == "muscles" else load_viseme_targets(preset_path)


def take_from_utterance(utterance: Utterance, *, fps: float, target: str = "muscles",
                        preset_path: str | os.PathLike | None = None) -> SpeechTake:
    """Coarticulate an existing utterance (3.1.3) for ``target``."""
    fps = check_fps(fps)
    targets = target_set(target, preset_path)
    result = coarticulate(utterance, targets, fps=fps)
    return SpeechTake(utterance=utterance, tracks=result.tracks, target=target, fps=fps,
                      ranges=dict(targets.ranges))


def _take(make_utterance, first_message: str, fps: float, target: str, preset_path, progress) -> SpeechTake:
    """Check the cheap things first (preset, fps), then the slow part, then coarticulate."""
    target_set(target, preset_path)  # fail on a bad preset before the slow part
    check_fps(fps)
    if progress:
        progress(0.05, first_message)
    utterance = make_utterance()
    if progress:
        progress(0.7, "coarticulating")
    take = take_from_utterance(utterance, fps=fps, target=target, preset_path=preset_path)
    if progress:
        progress(0.9, "tracks ready")
    return take


def estimated_seconds(text: str, rate: float) -> float:
    """How long ``text`` takes to say at ``rate`` words per minute, from its word count (within ~20 % of
    espeak-ng for English prose); cheap enough to check before synthesising."""
    return len(str(text).split()) / max(float(rate), 1.0) * 60.0


def check_text_length(text: str, rate: float) -> None:
    """Refuse a text whose take would pass ``MAX_TAKE_SECONDS`` before any synthesis."""
    seconds = estimated_seconds(text, rate)
    if seconds > MAX_TAKE_SECONDS or len(str(text)) > MAX_TEXT_CHARS:
        raise UserError(f"the text is {len(str(text))} characters, about {seconds / 60:.0f} minutes of speech; one "
                        f"take may be at most {MAX_TAKE_SECONDS / 60:.0f} minutes: split it into takes")


def take_from_text(text: str, *, voice: str = "en-us", rate: float = 175, pitch: float = 50,
                   volume: float = 100, fps: float = 24.0, target: str = "muscles",
                   preset_path: str | os.PathLike | None = None,
                   progress: Progress | None = None) -> SpeechTake:
    """Text -> espeak-ng speech -> coarticulated tracks (the MARY + MEDUSA pipeline of 4.3.4)."""
    check_text_length(text, rate)
    return _take(lambda: synthesize(text, voice=voice, rate=rate, pitch=pitch, volume=volume),
                 "synthesising speech", fps, target, preset_path, progress)


def take_from_audio(audio_path: str | os.PathLike, transcript: str | None, *, fps: float = 24.0,
                    target: str = "muscles", language: str = "en-us",
                    preset_path: str | os.PathLike | None = None,
                    progress: Progress | None = None) -> SpeechTake:
    """Recorded audio (+ transcript) -> forced alignment -> coarticulated tracks."""
    audio_header(audio_path)    # the length limit, from the header, before anything is decoded
    return _take(lambda: align_audio(audio_path, transcript or None, language=language),
                 "aligning audio to the transcript" if transcript else "recognising phones",
                 fps, target, preset_path, progress)
