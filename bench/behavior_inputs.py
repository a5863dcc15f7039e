# SPDX-License-Identifier: GPL-3.0-or-later
"""Bad and big input through the behaviour pipeline (issue 12: "silence-only audio, pure noise, a
10-minute file (bounded memory, progress, cancellable), text with unknown emoticons: clear messages or
sensible results").

Each case runs in its own child process (so one case's memory is not another's peak) through the engine
path Animate Speech takes: ``take_from_audio``/``take_from_text`` -> ``with_nonverbal`` (behaviour, thesis
4.3.5 / 4.2.1) -> ``with_loudness`` (4.2.1). The 10-minute file is the committed Festival clips of
tests/data/speech repeated, recognised without a transcript (phone recognition; forced alignment of a
10-minute transcript is the align branch's business); its figures: wall time, the child's peak resident
memory (``resource.getrusage(...).ru_maxrss``) and that peak minus the child's memory after imports, the
progress reports, and cancelling: Animate Speech's job (the operator's own class) started on it, cancelled
after 2 s, how long the cancel took to return and how long its worker thread ran on. One text case also
goes through ``./fh speak``. Last line: ``RESULT ...``.
"""
from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "speech"
CLIPS = ("slt_ill_disposed", "slt_amiable", "slt_conference", "slt_pump")   # Festival speech, tests/data/speech
UNKNOWN_TEXT = "Hi :-P can you XD show me <3 the way to the hall? :-D"


def _mb(kb: float) -> float:
    return kb / 1024.0


def _write(path: Path, samples, rate: int) -> Path:
    import soundfile
    soundfile.write(str(path), samples, rate, subtype="PCM_16")
    return path


def _long_file(folder: Path, seconds: float) -> Path:
    import numpy as np
    import soundfile
    pieces, rate = [], 16000
    for name in CLIPS:
        samples, rate = soundfile.read(str(DATA / f"{name}.wav"), dtype="float32")
        pieces += [samples, np.zeros(int(0.6 * rate), np.float32)]
    unit = np.concatenate(pieces)
    reps = int(np.ceil(seconds * rate / unit.size))
    return _write(folder / "ten_minutes.wav", np.tile(unit, reps)[: int(seconds * rate)], rate)


def _perform(take):
    from faces_hands_addon.performance import with_loudness, with_nonverbal
    take = with_nonverbal(take, style="neutral", seed=0)
    take, curve = with_loudness(take)
    return take, curve


def _audio_case(path: Path, transcript: str | None) -> dict:
    from faces_hands_addon.core.errors import UserError
    from faces_hands_addon.speech.takes import take_from_audio
    reports = []
    start = time.perf_counter()
    try:
        take = take_from_audio(path, transcript, fps=25, target="muscles",
                               progress=lambda f, m: reports.append((round(time.perf_counter() - start, 1), f, m)))
        take, curve = _perform(take)
    except UserError as error:
        return {"status": "refused", "message": str(error), "seconds": time.perf_counter() - start}
    layers = {name: len(tracks) for name, tracks in take.layers.items()}
    u = take.utterance
    return {"status": "ok", "seconds": time.perf_counter() - start, "duration": take.duration,
            "words": len(u.words), "phones": len([p for p in u.phones if not p.is_pause]),
            "layers": layers, "loudness_mean": float(curve.values.mean()), "warnings": u.warnings[:2],
            "progress": reports}


def _cancel_case(path: Path) -> dict:
    """Animate Speech's job on the long file, cancelled after 2 s (as Esc does: ``cleanup``)."""
    import blender_env
    from faces_hands_addon.speech.takes import take_from_audio
    animate = sys.modules[f"{blender_env.MODULE}.operators.speech.animate"]
    job = animate.AnimateSpeechJob("none", lambda progress: take_from_audio(path, None, fps=25, progress=progress),
                                   "neutral", 0, None, True, str(path), 1)
    start = time.perf_counter()
    fractions = []
    while time.perf_counter() - start < 2.0:
        fractions.append(job.step())
    cancel = time.perf_counter()
    job.cleanup()
    returned = time.perf_counter() - cancel
    job._thread.join()
    return {"status": "cancelled", "cancel_return_s": returned, "worker_ran_on_s": time.perf_counter() - cancel,
            "take_written": job.take is not None, "progress": sorted(set(round(f, 3) for f in fractions))}


