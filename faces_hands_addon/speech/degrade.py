# SPDX-License-Identifier: GPL-3.0-or-later
"""Seeded degradations of speech audio for accuracy measurements (tests, bench/lipsync_alignment.py).

Each function takes mono float samples and returns new ones of the same sample rate; none moves the
speech in time except ``change_speed``, whose labels scale by ``1 / factor``. Randomness comes from a
``numpy.random.Generator`` the caller seeds.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np
from scipy.signal import butter, fftconvolve, resample_poly, sosfiltfilt


def _peak_safe(samples: np.ndarray) -> np.ndarray:
    peak = float(np.max(np.abs(samples))) if samples.size else 0.0
    return (samples / peak * 0.99 if peak > 0.99 else samples).astype(np.float32)


def add_noise(samples: np.ndarray, snr_db: float, rng: np.random.Generator) -> np.ndarray:
    """White Gaussian noise at ``snr_db`` relative to the whole clip's mean power."""
    x = np.asarray(samples, dtype=np.float64)
    noise = rng.standard_normal(x.size)
    gain = np.sqrt(np.mean(x ** 2) / (np.mean(noise ** 2) * 10.0 ** (snr_db / 10.0)))
    return _peak_safe(x + gain * noise)


def band_limit(samples: np.ndarray, sample_rate: int, low_hz: float = 300.0, high_hz: float = 3400.0,
               order: int = 4) -> np.ndarray:
    """Telephone band: a Butterworth band-pass run forwards and backwards (zero phase: no delay)."""
    sos = butter(order, [low_hz, high_hz], btype="bandpass", fs=sample_rate, output="sos")
    return _peak_safe(sosfiltfilt(sos, np.asarray(samples, dtype=np.float64)))


def change_speed(samples: np.ndarray, factor: float) -> np.ndarray:
    """Play ``factor`` times faster by resampling (pitch moves too, like a tape): the result is
    ``1 / factor`` as long and every label time scales by ``1 / factor``."""
    ratio = Fraction(1.0 / factor).limit_denominator(200)
    return _peak_safe(resample_poly(np.asarray(samples, dtype=np.float64), ratio.numerator, ratio.denominator))


def reverberate(samples: np.ndarray, sample_rate: int, rt60_s: float, rng: np.random.Generator,
                direct_to_reverb_db: float = 0.0) -> np.ndarray:
    """Convolve with a synthetic room: a unit direct path at t = 0 plus Gaussian noise under an
    exponential decay reaching -60 dB at ``rt60_s``, scaled to ``direct_to_reverb_db``; the tail past
    the clip's end is cut."""
    n = int(round(rt60_s * sample_rate))
    t = np.arange(n) / sample_rate
    tail = rng.standard_normal(n) * np.exp(-6.9078 * t / rt60_s)
    tail[0] = 0.0
    tail *= 10.0 ** (-direct_to_reverb_db / 20.0) / np.sqrt(np.sum(tail ** 2))
    response = tail
    response[0] = 1.0
    x = np.asarray(samples, dtype=np.float64)
    return _peak_safe(fftconvolve(x, response)[: x.size])
