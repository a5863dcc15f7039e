# SPDX-License-Identifier: GPL-3.0-or-later
"""Regenerate the speech test fixtures in tests/data/speech/ with Festival (not pocketsphinx).

Needs Debian's ``festival`` and ``festvox-us-slt-hts`` (``apt-get install festival festvox-us-slt-hts``).
For every sentence the CMU ARCTIC SLT HTS voice speaks, Festival writes its waveform (32 kHz), and a
Scheme loop writes every segment (``segment_start``, ``end``) and every word (start of its first
segment, end of its last) as the HTS duration model placed them: the waveform follows these times,
so they are ground truth for an aligner that never saw them. The audio is resampled to 16 kHz mono
16-bit PCM (``resample_poly``, no delay); the labels go into ``<name>.tsv``:

    # comment lines
    text<TAB>the sentence
    phone<TAB>pau<TAB>0.0000<TAB>0.1750
    word<TAB>He<TAB>0.1750<TAB>0.3150

``--check`` regenerates into a temporary folder and compares with the committed files (Festival is
deterministic here), exit 1 on a difference. Usage: ``.venv/bin/python scripts/speech_fixtures.py [--check]``
(after ``make install``; any Python with numpy and scipy also works).
``festival_labels`` is also used by bench/lipsync_alignment.py.
"""
from __future__ import annotations

import argparse
import filecmp
import subprocess
import sys
import tempfile
import wave
from math import gcd
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
try:
    from scipy.signal import resample_poly
except ImportError:  # .venv (bpy's Python) has no scipy: use the wheels `make install` unpacked
    sys.path.insert(0, str(ROOT / "scripts"))
    import blender_env
    sys.path.insert(0, str(blender_env.wheel_site_packages(ROOT / ".blender-user")))
    from scipy.signal import resample_poly
OUT = ROOT / "tests" / "data" / "speech"
VOICE = "voice_cmu_us_slt_arctic_hts"
RATE = 16000
FIXTURES = {
    "slt_ill_disposed": "He was not an ill disposed young man.",
    "slt_amiable": "He might even have been made amiable himself.",
    "slt_conference": "Can you show me the way to the conference hall?",
    "slt_pump": "Peter kept the rope by the empty pump, while the brown fox jumped over the lazy dog.",
}
HEADER = ("Festival 2.5 + festvox-us-slt-hts (CMU ARCTIC SLT HTS voice), labels from its own segment and "
          "word times; made by scripts/speech_fixtures.py")


def _scheme_string(text: str) -> str:
    return text.replace("\\", "\\\\").replace('"', '\\"')


def festival_labels(text: str, folder: Path, name: str) -> tuple[Path, list, list]:
    """Festival's wave path (its own rate), segment rows [(phone, start, end)] and word rows
    [(word, start, end)] for ``text``."""
    wav, labels, script = folder / f"{name}.wav", folder / f"{name}.lab", folder / f"{name}.scm"
    script.write_text(
        f"({VOICE})\n"
        f'(set! utt (utt.synth (Utterance Text "{_scheme_string(text)}")))\n'
        f"(utt.save.wave utt \"{wav}\" 'riff)\n"
        f'(set! fd (fopen "{labels}" "w"))\n'
        '(mapcar (lambda (s) (format fd "phone\\t%s\\t%f\\t%f\\n" (item.name s) (item.feat s "segment_start") '
        "(item.feat s \"end\"))) (utt.relation.items utt 'Segment))\n"
        '(mapcar (lambda (w) (format fd "word\\t%s\\t%f\\t%f\\n" (item.name w) '
        '(item.feat w "R:SylStructure.daughter1.daughter1.segment_start") '
        "(item.feat w \"R:SylStructure.daughtern.daughtern.end\"))) (utt.relation.items utt 'Word))\n"
        "(fclose fd)\n", encoding="utf-8")
    subprocess.run(["festival", "-b", str(script)], check=True, capture_output=True)
    phones, words = [], []
    for line in labels.read_text(encoding="utf-8").splitlines():
        kind, label, start, end = line.split("\t")
        (phones if kind == "phone" else words).append((label, float(start), float(end)))
    if not phones or not words:
        raise RuntimeError(f"Festival wrote no labels for {text!r}")
    return wav, phones, words


def read_wav(path: Path) -> tuple[np.ndarray, int]:
    """16-bit PCM WAV (what Festival writes) as mono float64 in [-1, 1] and its rate."""
    with wave.open(str(path), "rb") as handle:
        if handle.getsampwidth() != 2:
            raise RuntimeError(f"{path}: expected 16-bit PCM")
        rate, channels = handle.getframerate(), handle.getnchannels()
        data = np.frombuffer(handle.readframes(handle.getnframes()), dtype="<i2").astype(np.float64)
    return data.reshape(-1, channels).mean(axis=1) / 32768.0, rate


def write_wav(path: Path, samples: np.ndarray, rate: int) -> None:
    pcm = np.round(np.clip(samples, -1.0, 32767 / 32768) * 32768.0).astype("<i2")
    with wave.open(str(path), "wb") as handle:
        handle.setnchannels(1)
        handle.setsampwidth(2)
        handle.setframerate(rate)
        handle.writeframes(pcm.tobytes())


def to_16k(path: Path) -> np.ndarray:
    samples, rate = read_wav(path)
    if rate != RATE:
        g = gcd(RATE, rate)
        samples = resample_poly(samples, RATE // g, rate // g)
    return samples


def write_fixture(name: str, text: str, out: Path, work: Path) -> None:
    wav, phones, words = festival_labels(text, work, name)
    write_wav(out / f"{name}.wav", to_16k(wav), RATE)
    lines = [f"# {HEADER}", f"text\t{text}"]
    lines += [f"{kind}\t{label}\t{a:.4f}\t{b:.4f}" for kind, rows in (("phone", phones), ("word", words))
              for label, a, b in rows]
    (out / f"{name}.tsv").write_text("\n".join(lines) + "\n", encoding="utf-8")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare a fresh run with the committed files")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        out = work / "out" if args.check else OUT
        out.mkdir(parents=True, exist_ok=True)
        for name, text in FIXTURES.items():
            write_fixture(name, text, out, work)
        if args.check:
            names = [f"{n}.{s}" for n in FIXTURES for s in ("wav", "tsv")]
            _, mismatch, errors = filecmp.cmpfiles(OUT, out, names, shallow=False)
            if mismatch or errors:
                print("differs from the committed fixtures:", ", ".join(mismatch + errors))
                return 1
            print(f"{len(names)} fixture files match")
    return 0


if __name__ == "__main__":
    sys.exit(main())
