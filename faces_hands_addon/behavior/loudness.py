# SPDX-License-Identifier: GPL-3.0-or-later
"""Volume-controlled intensity (thesis 4.2.1): the relative loudness of recorded speech scales the mouth
movement and, by per-parameter weights, the speech-accompanying expressions.

The thesis: "we extract a windowed power spectrum of the speech signal and fit an approximating B-spline
curve to it. An interpolating polynomial is fitted to the local maxima of this B-spline curve and
normalized to a [0, 1] range. It indicates the relative loudness of the speech signal. These relative
loudness values are individually weighted for each animation parameter [...] The weight for jaw rotation,
for instance, is greater than the weight for eyebrow movement."

Here: the power (dB) of 30 ms windows every 10 ms, computed in blocks (bounded memory for long files);
an approximating (least-squares) cubic B-spline through it, a knot every 40 ms; the spline's local maxima (one per syllable: the highest within
0.12 s, and not the noise floor of a pause, more than two ranges below the loudest); a piecewise cubic Hermite interpolating
polynomial (PCHIP: no overshoot) through them, held flat before the first and after the last; and
normalised to [0, 1] over ``range_db`` below the loudest maximum. A parameter with weight ``w`` is scaled
by ``1 - w + w * loudness`` (``presets/behavior/loudness.json``; the first matching name pattern wins).
"""
from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from typing import Mapping

import numpy as np
from scipy.interpolate import PchipInterpolator, splev, splrep
from scipy.ndimage import maximum_filter1d

from ..anim.tracks import Track, TrackSet
from ..core.errors import UserError
from ..core.presets import NUMBER, PresetFormat, read_preset, register_format

__all__ = ["LoudnessSettings", "Loudness", "load_loudness_settings", "windowed_power", "loudness_curve",
           "scale_tracks", "LOUDNESS_FORMAT"]

LOUDNESS_FORMAT = register_format(PresetFormat(
    "faces_hands.loudness", 1,
    shape={"about": str, "window_s": NUMBER, "hop_s": NUMBER, "range_db": NUMBER, "weights": {str: NUMBER}},
    required=("weights",)))
LOUDNESS_PRESET = "behavior/loudness.json"
_BLOCK_FRAMES = 4096        # windows per block of the power computation (memory ~ block * window)
_SYLLABLE_S = 0.12          # half the span in which one maximum counts (about a syllable)
_KNOT_S = 0.04              # knot spacing of the approximating B-spline (s)


@dataclass(frozen=True)
class LoudnessSettings:
    """Window and hop (s), the dynamic range mapped to [0, 1] (dB) and the weights (pattern -> w)."""

    window_s: float = 0.03
    hop_s: float = 0.01
    range_db: float = 30.0
    weights: tuple[tuple[str, float], ...] = (("*", 0.5),)

    def weight(self, name: str) -> float:
        """The weight of the control (or head channel) ``name``: the first matching pattern's, else 0."""
        for pattern, value in self.weights:
            if fnmatch.fnmatchcase(name, pattern):
                return float(value)
        return 0.0


def load_loudness_settings() -> LoudnessSettings:
    """The settings of ``presets/behavior/loudness.json`` (the artist's copy first), checked."""
    doc, source = read_preset(LOUDNESS_PRESET, LOUDNESS_FORMAT.name)
    weights = tuple((str(k), float(v)) for k, v in doc["weights"].items())
    bad = [k for k, v in weights if not 0.0 <= v <= 1.0]
    if bad:
        raise UserError(f"{source}: loudness weights must be in [0, 1] ({', '.join(bad)} are not)")
    settings = LoudnessSettings(float(doc.get("window_s", 0.03)), float(doc.get("hop_s", 0.01)),
                                float(doc.get("range_db", 30.0)), weights)
    if not (0.005 <= settings.window_s <= 0.2 and 0.001 <= settings.hop_s <= settings.window_s
            and settings.range_db > 0):
        raise UserError(f"{source}: window_s must be in [0.005, 0.2] s, hop_s in [0.001, window_s], range_db > 0")
    return settings


@dataclass(frozen=True)
class Loudness:
    """The relative loudness ``values`` in [0, 1] at ``times`` (s); ``maxima``: the spline maxima's times."""

    times: np.ndarray
    values: np.ndarray
    maxima: np.ndarray

    def sample(self, times) -> np.ndarray:
        return np.interp(times, self.times, self.values)


