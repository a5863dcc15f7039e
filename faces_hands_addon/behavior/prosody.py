# SPDX-License-Identifier: GPL-3.0-or-later
"""What the behaviour rules read off an :class:`~faces_hands_addon.speech.Utterance`: pitch extrema,
phoneme boundaries, long and filled pauses.

Pitch extrema follow thesis 4.2.1 "Facial Expressions from Pitch": the unvoiced (NaN) values are
dropped, the rest is approximated by a smoothing B-spline, its local maxima and minima are found and,
for each, the position and value of the extremum of the *original* pitch data between the preceding
and succeeding turning points of the spline are retrieved ("reconstructed" extrema). Only extrema whose
differences to the neighbouring opposite extrema exceed a speaker-dependent threshold are kept ("only
the most prominent maxima and minima"). The threshold is in semitones here, so one number serves low
and high voices.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import splev, splrep

__all__ = ["Extremum", "pitch_extrema", "accent_extrema", "utterance_extrema", "phone_boundaries", "snap", "FILLER", "is_filler"]

FILLER = re.compile(r"^(e+r+m*|e+h*m+|u+h+m*|u+m+|a+h+m*|ä+h*m*|ö+h*m*|h+m+|m{2,}|er+|erm+)$", re.IGNORECASE)
_SPLINE_SIGMA_ST = 0.35     # expected scatter of the tracked F0 around its melody (semitones)


@dataclass(frozen=True)
class Extremum:
    """A reconstructed pitch extremum: ``time`` (s), ``hz``, ``kind`` ("max" or "min") and ``level`` in
    [0, 1]: the pitch relative to the utterance's range (10th percentile -> 0, highest F0 -> 1)."""

    time: float
    hz: float
    kind: str
    level: float


def is_filler(text: str) -> bool:
    """A filled pause ("errr", "ähm", "uhm", "hmm"): 4.2.1 "Thinking and Word Search"."""
    return bool(FILLER.match(text.strip(".,;:!?-…'\"")))


def _semitones(hz: np.ndarray, reference: float) -> np.ndarray:
    return 12.0 * np.log2(hz / reference)


def _turning_points(times: np.ndarray, tck, hop: float) -> tuple[np.ndarray, np.ndarray]:
    """Times of the spline's local maxima and minima (sign changes of its derivative on a fine grid)."""
    grid = np.arange(times[0], times[-1] + 0.5 * hop, 0.5 * hop)
    slope = splev(grid, tck, der=1)
    sign = np.sign(slope)
    change = np.nonzero(sign[:-1] * sign[1:] < 0)[0]
    maxima = grid[change[sign[change] > 0]]
    minima = grid[change[sign[change] < 0]]
    return maxima, minima


def _reconstruct(times: np.ndarray, values: np.ndarray, spline_max: np.ndarray,
                 spline_min: np.ndarray) -> list[tuple[float, int, str]]:
    """For every spline extremum, the original sample of the same kind between its neighbouring turning
    points: (time, sample index, kind), in time order."""
    turns = sorted([(t, "max") for t in spline_max] + [(t, "min") for t in spline_min])
    found = []
    for k, (t, kind) in enumerate(turns):
        lo = turns[k - 1][0] if k > 0 else -np.inf
        hi = turns[k + 1][0] if k + 1 < len(turns) else np.inf
        inside = np.nonzero((times > lo) & (times < hi))[0]
        if inside.size == 0:
            continue
        pick = inside[np.argmax(values[inside])] if kind == "max" else inside[np.argmin(values[inside])]
        found.append((float(times[pick]), int(pick), kind))
    # merge neighbours of the same kind (the reconstruction can land two on one sample)
    merged: list[tuple[float, int, str]] = []
    for item in found:
        if merged and merged[-1][2] == item[2]:
            better = (values[item[1]] > values[merged[-1][1]]) == (item[2] == "max")
            if better:
                merged[-1] = item
            continue
        merged.append(item)
    return merged


def _prominent(items: list[tuple[float, int, str]], values: np.ndarray, threshold: float) -> list[int]:
    """Indices into ``items`` of the extrema that differ from both neighbouring opposite extrema (where
    they exist) by more than ``threshold``."""
    keep = []
    for k, (_, index, kind) in enumerate(items):
        sign = 1.0 if kind == "max" else -1.0
        diffs = [sign * (values[index] - values[items[j][1]]) for j in (k - 1, k + 1) if 0 <= j < len(items)]
        if diffs and min(diffs) > threshold:
            keep.append(k)
    return keep


def pitch_extrema(times: np.ndarray, f0_hz: np.ndarray, threshold_st: float, hop: float = 0.01) -> list[Extremum]:
    """The prominent reconstructed pitch maxima and minima of a contour (module docstring), in time order.

    ``f0_hz`` may hold NaN (unvoiced) or 0 values; fewer than six voiced frames give no extrema."""
    times = np.asarray(times, dtype=np.float64)
    f0 = np.asarray(f0_hz, dtype=np.float64)
    voiced = np.isfinite(f0) & (f0 > 0)
    t, hz = times[voiced], f0[voiced]
    if t.size < 6:
        return []
    reference = float(np.median(hz))
    st = _semitones(hz, reference)
    tck = splrep(t, st, k=3, s=t.size * _SPLINE_SIGMA_ST ** 2)
    spline_max, spline_min = _turning_points(t, tck, hop)
    items = _reconstruct(t, st, spline_max, spline_min)
    keep = _prominent(items, st, threshold_st)
    floor, top = float(np.percentile(hz, 10)), float(hz.max())
    span = max(top - floor, 1e-9)
    out = []
    for k in keep:
        time, index, kind = items[k]
        out.append(Extremum(time, float(hz[index]), kind, float(np.clip((hz[index] - floor) / span, 0.0, 1.0))))
    return out


