# SPDX-License-Identifier: GPL-3.0-or-later
"""Forced-alignment accuracy against references our aligner (pocketsphinx) never produced.

Ground truth:
* Festival 2.5 with the CMU ARCTIC SLT HTS voice (Debian ``festival`` + ``festvox-us-slt-hts``) speaks
  each sentence; its segment times (``segment_start``/``end`` of every Segment item) and word times
  (start of a word's first segment, end of its last) are where the HTS duration model placed them, so the
  waveform follows them. ``festival_labels`` of scripts/speech_fixtures.py runs it.
* espeak-ng through the extension's own ``synthesize``: its phone and word times are the synthesiser's
  phoneme events (ground truth for its own audio; the aligner sees only the samples).

Conditions (all seeded, numpy/scipy, ``faces_hands_addon.speech.degrade``): clean; white noise at 20 and
10 dB SNR; telephone band (300-3400 Hz Butterworth band-pass, zero phase); speed 0.9x and 1.1x by
resampling (labels scaled by 1/speed); reverb (a synthetic room: direct path + exponentially decaying
Gaussian noise, RT60 0.4 s, direct-to-reverberant 0 dB).

Metrics: word-boundary error = |aligned - reference| of every word's start and end (the words must be
the same sequence); word-onset error = starts only. Phone-onset error = |aligned - reference| start of
phones paired by a Needleman-Wunsch alignment over the unified phone inventory
(``faces_hands_addon.speech.evaluation.pair_phones``: equal phones cost 0, same viseme 0.5, same kind
1, else 2, gap 1; only pairs of equal phones or equal visemes are compared; pauses are left out).
Festival's radio phones map onto the unified inventory through ``festival_phone`` (ARPAbet in lower
case; pau -> sil; syllabic el/em/en -> l/m/n; hv -> hh; dx -> d). Per condition: median, 90th
percentile, share within 20 and 50 ms, and how many sentences the aligner refused (a refusal is the
transcript check saying the words do not fit the audio; those sentences add no errors).

Runs the extension installed by ``make install`` (``_harness.py``):
``.venv/bin/python bench/lipsync_alignment.py``. Last line: ``RESULT key=value ...``.
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)

import numpy as np  # noqa: E402

from faces_hands_addon import UserError  # noqa: E402
from faces_hands_addon.speech import align_audio, synthesize  # noqa: E402
from faces_hands_addon.speech import degrade  # noqa: E402
from faces_hands_addon.speech.evaluation import (error_summary, labelled_phones, signed_phone_onsets,  # noqa: E402
                                                 word_timing_errors)
from speech_fixtures import festival_labels, to_16k  # noqa: E402  (scripts/, on the path via _harness)

RATE = 16000
SEED = 2005
FESTIVAL_SENTENCES = [
    "Papa made a map, and Bob bought a bumpy boat.",
    "Maybe the baby will bump the blue ball by the pool.",
    "Put the paper bag on the top of the map.",
    "My mother brought plump plums home from the market.",
    "Please pass the pepper and a bowl of beans.",
    "The big brown bear was bumping into the maple tree.",
    "Patrick played the piano at the small pub by the harbour.",
    "Ben and Pam met a man from Memphis at the museum.",
    "The poem was about a boy who lived by the sea.",
    "Bring me the basket before the bus comes.",
    "The lamp above the bed is a bit too bright.",
    "Can you show me the way to the conference hall?",
    "She sells sea shells on the shore every summer.",
    "Thick fog rolled over the quiet harbour at dawn.",
    "Will you let the children feed the goats tomorrow?",
    "A cold wind was blowing through the narrow streets.",
    "Nobody noticed the little yellow car outside the church.",
    "The teacher asked the students to read the first chapter.",
    "Good judgement comes from experience, and experience comes from bad judgement.",
    "We walked along the river until the sun went down.",
    "Fresh vegetables are sold at the village market on Fridays.",
    "How long does it take to drive across the whole country?",
]
ESPEAK_SENTENCES = [
    "The quick brown fox jumps over the lazy dog.",
    "Albrecht built a talking head with lips, jaw and tongue.",
    "Would you like to hear the poem about the parallel lines once more?",
    "Every sound borrows a little of its neighbours.",
    "Peter Piper picked a peck of pickled peppers.",
]
CONDITIONS = ["clean", "noisy20", "noisy10", "telephone", "speed09", "speed11", "reverb"]


def degraded(samples: np.ndarray, condition: str, seed: int) -> tuple[np.ndarray, float]:
    """(audio, label time scale) of ``condition``."""
    rng = np.random.default_rng(seed)
    if condition == "clean":
        return samples, 1.0
    if condition.startswith("noisy"):
        return degrade.add_noise(samples, float(condition[5:]), rng), 1.0
    if condition == "telephone":
        return degrade.band_limit(samples, RATE), 1.0
    if condition.startswith("speed"):
        factor = int(condition[5:]) / 10
        return degrade.change_speed(samples, factor), 1.0 / factor
    if condition == "reverb":
        return degrade.reverberate(samples, RATE, 0.4, rng), 1.0
    raise ValueError(condition)


def festival_items(folder: Path):
    for k, text in enumerate(FESTIVAL_SENTENCES):
        wav, phones, words = festival_labels(text, folder, f"s{k:02d}")
        yield text, to_16k(wav).astype(np.float32), labelled_phones(phones), words


def espeak_items():
    from scipy.signal import resample_poly
    for text in ESPEAK_SENTENCES:
        spoken = synthesize(text)
        g = np.gcd(RATE, spoken.sample_rate)
        samples = resample_poly(spoken.samples, RATE // g, spoken.sample_rate // g).astype(np.float32)
        yield text, samples, spoken.phones, [(w.text, w.start, w.end) for w in spoken.words]


def measure(items, label: str):
    """Per condition: word-boundary, word-onset and phone-onset errors (s), refusals, audio s, align s."""
    out = {c: {"word": [], "onset": [], "phone": [], "signed": [], "refused": 0, "skipped": 0,
               "audio_s": 0.0, "align_s": 0.0} for c in CONDITIONS}
    for k, (text, samples, phones, words) in enumerate(items):
        for c, condition in enumerate(CONDITIONS):
            audio, scale = degraded(samples, condition, SEED + 100 * k + c)
            row = out[condition]
            row["audio_s"] += len(audio) / RATE
            started = time.perf_counter()
            try:
                aligned = align_audio(audio, text, sample_rate=RATE)
            except UserError as exc:
                row["refused"] += 1
                print(f"  {label} {condition}: refused {text!r}: {exc}")
                continue
            finally:
                row["align_s"] += time.perf_counter() - started
            reference = [(w, a * scale, b * scale) for w, a, b in words]
            try:
                onsets, ends = word_timing_errors(reference, aligned.words)
            except ValueError as exc:
                row["skipped"] += 1
                print(f"  {label} {condition}: skipped {text!r}: {exc}")
                continue
            scaled = [type(p)(p.symbol, p.phone, p.start * scale, p.duration * scale) for p in phones]
            row["word"] += list(onsets) + list(ends)
            row["onset"] += list(onsets)
            row["signed"] += list(onsets)
            row["phone"] += list(signed_phone_onsets(scaled, aligned.phones))
    return out


def table(results, label: str, sentences: int) -> None:
    print(f"\n{label}: {sentences} sentences; errors in ms (p50 / p90), shares within 20 / 50 ms in %")
    print(f"{'condition':<10} {'refused':>7} {'word n':>6} {'word p50':>8} {'p90':>6} {'<=20':>5} {'<=50':>5} "
          f"{'onset p50':>9} {'bias':>6} {'phone n':>7} {'phone p50':>9} {'p90':>6} {'<=20':>5} {'<=50':>5} "
          f"{'align RT':>8}")
    for condition in CONDITIONS:
        row = results[condition]
        w, o, p = (error_summary(row[k]) for k in ("word", "onset", "phone"))
        bias = 1000 * float(np.mean(row["signed"])) if row["signed"] else float("nan")
        print(f"{condition:<10} {row['refused']:>7} {w['n']:>6} {w['p50_ms']:>8.1f} {w['p90_ms']:>6.1f} "
              f"{w['within20_pct']:>5.1f} {w['within50_pct']:>5.1f} {o['p50_ms']:>9.1f} {bias:>+6.1f} "
              f"{p['n']:>7} {p['p50_ms']:>9.1f} {p['p90_ms']:>6.1f} {p['within20_pct']:>5.1f} "
              f"{p['within50_pct']:>5.1f} {row['align_s'] / max(row['audio_s'], 1e-9):>8.3f}")


def result_line(festival, espeak) -> str:
    keys = []
    for prefix, results in (("", festival), ("espeak_", espeak)):
        for condition in CONDITIONS:
            row = results[condition]
            w, p = error_summary(row["word"]), error_summary(row["phone"])
            tag = prefix if condition == "clean" else f"{prefix}{condition}_"
            keys += [f"{tag}word_p50_ms={w['p50_ms']:.1f}", f"{tag}word_p90_ms={w['p90_ms']:.1f}"]
            if condition == "clean" or prefix == "":
                keys += [f"{tag}word_within20_pct={w['within20_pct']:.1f}",
                         f"{tag}word_within50_pct={w['within50_pct']:.1f}"]
            keys += [f"{tag}phone_p50_ms={p['p50_ms']:.1f}", f"{tag}phone_p90_ms={p['p90_ms']:.1f}"]
            if row["refused"]:
                keys.append(f"{tag}refused={row['refused']}")
    return "RESULT " + " ".join(keys)


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        festival = measure(list(festival_items(Path(tmp))), "festival")
    espeak = measure(list(espeak_items()), "espeak")
    table(festival, "Festival cmu_us_slt_arctic_hts (HTS duration model times)", len(FESTIVAL_SENTENCES))
    table(espeak, "espeak-ng en-us via synthesize (phoneme event times)", len(ESPEAK_SENTENCES))
    print(result_line(festival, espeak))


if __name__ == "__main__":
    main()
