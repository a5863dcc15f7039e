"""Batch runs that never lose a file (`speak` / `lipsync`, one line or a jobs CSV), through the real CLI."""
from __future__ import annotations

import csv
import os
import re
import signal
import subprocess
import time

import numpy as np

from conftest import ROOT, fh_command, run_fh


def _recording(path, channels=8, rate=96000, seconds=1.0):
    import soundfile
    t = np.arange(int(rate * seconds)) / rate
    tone = 0.2 * np.sin(2 * np.pi * 180 * t)[:, None] * np.linspace(0.5, 1.0, channels)[None, :]
    soundfile.write(str(path), tone.astype(np.float32), rate, subtype="FLOAT")
    return path.read_bytes()


def test_the_source_recording_is_never_replaced(installed, tmp_path):
    take = tmp_path / "take.wav"
    before = _recording(take)
    result = run_fh(installed, "lipsync", "--rig", "mask", "--audio", take, "--transcript", "hello there", "--out",
                    tmp_path / "take.glb")
    assert result.returncode == 1
    assert "would replace the input" in result.stderr and "take.wav" in result.stderr
    assert take.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["take.wav"]


def test_a_foreign_wav_beside_the_output_is_kept_unless_overwrite(installed, tmp_path):
    foreign = tmp_path / "line.wav"
    before = _recording(foreign, channels=2, rate=48000, seconds=0.2)
    result = run_fh(installed, "speak", "--rig", "mask", "--text", "Hi.", "--out", tmp_path / "line.glb")
    assert result.returncode == 1 and "was not written by Faces & Hands" in result.stderr
    assert foreign.read_bytes() == before and not (tmp_path / "line.glb").exists()
    result = run_fh(installed, "speak", "--rig", "mask", "--text", "Hi.", "--out", tmp_path / "line.glb", "--overwrite")
    assert result.returncode == 0, result.stderr[-1500:]
    assert f"replacing {foreign}" in result.stdout and foreign.read_bytes() != before
    again = run_fh(installed, "speak", "--rig", "mask", "--text", "Hi.", "--out", tmp_path / "line.glb")   # ours now: replaced
    assert again.returncode == 0, again.stderr[-1500:]


def test_jobs_csv_names_failing_rows_writes_the_others_and_repeats_bytes(installed, tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    line = "Good morning, this line is spoken twice."
    rows = [(a / "line.glb", line, "", ""), (b / "line.glb", line, "", ""),     # the audio column is empty
            (a / "take.fbx", line, "", ""), (b / "take.fbx", line, "", ""),
            (tmp_path / "fast.glb", "Too fast.", "", "fast"), (tmp_path / "inf.glb", "Infinite.", "", "inf"),
            (tmp_path / "lost.glb", "", tmp_path / "missing.wav", ""), (a / "line.glb", "Again.", "", "")]
    jobs = tmp_path / "jobs.csv"
    with open(jobs, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["out", "text", "audio", "rate"])
        writer.writerows(rows)
    result = run_fh(installed, "speak", "--rig", "mask", "--jobs", jobs)
    assert result.returncode == 1, result.stdout[-2000:] + result.stderr[-2000:]
    summary = result.stdout.strip().splitlines()[-1]
    assert summary.startswith("faces_hands: 4 of 8 rows failed:"), summary
    for number, reason in ((6, "rate 'fast' is not a number"), (7, "rate 'inf' is outside"),
                           (8, "missing.wav"), (9, "which row 2 writes too")):
        assert re.search(rf"row {number} \([^)]*\): [^;]*{re.escape(reason)}", summary), (number, summary)
    for folder in (a, b):
        assert sorted(p.name for p in folder.iterdir()) == ["line.glb", "line.wav", "take.fbx", "take.wav"]
    for name in ("line.glb", "line.wav", "take.fbx", "take.wav"):      # the same line twice in one process
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    assert not [p for p in tmp_path.iterdir() if p.suffix == ".glb"]


def test_fail_fast_runs_nothing_when_a_row_is_bad(installed, tmp_path):
    jobs = tmp_path / "jobs.csv"
    jobs.write_text(f"out,text,rate\n{tmp_path / 'ok.glb'},Fine.,\n{tmp_path / 'bad.glb'},Bad.,nan\n")
    result = run_fh(installed, "speak", "--rig", "mask", "--jobs", jobs, "--fail-fast")
    assert result.returncode == 1 and "row 3" in result.stdout and "nothing was run" in result.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jobs.csv"]


def _start(installed, tmp_path, rows: int):
    jobs = tmp_path / "jobs.csv"
    text = "This sentence is long enough to keep the batch busy for a few seconds at least."
    jobs.write_text("out,text\n" + "".join(f"{tmp_path / f'row{n}.glb'},{text}\n" for n in range(rows)))
    env = dict(os.environ, TMPDIR=str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    return subprocess.Popen(fh_command(installed, "speak", "--rig", "mask", "--jobs", jobs), cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for(predicate, process, timeout=300.0):
    deadline = time.monotonic() + timeout
    while not predicate():
        if process.poll() is not None:
            stdout, stderr = process.communicate()
            raise AssertionError(f"the run ended early ({process.returncode}): {stdout[-1500:]} {stderr[-3000:]}")
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


def test_an_interrupt_reports_exactly_what_was_written(installed, tmp_path):
    process = _start(installed, tmp_path, rows=4)
    _wait_for(lambda: (tmp_path / "row0.wav").exists(), process)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr[-2000:]
    report = stderr.strip().splitlines()[-1]
    assert report.startswith("faces_hands: interrupted; written before that: "), report
    listed = set(report.split("written before that: ")[1].split(" (nothing else")[0].split(", "))
    on_disk = {str(p) for p in tmp_path.iterdir() if p.suffix in (".glb", ".wav")}
    assert listed == on_disk and str(tmp_path / "row0.glb") in listed
    rows = re.search(r"interrupted (?:in|after) row (\d+): rows written completely: ([\d, ]+)", stdout)
    assert rows, stdout[-2000:]
    complete = [int(n) for n in rows.group(2).split(", ")]
    assert all((tmp_path / f"row{n - 2}.glb").exists() and (tmp_path / f"row{n - 2}.wav").exists()
               for n in complete)
    assert not any((tmp_path / f"row{n}.glb").exists() for n in range(4) if n + 2 > int(rows.group(1)))
    assert int(rows.group(1)) < 5, "the interrupt came too late to test anything"


def test_sigterm_removes_every_temporary_folder(installed, tmp_path):
    process = _start(installed, tmp_path, rows=3)
    temp = tmp_path / "tmp"
    _wait_for(lambda: any(p.name.startswith("fh-jobs-") for p in temp.rglob("*"))   # under the run's root
              and (tmp_path / "row0.glb").exists(), process)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 143, stderr[-2000:]
    assert "terminated" in stderr.strip().splitlines()[-1]
    assert sorted(p.name for p in temp.iterdir()) == []