def accent_extrema(times: np.ndarray, f0_hz: np.ndarray, accents: np.ndarray) -> list[Extremum]:
    """Pitch extrema of synthesised speech from its accents (4.3.5 "Expressions linked to intonation": from
    text, head and brows follow "the intonation information provided by the TTS system"; 4.3.2: the
    TTS places accents on content words, "leading to a pitch excursion").

    A TTS contour is smooth and known to carry its accents where the TTS put them, so the accented
    syllables (``accents``: (start, end) rows in time order) are its pitch targets: one maximum at the
    highest F0 inside each accented syllable, one minimum at the lowest F0 between two neighbouring
    maxima (and before the first and after the last, within 0.4 s). espeak-ng does not hand out its F0
    targets; on its tracked contour the accents are sub-semitone bumps on a declination line and a
    phrase-initial rise, which the B-spline and the prominence threshold of :func:`pitch_extrema` remove,
    so from text only the phrase-initial peak survived (thesis example: a maximum on "show", none on
    "conference"). Levels are the pitch above the utterance's declination line (a straight line in
    semitones), relative to the range of that excursion (10th percentile -> 0, the largest -> 1): the
    head rises "proportionally to the pitch value" of the accent, not of the declining baseline. An
    accent without voiced frames gives no maximum."""
    times = np.asarray(times, dtype=np.float64)
    f0 = np.asarray(f0_hz, dtype=np.float64)
    voiced = np.isfinite(f0) & (f0 > 0)
    t, hz = times[voiced], f0[voiced]
    if t.size < 6:
        return []
    # levels above the declination line: the accent's own excursion, so a late accent of a long phrase
    # rises as clearly as an early one (the line: least squares in semitones over the voiced frames)
    st = _semitones(hz, float(np.median(hz)))
    residual = st - np.polyval(np.polyfit(t, st, 1), t)
    floor, top = float(np.percentile(residual, 10)), float(residual.max())
    span = max(top - floor, 1e-9)

    def make(index: int, kind: str) -> Extremum:
        return Extremum(float(t[index]), float(hz[index]), kind,
                        float(np.clip((residual[index] - floor) / span, 0.0, 1.0)))
    peaks = []
    for start, end in np.asarray(accents, dtype=np.float64).reshape(-1, 2):
        inside = np.nonzero((t >= start) & (t <= end))[0]
        if inside.size and (not peaks or inside[np.argmax(hz[inside])] != peaks[-1]):
            peaks.append(int(inside[np.argmax(hz[inside])]))
    out: list[Extremum] = []
    for k, peak in enumerate(peaks):
        low_t = t[peaks[k - 1]] if k else t[peak] - 0.4
        between = np.nonzero((t > low_t) & (t < t[peak]))[0]
        if between.size:
            out.append(make(int(between[np.argmin(hz[between])]), "min"))
        out.append(make(peak, "max"))
    if peaks:
        after = np.nonzero((t > t[peaks[-1]]) & (t < t[peaks[-1]] + 0.4))[0]
        if after.size:
            out.append(make(int(after[np.argmin(hz[after])]), "min"))
    return out


def utterance_extrema(utterance, threshold_st: float) -> list[Extremum]:
    """The pitch extrema the behaviour follows: from text (``source == "tts"``) at the TTS's accents
    (:func:`accent_extrema`, 4.3.5), from recorded speech the prominent reconstructed extrema of the
    tracked pitch (:func:`pitch_extrema`, 4.2.1)."""
    pitch = utterance.pitch
    accents = np.array([(s.start, s.end) for s in utterance.accented_syllables], dtype=np.float64)
    if utterance.source == "tts" and accents.size:
        return accent_extrema(pitch.times, pitch.f0_hz, accents)
    return pitch_extrema(pitch.times, pitch.f0_hz, threshold_st, pitch.hop)


def phone_boundaries(utterance) -> np.ndarray:
    """Every phone start and end of the utterance, sorted and unique (the points 4.3.5 synchronises all
    movement to: "All movement is synchronized at the phoneme level")."""
    edges = [0.0, float(utterance.duration)]
    for p in utterance.phones:
        edges += [float(p.start), float(p.end)]
    return np.unique(np.round(np.asarray(edges), 9))


def snap(time: float, boundaries: np.ndarray, low: float = -np.inf, high: float = np.inf) -> float:
    """The phoneme boundary closest to ``time`` within ``[low, high]`` (``time`` itself if none is)."""
    inside = boundaries[(boundaries >= low) & (boundaries <= high)]
    if inside.size == 0:
        return float(time)
    return float(inside[np.argmin(np.abs(inside - time))])
