# SPDX-License-Identifier: GPL-3.0-or-later
"""Fundamental frequency (F0) of speech every 10 ms: a vectorised YIN tracker in numpy.

Thesis 4.2 and 4.3.5 drive head and eyebrow movement from the pitch contour ("(time, value) pairs ...
the local pitch extrema"); this module measures that contour on any audio, synthetic or recorded.

Method (de Cheveigne & Kawahara's YIN): per frame, the difference function
d(tau) = sum_j (x_j - x_{j+tau})^2 computed with FFT correlations, its cumulative-mean normalisation
d'(tau), the first dip of d' below a threshold (else the global minimum), parabolic interpolation,
then a voicing decision (d' minimum and frame energy) and a 5-frame median that removes single-frame
octave jumps. **Unvoiced frames are NaN** (not 0), so averages over voiced frames need ``np.nanmean``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import fft as sfft
from scipy.ndimage import median_filter
from scipy.signal import resample_poly

ANALYSIS_RATE = 16000


@dataclass(frozen=True)
class PitchContour:
    """F0 in Hz at ``times`` (seconds, frame centres every ``hop`` s); NaN where unvoiced."""

    times: np.ndarray
    f0_hz: np.ndarray
    hop: float = 0.01

    @property
    def voiced(self) -> np.ndarray:
        return np.isfinite(self.f0_hz)


def _to_analysis_rate(samples: np.ndarray, sample_rate: int) -> np.ndarray:
    if sample_rate == ANALYSIS_RATE:
        return samples.astype(np.float32, copy=False)
    g = np.gcd(int(sample_rate), ANALYSIS_RATE)
    return resample_poly(samples, ANALYSIS_RATE // g, int(sample_rate) // g).astype(np.float32)


def track_pitch(samples: np.ndarray, sample_rate: int, *, hop: float = 0.01, fmin: float = 60.0,
                fmax: float = 500.0, threshold: float = 0.15, voicing_limit: float = 0.35,
                silence_db: float = -40.0, block_frames: int = 2048) -> PitchContour:
    """F0 contour of mono ``samples`` (any rate; analysed at 16 kHz), one value per ``hop`` seconds.

    A frame is voiced when the normalised difference minimum is below ``voicing_limit`` and its
    energy is within ``silence_db`` of the loudest frame. Returns NaN for unvoiced frames."""
    x = _to_analysis_rate(np.asarray(samples, dtype=np.float32).reshape(-1), sample_rate)
    sr = ANALYSIS_RATE
    hop_n = int(round(hop * sr))
    n_frames = int(np.ceil(len(x) / hop_n)) if len(x) else 0
    times = np.arange(n_frames) * hop
    if n_frames == 0:
        return PitchContour(times, np.zeros(0), hop)
    tau_min = max(2, int(sr / fmax))
    tau_max = int(np.ceil(sr / fmin))
    window = tau_max + 2  # integration window: at least one period of fmin
    span = window + tau_max + 1
    nfft = 1 << int(np.ceil(np.log2(span + window)))
    padded = np.concatenate([np.zeros(window // 2, np.float32), x, np.zeros(span + hop_n, np.float32)])

    f0 = np.full(n_frames, np.nan)
    best = np.ones(n_frames)
    energy = np.zeros(n_frames)
    lags = np.arange(tau_max + 1)
    for first in range(0, n_frames, block_frames):
        count = min(block_frames, n_frames - first)
        starts = (first + np.arange(count)) * hop_n
        frames = padded[starts[:, None] + np.arange(span)[None, :]]
        frames = frames - frames[:, :window].mean(axis=1, keepdims=True)
        head = frames[:, :window]
        spec_full = sfft.rfft(frames, nfft, workers=-1)
        spec_head = sfft.rfft(head, nfft, workers=-1)
        corr = sfft.irfft(np.conj(spec_head) * spec_full, nfft, workers=-1)[:, :tau_max + 1].astype(np.float64)
        squares = np.concatenate([np.zeros((count, 1)), np.cumsum(frames.astype(np.float64) ** 2, axis=1)],
                                 axis=1)
        energy_at = squares[:, lags + window] - squares[:, lags]  # sum of x^2 over the lagged window
        diff = energy_at[:, :1] + energy_at - 2.0 * corr
        diff[:, 0] = 0.0
        cumulative = np.cumsum(diff[:, 1:], axis=1)
        norm = np.ones_like(diff)
        norm[:, 1:] = diff[:, 1:] * lags[1:] / np.maximum(cumulative, 1e-12)
        norm[:, :tau_min] = 2.0
        below = norm < threshold
        # first dip below the threshold, followed down to its local minimum
        has_dip = below.any(axis=1)
        first_dip = np.where(has_dip, below.argmax(axis=1), norm.argmin(axis=1))
        rising = np.ones_like(norm, dtype=bool)
        rising[:, :-1] = norm[:, 1:] >= norm[:, :-1]
        rising &= lags[None, :] >= first_dip[:, None]
        tau = rising.argmax(axis=1)  # the bottom of the dip that starts at first_dip
        rows = np.arange(count)
        left = norm[rows, np.clip(tau - 1, 0, tau_max)]
        mid = norm[rows, tau]
        right = norm[rows, np.clip(tau + 1, 0, tau_max)]
        denom = left - 2.0 * mid + right
        shift = np.where(np.abs(denom) > 1e-12, 0.5 * (left - right) / np.where(denom == 0, 1, denom), 0.0)
        shift = np.clip(shift, -1.0, 1.0)
        period = tau + shift
        f0[first:first + count] = sr / np.maximum(period, 1e-6)
        best[first:first + count] = mid
        energy[first:first + count] = squares[:, window] / window

    loud = energy > energy.max() * 10.0 ** (silence_db / 10.0) if energy.max() > 0 else np.zeros(n_frames, bool)
    voiced = (best < voicing_limit) & loud & (f0 >= fmin * 0.9) & (f0 <= fmax * 1.1)
    f0 = np.where(voiced, f0, np.nan)
    f0 = _median_voiced(f0, 5)
    return PitchContour(times, f0, hop)


def _median_voiced(f0: np.ndarray, size: int) -> np.ndarray:
    """Median filter over voiced frames only (unvoiced frames stay NaN)."""
    voiced = np.isfinite(f0)
    if voiced.sum() < size:
        return f0
    filled = np.where(voiced, f0, 0.0)
    smoothed = median_filter(filled, size=size, mode="nearest")
    # where the window mixed in unvoiced zeros, keep the raw value
    counts = np.convolve(voiced.astype(float), np.ones(size), mode="same")
    return np.where(voiced, np.where(counts >= size, smoothed, f0), np.nan)
