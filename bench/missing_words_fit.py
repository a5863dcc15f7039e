# SPDX-License-Identifier: GPL-3.0-or-later
"""Fit the missing-word model of the transcript check (``speech/missing_words.py``) on labelled speech.

Recordings: the CALIBRATION sentences of ``bench/transcript_check.py`` and the EXTRA sentences here
(commas and longer phrases, where speakers pause), each spoken by Festival's CMU ARCTIC SLT HTS voice and
by one espeak-ng voice, clean and with seeded white noise at 10 dB SNR. Each is aligned (the real
``align_audio``) with its correct transcript and with every middle word (EXTRA: three of them) left out
in turn; the features of every word boundary (``missing_words.boundary_features``) are recorded, labelled
1 at the boundary where the left-out word belongs and 0 everywhere else (every boundary of the correct
transcripts, and the other boundaries of the shortened ones). Transcripts refused as a whole give no
boundaries.

The model is a logistic regression on the standardised features (L2 1e-3, full-batch gradient descent,
deterministic); its threshold is set so that ``--fpr`` (default 1 %) of the correct transcripts'
boundaries reach it. Leave-one-sentence-out cross-validation reports the share of left-out words named
at that rate. ``--write`` stores the model in ``presets/speech/transcript_check.json`` (then
``make install``); the held-out sentences are measured by ``bench/transcript_check.py``.

Run: ``make install`` then ``.venv/bin/python bench/missing_words_fit.py [--fpr 0.01] [--write]``. The
features are cached in the temp folder (``--reuse`` fits again without aligning). Last line: ``RESULT``.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)

import numpy as np  # noqa: E402
import soundfile  # noqa: E402
from transcript_check import CALIBRATION, phone_count, recordings, with_noise  # noqa: E402

from faces_hands_addon import UserError  # noqa: E402
from faces_hands_addon.speech import align_audio, missing_words  # noqa: E402

#: more sentences (commas and longer phrases, where speakers pause and lengthen words): the correct
#: transcript and EXTRA_LEFT_OUT middle words left out in turn
EXTRA = [
    "After the storm, the fishermen repaired their nets on the beach.",
    "If you finish your homework early, we can go to the cinema.",
    "The library is closed on Sundays, but the reading room stays open.",
    "My grandmother keeps her old letters in a wooden chest.",
    "When the bell rang, the pupils ran out into the yard.",
    "He painted the kitchen walls a pale shade of blue.",
    "Although it was late, the shop on the corner was still selling bread.",
    "The pilot announced a short delay before the plane took off.",
    "Two cats were sleeping on the warm roof of the garage.",
    "Please remember to water the plants while I am away.",
    "The river flooded the fields, and the farmers lost their crops.",
    "Our team scored twice in the last ten minutes of the game.",
]
EXTRA_LEFT_OUT = 3
ROOT = Path(__file__).resolve().parents[1]
PRESET = ROOT / "presets" / "speech" / "transcript_check.json"
CACHE = Path(tempfile.gettempdir()) / "missing_words_features.npz"
L2 = 1e-3


def collect(folder: Path):
    """Features, labels, row kind (1: a correct transcript's boundary) and sentence per boundary."""
    captured = {}
    original = missing_words.boundary_features

    def capture(*args, **kwargs):
        captured["features"] = original(*args, **kwargs)
        return captured["features"]

    missing_words.boundary_features = capture
    features, labels, correct, groups, phones = [], [], [], [], []
    sets = [(CALIBRATION, 0, None), (EXTRA, len(CALIBRATION), EXTRA_LEFT_OUT)]
    for sentences, first, limit in sets:
        (folder / f"set{first}").mkdir()
        for text, k, speaker, wav, _ in recordings(sentences, folder / f"set{first}"):
            k += first
            samples, rate = soundfile.read(str(wav), dtype="float64")
            words = text.rstrip(".").split()
            middle = list(range(1, len(words) - 1))
            if limit is not None:       # spread over the sentence: every third middle word or so
                middle = middle[k % 3::max(len(middle) // limit, 1)][:limit]
            for snr in (None, 10.0):
                _boundaries(captured, noisy_audio(samples, snr, k, speaker), rate, words, middle, k,
                            (features, labels, correct, groups, phones))
            print(f"  {speaker} #{k}: {sum(len(f) for f in features)} boundaries so far", flush=True)
    missing_words.boundary_features = original
    return tuple(np.concatenate(x) for x in (features, labels, correct, groups, phones))


def noisy_audio(samples, snr, k, speaker):
    return with_noise(samples, snr, 1000 * k + 10 * len(speaker) + int(snr or 0)).astype(np.float32)


def _boundaries(captured, audio, rate, words, middle, k, out) -> None:
    """Align ``audio`` with its transcript and with each ``middle`` word left out; append the boundaries'
    features, labels, kinds, sentence and left-out phone counts to the lists of ``out``."""
    features, labels, correct, groups, phones = out
    for left_out in [None] + middle:
        kept = words if left_out is None else words[:left_out] + words[left_out + 1:]
        captured.clear()
        try:
            align_audio(audio, " ".join(kept) + ".", sample_rate=rate)
        except UserError:
            continue
        rows = captured.get("features")
        if rows is None or len(rows) != len(kept) - 1:
            continue
        label = np.zeros(len(rows))
        if left_out is not None:
            label[left_out - 1] = 1.0
        features.append(rows)
        labels.append(label)
        correct.append(np.full(len(rows), left_out is None))
        groups.append(np.full(len(rows), k))
        phones.append(np.full(len(rows), phone_count(words[left_out]) if left_out else 0))


def fit(x: np.ndarray, y: np.ndarray):
    """Logistic regression on standardised features: (mean, scale, weights, bias)."""
    mean, scale = x.mean(axis=0), x.std(axis=0)
    scale = np.where(scale > 1e-9, scale, 1.0)
    z = (x - mean) / scale
    weights, bias = np.zeros(x.shape[1]), 0.0
    for _ in range(4000):
        p = 1.0 / (1.0 + np.exp(-(z @ weights + bias)))
        error = p - y
        weights -= 0.2 * (z.T @ error / len(y) + L2 * weights)
        bias -= 0.2 * float(error.mean())
    return mean, scale, weights, bias


def score(model, x):
    mean, scale, weights, bias = model
    return (x - mean) / scale @ weights + bias


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--fpr", type=float, default=0.01, help="share of correct boundaries named (default 0.01)")
    parser.add_argument("--write", action="store_true", help="store the model in presets/speech/transcript_check.json")
    parser.add_argument("--reuse", action="store_true", help="fit the cached features again without aligning")
    args = parser.parse_args()
    started = time.perf_counter()
    if args.reuse and CACHE.is_file():
        data = np.load(CACHE)
        x, y, correct, groups, phones = (data[k] for k in ("x", "y", "correct", "groups", "phones"))
    else:
        with tempfile.TemporaryDirectory() as tmp:
            x, y, correct, groups, phones = collect(Path(tmp))
        np.savez(CACHE, x=x, y=y, correct=correct, groups=groups, phones=phones)
    candidates = correct | (y == 1)      # the other boundaries of shortened transcripts are not clean negatives
    cv = np.zeros(len(y))
    for group in np.unique(groups):
        train = candidates & (groups != group)
        cv[groups == group] = score(fit(x[train], y[train]), x[groups == group])
    cv_threshold = np.quantile(cv[correct], 1.0 - args.fpr)
    named = cv[y == 1] >= cv_threshold
    short = phones[y == 1] <= 2
    model = fit(x[candidates], y[candidates])
    threshold = float(np.quantile(score(model, x[correct]), 1.0 - args.fpr))
    print(f"{int(correct.sum())} boundaries of correct transcripts, {int(y.sum())} left-out words "
          f"({int(short.sum())} of 1-2 phones); {time.perf_counter() - started:.0f} s")
    print(f"cross-validated (leave one sentence out) at {args.fpr:.1%} of correct boundaries: named "
          f"{named.mean():.1%} of left-out words ({named[short].mean():.1%} of 1-2 phones, "
          f"{named[~short].mean():.1%} of 3+)")
    block = {"features": list(missing_words.FEATURES), "mean": np.round(model[0], 6).tolist(),
             "scale": np.round(model[1], 6).tolist(), "weights": np.round(model[2], 6).tolist(),
             "bias": round(float(model[3]), 6), "threshold": round(threshold, 6)}
    print(json.dumps(block))
    if args.write:
        doc = json.loads(PRESET.read_text())
        doc["missing_word"] = block
        PRESET.write_text(json.dumps(doc, indent=2) + "\n")
        print(f"wrote {PRESET}")
    print(f"RESULT boundaries={len(y)} left_out={int(y.sum())} cv_named_pct={100 * named.mean():.1f} "
          f"cv_named_short_pct={100 * named[short].mean():.1f} cv_named_long_pct={100 * named[~short].mean():.1f} "
          f"fpr={args.fpr}")


if __name__ == "__main__":
    main()
