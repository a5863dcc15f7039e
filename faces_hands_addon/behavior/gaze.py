# SPDX-License-Identifier: GPL-3.0-or-later
"""Gaze: the fixations the rules ask for, random eye movement on top, and the lids that follow.

4.2.1 "Random Eye Movement" / 4.3.5 "Gaze": kept completely still, the eyes give "the awkward impression of
a dead stare", so the view direction varies randomly within a small range; consecutive positions must not
differ too much ("otherwise the movement seems erratic"). Each new jitter offset is drawn uniformly within
``gaze_jitter_step`` of the previous one per axis, and within ``gaze_jitter`` of the fixation; offsets change
every ``gaze_jitter_min_s..gaze_jitter_max_s`` seconds, never inside an accented syllable.

The eyelids accompany vertical eye movement: looking down closes them a little, looking up opens them
(the face rig's lids already rotate with ``eye_pitch``; the behaviour layer adds ``lid_follow`` times the
downward gaze as closure, since ``eyelid_close`` cannot open past its rest). The head term of 4.3.5 -- head
tilted down, lids open wider for a straight view, and vice versa -- adds ``lid_head`` closure per 3 deg of
head raise.
"""
from __future__ import annotations

import math

import numpy as np

from .events import BehaviorEvent
from .rules import Context

__all__ = ["jitter_events", "gaze_curves", "lid_follow"]


def jitter_events(ctx: Context, rng: np.random.Generator) -> list[BehaviorEvent]:
    """The random eye movements (module docstring) as ``gaze_jitter`` events with their offsets."""
    style = ctx.style
    events: list[BehaviorEvent] = []
    if style.gaze_jitter <= 0 or ctx.duration <= 0:
        return events
    offset = np.zeros(2)
    time = 0.0
    while True:
        time = ctx.clear_of_accents(time + rng.uniform(style.gaze_jitter_min_s, style.gaze_jitter_max_s))
        if time >= ctx.duration:
            break
        low = np.maximum(offset - style.gaze_jitter_step, -style.gaze_jitter)
        high = np.minimum(offset + style.gaze_jitter_step, style.gaze_jitter)
        offset = rng.uniform(low, high)
        if events:
            previous = events[-1]
            events[-1] = BehaviorEvent(previous.kind, previous.start, time, previous.params)
        events.append(BehaviorEvent("gaze_jitter", time, ctx.duration, {"yaw": float(offset[0]),
                                                                         "pitch": float(offset[1])}))
    return events


def _ramp(values: np.ndarray, width: int) -> np.ndarray:
    """Trailing moving average over ``width`` samples: a fixation change at a sample becomes a linear ramp
    over the following ``width`` samples (it never starts before the change)."""
    if width <= 1:
        return values
    padded = np.concatenate([np.full(width - 1, values[0]), values])
    total = np.cumsum(np.concatenate([[0.0], padded]))
    return (total[width:] - total[:-width]) / width


def gaze_curves(ctx: Context, events: list[BehaviorEvent], rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times, eye_yaw, eye_pitch) on a uniform grid at ``rate`` Hz: at every instant the fixation of the
    highest priority (the later one among equals; the listener, straight ahead, where none holds), each
    change a ramp of ``saccade_s``, plus the jitter."""
    n = int(math.ceil(ctx.duration * rate)) + 1
    grid = np.arange(n) / rate
    yaw, pitch = np.zeros(n), np.zeros(n)
    level = np.full(n, -1)
    fixations = [(e.gaze[2], k, e) for k, e in enumerate(events) if e.gaze is not None]
    for priority, _, event in sorted(fixations, key=lambda item: (item[0], item[1])):
        inside = (grid >= event.start) & (grid < event.end) & (level <= priority)
        yaw[inside], pitch[inside], level[inside] = event.gaze[0], event.gaze[1], priority
    jitter_yaw, jitter_pitch = np.zeros(n), np.zeros(n)
    for event in events:
        if event.kind == "gaze_jitter":
            inside = grid >= event.start
            jitter_yaw[inside], jitter_pitch[inside] = event.params["yaw"], event.params["pitch"]
    width = max(1, int(round(ctx.style.saccade_s * rate)))
    return grid, _ramp(yaw + jitter_yaw, width), _ramp(pitch + jitter_pitch, width)


def lid_follow(ctx: Context, eye_pitch: np.ndarray, head_pitch: np.ndarray) -> np.ndarray:
    """Extra lid closure from looking down and from a raised head (module docstring)."""
    return (ctx.style.lid_follow * np.maximum(-eye_pitch, 0.0)
            + ctx.style.lid_head * np.maximum(head_pitch, 0.0) / math.radians(3.0))
