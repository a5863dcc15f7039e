# SPDX-License-Identifier: GPL-3.0-or-later
"""Speech performance for 30 s of speech: text-to-speech + Utterance, forced alignment of
recorded audio, coarticulated tracks (muscles and visemes), each also as a ratio to real time.

Goals: tracks + keyframes for 30 s in < 1 s; alignment faster than 0.3x real time. (The thesis needed
7 s for 30 s of audio on its 2002 machine.) The last line is ``RESULT key=value ...``.

Runs the extension installed by ``make install`` (see ``_harness.py``), wheels included.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)

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

    keyframes_s = time_keyframes(utterance, fps=24)
    print(f"keyframes into Blender (13 muscle F-curves on a rig + 15 viseme F-curves, 24 fps): "
          f"{keyframes_s:.4f} s = {keyframes_s * SECONDS / duration:.4f} s per 30 s of speech")
    total_per_30s = (tracks_s + keyframes_s) * SECONDS / duration
    print(f"tracks + keyframes: {total_per_30s:.4f} s per 30 s of speech (goal < 1 s)")

    print(f"RESULT tracks_s_per_30s={tracks_per_30s:.4f} keyframes_s_per_30s={keyframes_s * SECONDS / duration:.4f} "
          f"tracks_keys_s_per_30s={total_per_30s:.4f} align_rt={align_s / duration:.4f} "
          f"tts_rt={tts_s / duration:.4f}")


def time_keyframes(utterance, fps: int) -> float:
    """Time ``apply_take`` (the speech operators' write path) for both targets, sound strip excluded."""
    import bpy
    from faces_hands_addon.speech.takes import take_from_utterance
    apply = _harness.EXTENSION.operators.speech.apply
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    _harness.EXTENSION.operators.common.timing.set_scene_fps(scene, fps)
    rig = bpy.data.objects.new("BenchRig", None)
    rig["fh_rig"] = 1
    mesh = bpy.data.meshes.new("BenchVisemes")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    character = bpy.data.objects.new("BenchVisemes", mesh)
    for obj in (rig, character):
        scene.collection.objects.link(obj)
    character.shape_key_add(name="Basis")
    from faces_hands_addon.speech import VISEMES
    for name in VISEMES:
        character.shape_key_add(name=name)
    takes = [(rig, take_from_utterance(utterance, fps=fps, target="muscles")),
             (character, take_from_utterance(utterance, fps=fps, target="visemes"))]

    def write():
        for obj, take in takes:
            apply.apply_take(scene, obj, take, add_sound=False)
    seconds, _ = best_of(3, write)
    return seconds


if __name__ == "__main__":
    main()
