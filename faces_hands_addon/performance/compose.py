# SPDX-License-Identifier: GPL-3.0-or-later
"""A performance: lip sync plus non-verbal behaviour plus emotion, each on its own layer of a face rig.

Thesis 4.3.5: the speech-related and the emotional contractions of a face are summed (and clamped, which
the layers' mixing rule does, ``anim.layers.mix``); the non-verbal signals that accompany speech (blinks,
brow raises, gaze, thinking faces) come from rules on the utterance (4.3.5, :mod:`..behavior`), the
emotions from the emoticons in the text (4.3.5, Table 4.1) and from an emotion for the whole take (4.4,
:mod:`..emotion`), which also sets the voice by Table 4.5 (:func:`voice_settings`).

The take's ``tracks`` stay the speech layer; :func:`with_nonverbal` adds ``layers["behavior"]`` and
``layers["emotion"]``, and the behaviour's head channels (``head.pitch/yaw/roll``, radians) as ``head``:
the face rig has no head joint, so the head turns as a whole, about the neck. :func:`perform` composes
them in order and lets speech own the lips where the layers conflict (:mod:`.priority`).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..anim.take import Span, Take
from ..anim.tracks import Track, TrackSet
from ..behavior import generate_behavior
from ..behavior.loudness import load_loudness_settings, loudness_curve, scale_tracks
from ..core.errors import UserError
from ..emotion import emotion_tracks, emotion_windows, expression_for, load_model, voice_for
from ..speech.articulation import load_articulation
from ..speech.closures import lip_closures
from ..speech.coarticulation import expand_segments
from ..speech.takes import SpeechTake
from .priority import load_priority, with_speech_priority

__all__ = ["voice_settings", "with_nonverbal", "with_loudness", "perform", "take_of"]


def voice_settings(emotion, rate: float, pitch: float = 50.0, volume: float = 100.0) -> dict[str, float]:
    """espeak-ng rate/pitch/volume for a take spoken with ``emotion`` (Table 4.5), around the given neutral
    voice; no emotion: the voice unchanged."""
    if emotion is None:
        return {"rate": rate, "pitch": pitch, "volume": volume}
    return voice_for(emotion, {"rate": rate, "pitch": pitch, "volume": volume}).synthesize_kwargs()


def _constant_expression(emotion, duration: float) -> TrackSet:
    tracks = TrackSet()
    times = np.array([0.0, max(duration, 1e-3)])
    for control, value in expression_for(emotion).items():
        tracks.add(Track(control, times, np.full(2, float(value))))
    return tracks


def _winks(utterance, model) -> list[tuple[float, float]]:
    """(start, end) of every wink of the utterance's emoticons (";-)"), as :func:`emotion.wink_curve` times it."""
    spans = []
    for window in emotion_windows(utterance):
        wink = model.tags.get(window.emotion, {}).get("wink")
        if wink:
            half = 0.5 * float(wink["hold"])
            spans.append((window.apex - half - float(wink["close"]), window.apex + half + float(wink["open"])))
    return spans


def with_nonverbal(take: SpeechTake, *, style: str | None = "neutral", seed: int = 0,
                   emotion=None) -> SpeechTake:
    """``take`` with a behaviour layer (``style`` from ``presets/behavior/styles.json``, every random choice
    from ``seed``; ``None``: no behaviour) and an emotion layer (the emoticons' emotions, plus ``emotion``
    for the whole take). Needs the muscle target (a face rig)."""
    if take.target != "muscles":
        raise UserError("non-verbal behaviour and emotions need a face rig; viseme shape keys only lip-sync")
    layers = dict(take.layers)
    ranges = dict(take.ranges)
    head = take.head
    model = load_model()
    if style is not None:
        behavior = generate_behavior(take.utterance, style, seed, lids_busy=_winks(take.utterance, model))
        layers["behavior"] = TrackSet({t.name: t for t in behavior.tracks if not t.name.startswith("head.")})
        head = TrackSet({t.name: t for t in behavior.tracks if t.name.startswith("head.")})
        ranges.update({name: (spec.minimum, spec.maximum) for name, spec in behavior.specs.items()
                       if not name.startswith("head.")})
    emotions = emotion_tracks(take.utterance, take.fps, model)
    if emotion is not None:
        emotions = emotions.merged(_constant_expression(emotion, take.duration))
    if len(emotions):
        ranges.update({t.name: (model.specs[t.name].minimum, model.specs[t.name].maximum) for t in emotions})
        layers["emotion"] = emotions.clipped(ranges)
    return replace(take, layers=layers, ranges=ranges, head=head)


def with_loudness(take: SpeechTake, settings=None) -> SpeechTake:
    """``take`` with its mouth (the speech layer), its behaviour layer and its head motion scaled by the
    relative loudness of its audio, each parameter by its own weight (4.2.1 "Volume-controlled
    Intensity", :mod:`..behavior.loudness`; the emotion layer is left alone). Returns the take and the
    curve as ``(take, loudness)``."""
    settings = settings or load_loudness_settings()
    curve = loudness_curve(take.utterance.samples, take.utterance.sample_rate, settings)
    layers = dict(take.layers)
    if "behavior" in layers:
        layers["behavior"] = scale_tracks(layers["behavior"], curve, settings, take.ranges)
    tracks = scale_tracks(take.tracks, curve, settings, take.ranges)
    head = scale_tracks(take.head, curve, settings) if take.head is not None and len(take.head) else take.head
    return replace(take, tracks=tracks, layers=layers, head=head), curve


def perform(take: SpeechTake, *, style: str | None = None, seed: int = 0, emotion=None,
            loudness: bool = False) -> SpeechTake:
    """The whole performance of a take: behaviour (``style``, seeded) and emotion layers when asked for or
    when the text carries emoticons, the loudness of recorded audio on mouth, behaviour and head (4.2.1)
    when ``loudness``, and finally speech's priority over the lips (:mod:`.priority`)."""
    if style or emotion is not None or take.utterance.emotions:
        take = with_nonverbal(take, style=style, seed=seed, emotion=emotion)
    if loudness:
        take, _ = with_loudness(take)
    return with_speech_priority(take)


def take_of(performed: SpeechTake, articulations=None) -> Take:
    """The bake's plain-data take (:class:`..anim.take.Take`) of a performed speech take: its layers (speech
    + behaviour + emotion), head motion, lip closures (3.1.3) and the spans of the exclusive articulations
    (the jaw while speaking, /p b m/, /f v/; ramps included) with the controls speech owns there
    (:mod:`.priority`)."""
    articulations = load_priority() if articulations is None else articulations
    layers = {"speech": performed.tracks, **performed.layers} if performed.target == "muscles" else {}
    closures = tuple(Span(c.start, c.end, c.viseme) for c in lip_closures(performed.utterance.phones))
    targets = load_articulation()
    owned = []
    for segment in expand_segments(performed.utterance, targets):
        if segment.phase == "release" or segment.duration <= 0:
            continue
        for articulation in articulations:
            if articulation.exclusive and targets.class_of.get(segment.phone) in articulation.classes:
                span = Span(segment.start - articulation.lead_s, segment.end + articulation.lag_s, articulation.name)
                owned.append((span, frozenset(articulation.owns)))
    return Take(layers, performed.duration, performed.head, closures, tuple(owned))
