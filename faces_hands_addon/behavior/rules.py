# SPDX-License-Identifier: GPL-3.0-or-later
"""The rules of thesis 4.3.5 "Generating Facial Expressions" (with the timing of 4.2.1): each turns the
utterance into :class:`~.events.BehaviorEvent` s, drawing every random choice from its own seeded
``numpy.random.Generator`` (one Bernoulli draw per candidate, so the observed rates are the style's
probabilities).

Gaze priorities (a higher one wins where fixations overlap): 0 phrase base gaze, 1 speaker state,
2 glances (accents, phrase boundaries), 3 questions, 4 thinking, 5 speaker turn.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .events import BehaviorEvent, envelope
from .prosody import Extremum, is_filler, snap
from .styles import CharacterStyle

__all__ = ["Context", "blink_events", "pitch_events", "accent_events", "question_events",
           "thinking_events", "regulator_events", "pause_after_word"]

BASE, STATE, GLANCE, QUESTION, THINKING, TURN = range(6)
_RAMP = 0.15                # rise time of brow / head gestures that are not pitch-timed (s)
_RELEASE = 0.2              # fall time of those gestures (s)


@dataclass
class Context:
    """What every rule reads: the utterance, the style, the phoneme boundaries (sorted) and the accented
    syllables as (start, end) rows."""

    utterance: object
    style: CharacterStyle
    boundaries: np.ndarray
    accents: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.utterance.duration)

    def clear_of_accents(self, time: float) -> float:
        """``time``, or just after the accented syllable it falls in (or within a saccade of): gaze never
        turns away from the listener during an accent (4.3.5: the speaker "does not shift its gaze further
        away"); the margin keeps a gaze change's ramp (``saccade_s``) out of the syllable too."""
        margin = self.style.saccade_s
        first = int(np.searchsorted(self.accents[:, 1] + margin, time, side="right"))  # the earlier ones end before
        for start, end in self.accents[first:]:  # in time order: a time pushed past one accent meets the next
            if start - margin >= time:
                break
            if time < end + margin:
                time = end + margin
        return float(time)


def _blink(onset: float, style: CharacterStyle, cause: str) -> BehaviorEvent:
    """A blink of 4.2.1 (after Pelachaud et al.): closing 1/8 s, apex 1/24 s, opening 1/12 s."""
    closed = onset + style.blink_close_s
    opening = closed + style.blink_apex_s
    end = opening + style.blink_open_s
    keys = {"lids": envelope([(onset, 0.0), (closed, 1.0), (opening, 1.0), (end, 0.0)])}
    return BehaviorEvent("blink", onset, end, {"cause": cause, "closed": closed, "opening": opening,
                                               "close_s": style.blink_close_s, "apex_s": style.blink_apex_s,
                                               "open_s": style.blink_open_s}, keys)


def _fill_gap(prev: float, nxt: float, ctx: Context) -> list[float]:
    """Onsets of the extra blinks between onsets ``prev`` and ``nxt`` so that no gap exceeds the blink
    interval (4.3.5: blinks "once every 4.8 seconds"), spread evenly, each moved to the closest phoneme
    boundary as far as that keeps every gap within the interval (4.2.1)."""
    interval = ctx.style.blink_interval_s
    count = math.ceil((nxt - prev) / interval - 1e-9) - 1
    if count <= 0:
        return []
    spacing = (nxt - prev) / (count + 1)
    slack = min(0.5 * (interval - spacing), 0.15)
    onsets = []
    for k in range(1, count + 1):
        target = prev + k * spacing
        onsets.append(snap(target, ctx.boundaries, target - slack, target + slack) if slack > 1e-6 else target)
    return onsets


def blink_events(ctx: Context, rng: np.random.Generator) -> list[BehaviorEvent]:
    """Blinks as punctuators at the start of pauses (4.2.1, 4.3.5 "Eye blinks") and as manipulators
    whenever the blink interval (4.8 s) would pass without one. The onset of a pause blink is the pause's
    start, a phoneme boundary; the phases keep the thesis' average durations (inside a pause the nearest
    boundaries are the pause's own ends)."""
    style = ctx.style
    length = style.blink_close_s + style.blink_apex_s + style.blink_open_s
    onsets: list[tuple[float, str]] = []
    for pause in ctx.utterance.pauses:
        if pause.kind == "leading" or pause.duration < style.blink_min_pause_s:
            continue
        if rng.random() >= style.blink_pause_probability:
            continue
        if pause.start + length > ctx.duration or (onsets and pause.start < onsets[-1][0] + length):
            continue
        onsets.append((float(pause.start), "pause"))
    anchors = [0.0] + [t for t, _ in onsets] + [max(ctx.duration - length, 0.0)]
    extra = []
    for prev, nxt in zip(anchors, anchors[1:]):
        extra += [(t, "interval") for t in _fill_gap(prev, nxt, ctx)]
    return [_blink(t, style, cause) for t, cause in sorted(onsets + extra)]


def _neighbour_minimum(extrema: list[Extremum], k: int, step: int, ctx: Context) -> float:
    """The time of the kept minimum next to maximum ``k`` in direction ``step`` (before the next maximum),
    else a point 0.3 s away, halfway to the next maximum at most."""
    j = k + step
    while 0 <= j < len(extrema):
        if extrema[j].kind == "min":
            return extrema[j].time
        if extrema[j].kind == "max":
            return 0.5 * (extrema[j].time + extrema[k].time)
        j += step
    return float(np.clip(extrema[k].time + 0.3 * step, 0.0, ctx.duration))


def pitch_events(ctx: Context, extrema: list[Extremum], rng: np.random.Generator) -> list[BehaviorEvent]:
    """Head and eyebrow movement at the prominent pitch maxima (4.3.5 "Expressions linked to intonation",
    4.2.1 "Facial Expressions from Pitch"): the head rises from the preceding minimum to the maximum in
    proportion to the pitch (at most ``head_raise_max_deg``, ~3 deg) and returns to rest at the next
    minimum, independent of its value; in about 75 % of the raises it also tilts sideways by a random
    amount. The brows rise at a maximum with probability 0.71 (Cave et al.): the left brow by an amount
    that depends on the pitch, the right one always by the same amount. All three times are moved to
    the closest phoneme boundary (4.2.1)."""
    style, events = ctx.style, []
    for k, ext in enumerate(extrema):
        if ext.kind != "max":
            continue
        before = _neighbour_minimum(extrema, k, -1, ctx)
        after = _neighbour_minimum(extrema, k, +1, ctx)
        peak = snap(ext.time, ctx.boundaries, before + 1e-3, after - 1e-3)
        rise = snap(before, ctx.boundaries, before - 0.05, peak - 1e-3)
        fall = snap(after, ctx.boundaries, peak + 1e-3, after + 0.05)
        draws = rng.random(4)
        events.append(BehaviorEvent("pitch_max", peak, peak, {"hz": ext.hz, "level": ext.level}))
        if draws[0] < style.head_raise_probability:
            amount = math.radians(style.head_raise_max_deg) * ext.level
            keys = {"head.pitch": envelope([(rise, 0.0), (peak, amount), (fall, 0.0)])}
            tilt = 0.0
            if draws[1] < style.head_tilt_probability:
                side = 1.0 if draws[2] < 0.5 else -1.0
                tilt = side * math.radians(style.head_tilt_max_deg) * (0.4 + 0.6 * rng.random())
                keys["head.roll"] = envelope([(rise, 0.0), (peak, tilt), (fall, 0.0)])
            events.append(BehaviorEvent("head_raise", rise, fall, {"peak": peak, "pitch_rad": amount,
                                                                   "tilt_rad": tilt, "hz": ext.hz}, keys))
        if draws[3] < style.brow_raise_probability:
            left = style.brow_raise_left * ext.level
            right = style.brow_raise_right
            keys = {"brow_L": envelope([(rise, 0.0), (peak, left), (fall, 0.0)]),
                    "brow_R": envelope([(rise, 0.0), (peak, right), (fall, 0.0)])}
            events.append(BehaviorEvent("brow_raise", rise, fall, {"peak": peak, "left": left, "right": right,
                                                                   "hz": ext.hz}, keys))
    return events


def accent_events(ctx: Context, rng: np.random.Generator) -> list[BehaviorEvent]:
    """4.3.5: "the talking head glances at the listener during 70 % of all accented syllables, and does
    not shift its gaze further away from the listener in all other cases" (``accent_hold`` events; every
    gaze change that would fall inside an accent waits for its end, :meth:`Context.clear_of_accents`)."""
    events = []
    for syllable in ctx.utterance.accented_syllables:
        start, end = float(syllable.start), float(syllable.end)
        if rng.random() < ctx.style.accent_glance_probability:
            until = min(ctx.clear_of_accents(end + ctx.style.glance_hold_s), ctx.duration)
            events.append(BehaviorEvent("accent_glance", start, until, {"syllable_end": end},
                                        gaze=(0.0, 0.0, GLANCE)))
        else:
            events.append(BehaviorEvent("accent_hold", start, end))
    return events


def pause_after_word(utterance, word_index: int) -> float:
    """The silence between word ``word_index`` and the next word (or the end of the audio)."""
    words = utterance.words
    nxt = words[word_index + 1].start if word_index + 1 < len(words) else utterance.duration
    return max(0.0, float(nxt) - float(words[word_index].end))


def question_events(ctx: Context) -> list[BehaviorEvent]:
    """4.3.5 "Questions": the eyes are on the listener during the question, and the brows and the head are
    raised on the last word, "lasting over a potentially following pause"."""
    style, events = ctx.style, []
    for sentence in ctx.utterance.sentences:
        if sentence.kind != "question":
            continue
        last = ctx.utterance.words[sentence.last_word]
        hold_end = float(last.end) + pause_after_word(ctx.utterance, sentence.last_word)
        start = float(last.start)
        up = min(start + _RAMP, 0.5 * (start + float(last.end)))
        down = min(hold_end + _RELEASE, ctx.duration + _RELEASE)
        head = math.radians(style.question_head_deg)
        keys = {"brow_L": envelope([(start, 0.0), (up, style.question_brow), (hold_end, style.question_brow),
                                    (down, 0.0)]),
                "head.pitch": envelope([(start, 0.0), (up, head), (hold_end, head), (down, 0.0)])}
        keys["brow_R"] = keys["brow_L"]
        events.append(BehaviorEvent("question_gaze", float(sentence.start), ctx.clear_of_accents(hold_end), {},
                                    gaze=(0.0, 0.0, QUESTION)))
        events.append(BehaviorEvent("question_raise", start, hold_end, {"word": last.text, "brow":
                                    style.question_brow, "head_rad": head}, keys))
    return events


def _thinking_spans(ctx: Context) -> list[tuple[float, float, bool]]:
    """(start, end, filled) of the thinking pauses: silent pauses inside the utterance at least
    ``thinking_pause_s`` long, and filled pauses (a filler word such as "errr" with the silence after it)."""
    spans = []
    for pause in ctx.utterance.pauses:
        if pause.kind in ("word", "phrase", "sentence") and pause.duration >= ctx.style.thinking_pause_s:
            spans.append((float(pause.start), float(pause.end), False))
    for k, word in enumerate(ctx.utterance.words):
        if is_filler(word.text):
            spans.append((float(word.start), float(word.end) + pause_after_word(ctx.utterance, k), True))
    spans.sort()
    merged: list[tuple[float, float, bool]] = []
    for span in spans:
        if merged and span[0] <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], span[1]), merged[-1][2] or span[2])
        else:
            merged.append(span)
    return merged


