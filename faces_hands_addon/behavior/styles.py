# SPDX-License-Identifier: GPL-3.0-or-later
"""Character styles (thesis 4.2.2 Results): "by specifying weights and frequencies for the movements of
head, eyes, and eyebrows, different synthetic characters can be designed that exhibit different ways of
visually accentuating their speech" -- some people underline by eyebrow movement, some by nodding.

A style is a flat set of numbers (probabilities, amplitudes, durations) read from the editable preset
``presets/behavior/styles.json``. ``neutral`` carries the thesis' own numbers (4.2.1, 4.3.5); every other
style lists only what it changes and takes the rest from ``neutral``.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Mapping

from ..core.errors import UserError
from ..core.presets import NUMBER, PresetFormat, read_preset, register_format

__all__ = ["CharacterStyle", "STYLES_FORMAT", "STYLES_PRESET", "load_styles", "load_style", "style_names"]

STYLES_FORMAT = register_format(PresetFormat(
    "faces_hands.behavior_styles", 1, shape={"about": str, "styles": {str: {str: NUMBER}}},
    required=("styles",)))
STYLES_PRESET = "behavior/styles.json"


@dataclass(frozen=True)
class CharacterStyle:
    """Weights and frequencies of the speech-related non-verbal behaviour (4.2.2). Defaults are the thesis'
    numbers; see ``presets/behavior/styles.json`` for the meaning and units of each field."""

    name: str = "neutral"
    # blinks (4.2.1 "Punctuators and Manipulators", 4.3.5 "Eye blinks")
    blink_interval_s: float = 4.8
    blink_close_s: float = 1.0 / 8.0
    blink_apex_s: float = 1.0 / 24.0
    blink_open_s: float = 1.0 / 12.0
    blink_pause_probability: float = 1.0
    blink_min_pause_s: float = 0.1
    # pitch-linked head and brows (4.2.1 "Facial Expressions from Pitch", 4.3.5 "Expressions linked to
    # intonation")
    pitch_threshold_st: float = 1.0
    head_raise_probability: float = 1.0
    head_raise_max_deg: float = 3.0
    head_tilt_probability: float = 0.75
    head_tilt_max_deg: float = 2.0
    brow_raise_probability: float = 0.71
    brow_raise_left: float = 0.45
    brow_raise_right: float = 0.3
    # gaze at accents and phrase boundaries (4.3.5 "Expressions linked to intonation", "Regulators")
    accent_glance_probability: float = 0.7
    phrase_glance_probability: float = 0.7
    glance_hold_s: float = 0.25
    # questions (4.3.5 "Questions")
    question_brow: float = 0.45
    question_head_deg: float = 3.0
    # thinking and word search (4.2.1 "Thinking and Word Search", 4.3.5 "Word search")
    thinking_pause_s: float = 0.6
    thinking_frown_probability: float = 0.25
    thinking_look_up: float = 0.45
    thinking_look_down: float = 0.4
    thinking_right: float = 0.2
    thinking_brow: float = 0.4
    thinking_frown: float = 0.3
    thinking_head_deg: float = 1.5
    # regulators and gaze (4.3.5 "Regulators", "Gaze"; 4.2.1 "Random Eye Movement")
    avert_yaw: float = 0.22
    avert_pitch: float = 0.06
    speaker_state_turn_deg: float = 5.0
    gaze_jitter: float = 0.07
    gaze_jitter_step: float = 0.045
    gaze_jitter_min_s: float = 0.35
    gaze_jitter_max_s: float = 0.9
    saccade_s: float = 0.05
    lid_follow: float = 0.2
    lid_head: float = 0.15
    # lip moistening (4.2.1 "Punctuators and Manipulators"; no numbers in the thesis, see behavior/moisten.py)
    lick_interval_s: float = 15.0
    lick_jitter: float = 0.25
    lick_min_pause_s: float = 0.3
    lick_s: float = 0.35
    lick_thinking_s: float = 0.8
    lick_jaw: float = 0.12
    lick_tongue: float = 0.4
    lick_tip: float = 0.6

    @classmethod
    def from_values(cls, name: str, values: Mapping[str, float], base: "CharacterStyle | None" = None,
                    source: str = "style") -> "CharacterStyle":
        """``base`` (default: the thesis numbers) with ``values`` replaced; unknown keys and values out of
        range raise a :class:`UserError`."""
        known = {f.name for f in fields(cls)} - {"name"}
        unknown = sorted(set(values) - known)
        if unknown:
            raise UserError(f"{source}: style {name!r} has unknown key {unknown[0]!r}; "
                            f"known keys: {', '.join(sorted(known))}")
        style = replace(base or cls(), name=name, **{k: float(v) for k, v in values.items()})
        style.check(source)
        return style

    def check(self, source: str = "style") -> None:
        """Probabilities in [0, 1], durations and amplitudes not negative, control values at most 1."""
        for f in fields(self):
            if f.name == "name":
                continue
            value = getattr(self, f.name)
            if value < 0:
                raise UserError(f"{source}: style {self.name!r}: {f.name} must not be negative, got {value}")
            if (f.name.endswith("probability") or f.name.startswith(("brow_", "question_brow", "thinking_b",
                                                                     "thinking_f", "lid_", "lick_jaw", "lick_tongue", "lick_tip", "lick_jitter"))) and value > 1:
                raise UserError(f"{source}: style {self.name!r}: {f.name} must be at most 1, got {value}")
        for f in ("blink_interval_s", "blink_close_s", "blink_apex_s", "blink_open_s", "saccade_s",
                  "gaze_jitter_min_s", "lick_s", "lick_thinking_s", "lick_interval_s"):
            if getattr(self, f) <= 0:
                raise UserError(f"{source}: style {self.name!r}: {f} must be positive")
        if self.gaze_jitter_max_s < self.gaze_jitter_min_s:
            raise UserError(f"{source}: style {self.name!r}: gaze_jitter_max_s must not be below gaze_jitter_min_s")
        if self.blink_interval_s <= self.blink_close_s + self.blink_apex_s + self.blink_open_s:
            raise UserError(f"{source}: style {self.name!r}: blink_interval_s must be longer than one blink")


def load_styles() -> dict[str, CharacterStyle]:
    """Every style of ``presets/behavior/styles.json`` (the artist's copy in the user folder wins)."""
    doc, source = read_preset(STYLES_PRESET, STYLES_FORMAT.name)
    raw = doc["styles"]
    if "neutral" not in raw:
        raise UserError(f"{source}: the styles need a \"neutral\" entry (the base of every other style)")
    neutral = CharacterStyle.from_values("neutral", raw["neutral"], source=source)
    styles = {"neutral": neutral}
    for name, values in raw.items():
        if name != "neutral":
            styles[name] = CharacterStyle.from_values(name, values, neutral, source)
    return styles


def style_names() -> list[str]:
    return list(load_styles())


def load_style(style: "str | CharacterStyle | Mapping[str, float]" = "neutral") -> CharacterStyle:
    """A style by name from the preset, a :class:`CharacterStyle` as it is, or a mapping of overrides
    applied to ``neutral``."""
    if isinstance(style, CharacterStyle):
        style.check()
        return style
    styles = load_styles()
    if isinstance(style, Mapping):
        return CharacterStyle.from_values("custom", style, styles["neutral"])
    if style not in styles:
        raise UserError(f"unknown character style {style!r}; choose one of {', '.join(styles)}")
    return styles[style]
