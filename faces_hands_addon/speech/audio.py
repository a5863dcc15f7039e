# SPDX-License-Identifier: GPL-3.0-or-later
"""Recorded audio in: WAV / FLAC / OGG through soundfile (libsndfile), any rate, mono or stereo,
16/24/32-bit integer or float, mixed to mono and resampled for analysis (16 kHz, what the
pocketsphinx en-us acoustic model and :mod:`speech.pitch` expect)."""
from __future__ import annotations

import os
from math import gcd

import numpy as np
from scipy.signal import resample_poly

from ..errors import UserError

ANALYSIS_RATE = 16000


def load_audio(path: str | os.PathLike) -> tuple[np.ndarray, int]:
    """``(mono float32 samples in [-1, 1], sample rate)`` of an audio file.

    Raises :class:`UserError` for a missing, unreadable, corrupt or empty file."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise UserError(f"audio file {path!r} does not exist")
    try:
        import soundfile  # noqa: PLC0415 - bundled wheel, imported when audio is read
    except Exception as exc:  # pragma: no cover - the wheel ships with the add-on
        raise UserError(f"cannot read audio: the soundfile module is missing ({exc})") from None
    try:
        data, rate = soundfile.read(path, dtype="float32", always_2d=True)
    except Exception as exc:  # soundfile raises LibsndfileError / RuntimeError / TypeError
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise UserError(f"cannot read audio file {os.path.basename(path)!r} ({reason}); "
                        "use a WAV, FLAC or OGG file") from None
    if data.shape[0] == 0:
        raise UserError(f"audio file {os.path.basename(path)!r} has no samples (zero length)")
    mono = data.mean(axis=1, dtype=np.float64).astype(np.float32)
    if not np.all(np.isfinite(mono)):
        raise UserError(f"audio file {os.path.basename(path)!r} contains invalid (NaN/inf) samples")
    return mono, int(rate)


def as_mono(samples: np.ndarray) -> np.ndarray:
    """Float32 mono from a (frames,) or (frames, channels) array of floats or integers."""
    array = np.asarray(samples)
    if array.ndim == 2:
        if np.issubdtype(array.dtype, np.integer):
            array = array.astype(np.float64) / float(np.iinfo(array.dtype).max + 1)
        array = array.mean(axis=1)
    elif np.issubdtype(array.dtype, np.integer):
        array = array.astype(np.float64) / float(np.iinfo(array.dtype).max + 1)
    if array.ndim != 1:
        raise UserError("audio samples must be a 1-D (mono) or 2-D (frames, channels) array")
    return array.astype(np.float32)


def to_analysis_rate(samples: np.ndarray, sample_rate: int, target: int = ANALYSIS_RATE) -> np.ndarray:
    """Polyphase resampling (scipy ``resample_poly``) of mono float samples to ``target`` Hz."""
    if sample_rate <= 0:
        raise UserError(f"invalid sample rate {sample_rate}")
    if sample_rate == target:
        return np.asarray(samples, dtype=np.float32)
    g = gcd(int(sample_rate), int(target))
    return resample_poly(np.asarray(samples, dtype=np.float32), target // g, int(sample_rate) // g).astype(np.float32)


def to_int16(samples: np.ndarray) -> np.ndarray:
    return (np.clip(samples, -1.0, 32767 / 32768) * 32768.0).astype(np.int16)


def save_wav(path: str | os.PathLike, samples: np.ndarray, sample_rate: int) -> None:
    """Write mono float samples as a 16-bit WAV (e.g. the audio of a synthesised Utterance, to put
    beside a baked animation: thesis 3.1.4, audio and animation come from the same timing)."""
    try:
        import soundfile  # noqa: PLC0415
    except Exception as exc:  # pragma: no cover
        raise UserError(f"cannot write audio: the soundfile module is missing ({exc})") from None
    try:
        soundfile.write(os.fspath(path), np.asarray(samples, dtype=np.float32), int(sample_rate), subtype="PCM_16")
    except Exception as exc:
        raise UserError(f"cannot write {os.fspath(path)!r} ({exc})") from None
