# SPDX-License-Identifier: GPL-3.0-or-later
"""Lip moistening (thesis 4.2.1 "Punctuators and Manipulators": "the moistening of the lips during
extended speech periods ... lick its lips during pauses that match the average lip moistening frequency
best. During pauses where a thinking or word search expression is exhibited, the tongue motion should be
slower").

The face rig has a rigid tongue with three direct controls (3.1.2 "Eyes, Teeth, Tongue"; ``tongue_out``,
``tongue_tip_up``, ``tongue_back``) and no sideways tongue control, so a lick is: the jaw opens a little,
the tongue comes out to the lips with its tip raised (the upper lip), the tip drops (the lower lip), and
the tongue goes back in. The thesis gives no numbers for it; the style's ``lick_*`` fields do:

* a lick is due ``lick_interval_s`` (jittered by +-``lick_jitter``, one seeded draw per lick) after the
  start or the last lick, so only long speech gets one;
* of the suitable pauses (inner pauses: word, phrase, sentence, of at least ``lick_min_pause_s`` and
  long enough for a lick of ``lick_s``) that
  begin at least half an interval after the last lick, the one closest to the due time is taken (the
  thesis: "pauses that match the average lip moistening frequency best"); none is taken when the
  utterance ends before the next lick would be due;
* the lick lasts ``lick_s``, or ``lick_thinking_s`` (slower) in a thinking pause that is long enough,
  and starts ``_LEAD_S`` into the pause (after the blink that punctuates it has closed the lids).
"""
from __future__ import annotations

import numpy as np

from .events import BehaviorEvent, envelope

__all__ = ["lick_events"]

_LEAD_S = 0.08              # from the pause's start to the lick's (s)
_TAIL_S = 0.05              # the lick ends at least this long before the pause does (s)


def _lick_keys(start: float, duration: float, style) -> dict:
    """Jaw a little open, tongue out with the tip up (upper lip) then down (lower lip), tongue in."""
    at = [start + f * duration for f in (0.0, 0.2, 0.35, 0.55, 0.75, 0.9, 1.0)]
    jaw = envelope([(at[0], 0.0), (at[1], style.lick_jaw), (at[5], style.lick_jaw), (at[6], 0.0)])
    out = envelope([(at[0], 0.0), (at[2], style.lick_tongue), (at[4], style.lick_tongue), (at[6], 0.0)])
    tip = envelope([(at[0], 0.0), (at[2], style.lick_tip), (at[3], style.lick_tip), (at[4], 0.0)])
    return {"lick_jaw": jaw, "tongue_out": out, "tongue_tip": tip}


def _suitable(ctx) -> list:
    style = ctx.style
    return [p for p in sorted(ctx.utterance.pauses, key=lambda p: p.start)
            if p.kind in ("word", "phrase", "sentence")
            and p.duration >= max(style.lick_min_pause_s, style.lick_s + _LEAD_S + _TAIL_S)]


def lick_events(ctx, rng: np.random.Generator, thinking: list[BehaviorEvent]) -> list[BehaviorEvent]:
    """The licks of the utterance (module docstring), in time order."""
    style, events = ctx.style, []
    candidates = _suitable(ctx)
    last = 0.0
    while True:
        interval = style.lick_interval_s * (1.0 + style.lick_jitter * (2.0 * rng.random() - 1.0))
        due = last + interval
        later = [p for p in candidates if p.start >= last + 0.5 * interval]
        if not later or (later[0].start > due and ctx.duration - last < interval):
            break
        pause = min(later, key=lambda p: abs(p.start - due))
        in_thought = any(t.start < pause.end and t.end > pause.start for t in thinking)
        room = pause.duration - _LEAD_S - _TAIL_S
        slow = in_thought and room >= style.lick_thinking_s
        duration = style.lick_thinking_s if slow else style.lick_s
        start = float(pause.start) + _LEAD_S
        events.append(BehaviorEvent("lick", start, start + duration, {"thinking": slow, "pause": pause.kind,
                                                                      "due": due}, _lick_keys(start, duration, style)))
        last = start + duration
    return events
