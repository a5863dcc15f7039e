# SPDX-License-Identifier: GPL-3.0-or-later
"""Emotion curves from the emoticons of an utterance (thesis 4.3.5 "Facial Expressions from Emotion Tags",
Table 4.1), for the ``emotion`` control layer.

"The apex of the emotion is determined by the position of the emoticon in the text input. We assume an
intensity of 100 % of the corresponding emotion at its climax. The area of influence of an emotion is the
intonational phrase during which it occurs. ... Towards the borders of these phrases, the intensity of the
emotion decreases linearly to zero. If an emotion is specified between two phrases, the emotion stretches
over both phrases."

So each tag's intensity is 0 at the start of its first phrase, 1 at the apex (the tag's time, placed by
:func:`..speech.utterance.assemble_utterance`), 0 at the end of its last phrase, linear in between. When
the apex falls on a border (an emoticon after the utterance's last word) that side fades over the
neighbouring pause instead (to the next phrase, or the end of the audio), our choice where the thesis'
rule has no length to fade over. The tag's expression is its emotion word's (:mod:`.expressions`) at full
intensity; ``;-)`` (kidding) adds a wink (4.3.5, Fig. 4.7), one lid closing and opening around the apex.
Emotions add up (4.3.5: contractions are summed) and each control is clamped to its range; the curves are
sampled on the frame grid plus every border and apex, as a :class:`..anim.tracks.TrackSet` ready for the
``emotion`` layer, where :func:`..anim.layers.mix` adds them to the speech contractions.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..anim.timing import check_fps
from ..anim.tracks import Track, TrackSet, frame_times
from ..core.errors import UserError
from .expressions import EmotionModel, expression_for, load_model

__all__ = ["EmotionWindow", "emotion_windows", "intensity", "wink_curve", "emotion_tracks"]

EPSILON = 1e-9


@dataclass(frozen=True)
class EmotionWindow:
    """One tag's area of influence (4.3.5): intensity 0 at ``start``, 1 at ``apex``, 0 at ``end``."""

    emotion: str
    start: float
    apex: float
    end: float


def _phrase_of(utterance, word: int) -> int:
    return utterance.words[word].phrase if 0 <= word < len(utterance.words) else -1


def emotion_windows(utterance) -> list[EmotionWindow]:
    """The window of every timed emotion tag of ``utterance`` (an :class:`..speech.Utterance`): its
    intonational phrase, or both phrases when the emoticon stands between two (4.3.5). Tags without a
    time (no words) are skipped."""
    phrases = utterance.phrases
    windows = []
    for tag in utterance.emotions:
        if tag.time is None or not phrases:
            continue
        ids = [p for p in (_phrase_of(utterance, tag.previous_word), _phrase_of(utterance, tag.next_word)) if p >= 0]
        if not ids:
            continue
        first, last = min(ids), max(ids)
        start, end = phrases[first].start, phrases[last].end
        apex = min(max(float(tag.time), start), end)
        if apex - start <= EPSILON and first > 0:
            start = phrases[first - 1].end
        elif apex - start <= EPSILON:
            start = 0.0
        if end - apex <= EPSILON:
            end = phrases[last + 1].start if last + 1 < len(phrases) else max(utterance.duration, end)
        windows.append(EmotionWindow(tag.emotion, float(start), apex, float(end)))
    return windows


def intensity(window: EmotionWindow, times: np.ndarray) -> np.ndarray:
    """Intensity of ``window`` at ``times`` (4.3.5): linear 0 -> 1 -> 0 over start, apex, end; 0 outside."""
    knots, levels = [window.apex], [1.0]
    if window.apex - window.start > EPSILON:
        knots, levels = [window.start] + knots, [0.0] + levels
    if window.end - window.apex > EPSILON:
        knots, levels = knots + [window.end], levels + [0.0]
    return np.interp(np.asarray(times, dtype=np.float64), knots, levels, left=0.0, right=0.0)


def wink_curve(apex: float, wink: dict, times: np.ndarray) -> np.ndarray:
    """The lid closure of a wink centred on ``apex``: closing over ``close`` s, closed for ``hold`` s,
    opening over ``open`` s, at ``value`` (the kidding emoticon ;-), 4.3.5)."""
    value, hold = float(wink["value"]), float(wink["hold"])
    closed_from, closed_to = apex - 0.5 * hold, apex + 0.5 * hold
    knots = [closed_from - float(wink["close"]), closed_from, closed_to, closed_to + float(wink["open"])]
    levels = [0.0, value, value, 0.0]
    keep = [0] + [k for k in range(1, 4) if knots[k] - knots[k - 1] > EPSILON]
    knots, levels = [knots[k] for k in keep], [levels[k] for k in keep]
    return np.interp(np.asarray(times, dtype=np.float64), knots, levels, left=0.0, right=0.0)


def _sample_times(windows: list[EmotionWindow], winks: list[tuple[float, dict]], fps: float,
                  duration: float) -> np.ndarray:
    extra = [t for w in windows for t in (w.start, w.apex, w.end)]
    for apex, wink in winks:
        half = 0.5 * float(wink["hold"])
        extra += [apex - half - float(wink["close"]), apex - half, apex + half, apex + half + float(wink["open"])]
    end = max([duration] + extra)
    grid = frame_times(fps, 0.0, end)
    times = np.union1d(grid, np.asarray([t for t in extra if t >= 0.0], dtype=np.float64))
    keep = np.concatenate([[True], np.diff(times) > EPSILON])
    return times[keep]


def emotion_tracks(utterance, fps: float = 30.0, model: EmotionModel | None = None) -> TrackSet:
    """Per-control curves of the emotions of ``utterance`` for the ``emotion`` layer (4.3.5): every tag's
    expression times its intensity, winks added, summed and clamped to the controls' ranges, sampled at
    ``fps`` plus every border and apex. No timed tags: an empty set."""
    fps = check_fps(fps)
    model = load_model() if model is None else model
    windows = emotion_windows(utterance)
    if not windows:
        return TrackSet()
    for window in windows:
        if window.emotion not in model.tags:
            raise UserError(f"no expression for the emotion {window.emotion!r}; add it to the \"tags\" of "
                            "presets/emotion/basic_expressions.json")
    winks = [(w.apex, model.tags[w.emotion]["wink"]) for w in windows if model.tags[w.emotion].get("wink")]
    times = _sample_times(windows, winks, fps, float(utterance.duration))
    totals: dict[str, np.ndarray] = {}
    for window in windows:
        weight = intensity(window, times)
        for control, value in expression_for(model.tags[window.emotion]["word"], model).items():
            totals[control] = totals.get(control, 0.0) + value * weight
    for apex, wink in winks:
        totals[wink["control"]] = totals.get(wink["control"], 0.0) + wink_curve(apex, wink, times)
    tracks = TrackSet()
    for control, values in totals.items():
        spec = model.specs[control]
        tracks.add(Track(control, times, np.clip(values, spec.minimum, spec.maximum)))
    return tracks
