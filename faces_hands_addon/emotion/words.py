# SPDX-License-Identifier: GPL-3.0-or-later
"""Emotion words and the activation-evaluation disk (thesis 4.4.1, Table 4.4, 4.4.3).

An emotion is a point in emotion space: activation, evaluation and power, each from -100 to +100 (Table
4.4, the NECA working model, ``presets/emotion/emotion_words.json``). The face only uses the first two
(4.4.3: "we only use the first two dimensions"): Cowie's disk-shaped activation-evaluation space in polar
form, the angle ``omega`` describing similarity and the radius ``r`` (distance from the neutral centre)
intensity. Evaluation is the horizontal axis and activation the vertical one (Fig. 4.9), so

    omega = atan2(activation, evaluation) in degrees, in [0, 360);   r = sqrt(activation^2 + evaluation^2)

The disk's outer bound (r = 100) holds the most intense emotions; points outside it are projected onto it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..core.errors import UserError
from ..core.presets import NUMBER, PresetFormat, read_preset, register_format

__all__ = ["FORMAT", "DISK_RADIUS", "EmotionPoint", "load_words", "emotion_point", "polar", "from_polar",
           "parse_emotion"]

FORMAT = register_format(PresetFormat(
    "faces_hands.emotion_words", 1, required=("words",),
    shape={"about": str, "words": {str: {"activation": NUMBER, "evaluation": NUMBER, "power": NUMBER}},
           "scaled": {str: {"like": str, "radius": NUMBER}}}))
DISK_RADIUS = 100.0
DIMENSIONS = ("activation", "evaluation", "power")


@dataclass(frozen=True)
class EmotionPoint:
    """A point in emotion space (Table 4.4 scales, -100..100); ``word`` names it when it came from a word."""

    activation: float
    evaluation: float
    power: float = 0.0
    word: str = ""

    @property
    def angle(self) -> float:
        """omega in degrees, [0, 360) (4.4.3: "the angle omega describes similarity")."""
        return polar(self.activation, self.evaluation)[0]

    @property
    def radius(self) -> float:
        """r: distance from the centre of the activation-evaluation disk, at most 100 (4.4.3: intensity)."""
        return polar(self.activation, self.evaluation)[1]


def polar(activation: float, evaluation: float) -> tuple[float, float]:
    """(omega in degrees in [0, 360), r) of an activation-evaluation point (4.4.3, Fig. 4.9); r is clipped to
    the disk (at most 100) and omega is 0 at the centre."""
    a, e = float(activation), float(evaluation)
    if not (math.isfinite(a) and math.isfinite(e)):
        raise UserError(f"activation and evaluation must be finite numbers, not {activation!r}, {evaluation!r}")
    radius = math.hypot(a, e)
    if radius == 0.0:
        return 0.0, 0.0
    angle = math.degrees(math.atan2(a, e)) % 360.0
    return angle, min(radius, DISK_RADIUS)


def from_polar(angle: float, radius: float) -> tuple[float, float]:
    """(activation, evaluation) of the disk point at ``angle`` degrees and ``radius`` (inverse of :func:`polar`)."""
    theta = math.radians(float(angle))
    return float(radius) * math.sin(theta), float(radius) * math.cos(theta)


def _checked(source: str, name: str, entry: dict) -> EmotionPoint:
    values = [float(entry[d]) for d in DIMENSIONS]
    if any(abs(v) > DISK_RADIUS for v in values):
        raise UserError(f"{source}: emotion word {name!r}: activation, evaluation and power must lie in "
                        "-100..100 (thesis Table 4.4 scales)")
    return EmotionPoint(*values, word=name)


def load_words() -> dict[str, EmotionPoint]:
    """Every emotion word of ``presets/emotion/emotion_words.json`` (the user's copy if there is one): the
    Table 4.4 rows, surprise (4.4.3: activation 100, evaluation and power 0) and the scaled words (Fig.
    4.17: the angle of their model word, their own radius), in file order."""
    doc, source = read_preset("emotion/emotion_words.json", FORMAT.name)
    words: dict[str, EmotionPoint] = {}
    for name, entry in doc["words"].items():
        missing = [d for d in DIMENSIONS if d not in entry]
        if missing:
            raise UserError(f"{source}: emotion word {name!r} lacks {', '.join(missing)}")
        words[str(name)] = _checked(source, str(name), entry)
    for name, entry in (doc.get("scaled") or {}).items():
        model = words.get(str(entry.get("like", "")))
        if model is None or "radius" not in entry:
            raise UserError(f"{source}: scaled word {name!r} needs \"like\" (a word above) and \"radius\"")
        radius = float(entry["radius"])
        if not 0.0 < radius <= DISK_RADIUS or model.radius == 0.0:
            raise UserError(f"{source}: scaled word {name!r}: radius must lie in (0, 100] and its model word "
                            "must not be neutral")
        activation, evaluation = from_polar(model.angle, radius)
        power = max(-DISK_RADIUS, min(DISK_RADIUS, model.power * radius / model.radius))
        words[str(name)] = EmotionPoint(activation, evaluation, power, word=str(name))
    return words


def emotion_point(emotion, words: dict[str, EmotionPoint] | None = None) -> EmotionPoint:
    """An :class:`EmotionPoint` from a word of the table (``"fear"``), an ``(activation, evaluation)`` or
    ``(activation, evaluation, power)`` sequence, or an EmotionPoint."""
    if isinstance(emotion, EmotionPoint):
        return emotion
    if isinstance(emotion, str):
        words = load_words() if words is None else words
        point = words.get(emotion.strip().lower())
        if point is None:
            raise UserError(f"unknown emotion word {emotion!r}; use one of {', '.join(words)} "
                            "(or give activation and evaluation)")
        return point
    try:
        values = [float(v) for v in emotion]
    except (TypeError, ValueError):
        raise UserError(f"an emotion is a word or (activation, evaluation[, power]), not {emotion!r}") from None
    if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
        raise UserError(f"an emotion point needs 2 or 3 finite numbers (activation, evaluation[, power]), "
                        f"not {emotion!r}")
    return EmotionPoint(*values)


def parse_emotion(text: str | None):
    """``None``, a word of the emotion table (``"joy"``) or ``"activation,evaluation[,power]"`` (``"50,-20"``),
    checked (an unknown word or a bad point is a :class:`UserError` naming the choices)."""
    if text is None or not str(text).strip():
        return None
    text = str(text).strip()
    if any(ch.isdigit() for ch in text) and "," in text:
        try:
            values = tuple(float(v) for v in text.split(","))
        except ValueError:
            raise UserError(f"--emotion {text!r}: give a word or activation,evaluation (two numbers)") from None
        emotion_point(values)
        return values
    emotion_point(text)
    return text.lower()