def windowed_power(samples: np.ndarray, rate: int, window_s: float = 0.03, hop_s: float = 0.01):
    """(frame centre times, power in dB re full scale) of ``window_s`` windows every ``hop_s``, in blocks
    of :data:`_BLOCK_FRAMES` windows (a 10-minute file never makes a frames x window copy)."""
    x = np.asarray(samples, dtype=np.float32).reshape(-1)
    win, hop = max(1, int(round(window_s * rate))), max(1, int(round(hop_s * rate)))
    if x.size < win:
        return np.zeros(0), np.zeros(0)
    count = (x.size - win) // hop + 1
    view = np.lib.stride_tricks.sliding_window_view(x, win)[::hop]
    power = np.empty(count)
    for start in range(0, count, _BLOCK_FRAMES):
        block = view[start:start + _BLOCK_FRAMES].astype(np.float64)
        power[start:start + len(block)] = np.mean(block * block, axis=1)
    times = (np.arange(count) * hop + 0.5 * win) / rate
    return times, 10.0 * np.log10(np.maximum(power, 1e-12))


def _approximating_spline(times: np.ndarray, db: np.ndarray) -> np.ndarray:
    """A least-squares cubic B-spline through the frame power with a knot every :data:`_KNOT_S` (fine
    enough for syllables, ~4 per second), read back at the frames: linear in the length (FITPACK's
    smoothing spline and make_lsq_spline took 13 s on 10 minutes, this 0.1 s)."""
    inner = np.arange(times[0] + _KNOT_S, times[-1] - 0.5 * _KNOT_S, _KNOT_S)
    return splev(times, splrep(times, db, k=3, task=-1, t=inner))


def loudness_curve(samples: np.ndarray, rate: int, settings: LoudnessSettings | None = None) -> Loudness:
    """The relative loudness of ``samples`` (module docstring); a signal too short for a spline, or
    without any maximum, gives a flat curve of ones (nothing scaled)."""
    settings = settings or LoudnessSettings()
    times, db = windowed_power(samples, rate, settings.window_s, settings.hop_s)
    if times.size < 8 or times[-1] - times[0] < 3 * _KNOT_S:
        return Loudness(np.array([0.0]), np.array([1.0]), np.zeros(0))
    # silence below two ranges under the loudest frame is all the same (no -120 dB pits for the spline)
    smooth = _approximating_spline(times, np.maximum(db, db.max() - 2.0 * settings.range_db))
    slope = np.diff(smooth)
    peaks = np.nonzero((slope[:-1] > 0) & (slope[1:] <= 0))[0] + 1
    # the syllables' maxima: the highest within +-_SYLLABLE_S, and not the noise of a pause (2 ranges down)
    reach = max(1, int(round(_SYLLABLE_S / settings.hop_s)))
    highest = maximum_filter1d(smooth, 2 * reach + 1, mode="nearest")
    peaks = peaks[(smooth[peaks] >= highest[peaks]) & (smooth[peaks] >= smooth.max() - 2.0 * settings.range_db)]
    if peaks.size == 0:
        return Loudness(times, np.ones_like(times), np.zeros(0))
    peak_t, peak_db = times[peaks], smooth[peaks]
    envelope = (PchipInterpolator(peak_t, peak_db, extrapolate=False)(times) if peaks.size > 1
                else np.full_like(times, peak_db[0]))
    envelope = np.where(times < peak_t[0], peak_db[0], np.where(times > peak_t[-1], peak_db[-1], envelope))
    values = np.clip(1.0 - (peak_db.max() - envelope) / settings.range_db, 0.0, 1.0)
    return Loudness(times, values, peak_t)


def scale_tracks(tracks: TrackSet, loudness: Loudness, settings: LoudnessSettings,
                 ranges: Mapping[str, tuple[float, float]] | None = None) -> TrackSet:
    """Every track scaled by ``1 - w + w * loudness(t)`` with its own weight ``w`` (``settings.weight``),
    then clipped to ``ranges`` where given; weight-0 tracks come back unchanged."""
    out = TrackSet()
    for track in tracks:
        w = settings.weight(track.name)
        if w <= 0.0:
            out.add(track)
            continue
        values = track.values * (1.0 - w + w * loudness.sample(track.times))
        if ranges and track.name in ranges:
            values = np.clip(values, *ranges[track.name])
        out.add(Track(track.name, track.times, values))
    return out
