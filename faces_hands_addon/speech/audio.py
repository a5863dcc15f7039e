# SPDX-License-Identifier: GPL-3.0-or-later
"""Recorded audio in: WAV / FLAC / OGG through soundfile (libsndfile), any rate, mono or stereo,
16/24/32-bit integer or float, mixed to mono and resampled for analysis (16 kHz, what the
pocketsphinx en-us acoustic model and :mod:`speech.pitch` expect)."""
from __future__ import annotations

import os
from dataclasses import dataclass
from math import gcd

import numpy as np
from scipy.signal import resample_poly

from ..core.errors import UserError
from ..core.foreign_files import check_path

ANALYSIS_RATE = 16000
MAX_TAKE_SECONDS = 3600.0        # one take: an hour of speech (longer recordings: split them into takes)
MAX_DECODED_BYTES = 4_000_000_000   # float32 samples of all channels, checked from the header before decoding
SOFTWARE = "Faces & Hands"       # the WAV "software" tag that marks files this extension wrote


@dataclass(frozen=True)
class AudioHeader:
    """What an audio file's header says, read without decoding its samples."""
    frames: int
    sample_rate: int
    channels: int
    software: str

    @property
    def duration(self) -> float:
        return self.frames / self.sample_rate if self.sample_rate > 0 else 0.0

    @property
    def written_here(self) -> bool:
        """The file carries this extension's software tag (a WAV written beside a take)."""
        return self.software.startswith(SOFTWARE)


def _soundfile():
    try:
        import soundfile  # noqa: PLC0415 - bundled wheel, imported when audio is read
    except Exception as exc:  # pragma: no cover - the wheel ships with the add-on
        raise UserError(f"cannot read or write audio: the soundfile module is missing ({exc})") from None
    return soundfile


def _reason(exc: Exception) -> str:
    return str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__


def audio_header(path: str | os.PathLike) -> AudioHeader:
    """The header of an audio file (length, rate, channels), checked against the take limits before any
    work: an hour at most, and at most ``MAX_DECODED_BYTES`` once decoded. Instant even for huge files."""
    path = os.fspath(check_path(path, "the audio file"))
    name = os.path.basename(path)
    try:
        with _soundfile().SoundFile(path) as handle:
            header = AudioHeader(int(handle.frames), int(handle.samplerate), int(handle.channels),
                                 str(handle.software or ""))
    except UserError:
        raise
    except Exception as exc:  # soundfile raises LibsndfileError / RuntimeError / TypeError
        raise UserError(f"cannot read audio file {name!r} ({_reason(exc)}); use a WAV, FLAC or OGG file") from None
    if header.frames <= 0 or header.sample_rate <= 0:
        raise UserError(f"audio file {name!r} has no samples (zero length)")
    if header.duration > MAX_TAKE_SECONDS:
        raise UserError(f"audio file {name!r} is {header.duration / 60:.1f} minutes long; one take may be at most "
                        f"{MAX_TAKE_SECONDS / 60:.0f} minutes: split the recording into takes")
    if header.frames * header.channels * 4 > MAX_DECODED_BYTES:
        raise UserError(f"audio file {name!r} would take {header.frames * header.channels * 4 / 1e9:.1f} GB "
                        f"decoded ({header.channels} channels); the limit is {MAX_DECODED_BYTES / 1e9:.0f} GB")
    return header


def written_here(path: str | os.PathLike) -> bool:
    """``path`` is an audio file this extension wrote (its software tag), so a new take may replace it."""
    try:
        with _soundfile().SoundFile(os.fspath(path)) as handle:
            return str(handle.software or "").startswith(SOFTWARE)
    except Exception:  # not audio, unreadable, missing: not ours
        return False


def load_audio(path: str | os.PathLike) -> tuple[np.ndarray, int]:
    """``(mono float32 samples in [-1, 1], sample rate)`` of an audio file.

    Raises :class:`UserError` for a missing, unreadable, corrupt, empty or too long file (the length is
    checked from the header first, ``audio_header``)."""
    path = os.fspath(path)
    audio_header(path)
    try:
        data, rate = _soundfile().read(path, dtype="float32", always_2d=True)
    except Exception as exc:  # soundfile raises LibsndfileError / RuntimeError / TypeError
        raise UserError(f"cannot read audio file {os.path.basename(path)!r} ({_reason(exc)}); "
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
    beside a baked animation: thesis 3.1.4, audio and animation come from the same timing), tagged with
    ``SOFTWARE`` so a later run knows it may replace the file."""
    samples = np.asarray(samples, dtype=np.float32)
    if not np.all(np.isfinite(samples)):
        raise UserError("the audio to write contains invalid (NaN/inf) samples")
    try:
        with _soundfile().SoundFile(os.fspath(path), "w", int(sample_rate), 1, "PCM_16", format="WAV") as handle:
            handle.software = SOFTWARE
            handle.write(samples)
    except Exception as exc:
        raise UserError(f"cannot write {os.fspath(path)!r} ({exc})") from None
