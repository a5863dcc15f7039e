# SPDX-License-Identifier: GPL-3.0-or-later
"""Cohen-Massaro coarticulation with the MEDUSA extensions of thesis 3.1.3.

For every speech parameter p the trajectory is the dominance-weighted average of the segment targets

    F_p(t) = sum_s D_sp(t) T_sp / sum_s D_sp(t)                                   (3.1.3, "F_p")

with the negative-exponential dominance functions

    D_sp(t) = alpha_sp exp(-theta<-_sp |tau|^c)   if tau(t) >= 0
              alpha_sp exp(-theta->_sp |tau|^c)   if tau(t) <  0
    tau(t)  = (t_start^s + t_dur^s / 2) + t_off^sp - t                             (3.1.3, "tau")

(``theta_back`` = theta<-, ``theta_fwd`` = theta->, c = 1 by default). The adaptations of 3.1.3:

* **Speed-up.** At a time t inside segment k only the segments k-11 .. k+11 count fully; a segment
  12 away is led to 0 across segment k with a cubic Hermite curve that starts from its value and
  slope at the boundary (slope limited so the curve stays monotone and never negative), so F_p stays
  continuous. Cost is O(times x 25 x parameters) whatever the utterance length.
* **Closure and release phases.** /p b/ are split into a closure (``closure_fraction`` of the
  segment) and a release; /m f v/ are one closure ("handled in the same way as the bilabial
  closure"). Which phones, and the fraction, come from the preset's ``phases``.
* **Key frames.** Frames are equidistant at ``fps`` (on the whole-frame grid k/fps), plus a key at
  the start of every closure, at the start of its release (if any) and at the start of the next
  phoneme; grid frames inside that closure/release interval are skipped, then equidistant sampling
  resumes. High closure magnitudes make the lips reach their targets at the closure key frame;
  closures give their magnitude at their edges (``"alpha_at": "edges"``, see ``articulation``), so
  a long /m/ holds the lips closed from its first key frame to its last.
* **Release visemes** have their dominance peak at the start of their interval; their targets are
  the next segment's unless the preset gives explicit release targets.

Diphthongs (``PhoneInfo.glide_to``) are split 60/40 into their start and end vowels.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..anim.tracks import Track, TrackSet, frame_times
from ..core.errors import UserError
from .articulation import TargetSet, load_articulation
from .phonemes import PHONES, SILENCE

NEIGHBOURS = 11           # segments considered fully on each side (3.1.3 "Speed-up")
DIPHTHONG_SPLIT = 0.6
MAX_HALF_DURATION = 1.0   # s; caps the edge-alpha scaling of very long closures (no overflow)
_MIN_TAU = 1e-9


@dataclass(frozen=True)
class Segment:
    """An expanded segment: ``phase`` is "normal", "glide" (second half of a diphthong),
    "closure" or "release"; ``row`` indexes the target set (-1 for a release)."""

    phone: str
    start: float
    duration: float
    phase: str
    row: int

    @property
    def end(self) -> float:
        return self.start + self.duration


@dataclass
class CoarticulationResult:
    """``values[p, i]`` of parameter ``parameters[p]`` at ``times[i]``; ``tracks`` holds the same as
    a TrackSet; ``key_times`` are the closure/release/next-phoneme key frames."""

    tracks: TrackSet
    parameters: tuple[str, ...]
    times: np.ndarray
    values: np.ndarray
    key_times: np.ndarray
    segments: list[Segment]


def _clean_segments(source) -> list[tuple[str, float, float]]:
    raw = source.segments() if hasattr(source, "segments") else list(source)
    segments = []
    for item in raw:
        try:
            phone, start, duration = item
            start, duration = float(start), float(duration)
        except (TypeError, ValueError):
            raise UserError("segments must be (phone, start, duration) triples") from None
        if phone not in PHONES:
            raise UserError(f"unknown phone {phone!r} in the segments; known: {', '.join(PHONES)}")
        if not (np.isfinite(start) and np.isfinite(duration)) or duration < 0:
            raise UserError(f"segment {phone!r} has an invalid start/duration ({start}, {duration})")
        if duration > 0:
            segments.append((phone, start, duration))
    if not segments:
        raise UserError("nothing to animate: no phones with a duration")
    segments.sort(key=lambda s: s[1])
    tiled = []
    cursor = segments[0][1]
    for phone, start, duration in segments:
        end = start + duration
        if start > cursor + 1e-9:
            tiled.append((SILENCE, cursor, start - cursor))
        start = max(start, cursor)
        if end > start:
            tiled.append((phone, start, end - start))
            cursor = end
    return tiled


def expand_segments(source, target_set: TargetSet) -> list[Segment]:
    """Split closures/releases and diphthongs (see the module docstring); ``source`` is an Utterance
    or ``(phone, start, duration)`` triples."""
    out: list[Segment] = []
    for phone, start, duration in _clean_segments(source):
        row = target_set.row_of[phone]
        phase = target_set.phase(phone)
        glide = PHONES[phone].glide_to
        if phase == "closure_release":
            closure = duration * target_set.closure_fraction
            out.append(Segment(phone, start, closure, "closure", row))
            out.append(Segment(phone, start + closure, duration - closure, "release", -1))
        elif phase == "closure":
            out.append(Segment(phone, start, duration, "closure", row))
        elif glide:
            first = duration * DIPHTHONG_SPLIT
            out.append(Segment(phone, start, first, "normal", row))
            out.append(Segment(glide, start + first, duration - first, "glide", target_set.row_of[glide]))
        else:
            out.append(Segment(phone, start, duration, "normal", row))
    return out


def _segment_arrays(segments: list[Segment], ts: TargetSet) -> dict[str, np.ndarray]:
    """(S, P) arrays of targets, dominance parameters and absolute peak times."""
    S, P = len(segments), len(ts.parameters)
    starts = np.array([s.start for s in segments])
    durations = np.array([s.duration for s in segments])
    arrays = {k: np.empty((S, P)) for k in ("target", "alpha", "theta_back", "theta_fwd", "c", "peak")}
    for i, seg in enumerate(segments):
        if seg.phase == "release":
            following = segments[i + 1].row if i + 1 < S else ts.row_of[SILENCE]
            target = ts.targets[following] if ts.release_targets is None else ts.release_targets
            dom = ts.release
            arrays["target"][i] = target
            arrays["alpha"][i], arrays["c"][i] = dom.alpha, dom.c
            arrays["theta_back"][i], arrays["theta_fwd"][i] = dom.theta_back, dom.theta_fwd
            arrays["peak"][i] = seg.start + dom.peak_offset  # release peak: start of its interval
            continue
        r = seg.row
        arrays["target"][i] = ts.targets[r]
        arrays["alpha"][i], arrays["c"][i] = ts.alpha[r], ts.c[r]
        if ts.alpha_at_edges[r] and not ts.peak_at_start[r]:
            # alpha is the dominance at the segment's edges: scale the peak magnitude by duration
            half = min(seg.duration / 2, MAX_HALF_DURATION) ** ts.c[r]
            arrays["alpha"][i] = ts.alpha[r] * np.exp(np.maximum(ts.theta_back[r], ts.theta_fwd[r]) * half)
        arrays["theta_back"][i], arrays["theta_fwd"][i] = ts.theta_back[r], ts.theta_fwd[r]
        anchor = seg.start if ts.peak_at_start[r] else seg.start + seg.duration / 2
        arrays["peak"][i] = anchor + ts.peak_offset[r]
    arrays["start"], arrays["duration"] = starts, durations
    return arrays


def _dominance(t: np.ndarray, a: dict, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """D_sp(t) and dD/dt for times ``t`` (shape (T, 1, 1) or broadcastable) and segments ``idx``."""
    tau = a["peak"][idx] - t
    theta = np.where(tau >= 0, a["theta_back"][idx], a["theta_fwd"][idx])
    c = a["c"][idx]
    magnitude = np.maximum(np.abs(tau), _MIN_TAU)
    d = a["alpha"][idx] * np.exp(-theta * magnitude ** c)
    slope = d * theta * c * magnitude ** (c - 1.0) * np.sign(tau)
    return d, slope


def _hermite_fade(u, value, slope_times_length, fading_out: bool):
    """Cubic Hermite from (value, slope) at the near boundary to (0, 0) at the far one, with the
    slope limited to 3*value so the curve is monotone and non-negative (Fritsch-Carlson)."""
    u = np.clip(u, 0.0, 1.0)
    if fading_out:  # value at u = 0, zero at u = 1
        m = np.clip(slope_times_length, -3.0 * value, 0.0)
        return (2 * u ** 3 - 3 * u ** 2 + 1) * value + (u ** 3 - 2 * u ** 2 + u) * m
    m = np.clip(slope_times_length, 0.0, 3.0 * value)  # zero at u = 0, value at u = 1
    return (-2 * u ** 3 + 3 * u ** 2) * value + (u ** 3 - u ** 2) * m


def evaluate(times: np.ndarray, arrays: dict, window: int | None = NEIGHBOURS,
             block: int = 2048) -> np.ndarray:
    """F_p at ``times`` -> (T, P). ``window=None`` sums over every segment (the original algorithm)."""
    times = np.asarray(times, dtype=float)
    starts, durations = arrays["start"], arrays["duration"]
    S = len(starts)
    out = np.empty((len(times), arrays["target"].shape[1]))
    for first in range(0, len(times), block):
        t = times[first:first + block]
        if window is None:
            idx = np.broadcast_to(np.arange(S), (len(t), S))
            d, _ = _dominance(t[:, None, None], arrays, idx)
        else:
            k = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, S - 1)
            offsets = np.arange(-window - 1, window + 2)
            raw = k[:, None] + offsets[None, :]
            valid = (raw >= 0) & (raw < S)
            idx = np.clip(raw, 0, S - 1)
            d, _ = _dominance(t[:, None, None], arrays, idx)
            # the 12th segment on each side: Hermite fade across the current segment k
            length = durations[k]
            u = ((t - starts[k]) / length)[:, None]
            d_early, s_early = _dominance(starts[k][:, None], arrays, idx[:, 0])
            d[:, 0] = _hermite_fade(u, d_early, s_early * length[:, None], fading_out=True)
            end_k = (starts[k] + length)[:, None]
            d_late, s_late = _dominance(end_k, arrays, idx[:, -1])
            d[:, -1] = _hermite_fade(u, d_late, s_late * length[:, None], fading_out=False)
            d = np.where(valid[:, :, None], d, 0.0)
        numerator = np.einsum("tsp,tsp->tp", d, arrays["target"][idx])
        denominator = d.sum(axis=1)
        out[first:first + len(t)] = numerator / np.maximum(denominator, 1e-300)
    return out


def sample_times(segments: list[Segment], fps: float, end: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Equidistant frames k/fps plus closure/release/next-phoneme key frames (3.1.3); grid frames
    inside a closure-to-next-phoneme interval, or closer than a quarter frame to a key, are dropped."""
    start = segments[0].start
    end = segments[-1].end if end is None else end
    grid = frame_times(fps, max(start, 0.0), end)
    keys, holds = [], []
    i = 0
    while i < len(segments):
        seg = segments[i]
        if seg.phase != "closure":
            i += 1
            continue
        keys.append(seg.start)
        stop = seg.end
        if i + 1 < len(segments) and segments[i + 1].phase == "release":
            keys.append(segments[i + 1].start)
            stop = segments[i + 1].end
            i += 1
        keys.append(stop)
        holds.append((seg.start, stop))
        i += 1
    keys = np.unique(np.array(keys, dtype=float))
    keep = np.ones(grid.shape, dtype=bool)
    for a, b in holds:
        keep &= ~((grid > a) & (grid < b))
    if keys.size:
        j = np.clip(np.searchsorted(keys, grid), 1, max(keys.size - 1, 1))
        nearest = np.minimum(np.abs(grid - keys[j - 1]), np.abs(grid - keys[np.minimum(j, keys.size - 1)]))
        keep &= nearest >= 0.25 / fps
    return np.unique(np.concatenate([grid[keep], keys])), keys


def coarticulate(source, targets: TargetSet | None = None, *, fps: float = 30.0,
                 times: Sequence[float] | np.ndarray | None = None,
                 window: int | None = NEIGHBOURS) -> CoarticulationResult:
    """Trajectories of every parameter of ``targets`` (default: the muscle preset) for an Utterance
    or ``(phone, start, duration)`` triples, sampled at ``fps`` with closure key frames, or at the
    given ``times``. ``window=None`` evaluates the unwindowed sum (for comparison)."""
    ts = targets if targets is not None else load_articulation()
    segments = expand_segments(source, ts)
    arrays = _segment_arrays(segments, ts)
    if times is None:
        sample, keys = sample_times(segments, fps)
    else:
        sample = np.unique(np.asarray(times, dtype=float))
        if sample.size == 0 or not np.all(np.isfinite(sample)):
            raise UserError("sample times must be a non-empty list of finite numbers")
        keys = np.zeros(0)
    values = evaluate(sample, arrays, window).T
    tracks = TrackSet({name: Track(name, sample, values[p]) for p, name in enumerate(ts.parameters)})
    return CoarticulationResult(tracks, ts.parameters, sample, values, keys, segments)
