# SPDX-License-Identifier: GPL-3.0-or-later
"""Non-verbal speech-related behaviour from an utterance (thesis 4.3.5, with the timing of 4.2.1): the
``behavior`` layer's curves and the list of what was decided.

:func:`generate_behavior` runs the rules of :mod:`.rules` and :mod:`.gaze` with one seeded
``numpy.random.Generator`` per rule (children of ``SeedSequence(seed)``, so the same seed gives the same
bytes and one rule's draws do not shift another's), then renders their events into a
:class:`~faces_hands_addon.anim.TrackSet` for the ``behavior`` layer (:data:`anim.layers.LAYERS`): the
face rig's controls (brows, frown, lids, gaze) and the head channels ``head.pitch/yaw/roll`` (radians;
the face rig has no head controls). All tracks share one time axis: a uniform grid at ``rate`` Hz plus
every key time of every event, so a blink's phases are exact keys.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ..anim.tracks import Track, TrackSet
from ..core.controls import ControlSpec
from ..core.errors import UserError
from .events import CHANNEL_CONTROLS, COMBINE, BehaviorEvent, channel_specs, sample_envelope
from .gaze import gaze_curves, jitter_events, lid_follow
from .moisten import lick_events
from .prosody import phone_boundaries, utterance_extrema
from .rules import (Context, accent_events, blink_events, pitch_events, question_events, regulator_events,
                    thinking_events)
from .styles import CharacterStyle, load_style

__all__ = ["BehaviorResult", "generate_behavior", "RULES"]

RULES = ("blinks", "pitch", "accents", "thinking", "regulators", "jitter", "moisten")


@dataclass
class BehaviorResult:
    """The ``behavior`` layer's ``tracks``, the ``events`` in time order, the ``style`` and ``seed`` used,
    and the :class:`ControlSpec` of every track (``specs``)."""

    tracks: TrackSet
    events: list[BehaviorEvent]
    style: CharacterStyle
    seed: int
    specs: Mapping[str, ControlSpec]

    def of_kind(self, kind: str) -> list[BehaviorEvent]:
        return [e for e in self.events if e.kind == kind]

    def count(self, kind: str) -> int:
        return len(self.of_kind(kind))

    def layer_values(self, time: float) -> dict[str, float]:
        """The face controls' behaviour-layer values at ``time`` (head channels left out: no face control)."""
        return {t.name: float(t.sample(time)) for t in self.tracks if not t.name.startswith("head.")}


def _context(utterance, style: CharacterStyle) -> Context:
    accents = np.array([(s.start, s.end) for s in utterance.accented_syllables], dtype=np.float64).reshape(-1, 2)
    return Context(utterance, style, phone_boundaries(utterance), accents)


def _events(ctx: Context, seed: int) -> list[BehaviorEvent]:
    rngs = dict(zip(RULES, (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(len(RULES)))))
    extrema = utterance_extrema(ctx.utterance, ctx.style.pitch_threshold_st)
    thinking = thinking_events(ctx, rngs["thinking"])
    events = (blink_events(ctx, rngs["blinks"]) + pitch_events(ctx, extrema, rngs["pitch"])
              + accent_events(ctx, rngs["accents"]) + question_events(ctx) + thinking
              + regulator_events(ctx, rngs["regulators"], thinking) + jitter_events(ctx, rngs["jitter"])
              + lick_events(ctx, rngs["moisten"], thinking))
    order = sorted(range(len(events)), key=lambda k: (events[k].start, events[k].kind, k))
    return [events[k] for k in order]


def _grid(ctx: Context, events: list[BehaviorEvent], rate: float) -> np.ndarray:
    uniform = np.arange(int(np.ceil(ctx.duration * rate)) + 1) / rate
    keys = [np.asarray(times) for e in events for times, _ in e.keys.values()]
    grid = np.concatenate([uniform, *keys]) if keys else uniform
    grid = np.unique(np.round(grid[(grid >= 0.0) & (grid <= ctx.duration + 1e-9)], 9))
    # drop keys closer than a microsecond to the one before (rounding twins)
    return grid[np.concatenate([[True], np.diff(grid) > 1e-6])]


