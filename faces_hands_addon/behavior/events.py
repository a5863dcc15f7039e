# SPDX-License-Identifier: GPL-3.0-or-later
"""Discrete behaviour events and the channels they move.

A :class:`BehaviorEvent` is one decision of a rule (a blink, a head raise, a glance, a thinking pause...):
its ``kind``, ``start`` and ``end`` in seconds, the numbers it was drawn with (``params``), the
piecewise-linear envelopes it adds to *abstract channels* (``keys``) and, for gaze, the fixation it asks
for (``gaze``: eye_yaw, eye_pitch, priority). :func:`channel_specs` lists the rig controls the abstract
channels end up on.

Abstract channels and how overlapping events combine on them:

* ``head.pitch`` (+ raises the chin), ``head.yaw`` (+ turns to the character's left), ``head.roll``
  (+ tilts the top of the head to the character's left), radians. The face rig has no head controls
  (its controls are muscles, jaw, eyes, lids, tongue), so head rotation is emitted as these three
  named channels; pitch raises combine by their maximum (a raise during a raise does not add up),
  yaw and roll by their sum.
* ``brow_L`` / ``brow_R``: eyebrow raise, put on ``frontalis_inner_*`` and ``frontalis_outer_*``;
  maximum.
* ``frown``: put on ``corrugator_supercilii_L/R`` (and ``procerus`` at 60 %); maximum.
* ``lids``: eyelid closure, put on ``eyelid_close_L/R``; sum, then clamped to [0, 1].
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from ..core.controls import ControlSpec
from ..face.controls import DIRECT_CONTROLS, muscle_control

__all__ = ["BehaviorEvent", "envelope", "HEAD_CHANNELS", "CHANNEL_CONTROLS", "COMBINE", "channel_specs",
           "control_names"]

HEAD_LIMIT_RAD = 0.35
HEAD_CHANNELS = (
    ControlSpec("head.pitch", -HEAD_LIMIT_RAD, HEAD_LIMIT_RAD, 0.0, "head", "direct",
                "head rotation about the horizontal axis: + raises the chin (4.2.1: at most ~3 deg at a "
                "pitch maximum)", "rad"),
    ControlSpec("head.yaw", -HEAD_LIMIT_RAD, HEAD_LIMIT_RAD, 0.0, "head", "direct",
                "head turn about the vertical axis: + turns to the character's left", "rad"),
    ControlSpec("head.roll", -HEAD_LIMIT_RAD, HEAD_LIMIT_RAD, 0.0, "head", "direct",
                "sideways head tilt: + tilts the top of the head to the character's left", "rad"),
)

# abstract channel -> (rig control, weight)
CHANNEL_CONTROLS: dict[str, tuple[tuple[str, float], ...]] = {
    "head.pitch": (("head.pitch", 1.0),),
    "head.yaw": (("head.yaw", 1.0),),
    "head.roll": (("head.roll", 1.0),),
    "brow_L": (("frontalis_inner_L", 1.0), ("frontalis_outer_L", 1.0)),
    "brow_R": (("frontalis_inner_R", 1.0), ("frontalis_outer_R", 1.0)),
    "frown": (("corrugator_supercilii_L", 1.0), ("corrugator_supercilii_R", 1.0), ("procerus", 0.6)),
    "lids": (("eyelid_close_L", 1.0), ("eyelid_close_R", 1.0)),
    "lick_jaw": (("jaw_open", 1.0),),
    "tongue_out": (("tongue_out", 1.0),),
    "tongue_tip": (("tongue_tip_up", 1.0),),
}
COMBINE = {"head.pitch": "max", "head.yaw": "sum", "head.roll": "sum", "brow_L": "max", "brow_R": "max",
           "frown": "max", "lids": "sum", "lick_jaw": "max", "tongue_out": "max", "tongue_tip": "max"}
GAZE_CONTROLS = ("eye_yaw", "eye_pitch")


@dataclass(frozen=True)
class BehaviorEvent:
    """One rule decision (module docstring). ``keys[channel] = (times, values)``: an envelope that is 0
    outside ``times``; ``gaze = (eye_yaw, eye_pitch, priority)`` holds over ``start..end``."""

    kind: str
    start: float
    end: float
    params: Mapping[str, Any] = field(default_factory=dict)
    keys: Mapping[str, tuple[tuple[float, ...], tuple[float, ...]]] = field(default_factory=dict)
    gaze: tuple[float, float, int] | None = None

    @property
    def duration(self) -> float:
        return self.end - self.start


def envelope(points: list[tuple[float, float]], gap: float = 1e-4) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """A piecewise-linear envelope through ``points`` (time, value) with strictly increasing times: a point
    not later than the one before is pushed ``gap`` after it."""
    times: list[float] = []
    values: list[float] = []
    for t, v in points:
        t = float(t)
        if times and t <= times[-1]:
            t = times[-1] + gap
        times.append(t)
        values.append(float(v))
    return tuple(times), tuple(values)


def control_names() -> tuple[str, ...]:
    """Every control the behaviour layer writes, in a fixed order."""
    names: list[str] = []
    for pairs in CHANNEL_CONTROLS.values():
        names += [n for n, _ in pairs if n not in names]
    return tuple(names) + GAZE_CONTROLS


def channel_specs() -> dict[str, ControlSpec]:
    """The :class:`ControlSpec` of every control in :func:`control_names` (face controls from the face rig,
    the head channels from :data:`HEAD_CHANNELS`)."""
    direct = {c.name: c for c in DIRECT_CONTROLS}
    head = {c.name: c for c in HEAD_CHANNELS}
    return {n: head.get(n) or direct.get(n) or muscle_control(n) for n in control_names()}


def sample_envelope(grid: np.ndarray, keys: tuple[tuple[float, ...], tuple[float, ...]]) -> np.ndarray:
    """An envelope read on ``grid`` (0 outside its span)."""
    times, values = keys
    return np.interp(grid, np.asarray(times), np.asarray(values), left=0.0, right=0.0)
