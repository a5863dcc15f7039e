"""`faces_hands jobs` through the real CLI: local workers sharing a queue, resume, a worker killed mid-row,
and the OpenJD bundle under `openjd run` (a stand-in `blender` runs the bpy module), all giving the same
bytes for the same row."""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import ROOT, fh_command, run_fh

ROWS = [("speak", "a/one.glb", "Hello there.", "en-us", ""),
        ("speak", "two.glb", "Good morning to you.", "de", "joy"),
        ("speak", "three.glb", "See you soon.", "en-us", "anger")]
OUTPUTS = [name for _, out, *_ in ROWS for name in (out, out[:-4] + ".wav")]


def _manifest(folder: Path, rows=ROWS) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "jobs.csv"
    path.write_text("action,out,text,voice,emotion\n" + "".join(",".join(row) + "\n" for row in rows))
    return path


def _report(out: Path) -> dict:
    doc = json.loads((out / "jobs_report.json").read_text())
    return {state: [row["line"] for row in doc["rows"] if row["state"] == state]
            for state in ("done", "skipped", "failed", "not_run")}


def _files(out: Path) -> list[str]:
    return sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file() and ".fh-farm" not in p.parts)


@pytest.fixture(scope="module")
def two_workers(installed, tmp_path_factory):
    """The three rows on two workers (the rows' order between workers is whatever the queue gave)."""
    folder = tmp_path_factory.mktemp("jobs")
    manifest = _manifest(folder)
    result = run_fh(installed, "jobs", manifest, "--out-dir", folder / "out", "--workers", "2")
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-3000:]
    return manifest, folder / "out"


def test_two_workers_write_every_row_with_its_sidecar_and_report(two_workers):
    _, out = two_workers
    assert _report(out) == {"done": [2, 3, 4], "skipped": [], "failed": [], "not_run": []}
    expected = sorted(OUTPUTS + [out_name + ".fhjob.json" for _, out_name, *_ in ROWS] + ["jobs_report.json"])
    assert _files(out) == expected
    sidecar = json.loads((out / "two.glb.fhjob.json").read_text())
    assert sidecar["complete"] and sidecar["extension_version"] and set(sidecar["outputs"]) == {"two.glb", "two.wav"}
    assert not list((out / ".fh-farm" / "staging").glob("*/*"))
    assert {p.name for p in (out / ".fh-farm" / "logs").iterdir()} == {"worker-1.log", "worker-2.log"}


def test_a_rerun_skips_exactly_the_current_rows(installed, two_workers, tmp_path):
    manifest, original = two_workers
    out = tmp_path / "out"
    shutil.copytree(original, out, symlinks=True, copy_function=shutil.copy2)   # mtimes kept: still current
    before = {name: (out / name).read_bytes() for name in OUTPUTS}
    result = run_fh(installed, "jobs", manifest, "--out-dir", out, "--workers", "2")
    assert result.returncode == 0, result.stderr[-2000:]
    assert _report(out) == {"done": [], "skipped": [2, 3, 4], "failed": [], "not_run": []}
    os.utime(out / "two.wav", ns=(1, 1))                  # one output no longer as its sidecar recorded it
    result = run_fh(installed, "jobs", manifest, "--out-dir", out, "--check")
    assert "2 already current (a run skips them), 1 to run" in result.stdout, result.stdout + result.stderr
    result = run_fh(installed, "jobs", manifest, "--out-dir", out)
    assert result.returncode == 0, result.stderr[-2000:]
    assert _report(out) == {"done": [3], "skipped": [2, 4], "failed": [], "not_run": []}
    assert all((out / name).read_bytes() == before[name] for name in OUTPUTS)      # the same bytes again


def test_a_worker_killed_mid_row_leaves_no_partial_file(installed, tmp_path):
    manifest = _manifest(tmp_path, ROWS[:2])
    out = tmp_path / "out"
    process = subprocess.Popen(fh_command(installed, "jobs", manifest, "--out-dir", out), cwd=ROOT,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    staging = out / ".fh-farm" / "staging"
    deadline = time.monotonic() + 300
    while not any(staging.glob("*/line-2-*")):             # the worker started the first row
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.05)
    worker = next(staging.glob("*/line-2-*")).parent
    os.kill(int(worker.name.rsplit("-", 1)[1]), signal.SIGKILL)
    stdout, stderr = process.communicate(timeout=600)
    assert process.returncode == 1, stderr[-2000:]
    assert "line 2 (a/one.glb): the worker process ended during this row (killed by signal 9" in stdout
    assert _report(out)["failed"] == [2] and _report(out)["done"] == [3]
    assert _files(out) == ["jobs_report.json", "two.glb", "two.glb.fhjob.json", "two.wav"]
    assert not worker.exists()


def _standin(folder: Path) -> Path:
    sys.path.insert(0, str(ROOT / "scripts"))
    import blender_standin
    return blender_standin.write_wrapper(folder / "blender")


def test_the_openjd_bundle_runs_under_openjd_run_with_the_same_bytes(installed, two_workers, tmp_path):
    manifest, local = two_workers
    out, bundle = tmp_path / "out", tmp_path / "bundle"
    blender = _standin(tmp_path)
    result = run_fh(installed, "jobs", manifest, "--out-dir", out, "--openjd", bundle, "--chunk", "2",
                    "--extension-zip", installed.zip_path, "--blender", blender)
    assert result.returncode == 0, result.stderr[-2000:]
    assert sorted(p.name for p in bundle.iterdir()) == ["asset_references.json", "parameter_values.json",
                                                        "template.json"]
    openjd = Path(sys.executable).with_name("openjd")
    check = subprocess.run([openjd, "check", bundle / "template.json"], capture_output=True, text=True)
    assert check.returncode == 0 and "passes validation checks" in check.stdout, check.stdout + check.stderr
    values = json.loads((bundle / "parameter_values.json").read_text())["parameterValues"]
    params = [arg for v in values for arg in ("-p", f"{v['name']}={v['value']}")]
    import blender_env
    import bpy
    cache = bpy.utils.extension_path_user(blender_env.MODULE, path="cache")    # warm: the local run filled it
    params += ["-p", f"CacheDir={cache}"]
    env = {k: v for k, v in os.environ.items() if k != "BLENDER_USER_RESOURCES"}
    env["OPENBLAS_NUM_THREADS"] = "1"     # the local run had the machine's count: the bytes may not depend on it
    run = subprocess.run([openjd, "run", bundle / "template.json", *params], capture_output=True, text=True,
                         cwd=tmp_path, env=env, timeout=1200)
    log = run.stdout + run.stderr
    assert run.returncode == 0 and "Session ended successfully" in log, log[-4000:]
    assert "openjd_env: BLENDER_USER_RESOURCES=" in log and "<= Blender <" in log    # installed, version checked
    assert f"openjd_env: FH_CACHE_DIR={cache}" in log
    assert log.count("Running step 'BakeRows'") == 1 and "Running step 'MergeReports'" in log
    assert _report(out) == {"done": [2, 3, 4], "skipped": [], "failed": [], "not_run": []}
    for name in OUTPUTS:                  # chunks of 2 in one process each vs. two workers: the same bytes
        assert (out / name).read_bytes() == (local / name).read_bytes(), name