def _text_case() -> dict:
    from faces_hands_addon.speech.takes import take_from_text
    take, _ = _perform(take_from_text(UNKNOWN_TEXT, fps=25, target="muscles"))
    return {"status": "ok", "words": [w.text for w in take.utterance.words], "warnings": take.utterance.warnings,
            "emotions": [t.emoticon for t in take.utterance.emotions]}


def child(case: str, folder: Path) -> None:
    import numpy as np
    sys.path.insert(0, str(ROOT / "bench"))
    import _harness  # noqa: F401  (faces_hands_addon = the installed copy)
    import faces_hands_addon.speech.takes  # noqa: F401
    import faces_hands_addon.performance  # noqa: F401
    base_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    rate = 16000
    if case == "silence":
        out = _audio_case(_write(folder / "silence.wav", np.zeros(5 * rate, np.float32), rate), "hello there")
    elif case == "noise":
        noise = np.random.default_rng(0).normal(0.0, 0.1, 5 * rate).astype(np.float32)
        path = _write(folder / "noise.wav", noise, rate)
        out = {"no_transcript": _audio_case(path, None), "transcript": _audio_case(path, "hello there")}
        out["status"] = "/".join(v["status"] for v in out.values())
    elif case == "ten_min":
        out = _audio_case(_long_file(folder, 600.0), None)
    elif case == "cancel":
        out = _cancel_case(_long_file(folder, 600.0))
    else:
        out = _text_case()
    peak_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    out.update(peak_mb=_mb(peak_kb), after_imports_mb=_mb(base_kb))
    print("CASE " + json.dumps(out, default=str))


def _run_child(case: str, folder: Path) -> dict:
    result = subprocess.run([sys.executable, __file__, "--case", case, str(folder)], capture_output=True, text=True,
                            timeout=1800)
    lines = [line for line in result.stdout.splitlines() if line.startswith("CASE ")]
    if result.returncode != 0 or not lines:
        raise SystemExit(f"case {case} failed:\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}")
    return json.loads(lines[-1][5:])


def _fh_case(folder: Path) -> dict:
    start = time.perf_counter()
    out = folder / "unknown.glb"
    result = subprocess.run([str(ROOT / "fh"), "speak", "--text", UNKNOWN_TEXT, "--style", "neutral", "--seed", "1",
                             "--fps", "25", "--out", str(out)], capture_output=True, text=True, timeout=900, cwd=ROOT)
    warned = [line for line in result.stdout.splitlines() if "not emoticons of Table 4.1" in line]
    return {"returncode": result.returncode, "glb": out.exists(), "warning": warned[:1],
            "seconds": time.perf_counter() - start, "tail": result.stdout[-400:] + result.stderr[-400:]}


def main() -> None:
    with tempfile.TemporaryDirectory(prefix="fh-bench-behavior-") as tmp:
        folder = Path(tmp)
        cases = {case: _run_child(case, folder) for case in ("silence", "noise", "unknown_emoticon", "ten_min",
                                                             "cancel")}
        cases["fh_unknown_emoticon"] = _fh_case(folder)
    for name, figures in cases.items():
        print(f"== {name}: {json.dumps(figures, default=str)[:1500]}")
    ten, cancel, text = cases["ten_min"], cases["cancel"], cases["unknown_emoticon"]
    unknown = "ok" if text["warnings"] and not {"P", "XD", "D", "3"} & set(text["words"]) else "bad"
    fh_ok = "ok" if cases["fh_unknown_emoticon"]["returncode"] == 0 and cases["fh_unknown_emoticon"]["warning"] else "bad"
    print(f"RESULT ten_min_s={ten['seconds']:.1f} ten_min_peak_mb={ten['peak_mb']:.0f} "
          f"ten_min_work_mb={ten['peak_mb'] - ten['after_imports_mb']:.0f} ten_min_status={ten['status']} "
          f"cancel_return_s={cancel['cancel_return_s']:.3f} cancel_worker_s={cancel['worker_ran_on_s']:.1f} "
          f"silence={cases['silence']['status']} noise={cases['noise']['status']} unknown_emoticon={unknown} "
          f"fh_unknown_emoticon={fh_ok}")


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--case":
        child(sys.argv[2], Path(sys.argv[3]))
    else:
        main()
