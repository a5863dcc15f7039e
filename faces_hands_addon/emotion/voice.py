# SPDX-License-Identifier: GPL-3.0-or-later
"""Emotions in the voice: the emotion dimension prosody rules of thesis 4.4.2, Table 4.5 (Schröder's rules
in the MARY text-to-speech system), turned into espeak-ng settings.

Each row of Table 4.5 is linear in the dimensions: the change of a prosodic parameter from its neutral
value is ``c_A * activation + c_E * evaluation + c_P * power`` percent (4.4.2: "the value 0.5% linking
activation to rate means that for an activation level of +50, rate increases by +25%"). The printed table
shows the coefficients of pitch (0.3, 0.1, -0.1) and range (0.4) without a percent sign; they are read,
like every other row, as percent per unit. Two rows are categorical: the preferred accent shape follows
evaluation, the preferred boundary type power.

espeak-ng takes a rate in words per minute, a base pitch and a pitch range on its 0..100 scales (50 is the
voice's own) and a volume in percent (:func:`..speech.tts.synthesize` takes rate, pitch and volume; the
range is the espeak-ng parameter of the same name). Rate, range and volume scale linearly with their
percent change; espeak's pitch scale is close to logarithmic in F0 and near its default one unit moves
the base pitch by about one percent, so a pitch change of p % becomes ``p * PITCH_UNITS_PER_PERCENT`` units.
Pauses and segment durations have no espeak-ng parameter; they are returned as factors for the caller.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ..speech.espeak import PITCH_RANGE, RATE_RANGE, VOLUME_RANGE
from .words import EmotionPoint, emotion_point

__all__ = ["TABLE_4_5", "NEUTRAL", "PITCH_UNITS_PER_PERCENT", "VoiceSettings", "prosody_changes", "voice_for",
           "accent_shape", "boundary_type"]

# Table 4.5: percent change per unit of (activation, evaluation, power)
TABLE_4_5 = {
    "pitch": (0.3, 0.1, -0.1),
    "pitch-dynamics": (0.3, 0.0, -0.3),
    "range": (0.4, 0.0, 0.0),
    "range-dynamics": (1.2, 0.0, 0.4),
    "accent-prominence": (0.5, -0.5, 0.0),
    "accent-slope": (1.0, -0.5, 0.0),
    "rate": (0.5, 0.2, 0.0),
    "number-of-pauses": (0.7, 0.0, 0.0),
    "pause-duration": (-0.2, 0.0, 0.0),
    "vowel-duration": (0.0, 0.3, 0.3),
    "nasal-duration": (0.0, 0.3, 0.3),
    "liquid-duration": (0.0, 0.3, 0.3),
    "plosive-duration": (0.5, -0.3, 0.0),
    "fricative-duration": (0.5, -0.3, 0.0),
    "volume": (0.33, 0.0, 0.0),
}
# the neutral voice: the defaults of speech.tts.synthesize and espeak-ng's own range
NEUTRAL = {"rate": 175.0, "pitch": 50.0, "range": 50.0, "volume": 100.0}
RANGE_RANGE = (0, 100)
PITCH_UNITS_PER_PERCENT = 1.0
DURATIONS = ("vowel", "nasal", "liquid", "plosive", "fricative")


@dataclass(frozen=True)
class VoiceSettings:
    """espeak-ng settings for an emotion (Table 4.5): ``rate`` words per minute, ``pitch`` and ``range`` on
    espeak's 0..100 scales, ``volume`` percent; ``pause_count`` / ``pause_duration`` and ``durations``
    (segment class -> factor) are factors on the neutral values; ``accent_shape`` and ``boundary_type`` the
    categorical rows; ``changes`` every row's percent change."""

    rate: float
    pitch: float
    range: float
    volume: float
    pause_count: float
    pause_duration: float
    durations: dict[str, float] = field(default_factory=dict)
    accent_shape: str = "rising"
    boundary_type: str = "high"
    changes: dict[str, float] = field(default_factory=dict)

    def synthesize_kwargs(self) -> dict[str, float]:
        """The arguments :func:`faces_hands_addon.speech.synthesize` takes (rate, pitch, volume)."""
        return {"rate": self.rate, "pitch": self.pitch, "volume": self.volume}


def prosody_changes(activation: float, evaluation: float, power: float) -> dict[str, float]:
    """Percent change of every Table 4.5 parameter from neutral: sum of coefficient times dimension."""
    return {name: ca * activation + ce * evaluation + cp * power
            for name, (ca, ce, cp) in TABLE_4_5.items()}


def accent_shape(evaluation: float) -> str:
    """Table 4.5 preferred-accent-shape: E <= -20 falling, -20 < E <= 40 rising, E > 40 alternating."""
    if evaluation <= -20.0:
        return "falling"
    return "rising" if evaluation <= 40.0 else "alternating"


def boundary_type(power: float) -> str:
    """Table 4.5 preferred-boundary-type: P <= 0 high, P > 0 low."""
    return "high" if power <= 0.0 else "low"


def _clip(value: float, bounds: tuple[float, float]) -> float:
    return float(min(max(value, bounds[0]), bounds[1]))


def voice_for(emotion, neutral: dict[str, float] | None = None) -> VoiceSettings:
    """espeak-ng settings for ``emotion`` (a word of the table, an (activation, evaluation[, power]) point
    or an EmotionPoint) by the rules of Table 4.5, around ``neutral`` (default :data:`NEUTRAL`), clipped
    to espeak-ng's ranges."""
    point: EmotionPoint = emotion_point(emotion)
    base = dict(NEUTRAL, **(neutral or {}))
    changes = prosody_changes(point.activation, point.evaluation, point.power)
    return VoiceSettings(
        rate=_clip(base["rate"] * (1.0 + changes["rate"] / 100.0), RATE_RANGE),
        pitch=_clip(base["pitch"] + PITCH_UNITS_PER_PERCENT * changes["pitch"], PITCH_RANGE),
        range=_clip(base["range"] * (1.0 + changes["range"] / 100.0), RANGE_RANGE),
        volume=_clip(base["volume"] * (1.0 + changes["volume"] / 100.0), VOLUME_RANGE),
        pause_count=max(0.0, 1.0 + changes["number-of-pauses"] / 100.0),
        pause_duration=max(0.0, 1.0 + changes["pause-duration"] / 100.0),
        durations={k: max(0.0, 1.0 + changes[f"{k}-duration"] / 100.0) for k in DURATIONS},
        accent_shape=accent_shape(point.evaluation),
        boundary_type=boundary_type(point.power),
        changes=changes,
    )