def _channels(events: list[BehaviorEvent], grid: np.ndarray) -> dict[str, np.ndarray]:
    """Every abstract channel on ``grid``, overlapping events combined as :data:`.events.COMBINE` says
    (``max``: the value of larger magnitude, ``sum``). Each event is read only over its own span (it is 0
    outside), into running arrays: memory O(grid), not O(events x grid) (a 10-minute take has thousands)."""
    out = {}
    for channel, mode in COMBINE.items():
        high, low, total = np.zeros_like(grid), np.zeros_like(grid), np.zeros_like(grid)
        for e in events:
            if channel not in e.keys:
                continue
            times = e.keys[channel][0]
            a, b = np.searchsorted(grid, times[0], "left"), np.searchsorted(grid, times[-1], "right")
            if a >= b:
                continue
            piece = sample_envelope(grid[a:b], e.keys[channel])
            if mode == "max":
                np.maximum(high[a:b], piece, out=high[a:b])
                np.minimum(low[a:b], piece, out=low[a:b])
            else:
                total[a:b] += piece
        out[channel] = np.where(np.abs(high) >= np.abs(low), high, low) if mode == "max" else total
    return out


def _render(ctx: Context, events: list[BehaviorEvent], rate: float) -> tuple[TrackSet, dict[str, ControlSpec]]:
    specs = channel_specs()
    grid = _grid(ctx, events, rate)
    channels = _channels(events, grid)
    gaze_times, eye_yaw, eye_pitch = gaze_curves(ctx, events, rate)
    eye_yaw, eye_pitch = np.interp(grid, gaze_times, eye_yaw), np.interp(grid, gaze_times, eye_pitch)
    channels["lids"] = channels["lids"] + lid_follow(ctx, eye_pitch, channels["head.pitch"])
    values: dict[str, np.ndarray] = {}
    for channel, pairs in CHANNEL_CONTROLS.items():
        for control, weight in pairs:
            values[control] = values.get(control, 0.0) + weight * channels[channel]
    values["eye_yaw"], values["eye_pitch"] = eye_yaw, eye_pitch
    tracks = TrackSet()
    for name in specs:
        spec = specs[name]
        tracks.add(Track(name, grid, np.clip(values[name], spec.minimum, spec.maximum)))
    return tracks, specs


def generate_behavior(utterance, style: "str | CharacterStyle | Mapping[str, float]" = "neutral", seed: int = 0,
                      rate: float = 100.0, lids_busy: "Sequence[tuple[float, float]]" = ()) -> BehaviorResult:
    """The non-verbal behaviour of ``utterance`` (a :class:`~faces_hands_addon.speech.Utterance`) in character
    ``style`` (a name from ``presets/behavior/styles.json``, a :class:`CharacterStyle` or overrides of
    ``neutral``), every random choice drawn from generators seeded by ``seed``; curves sampled at ``rate``
    Hz plus the events' own key times (module docstring). ``lids_busy``: (start, end) intervals in which
    something else closes the lids (the wink of ";-)", 4.3.5): a blink overlapping one is left out, so the
    wink is not drowned by a blink of both eyes (the wink's closure takes the blink's place)."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise UserError(f"the behaviour seed must be a whole number >= 0, got {seed!r}")
    if not np.isfinite(rate) or rate <= 0 or rate > 1000:
        raise UserError(f"the behaviour sampling rate must be in (0, 1000] Hz, got {rate!r}")
    if utterance.duration <= 0:
        raise UserError("the utterance has no audio; synthesise or load speech first")
    resolved = load_style(style)
    ctx = _context(utterance, resolved)
    events = _events(ctx, int(seed))
    busy = [(float(a), float(b)) for a, b in lids_busy]
    events = [e for e in events if e.kind != "blink" or not any(e.start < b and e.end > a for a, b in busy)]
    tracks, specs = _render(ctx, events, float(rate))
    return BehaviorResult(tracks, events, resolved, int(seed), specs)
