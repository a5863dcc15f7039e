# SPDX-License-Identifier: GPL-3.0-or-later
"""A long recording through ``./fh lipsync`` end to end: wall time, peak memory, the file's clip length.

The recording is Festival's HTS voice (Debian ``festival`` + ``festvox-us-slt-hts``) speaking the sentences of
``mouth_cues.SENTENCES`` again and again, 0.5 s apart, until ``--minutes`` (default 3) are filled; the
transcript is the same sentences. One real ``./fh lipsync --audio ... --transcript ... --out take.glb``
(engine-ready weights, 30 fps) runs on it; its wall time and peak resident memory (``getrusage`` of the
children: Blender's process) are what the user waits for and what the machine must have. The GLB's clip must
last as long as the WAV. Last line: ``RESULT ...``.
"""
from __future__ import annotations

import argparse
import resource
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
from mouth_cues import SENTENCES, festival  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
GAP_S = 0.5


def long_recording(folder: Path, seconds: float) -> tuple[Path, str]:
    clips = []
    for index, text in enumerate(SENTENCES):
        wav, _, _ = festival(text, folder, f"s{index:02d}")
        samples, rate = soundfile.read(str(wav), dtype="float64")
        clips.append((samples, text))
    pieces, words, total, k = [], [], 0.0, 0
    while total < seconds:
        samples, text = clips[k % len(clips)]
        pieces += [samples, np.zeros(int(GAP_S * rate))]
        words.append(text)
        total += len(samples) / rate + GAP_S
        k += 1
    out = folder / "long_take.wav"
    soundfile.write(str(out), np.concatenate(pieces), rate, subtype="PCM_16")
    return out, " ".join(words)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", type=float, default=3.0)
    args = parser.parse_args()
    if shutil.which("festival") is None:
        sys.exit("needs Debian's festival + festvox-us-slt-hts")
    folder = Path(tempfile.mkdtemp(prefix="fh-long-take-"))
    try:
        wav, text = long_recording(folder, args.minutes * 60)
        seconds = soundfile.info(str(wav)).duration
        out = folder / "take.glb"
        started = time.perf_counter()
        done = subprocess.run([str(ROOT / "fh"), "lipsync", "--audio", str(wav), "--transcript", text, "--out",
                               str(out), "--fps", "30"], capture_output=True, text=True)
        wall = time.perf_counter() - started
        peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        if done.returncode != 0:
            print(done.stderr[-2000:])
            return 1
        glb = client.Glb(out)
        skin = client.Skin(glb)
        keys, _, _ = client.weights_channel(glb, None, skin.node)
        print(f"{seconds:.1f} s recording ({len(text.split())} words), {len(keys)} keys at 30 fps: "
              f"./fh lipsync {wall:.1f} s wall ({seconds / wall:.2f}x real time), peak memory {peak_mb:.0f} MB, "
              f"GLB {glb.size / 1e6:.2f} MB, clip {keys[-1]:.2f} s")
        print(f"RESULT audio_s={seconds:.1f} lipsync_s={wall:.1f} peak_mb={peak_mb:.0f} frames={len(keys)} "
              f"glb_mb={glb.size / 1e6:.2f} clip_minus_wav_ms={(keys[-1] - seconds) * 1000:.1f}")
        return 0
    finally:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