def thinking_events(ctx: Context, rng: np.random.Generator) -> list[BehaviorEvent]:
    """Thinking and word search in long or filled pauses (4.2.1, 4.3.5 "Word search"): with probability
    0.25 the character looks down and frowns slightly, otherwise it looks up with raised brows (and a
    slightly raised head, Fig. 4.2); in both cases the gaze shifts slightly to the right (Andersen:
    rightward lateral eye movements go with verbal activity). Right is the character's right (-eye_yaw)."""
    style, events = ctx.style, []
    for start, end, filled in _thinking_spans(ctx):
        ramp = min(_RAMP, 0.25 * (end - start))
        frown = rng.random() < style.thinking_frown_probability
        if frown:
            keys = {"frown": envelope([(start, 0.0), (start + ramp, style.thinking_frown),
                                       (end - ramp, style.thinking_frown), (end, 0.0)])}
            gaze = (-style.thinking_right, -style.thinking_look_down, THINKING)
        else:
            brow = envelope([(start, 0.0), (start + ramp, style.thinking_brow), (end - ramp, style.thinking_brow),
                             (end, 0.0)])
            head = math.radians(style.thinking_head_deg)
            keys = {"brow_L": brow, "brow_R": brow,
                    "head.pitch": envelope([(start, 0.0), (start + ramp, head), (end - ramp, head), (end, 0.0)])}
            gaze = (-style.thinking_right, style.thinking_look_up, THINKING)
        events.append(BehaviorEvent("thinking", start, end, {"mode": "down" if frown else "up", "filled": filled},
                                    keys, gaze))
    return events


