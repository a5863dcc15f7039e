# SPDX-License-Identifier: GPL-3.0-or-later
"""Facial expressions for any emotion from six basic ones (thesis 4.4.3, Eqs. 4.6-4.10, Table 4.6).

The basic expressions (``presets/emotion/basic_expressions.json``) are control values of the face rig for
joy, anger, fear, hate, sorry-for and surprise, each placed on the activation-evaluation disk at its word's
angle ``omega_E`` and radius ``r_E`` (:mod:`.words`). A new emotion at (``omega``, ``r``):

* at the angle of a basic emotion E it is E scaled by the ratio of the radii (Eqs. 4.6, 4.7):
  ``v_new(m) = r / r_E * v_E(m)`` for every control ``m`` of E;
* otherwise it mixes the two basic emotions E1, E2 next to it on the disk (``omega_E1 < omega < omega_E2``),
  both first scaled to its radius: ``v'_i(m) = r / r_Ei * v_Ei(m)``. A control without antagonist is
  interpolated by angle (Eq. 4.9); a muscle with antagonists (Table 4.6) gets the net contraction of its
  class, ``S+ - S-`` (Eq. 4.10), shared in proportion to ``v'_1(m) + v'_2(m)``, or 0 when the antagonists
  are stronger. Controls absent from one expression count as 0 there (which, as the thesis notes, makes
  Eqs. 4.4 and 4.5 unnecessary).

Eq. 4.10 as printed sums the two scaled expressions without the angular weights of Eq. 4.9; it is
implemented as printed. Results are clamped to the controls' ranges (a radius beyond the basic one can
push a contraction past 1).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

from ..core.controls import ControlSpec, clamp_controls
from ..core.errors import UserError
from ..core.presets import NUMBER, PresetFormat, read_preset, register_format
from ..face.controls import control_specs
from ..face.muscle_layout import FORMAT as MUSCLE_FORMAT
from .words import EmotionPoint, emotion_point, load_words

__all__ = ["FORMAT", "BasicExpression", "EmotionModel", "load_model", "face_specs", "scaled_expression",
           "mixed_expression", "expression_for", "ANGLE_TOLERANCE"]

FORMAT = register_format(PresetFormat(
    "faces_hands.emotion_expressions", 1, required=("basic", "antagonists"),
    shape={"about": str,
           "basic": {str: {"label": str, "facs": str, "controls": {str: NUMBER}}},
           "antagonists": [[[str]]],
           "tags": {str: {"word": str, "wink": {"control": str, "value": NUMBER, "close": NUMBER,
                                                "hold": NUMBER, "open": NUMBER}}}}))
ANGLE_TOLERANCE = 1e-6  # degrees: closer to a basic emotion's angle than this is "at" it (Eqs. 4.6, 4.7)


@dataclass(frozen=True)
class BasicExpression:
    """A basic expression e of emotion E (4.4.3): its word, angle omega_E, radius r_E and control values."""

    word: str
    label: str
    facs: str
    point: EmotionPoint
    controls: dict[str, float]

    @property
    def angle(self) -> float:
        return self.point.angle

    @property
    def radius(self) -> float:
        return self.point.radius


@dataclass(frozen=True)
class EmotionModel:
    """Everything 4.4.3 needs: the basic expressions sorted by angle, the antagonist classes (Table 4.6:
    ``same[m]`` = A+(m), ``opposite[m]`` = A-(m)), the emotion words, the rig's control specs and the
    emoticon tags (Table 4.1 emotion -> word, optional wink)."""

    basics: tuple[BasicExpression, ...]
    same: dict[str, tuple[str, ...]]
    opposite: dict[str, tuple[str, ...]]
    words: dict[str, EmotionPoint]
    specs: dict[str, ControlSpec]
    tags: dict[str, dict]


def face_specs() -> dict[str, ControlSpec]:
    """The face rig's control specs (muscles of ``presets/face/muscles.json`` with their mirrored ``_L``
    twins, then the direct parameters), read without building a rig."""
    doc, _ = read_preset("face/muscles.json", MUSCLE_FORMAT.name)
    names: list[str] = []
    for entry in doc["muscles"]:
        names.append(str(entry["name"]))
        if entry.get("mirror") and names[-1].endswith("_R"):
            names.append(names[-1][:-2] + "_L")
    return control_specs(names)


def _antagonists(source: str, pairs: list, specs: Mapping[str, ControlSpec]):
    same: dict[str, tuple[str, ...]] = {}
    opposite: dict[str, tuple[str, ...]] = {}
    for pair in pairs:
        if len(pair) != 2 or not pair[0] or not pair[1]:
            raise UserError(f"{source}: every antagonist entry is [[muscles], [their antagonists]] (Table 4.6)")
        plus, minus = tuple(pair[0]), tuple(pair[1])
        for name in plus + minus:
            if name not in specs or specs[name].kind != "muscle":
                raise UserError(f"{source}: antagonist {name!r} is not a muscle of the face rig")
            if name in same:
                raise UserError(f"{source}: muscle {name!r} is in two antagonist classes")
        for name in plus:
            same[name], opposite[name] = plus, minus
        for name in minus:
            same[name], opposite[name] = minus, plus
    return same, opposite


def _tags(source: str, tags: dict, words: Mapping[str, EmotionPoint], specs) -> dict[str, dict]:
    for emotion, entry in tags.items():
        if entry.get("word") not in words:
            raise UserError(f"{source}: tag {emotion!r} names the unknown emotion word {entry.get('word')!r}")
        wink = entry.get("wink")
        if wink is not None:
            if wink.get("control") not in specs or any(float(wink.get(k, -1)) < 0 for k in ("close", "hold", "open")):
                raise UserError(f"{source}: tag {emotion!r}: the wink needs a rig control and non-negative "
                                "close, hold and open times in seconds")
    return {str(k): dict(v) for k, v in tags.items()}


def load_model() -> EmotionModel:
    """The emotion model from the presets (the user's copies if there are any), checked against the rig:
    every control named exists, every basic word is an emotion word at a distinct angle off the centre."""
    words = load_words()
    specs = face_specs()
    doc, source = read_preset("emotion/basic_expressions.json", FORMAT.name)
    basics = []
    for word, entry in doc["basic"].items():
        if word not in words or words[word].radius == 0.0:
            raise UserError(f"{source}: basic expression {word!r} must be an emotion word off the neutral centre")
        controls = {str(k): float(v) for k, v in entry["controls"].items()}
        unknown = [name for name in controls if name not in specs]
        if unknown:
            raise UserError(f"{source}: basic expression {word!r}: {unknown[0]!r} is not a face control")
        basics.append(BasicExpression(str(word), str(entry.get("label", word)), str(entry.get("facs", "")),
                                      words[word], clamp_controls(controls, specs)))
    if len(basics) < 2:
        raise UserError(f"{source}: the emotion disk needs at least two basic expressions")
    basics.sort(key=lambda b: b.angle)
    for first, second in zip(basics, basics[1:]):
        if second.angle - first.angle <= ANGLE_TOLERANCE:
            raise UserError(f"{source}: basic expressions {first.word!r} and {second.word!r} share one angle")
    same, opposite = _antagonists(source, doc["antagonists"], specs)
    tags = _tags(source, doc.get("tags") or {}, words, specs)
    return EmotionModel(tuple(basics), same, opposite, words, specs, tags)


def scaled_expression(basic: BasicExpression, radius: float) -> dict[str, float]:
    """Eqs. 4.6, 4.7: M_new = M_e and v_new(m) = r_new / r_E * v_e(m) (not yet clamped)."""
    ratio = float(radius) / basic.radius
    return {name: ratio * value for name, value in basic.controls.items()}


def mixed_expression(first: BasicExpression, second: BasicExpression, angle: float, radius: float,
                     same: Mapping[str, tuple[str, ...]], opposite: Mapping[str, tuple[str, ...]]
                     ) -> dict[str, float]:
    """Eqs. 4.8-4.10 for an emotion at ``angle`` (degrees, ``first.angle <= angle <= second.angle`` after
    unwrapping) and ``radius`` between the basic expressions ``first`` (E1) and ``second`` (E2); not yet
    clamped. ``same``/``opposite`` give A+(m) and A-(m) of Table 4.6 (muscles without antagonists are absent)."""
    span = second.angle - first.angle
    if span <= 0.0:
        span += 360.0
    offset = (angle - first.angle) % 360.0
    w2 = offset / span                       # (omega_new - omega_E1) / (omega_E2 - omega_E1)
    w1 = 1.0 - w2                            # (omega_E2 - omega_new) / (omega_E2 - omega_E1)
    k1, k2 = radius / first.radius, radius / second.radius
    v1 = {m: k1 * v for m, v in first.controls.items()}     # v'_e1
    v2 = {m: k2 * v for m, v in second.controls.items()}    # v'_e2
    controls = list(dict.fromkeys(list(first.controls) + list(second.controls)))   # Eq. 4.8
    out: dict[str, float] = {}
    for m in controls:
        if not opposite.get(m):                                           # Eq. 4.9
            out[m] = w2 * v2.get(m, 0.0) + w1 * v1.get(m, 0.0)
            continue
        s_plus = sum(v1.get(n, 0.0) + v2.get(n, 0.0) for n in same[m])       # Eq. 4.10
        s_minus = sum(v1.get(n, 0.0) + v2.get(n, 0.0) for n in opposite[m])
        own = v1.get(m, 0.0) + v2.get(m, 0.0)
        out[m] = 0.0 if s_plus <= s_minus else (s_plus - s_minus) / s_plus * own
    return out


def _neighbours(basics: tuple[BasicExpression, ...], angle: float):
    """(E, None) when ``angle`` is at basic emotion E's angle, else (E1, E2): the basic emotions on either
    side of ``angle`` going round the disk (4.4.3: "neighbors on the emotion wheel")."""
    for basic in basics:
        gap = abs((angle - basic.angle + 180.0) % 360.0 - 180.0)
        if gap <= ANGLE_TOLERANCE:
            return basic, None
    for first, second in zip(basics, basics[1:] + basics[:1]):
        span = (second.angle - first.angle) % 360.0 or 360.0
        if (angle - first.angle) % 360.0 < span:
            return first, second
    raise AssertionError("the basic emotions cover the whole disk")


def expression_for(emotion, model: EmotionModel | None = None) -> dict[str, float]:
    """Control values of the face for ``emotion``: a word of the table (``"anxiety"``), an
    ``(activation, evaluation[, power])`` point or an :class:`EmotionPoint` (4.4.3, Eqs. 4.6-4.10).
    Returns the controls of M_new, clamped to their ranges; the neutral centre gives ``{}``."""
    model = load_model() if model is None else model
    point = emotion_point(emotion, model.words)
    angle, radius = point.angle, point.radius
    if radius == 0.0:
        return {}
    first, second = _neighbours(model.basics, angle)
    if second is None:
        values = scaled_expression(first, radius)
    else:
        values = mixed_expression(first, second, angle, radius, model.same, model.opposite)
    if not all(math.isfinite(v) for v in values.values()):
        raise UserError(f"the expression of {emotion!r} is not finite; check the basic expressions preset")
    return clamp_controls(values, model.specs)
