# SPDX-License-Identifier: GPL-3.0-or-later
"""Emotions (thesis 4.4): emotion words on the activation-evaluation disk (Table 4.4), facial expressions of
any emotion from six basic ones (4.4.3, Eqs. 4.6-4.10, Table 4.6), emotional prosody for espeak-ng (4.4.2,
Table 4.5) and emotion curves from the emoticons of an utterance for the ``emotion`` layer (4.3.5).

* :func:`expression_for` -- a word or an (activation, evaluation) point -> face control values.
* :func:`voice_for` -- a word or point -> :class:`VoiceSettings` (espeak-ng rate, pitch, range, volume).
* :func:`emotion_tracks` -- an :class:`~faces_hands_addon.speech.Utterance` -> a
  :class:`~faces_hands_addon.anim.tracks.TrackSet` for the emotion layer.

Engine only: no bpy. The presets are ``presets/emotion/emotion_words.json`` and ``basic_expressions.json``.
"""
from .expressions import (BasicExpression, EmotionModel, expression_for, face_specs, load_model,
                          mixed_expression, scaled_expression)
from .timeline import EmotionWindow, emotion_tracks, emotion_windows, intensity, wink_curve
from .voice import TABLE_4_5, VoiceSettings, prosody_changes, voice_for
from .words import DISK_RADIUS, EmotionPoint, emotion_point, from_polar, load_words, parse_emotion, polar

__all__ = [
    "EmotionPoint", "load_words", "emotion_point", "parse_emotion", "polar", "from_polar", "DISK_RADIUS",
    "BasicExpression", "EmotionModel", "load_model", "face_specs", "scaled_expression", "mixed_expression",
    "expression_for",
    "TABLE_4_5", "VoiceSettings", "prosody_changes", "voice_for",
    "EmotionWindow", "emotion_windows", "intensity", "wink_curve", "emotion_tracks",
]
