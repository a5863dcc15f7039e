# SPDX-License-Identifier: GPL-3.0-or-later
"""The transcript check of audio lip sync (``speech/transcript_check.py``) on a labelled set.

Recordings: every sentence is spoken by Festival's CMU ARCTIC SLT HTS voice (Debian ``festival`` +
``festvox-us-slt-hts``) and by one espeak-ng voice (the extension's own synthesis, voices in turn).
Conditions per recording (white noise seeded per recording and condition, SNR over the whole file):

* correct transcript, clean, 20 dB and 10 dB SNR -> must be accepted (no refusal);
* wrong transcript (another sentence of the same set), clean and 10 dB -> must be refused;
* one word left out of the transcript (the speaker says it), clean and 10 dB -> a warning must name
  the place (a gap "between 'a' and 'b'" or a neighbouring word as not matching);
* one word added to the transcript (not spoken), clean and 10 dB -> a warning must name that word;
* silence and non-speech (digital silence, hiss, white and brown noise, mains hum; with a transcript
  and without) -> must be refused.

No-transcript mode (phone recognition) runs on the clean correct recordings: its non-pause phones are
counted against Festival's/espeak's own phone count, with the longest phone it reports.

``--calibrate`` runs the CALIBRATION sentences and prints the raw scores (word confidences, gaps, level
spreads) the thresholds in ``transcript_check.py`` were read from; without it the HELD-OUT sentences
are measured with the thresholds as committed. Last line: ``RESULT ...``.
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)

import numpy as np  # noqa: E402
import soundfile  # noqa: E402
from scipy.signal import lfilter  # noqa: E402

from faces_hands_addon import UserError  # noqa: E402
from faces_hands_addon.speech import align_audio, synthesize  # noqa: E402
from faces_hands_addon.speech import transcript_check  # noqa: E402
from faces_hands_addon.speech.tts import pronounce  # noqa: E402

CALIBRATION = [
    "The quick brown fox jumps over the lazy dog.",
    "Please call Stella and ask her to bring these things from the store.",
    "My mother brought plump plums home from the market.",
    "The old man walked slowly along the river in the rain.",
    "We will meet at the station at seven tomorrow morning.",
    "She opened the window and looked at the garden below.",
    "A cold wind was blowing across the empty field.",
    "The children played football in the park after school.",
    "He forgot his keys on the kitchen table again.",
    "The little girl drew a picture of her yellow house.",
    "They sailed across the lake in a small wooden boat.",
    "Nobody knew where the strange letter had come from.",
]
HELD_OUT = [
    "The doctor told him to drink more water every day.",
    "Our neighbours are painting their fence bright green.",
    "I would like a cup of tea with milk and sugar.",
    "The train was late because of the heavy snow.",
    "Put the paper bag on the top of the shelf.",
    "Her brother plays the violin in the city orchestra.",
    "The museum opens at nine and closes at five.",
    "We found an old map hidden inside the book.",
    "The farmer sold fresh eggs at the village market.",
    "Turn left at the bridge and follow the road north.",
    "The cat slept all afternoon beside the warm fire.",
    "Many people gathered in the square to hear the music.",
    "He carried the heavy box up the narrow stairs.",
    "The teacher asked the students to read the first chapter.",
]
ESPEAK_VOICES = ["en-us", "en-us+f3", "en", "en-us+m3"]
ADDED = ["yesterday", "purple", "quietly", "elephant", "certainly", "banana", "tonight"]
SNRS = {"clean": None, "20dB": 20.0, "10dB": 10.0}
#: the transcript check's warnings that name words (a false alarm on a correct transcript)
WORD_WARNINGS = ("do not match", "not in the transcript", "not in the recording", "far longer",
                 "missing from the transcript")


def festival(text: str, wav: Path) -> Path:
    script = wav.with_suffix(".scm")
    script.write_text(f'(voice_cmu_us_slt_arctic_hts)\n(set! utt (utt.synth (Utterance Text "{text}")))\n'
                      f'(utt.save.wave utt "{wav}" \'riff)\n(utt.save.segs utt "{wav.with_suffix(".segs")}")\n')
    subprocess.run(["festival", "-b", str(script)], check=True, capture_output=True)
    segs = [line.split()[2] for line in wav.with_suffix(".segs").read_text().splitlines()
            if len(line.split()) == 3 and line.split()[2] not in ("pau", "#")]
    return wav, len(segs)


def espeak(text: str, voice: str, wav: Path):
    spoken = synthesize(text, voice=voice)
    soundfile.write(str(wav), spoken.samples, spoken.sample_rate, subtype="PCM_16")
    return wav, sum(not p.is_pause for p in spoken.phones)


def with_noise(samples: np.ndarray, snr_db, seed: int) -> np.ndarray:
    if snr_db is None:
        return samples
    noise = np.random.default_rng(seed).standard_normal(len(samples))
    gain = np.sqrt(np.mean(samples ** 2) / (np.mean(noise ** 2) * 10 ** (snr_db / 10)))
    mixed = samples + gain * noise
    return mixed / max(1.0, np.abs(mixed).max())


def non_speech(seed: int) -> dict[str, np.ndarray]:
    """4 s at 16 kHz: silence, hiss, white and brown noise, mains hum (seeded)."""
    rng = np.random.default_rng(seed)
    t = np.arange(64000) / 16000
    brown = lfilter([1.0], [1.0, -0.995], rng.standard_normal(64000))
    return {"digital_silence": np.zeros(64000), "hiss_-60dBFS": rng.standard_normal(64000) * 1e-3,
            "white_-20dBFS": rng.standard_normal(64000) * 0.1,
            "brown_noise": 0.3 * brown / np.abs(brown).max(),
            "hum_50Hz": 0.2 * sum(np.sin(2 * np.pi * 50 * k * t) / k for k in (1, 2, 3))}


def edits(text: str, k: int):
    """The transcript with one middle word left out (returns it and the neighbours) or one word added."""
    words = text.rstrip(".").split()
    drop = 1 + k % (len(words) - 2)
    dropped = " ".join(words[:drop] + words[drop + 1:]) + "."
    neighbours = {words[drop - 1].lower(), words[drop + 1].lower()}
    add_at = 1 + (k * 3) % (len(words) - 1)
    extra = ADDED[k % len(ADDED)]
    added = " ".join(words[:add_at] + [extra] + words[add_at:]) + "."
    return dropped, neighbours, added, extra, words[drop]


def phone_count(word: str) -> int:
    """How many phones espeak-ng says ``word`` with (a left-out 1-2 phone function word is the hard case)."""
    return sum(len(phones) for phones in pronounce(word).values())


def run(audio, transcript, rate=16000):
    started = time.perf_counter()
    try:
        utterance = align_audio(audio, transcript, sample_rate=None if isinstance(audio, str) else rate)
        return {"refused": False, "warnings": utterance.warnings, "seconds": time.perf_counter() - started,
                "utterance": utterance}
    except UserError as exc:
        return {"refused": True, "warnings": [str(exc)], "seconds": time.perf_counter() - started}


def named(result, names) -> bool:
    text = " ".join(result["warnings"]).lower()
    return not result["refused"] and any(f"'{n.lower()}'" in text for n in names)


def recordings(sentences, folder: Path):
    out = []
    for k, text in enumerate(sentences):
        out.append((text, k, "festival", *festival(text, folder / f"f{k}.wav")))
        voice = ESPEAK_VOICES[k % len(ESPEAK_VOICES)]
        out.append((text, k, f"espeak:{voice}", *espeak(text, voice, folder / f"e{k}.wav")))
    return out


def evaluate(sentences, folder: Path, fits: list):
    """Every condition on every recording; returns per-condition lists of booleans (success) and times."""
    ok: dict[str, list[bool]] = {}
    times: list[float] = []
    phone_counts = []

    def record(condition, item, result, success, extra=None):
        ok.setdefault(condition, []).append(success)
        times.append(result["seconds"])
        fits.append({"condition": condition, "item": item, "refused": result["refused"],
                     "warnings": result["warnings"], "fit": _LAST.pop("fit", None), **(extra or {})})

    for text, k, speaker, wav, reference_phones in recordings(sentences, folder):
        samples, rate = soundfile.read(str(wav), dtype="float64")
        item = f"{speaker} #{k}"
        wrong = sentences[(k + 1) % len(sentences)]
        dropped, neighbours, added, extra, left_out = edits(text, k)
        for name, snr in SNRS.items():
            seed = 1000 * k + 10 * len(speaker) + int(snr or 0)
            noisy = folder / f"{wav.stem}_{name}.wav"
            soundfile.write(str(noisy), with_noise(samples, snr, seed), rate, subtype="PCM_16")
            result = run(str(noisy), text)
            record(f"correct_{name}", item, result, not result["refused"])
            if name == "20dB":
                continue
            result = run(str(noisy), wrong)
            record(f"wrong_{name}", item, result, result["refused"])
            result = run(str(noisy), dropped)
            record(f"missing_{name}", item, result, named(result, neighbours),
                   {"names": sorted(neighbours), "left_out": left_out, "phones": phone_count(left_out)})
            result = run(str(noisy), added)
            record(f"extra_{name}", item, result, named(result, [extra]), {"names": [extra]})
            if name == "clean":
                result = run(str(noisy), None)
                phones = [p for p in result["utterance"].phones] if not result["refused"] else []
                longest = max((p.duration for p in phones if not p.is_pause), default=0.0)
                phone_counts.append((sum(not p.is_pause for p in phones), reference_phones, longest,
                                     result["refused"]))
                if result["refused"]:
                    print(f"  no transcript, {item}: refused: {result['warnings'][0]}")
    for seed in range(2):
        for name, samples in non_speech(seed).items():
            for transcript in (sentences[seed], None):
                result = run(samples.astype(np.float32), transcript)
                record("silence", f"{name} seed {seed} {'text' if transcript else 'none'}", result,
                       result["refused"])
    return ok, times, phone_counts


_LAST: dict = {}


def _recording_judge(original):
    def judge(fit):
        _LAST["fit"] = {"words": [(w.text, w.start, w.end, round(w.confidence, 1)) for w in fit.words],
                        "gaps": fit.gaps, "uncovered": round(fit.uncovered_share, 3),
                        "mean": round(fit.mean_confidence, 1)}
        return original(fit)
    return judge


def pct(values) -> float:
    return 100.0 * sum(values) / max(len(values), 1)


def main() -> None:
    calibrate = "--calibrate" in sys.argv
    sentences = CALIBRATION if calibrate else HELD_OUT
    transcript_check.judge = _recording_judge(transcript_check.judge)
    started = time.perf_counter()
    fits: list = []
    with tempfile.TemporaryDirectory() as tmp:
        ok, times, phone_counts = evaluate(sentences, Path(tmp), fits)
    dump = Path(tempfile.gettempdir()) / f"transcript_check_{'calibration' if calibrate else 'held_out'}.json"
    dump.write_text(json.dumps(fits, indent=1, default=str))
    print(f"raw scores written to {dump}")
    print(f"{'calibration' if calibrate else 'held-out'} set: {len(sentences)} sentences x 2 voices")
    for condition, values in ok.items():
        print(f"  {condition:16s} {sum(values):3d}/{len(values):3d} = {pct(values):5.1f} %")
    for row in fits:
        if row["condition"].startswith("correct") and row["refused"] or \
                row["condition"].startswith(("wrong", "silence")) and not row["refused"]:
            print(f"  FAIL {row['condition']} {row['item']}: {row['warnings']}")
    correct = [r for r in fits if r["condition"].startswith("correct") and not r["refused"]]
    alarms = [r for r in correct if any(m in w for w in r["warnings"] for m in WORD_WARNINGS)]
    print(f"  false alarms: {len(alarms)}/{len(correct)} accepted correct transcripts got a word warning")
    for label, keep in (("of 1-2 phones", lambda n: n <= 2), ("of 3+ phones", lambda n: n >= 3)):
        rows = [r for r in fits if r["condition"].startswith("missing") and keep(r["phones"])]
        hits = [r for r in rows if not r["refused"] and any(f"'{n}'" in " ".join(r["warnings"]).lower()
                                                            for n in r["names"])]
        print(f"  left-out words {label}: named {len(hits)}/{len(rows)} "
              f"({', '.join(sorted({r['left_out'] for r in rows}))})")
    recognised = [(n, ref, longest) for n, ref, longest, refused in phone_counts if not refused]
    print(f"  no transcript: {len(recognised)}/{len(phone_counts)} recognised; phones/reference median "
          f"{np.median([n / ref for n, ref, _ in recognised]):.2f}, longest phone "
          f"{max(longest for _, _, longest in recognised):.2f} s")
    print(f"  alignment time per call: median {np.median(times):.2f} s, max {max(times):.2f} s; "
          f"total {time.perf_counter() - started:.0f} s")
    # missing_words_named_pct: left-out words (named by their place) and added words (by name) together
    missing = ok["missing_clean"] + ok["missing_10dB"] + ok["extra_clean"] + ok["extra_10dB"]
    print(f"RESULT wrong_refused_pct={pct(ok['wrong_clean'] + ok['wrong_10dB']):.1f} "
          f"silence_refused_pct={pct(ok['silence']):.1f} correct_10db_accepted_pct={pct(ok['correct_10dB']):.1f} "
          f"missing_words_named_pct={pct(missing):.1f} sentences={len(sentences)}")


if __name__ == "__main__":
    main()