def _phrase_base(ctx: Context, rng: np.random.Generator) -> list[BehaviorEvent]:
    """A slightly averted base gaze per intonational phrase of a statement (4.1.1: "for statements the
    speaker does not constantly look at the listener"), on a random side; it changes only at phrase
    starts and never inside an accent."""
    events = []
    phrases = ctx.utterance.phrases
    for k, phrase in enumerate(phrases):
        start = ctx.clear_of_accents(float(phrase.start))
        end = float(phrases[k + 1].start) if k + 1 < len(phrases) else ctx.duration
        side = 1.0 if rng.random() < 0.5 else -1.0
        yaw = side * ctx.style.avert_yaw * (0.5 + 0.5 * rng.random())
        pitch = -ctx.style.avert_pitch * rng.random()
        events.append(BehaviorEvent("base_gaze", start, max(end, start + 1e-3), {"phrase": k}, gaze=(yaw, pitch, BASE)))
    return events


def regulator_events(ctx: Context, rng: np.random.Generator, thinking: list[BehaviorEvent]) -> list[BehaviorEvent]:
    """Turn-taking signals (4.1.1, 4.3.5 "Regulators"): *speaker state* at the start (gaze averted, head
    turned away), *speaker within-turn* glances at the listener in 70 % of the pauses at intonational
    phrase boundaries (pauses of kind "phrase" and "sentence"; a pause spent thinking is a thinking pause
    instead), *speaker turn* at the end (looking at the listener)."""
    style, u = ctx.style, ctx.utterance
    events = _phrase_base(ctx, rng)
    if u.words:
        first_end = float(u.phrases[0].end) if u.phrases else float(u.words[0].end)
        side = 1.0 if rng.random() < 0.5 else -1.0
        lead = float(u.words[0].start)
        reach = lead if lead >= 0.1 else min(0.3, first_end)
        turn = side * math.radians(style.speaker_state_turn_deg)
        back = ctx.clear_of_accents(first_end)
        keys = {"head.yaw": envelope([(0.0, 0.0), (reach, turn), (back, turn), (back + 0.4, 0.0)])}
        events.append(BehaviorEvent("speaker_state", 0.0, back, {"side": side, "turn_rad": turn}, keys,
                                    gaze=(side * style.avert_yaw, -style.avert_pitch, STATE)))
        last = u.words[-1]
        events.append(BehaviorEvent("speaker_turn", float(last.start), ctx.duration, {}, gaze=(0.0, 0.0, TURN)))
    thinking_spans = [(e.start, e.end) for e in thinking]
    for pause in u.pauses:
        if pause.kind not in ("phrase", "sentence"):
            continue
        if any(a < pause.end and pause.start < b for a, b in thinking_spans):
            continue
        if rng.random() < style.phrase_glance_probability:
            until = min(ctx.clear_of_accents(float(pause.end) + style.glance_hold_s), ctx.duration)
            events.append(BehaviorEvent("within_turn_glance", float(pause.start), until, {"pause": pause.kind},
                                        gaze=(0.0, 0.0, GLANCE)))
        else:
            events.append(BehaviorEvent("within_turn_skip", float(pause.start), float(pause.end)))
    return events
