# SPDX-License-Identifier: GPL-3.0-or-later
"""Speech performance for 30 s of speech, end to end and by engine stage.

End to end (what a user waits for): ``./fh speak --text T --out x.glb`` for ~30 s of text and
``./fh lipsync --audio F --transcript T --out x.glb`` for a ~30-s recording (Festival's CMU ARCTIC SLT
HTS voice reading the same text: a recording our synthesiser did not make), each run as a real
subprocess. The commands print no timing split, so the split comes from their own progress lines: every
line of the merged stdout/stderr (``PYTHONUNBUFFERED=1``; the progress lines are flushed) is stamped as it
arrives, and a stage is the interval between the lines that open consecutive stages:

* start-up: process start -> "synthesising speech" / "aligning audio to the transcript" (``./fh``'s
  ``make -s install`` up-to-date check, bpy import, enabling the extension, argument checks);
* synthesis / alignment -> "coarticulating"; coarticulation -> "tracks ready";
* rig + keys: -> "N s of speech ... on 'FH Head'" (building the default head, writing the take's keys);
* bake: -> "Baked ..." (weights of the ARKit/viseme/emotion targets; with the shape cache cold
  (``FH_NO_SHAPE_CACHE=1``) every target is simulated, warm it is read from the user folder);
* export: -> "wrote x.glb"; exit: the rest (the WAV beside it, process teardown).

Each is reported in seconds and as a real-time factor (stage seconds / speech seconds; the speech length
is the command's own "N s of speech" line). ``speak`` runs cold and warm, ``lipsync`` warm.

Engine stages in the same run (``synthesize``, ``align_audio``, ``coarticulate``, ``apply_take``), best of
a few calls: goals tracks + keyframes for 30 s in < 1 s; alignment faster than 0.3x real time. (The
thesis needed 7 s for 30 s of audio on its 2002 machine.) The last line is ``RESULT key=value ...``.

Runs the extension installed by ``make install`` (see ``_harness.py``), wheels included:
``.venv/bin/python bench/speech.py``.
"""
from __future__ import annotations

import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)

import numpy as np  # noqa: E402

from faces_hands_addon.speech import (align_audio, coarticulate, compare_phone_onsets,  # noqa: E402
                                      load_articulation, load_viseme_targets, synthesize)

SECONDS = 30.0
ROOT = Path(__file__).resolve().parents[1]
# (stage, the line that ends it); start-up ends at the first progress line (see the module docstring)
STAGE_ENDS = (("start-up", re.compile(r"\] (synthesising speech|aligning audio)")),
              ("synthesis/alignment", re.compile(r"\] coarticulating")),
              ("coarticulation", re.compile(r"\] tracks ready")),
              ("rig + keys", re.compile(r"[0-9.]+ s of speech \(")),
              ("bake", re.compile(r"^Baked ")),
              ("export", re.compile(r"^wrote .*\.glb")))
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

    keys = end_to_end(text)
    print(f"RESULT {' '.join(keys)} tracks_s_per_30s={tracks_per_30s:.4f} "
          f"keyframes_s_per_30s={keyframes_s * SECONDS / duration:.4f} "
          f"tracks_keys_s_per_30s={total_per_30s:.4f} align_rt={align_s / duration:.4f} "
          f"tts_rt={tts_s / duration:.4f}")


def timed_command(arguments: list[str], env: dict) -> tuple[list[tuple[float, str]], float, float]:
    """Run ``./fh arguments``; every output line with the seconds since the start, the wall total and the
    CPU seconds (user + system) of the command's processes (wall >> CPU: the machine was shared)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    process = subprocess.Popen([str(ROOT / "fh"), *arguments], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               text=True, bufsize=1, env={**os.environ, **env, "PYTHONUNBUFFERED": "1"})
    lines = [(time.perf_counter() - started, line.rstrip("\n")) for line in process.stdout]
    code = process.wait()
    total = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if code != 0:
        sys.exit(f"./fh {arguments[0]} failed ({code}):\n" + "\n".join(line for _, line in lines[-20:]))
    return lines, total, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def stage_split(lines: list[tuple[float, str]], total: float) -> tuple[float, dict[str, float]]:
    """(speech seconds, stage -> seconds) from the stamped lines (``STAGE_ENDS``)."""
    speech = next(float(m.group(1)) for _, line in lines if (m := re.search(r"([0-9.]+) s of speech \(", line)))
    stages, previous = {}, 0.0
    for stage, pattern in STAGE_ENDS:
        at = next(t for t, line in lines if pattern.search(line))
        stages[stage], previous = at - previous, at
    stages["exit"] = total - previous
    return speech, stages


def festival_recording(text: str, folder: Path) -> Path:
    """``text`` read by Festival's SLT HTS voice as a 16 kHz WAV."""
    from speech_fixtures import festival_labels, to_16k, write_wav  # scripts/, on the path via _harness
    wav, _, _ = festival_labels(text, folder, "festival_30s")
    out = folder / "recording.wav"
    write_wav(out, to_16k(wav), 16000)
    return out


def end_to_end(text: str) -> list[str]:
    """The two commands, timed by stage; returns RESULT keys."""
    keys = []
    # ./fh runs `make -s install` first: bring the install up to date untimed, so start-up is only the
    # up-to-date check and not a rebuild
    subprocess.run(["make", "-s", "-C", str(ROOT), "install"], check=True, capture_output=True)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        recording = festival_recording(text, folder)
        runs = [("speak_cold", ["speak", "--text", text, "--out", str(folder / "speak_cold.glb")],
                 {"FH_NO_SHAPE_CACHE": "1"}),
                ("speak", ["speak", "--text", text, "--out", str(folder / "speak.glb")], {}),
                ("lipsync", ["lipsync", "--audio", str(recording), "--transcript", text,
                             "--out", str(folder / "lipsync.glb")], {})]
        print(f"settings: {os.cpu_count()} cores, default voice/rate/fps (30), weights export (the default), "
              "shape cache in the user folder (speak_cold: FH_NO_SHAPE_CACHE=1); wall = what a user waits, "
              "CPU = user + system of the command's processes (> wall where a second core worked)")
        for name, arguments, env in runs:
            load = os.getloadavg()[0]
            lines, total, cpu = timed_command(arguments, env)
            speech, stages = stage_split(lines, total)
            split = ", ".join(f"{stage} {sec:.2f} s ({sec / speech:.3f}x)" for stage, sec in stages.items())
            print(f"./fh {arguments[0]}{' (shape cache off)' if env else ''}: {speech:.1f} s of speech in "
                  f"{total:.1f} s = {total / speech:.3f}x real time = {total * SECONDS / speech:.1f} s per 30 s "
                  f"(CPU {cpu:.1f} s; load average before {load:.1f}); {split}")
            keys += [f"{name}_s_per_30s={total * SECONDS / speech:.2f}", f"{name}_cpu_s_per_30s={cpu * SECONDS / speech:.2f}",
                     f"{name}_total_rt={total / speech:.3f}", f"{name}_cpu_rt={cpu / speech:.3f}"]
            keys += [f"{name}_{re.sub(r'[^a-z]+', '_', stage).strip('_')}_rt={sec / speech:.4f}"
                     for stage, sec in stages.items()]
    return keys


def time_keyframes(utterance, fps: int) -> float:
    """Time ``apply_take`` (the speech operators' write path) for both targets, sound strip excluded."""
    import bpy
    from faces_hands_addon.speech.takes import take_from_utterance
    apply = _harness.EXTENSION.operators.speech.apply
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    _harness.EXTENSION.operators.adapters.timing.set_scene_fps(scene, fps)
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
