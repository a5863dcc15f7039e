# SPDX-License-Identifier: GPL-3.0-or-later
"""Speech performance for 30 s of speech (issue 4): text-to-speech + Utterance, forced alignment of
recorded audio, coarticulated tracks (muscles and visemes), each also as a ratio to real time.

Goals: tracks + keyframes for 30 s in < 1 s; alignment faster than 0.3x real time. (The thesis needed
7 s for 30 s of audio on its 2002 machine.) The last line is ``RESULT key=value ...``.

Runs the engine from this source tree. Its run-time wheels (espeakng-loader, pocketsphinx, scipy,
soundfile) come from the Python running it or, failing that, from the extension installed by
``make install`` into ``.blender-user``.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
try:
    import espeakng_loader  # noqa: F401
    import pocketsphinx  # noqa: F401
    import scipy  # noqa: F401
    import soundfile  # noqa: F401
except ImportError:
    sys.path.insert(0, str(ROOT / "scripts"))
    import blender_env  # noqa: E402
    sys.path.insert(0, str(blender_env.wheel_site_packages(ROOT / ".blender-user")))

import numpy as np  # noqa: E402

from faces_hands_addon.speech import (align_audio, coarticulate, compare_phone_onsets,  # noqa: E402
                                      load_articulation, load_viseme_targets, synthesize)

SECONDS = 30.0
PARAGRAPH = ("Can you show me the way to the conference hall? The talking head speaks every line with "
             "lips, jaw and tongue moving together, and each sound borrows a little of its neighbours. "
             "Peter Piper picked a peck of pickled peppers, while the quick brown fox jumped over the "
             "lazy dog. Would you like to hear the poem about the two parallel lines once more? ")


def best_of(runs: int, function):
    times, result = [], None
    for _ in range(runs):
        started = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - started)
    return min(times), result


def main() -> None:
    # text long enough for ~30 s of speech at the default rate, trimmed at a sentence end
    text = PARAGRAPH * 3
    probe = synthesize(text)
    cut = next(s.text_end for s in probe.sentences if s.end >= SECONDS - 2.0)
    text = text[:cut].strip()

    tts_s, utterance = best_of(3, lambda: synthesize(text))
    duration = utterance.duration
    print(f"speech: {duration:.1f} s, {len(utterance.words)} words, {len(utterance.phones)} phones")
    print(f"text-to-speech + Utterance: {tts_s:.3f} s  ({tts_s / duration:.4f}x real time)")

    align_s, aligned = best_of(2, lambda: align_audio(utterance.samples, text,
                                                      sample_rate=utterance.sample_rate))
    errors = compare_phone_onsets(utterance.phones, aligned.phones)
    print(f"forced alignment: {align_s:.3f} s  ({align_s / duration:.3f}x real time); "
          f"oracle phone-onset error median {np.median(errors) * 1000:.1f} ms, "
          f"90th percentile {np.percentile(errors, 90) * 1000:.1f} ms over {len(errors)} phones")

    muscles, visemes = load_articulation(), load_viseme_targets()
    for fps in (24, 60):
        tracks_s, result = best_of(5, lambda: (coarticulate(utterance, muscles, fps=fps),
                                               coarticulate(utterance, visemes, fps=fps)))
        keys = len(result[0].times)
        print(f"coarticulated tracks at {fps} fps (13 muscle + 15 viseme tracks, {keys} keys each): "
              f"{tracks_s:.4f} s = {tracks_s * SECONDS / duration:.4f} s per 30 s of speech")
    tracks_per_30s = tracks_s * SECONDS / duration

    # ---- KEYFRAMES (lead): time writing these tracks into Blender F-curves here and add
    # ---- `keyframes_s_per_30s=...` to the RESULT line below.

    print(f"RESULT tracks_s_per_30s={tracks_per_30s:.4f} align_rt={align_s / duration:.4f} "
          f"tts_rt={tts_s / duration:.4f}")


if __name__ == "__main__":
    main()
