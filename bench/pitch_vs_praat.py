# SPDX-License-Identifier: GPL-3.0-or-later
"""Our F0 tracker (speech/pitch.py, YIN in numpy) against Praat's (through praat-parselmouth), on the same
audio in the same run.

Behaviour from recorded audio (thesis 4.2.1) needs the pitch every 10 ms and its extrema. Praat is the
phoneticians' reference tracker; it is a bench dependency only (``.venv/bin/pip install
praat-parselmouth``), never shipped. Audio: the Festival HTS sentences of ``mouth_cues.py`` (Debian
``festival`` + ``festvox-us-slt-hts``), clean and with white noise at 10 dB SNR, plus espeak-ng speech
of the same sentences. Both trackers get 60-500 Hz and a 10 ms step; Praat runs its default
autocorrelation method. Figures over frames both call voiced: median and p90 of |difference| in
semitones, the gross error rate (> 20 %, octave jumps), voicing agreement over all frames, and the time
each tracker takes. Last line: ``RESULT ...``.
"""
from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)

import numpy as np  # noqa: E402
import soundfile  # noqa: E402

from faces_hands_addon.speech import synthesize  # noqa: E402
from faces_hands_addon.speech.pitch import track_pitch  # noqa: E402
from mouth_cues import SENTENCES, add_noise, festival  # noqa: E402

FMIN, FMAX, HOP = 60.0, 500.0, 0.01


def praat_pitch(samples: np.ndarray, rate: int):
    import parselmouth
    pitch = parselmouth.Sound(samples.astype(np.float64), sampling_frequency=rate).to_pitch(
        time_step=HOP, pitch_floor=FMIN, pitch_ceiling=FMAX)
    f0 = pitch.selected_array["frequency"]
    return pitch.xs(), np.where(f0 > 0, f0, np.nan)


def compare(samples: np.ndarray, rate: int):
    started = time.perf_counter()
    ours = track_pitch(samples, rate, hop=HOP, fmin=FMIN, fmax=FMAX)
    our_s = time.perf_counter() - started
    started = time.perf_counter()
    times, praat = praat_pitch(samples, rate)
    praat_s = time.perf_counter() - started
    mine = np.interp(times, ours.times, np.nan_to_num(ours.f0_hz, nan=0.0))
    mine_voiced = np.interp(times, ours.times, ours.voiced.astype(float)) > 0.5
    mine = np.where(mine_voiced, mine, np.nan)
    both = np.isfinite(mine) & np.isfinite(praat)
    semitones = np.abs(12 * np.log2(mine[both] / praat[both]))
    gross = np.abs(mine[both] / praat[both] - 1) > 0.2
    agree = np.isfinite(mine) == np.isfinite(praat)
    return semitones, gross, agree, our_s, praat_s, len(samples) / rate


def main() -> None:
    try:
        import parselmouth  # noqa: F401
    except ImportError:
        sys.exit("needs praat-parselmouth in the bench venv: .venv/bin/pip install praat-parselmouth")
    if shutil.which("festival") is None:
        sys.exit("needs Debian's festival + festvox-us-slt-hts")
    folder = Path(tempfile.mkdtemp(prefix="fh-pitch-bench-"))
    rows = {"festival clean": [], "festival 10 dB": [], "espeak-ng": []}
    try:
        for index, text in enumerate(SENTENCES):
            wav, _, _ = festival(text, folder, f"p{index:02d}")
            noisy = add_noise(wav, folder / f"p{index:02d}_noisy.wav", 10.0, seed=index)
            for label, path in (("festival clean", wav), ("festival 10 dB", noisy)):
                samples, rate = soundfile.read(str(path), dtype="float64")
                rows[label].append(compare(samples, rate))
            utterance = synthesize(text)
            rows["espeak-ng"].append(compare(np.asarray(utterance.samples, dtype=np.float64),
                                             utterance.sample_rate))
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    print(f"{len(SENTENCES)} sentences per row; |ours - Praat| over frames both call voiced")
    print(f"{'audio':16} {'frames':>7} {'p50 st':>7} {'p90 st':>7} {'gross %':>8} {'voicing agree %':>16} "
          f"{'ours s':>7} {'Praat s':>8} {'audio s':>8}")
    figures = {}
    for label, results in rows.items():
        semitones = np.concatenate([r[0] for r in results])
        gross = np.concatenate([r[1] for r in results])
        agree = np.concatenate([r[2] for r in results])
        our_s, praat_s, audio_s = (sum(r[k] for r in results) for k in (3, 4, 5))
        print(f"{label:16} {len(semitones):7d} {np.median(semitones):7.2f} {np.percentile(semitones, 90):7.2f} "
              f"{100 * gross.mean():8.1f} {100 * agree.mean():16.1f} {our_s:7.2f} {praat_s:8.2f} {audio_s:8.1f}")
        figures[label] = (np.median(semitones), np.percentile(semitones, 90), 100 * gross.mean(), 100 * agree.mean())
    clean, noisy, espeak = figures["festival clean"], figures["festival 10 dB"], figures["espeak-ng"]
    print(f"RESULT p50_st={clean[0]:.3f} p90_st={clean[1]:.3f} gross_pct={clean[2]:.2f} voicing_agree_pct={clean[3]:.1f} "
          f"noisy_p50_st={noisy[0]:.3f} noisy_gross_pct={noisy[2]:.2f} noisy_voicing_agree_pct={noisy[3]:.1f} "
          f"espeak_p50_st={espeak[0]:.3f} espeak_gross_pct={espeak[2]:.2f}")


if __name__ == "__main__":
    main()
