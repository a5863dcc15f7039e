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
from dataclasses import dataclass
from typing import Callable

from ..anim import TrackSet
from ..errors import UserError
from .align import align_audio
from .articulation import TargetSet, load_articulation, load_viseme_targets
from .coarticulation import coarticulate
from .tts import synthesize
from .utterance import Utterance

TARGETS = ("muscles", "visemes")

Progress = Callable[[float, str], None]


@dataclass
class SpeechTake:
    """One line of speech ready to be put on a character."""

    utterance: Utterance
    tracks: TrackSet
    target: str
    fps: float
    ranges: dict[str, tuple[float, float]]

    @property
    def duration(self) -> float:
        return float(self.utterance.duration)


def target_set(target: str, preset_path: str | os.PathLike | None = None) -> TargetSet:
    if target not in TARGETS:
        raise UserError(f"unknown lip-sync target {target!r}; use one of {', '.join(TARGETS)}")
    return load_articulation(preset_path) if target == "muscles" else load_viseme_targets(preset_path)


def _check_fps(fps: float) -> float:
    fps = float(fps)
    if not (1.0 <= fps <= 1000.0):
        raise UserError(f"frame rate {fps} is outside 1..1000 fps")
    return fps


def take_from_utterance(utterance: Utterance, *, fps: float, target: str = "muscles",
                        preset_path: str | os.PathLike | None = None) -> SpeechTake:
    """Coarticulate an existing utterance (3.1.3) for ``target``."""
    fps = _check_fps(fps)
    targets = target_set(target, preset_path)
    result = coarticulate(utterance, targets, fps=fps)
    return SpeechTake(utterance=utterance, tracks=result.tracks, target=target, fps=fps,
                      ranges=dict(targets.ranges))


def take_from_text(text: str, *, voice: str = "en-us", rate: float = 175, pitch: float = 50,
                   volume: float = 100, fps: float = 24.0, target: str = "muscles",
                   preset_path: str | os.PathLike | None = None,
                   progress: Progress | None = None) -> SpeechTake:
    """Text -> espeak-ng speech -> coarticulated tracks (the MARY + MEDUSA pipeline of 4.3.4)."""
    target_set(target, preset_path)  # fail on a bad preset before the slow part
    _check_fps(fps)
    if progress:
        progress(0.05, "synthesising speech")
    utterance = synthesize(text, voice=voice, rate=rate, pitch=pitch, volume=volume)
    if progress:
        progress(0.7, "coarticulating")
    take = take_from_utterance(utterance, fps=fps, target=target, preset_path=preset_path)
    if progress:
        progress(0.9, "tracks ready")
    return take


def take_from_audio(audio_path: str | os.PathLike, transcript: str | None, *, fps: float = 24.0,
                    target: str = "muscles", language: str = "en-us",
                    preset_path: str | os.PathLike | None = None,
                    progress: Progress | None = None) -> SpeechTake:
    """Recorded audio (+ transcript) -> forced alignment -> coarticulated tracks."""
    target_set(target, preset_path)
    _check_fps(fps)
    if progress:
        progress(0.05, "aligning audio to the transcript" if transcript else "recognising phones")
    utterance = align_audio(audio_path, transcript or None, language=language)
    if progress:
        progress(0.7, "coarticulating")
    take = take_from_utterance(utterance, fps=fps, target=target, preset_path=preset_path)
    if progress:
        progress(0.9, "tracks ready")
    return take
