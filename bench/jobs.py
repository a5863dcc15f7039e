"""Dialogue at studio scale: `faces_hands jobs` on a manifest of spoken lines (2-6 s each, several voices,
emotions and styles), through the CLI as a user runs it.

* ``check_100k_s``: `--check` of a 100,000-row manifest (the whole command, Blender's start included);
  ``check_100k_cpu_s``: its CPU seconds beyond the same command on one row (the check's own).
* ``lines_per_min_1w`` / ``lines_per_min_2w`` and ``speedup_2w``: the same rows on 1 and on 2 workers (into
  two folders, one after the other, the shape cache warm); the machine's load average is given beside them
  (the machine is shared: a busy neighbour takes the second core).
* ``line_overhead_cpu_s`` and ``cpu_s_per_speech_s``: each row's CPU seconds fitted as a + b * speech seconds
  (the rows' own CPU time, which a neighbour's load does not inflate); a is what a line costs beyond its
  speech's share.
* ``resume_s``: the rerun with nothing to do (every row current), the whole command; ``resume_1000_s`` the
  same on 1,000 rows whose sidecars and (stand-in) files the engine's commit wrote.
* ``kill_lost_rows`` / ``kill_partial_files``: 2 workers, one SIGKILLed in the middle of a row, then a
  rerun: rows still not current, and files in the output folder that no complete sidecar lists.
* ``openjd_*``: the generated bundle under ``openjd run`` (Blender's command line from
  ``scripts/blender_standin.py``), ``openjd_task_overhead_s``: a task's wall time beyond its rows' (Blender
  start, rig build), ``openjd_same_bytes``: its outputs equal the local run's.
* ``peak_rss_mb_max``: the largest peak resident memory of a worker.
* ``start_cpu_s_warm`` / ``start_cpu_s_off``: CPU seconds of the whole ``jobs`` command on one row and one
  worker (Blender's start twice, the rig, the row) with the rig cache warm and off (``FH_NO_RIG_CACHE=1``):
  their difference is what the cache saves each worker, in CPU time, which a neighbour's load does not
  inflate as it does wall time.
* ``rig_cache``: ``warm`` (default: the warm-up run keeps the built default character in the user's cache
  folder, every later worker copies it instead of building), ``cold`` (the cached rigs removed before each
  throughput run: its workers build and store it) or ``off`` (``FH_NO_RIG_CACHE=1``: built by every worker,
  nothing stored).

``--rows N`` (default 200; ``--full``: 1,000); ``--openjd-rows``/``--kill-rows`` size those parts. Last line:
``RESULT key=value ...``.
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
import blender_standin  # noqa: E402

USER_DIR = Path(os.environ.get("FH_BENCH_USER_DIR", ROOT / ".blender-user"))
VOICES = ("en-us", "de", "fr", "es")
EMOTIONS = ("", "joy", "anger", "fear", "50,-20", "relief")
STYLES = ("", "nodder", "expressive", "reserved")
WORDS = ("the quick brown fox jumps over a lazy dog while seven bright lanterns glow across the quiet "
         "harbour and old sailors sing about distant islands we may never see again").split()


RIG: list[str] = []          # ``--rig mask``: the face-only head instead of the default character


def fh(*args) -> list[str]:
    """The command line of ``faces_hands ARGS`` (a ``jobs`` run on the rig ``--rig`` chose)."""
    extra = RIG if args and args[0] == "jobs" and "--openjd" not in args else []
    return [sys.executable, str(ROOT / "scripts" / "fh_launch.py"), "--user-dir", str(USER_DIR), "--",
            *map(str, args), *extra]


def manifest(path: Path, rows: int, seed: int = 7) -> Path:
    """``rows`` speak rows of 6-18 words (about 2-6 s at 175 words per minute)."""
    rng = np.random.default_rng(seed)
    with open(path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(["action", "out", "text", "voice", "emotion", "style", "seed"])
        for n in range(rows):
            words = rng.choice(WORDS, size=int(rng.integers(6, 19)))
            writer.writerow(["speak", f"ch{n % 5}/line{n:05d}.glb", " ".join(words).capitalize() + ".",
                             VOICES[n % len(VOICES)], EMOTIONS[n % len(EMOTIONS)], STYLES[n % len(STYLES)], n])
    return path


def timed(command: list[str], **kw) -> tuple[float, subprocess.CompletedProcess]:
    started = time.perf_counter()
    result = subprocess.run(command, capture_output=True, text=True, **kw)
    if result.returncode not in (0, 1):
        raise SystemExit(f"{command[-6:]} failed ({result.returncode}): {result.stderr[-3000:]}")
    return time.perf_counter() - started, result


def cpu_of(command: list[str]) -> float:
    """CPU seconds (user + system) the command took, its children included; a neighbour's load does not
    inflate them as it does wall time."""
    import resource
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    timed(command)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime


def report(out: Path) -> dict:
    return json.loads((out / "jobs_report.json").read_text())


def speech_seconds(out: Path, name: str) -> float:
    import wave
    with wave.open(str(out / (name[:-4] + ".wav"))) as handle:
        return handle.getnframes() / handle.getframerate()


def check_100k(folder: Path) -> dict:
    """The whole `--check` command on 100,000 rows; its CPU beyond the same command on one row (Blender's
    start and the extension's) is the check's own."""
    path = manifest(folder / "big.csv", 100_000)
    wall, result = timed(fh("jobs", path, "--out-dir", folder / "big_out", "--check"))
    inner = re.search(r"done in ([\d.]+) s", result.stderr)
    one = manifest(folder / "one.csv", 1)
    cpu_big = cpu_of(fh("jobs", path, "--out-dir", folder / "big_out", "--check"))
    cpu_one = cpu_of(fh("jobs", one, "--out-dir", folder / "big_out", "--check"))
    return {"check_100k_s": wall, "check_100k_inner_s": float(inner.group(1)) if inner else -1.0,
            "check_100k_cpu_s": cpu_big - cpu_one, "check_1_row_cpu_s": cpu_one}


def resume_at_scale(folder: Path, rows: int) -> dict:
    """A rerun with nothing to do on ``rows`` rows: their sidecars and files made by the engine's commit
    (small stand-in files: a resume only reads sidecars and looks at the files' size and time), keyed as
    the command keys them; then the real command, timed whole."""
    sys.path.insert(0, str(ROOT / "bench"))
    import _harness  # noqa: F401  (the installed extension, in this process)
    from faces_hands_addon.farm.check import check_manifest
    from faces_hands_addon.farm.resume import commit_row, plan_rows, staging_folder
    identity = _harness.addon_module("operators.farm.runner").run_identity(None, 30.0)
    path, out = manifest(folder / f"resume{rows}.csv", rows, seed=5), folder / f"out_resume{rows}"
    checked = check_manifest(path, out, fps=30.0, max_frames=5000)
    staging = staging_folder(out)
    for row, key, inputs in plan_rows(checked.rows, out, identity).todo:
        staged = {}
        for name in row.outputs():
            staged[name] = staging / name
            staged[name].parent.mkdir(parents=True, exist_ok=True)
            staged[name].write_bytes(b"stand-in " + name.encode())
        commit_row(out, row, key, inputs, staged, staging, identity.extension_version)
    wall, _ = timed(fh("jobs", path, "--out-dir", out, "--workers", 2))
    doc = report(out)
    return {f"resume_{rows}_s": wall, f"resume_{rows}_skipped": doc["counts"]["skipped"],
            f"resume_{rows}_cpu_s": cpu_of(fh("jobs", path, "--out-dir", out, "--workers", 2))}


RIG_CACHE = USER_DIR / "extensions" / ".user" / "user_default" / "faces_hands" / "cache" / "rigs"


def throughput(path: Path, folder: Path, rig_cache: str = "warm") -> dict:
    """1 worker, then 2 workers, on the same rows (each into its own folder); the per-row CPU fit."""
    figures, loads = {}, []
    for workers in (1, 2):
        out = folder / f"out{workers}"
        if rig_cache == "cold":
            shutil.rmtree(RIG_CACHE, ignore_errors=True)
        loads.append(os.getloadavg()[0])
        wall, result = timed(fh("jobs", path, "--out-dir", out, "--workers", workers))
        doc = report(out)
        figures[f"row_cpu_s_median_{workers}w"] = float(np.median([r["cpu_s"] for r in doc["rows"]
                                                                   if r["state"] == "done"]))
        figures[f"lines_per_min_{workers}w"] = doc["counts"]["done"] / wall * 60.0
        figures[f"failed_{workers}w"] = doc["counts"]["failed"]
        figures[f"wall_{workers}w_s"] = wall
        rss = [v for v in doc["worker_peak_rss_mb"].values() if v]
        figures["peak_rss_mb_max"] = max([figures.get("peak_rss_mb_max", 0.0)] + rss)
    loads.append(os.getloadavg()[0])
    figures["speedup_2w"] = figures["lines_per_min_2w"] / figures["lines_per_min_1w"]
    figures["load_1w"], figures["load_2w"], figures["load_end"] = loads
    rows = [r for r in report(folder / "out1")["rows"] if r["state"] == "done"]
    speech = np.array([speech_seconds(folder / "out1", r["out"]) for r in rows])
    cpu = np.array([r["cpu_s"] for r in rows])
    slope, intercept = np.polyfit(speech, cpu, 1)
    figures.update(line_overhead_cpu_s=intercept, cpu_s_per_speech_s=slope, speech_s_mean=speech.mean(),
                   row_cpu_s_median=float(np.median(cpu)), row_wall_s_median=float(np.median(
                       [r["seconds"] for r in rows])))
    wall, _ = timed(fh("jobs", path, "--out-dir", folder / "out1", "--workers", 2))
    figures["resume_s"] = wall
    figures["resume_skipped"] = report(folder / "out1")["counts"]["skipped"]
    same = all((folder / "out1" / r["out"]).read_bytes() == (folder / "out2" / r["out"]).read_bytes() for r in rows)
    figures["same_bytes_1w_2w"] = int(same)
    return figures


def start_cost(folder: Path) -> dict:
    """CPU seconds of a one-row, one-worker run with the rig cache warm, then off (module docstring)."""
    one = manifest(folder / "start.csv", 1, seed=11)
    figures, before = {}, os.environ.get("FH_NO_RIG_CACHE")
    for mode in ("warm", "off"):
        os.environ["FH_NO_RIG_CACHE"] = "1" if mode == "off" else "0"
        try:
            figures[f"start_cpu_s_{mode}"] = cpu_of(fh("jobs", one, "--out-dir", folder / f"start_{mode}"))
        finally:
            os.environ.pop("FH_NO_RIG_CACHE", None)
            if before is not None:
                os.environ["FH_NO_RIG_CACHE"] = before
    same = (folder / "start_warm" / "ch0" / "line00000.glb").read_bytes() == \
        (folder / "start_off" / "ch0" / "line00000.glb").read_bytes()
    figures["start_same_bytes"] = int(same)
    return figures


def partial_files(out: Path) -> int:
    listed = {"jobs_report.json"}
    for sidecar in out.rglob("*.fhjob.json"):
        doc = json.loads(sidecar.read_text())
        if doc.get("complete"):
            listed |= set(doc["outputs"]) | {str(sidecar.relative_to(out))}
    files = [p for p in out.rglob("*") if p.is_file() and ".fh-farm" not in p.relative_to(out).parts]
    staging = out / ".fh-farm" / "staging"
    leftovers = [p for p in staging.rglob("*") if p.is_file()] if staging.is_dir() else []
    return sum(str(p.relative_to(out)) not in listed for p in files) + len(leftovers)


def kill_one(path: Path, folder: Path) -> dict:
    out = folder / "out_kill"
    process = subprocess.Popen(fh("jobs", path, "--out-dir", out, "--workers", 2), stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    staging, deadline = out / ".fh-farm" / "staging", time.monotonic() + 900
    while True:
        busy = [p for p in staging.glob("*/line-*")] if staging.is_dir() else []
        done = len(list(out.rglob("*.fhjob.json")))
        if busy and done >= 2:
            break
        if process.poll() is not None or time.monotonic() > deadline:
            raise SystemExit("the run ended before a worker could be killed")
        time.sleep(0.1)
    time.sleep(1.0)
    os.kill(int(busy[0].parent.name.rsplit("-", 1)[1]), signal.SIGKILL)
    process.communicate()
    failed_first = report(out)["counts"]["failed"]
    partial_after_kill = partial_files(out)
    timed(fh("jobs", path, "--out-dir", out, "--workers", 2))
    doc = report(out)
    lost = doc["counts"]["rows"] - doc["counts"]["done"] - doc["counts"]["skipped"]
    return {"kill_failed_rows": failed_first, "kill_partial_after_kill": partial_after_kill,
            "kill_lost_rows": lost, "kill_partial_files": partial_files(out)}


def openjd(path: Path, folder: Path, chunk: int, local: Path) -> dict:
    zip_path = sorted((ROOT / "dist").glob("faces_hands-*-py311-linux_x64.zip"))[-1]
    blender = blender_standin.write_wrapper(folder / "blender")
    bundle, out = folder / "bundle", folder / "out_openjd"
    timed(fh("jobs", path, "--out-dir", out, "--openjd", bundle, "--chunk", chunk, "--extension-zip", zip_path,
             "--blender", blender))
    openjd_cli = Path(sys.executable).with_name("openjd")
    check = subprocess.run([openjd_cli, "check", bundle / "template.json"], capture_output=True, text=True)
    values = json.loads((bundle / "parameter_values.json").read_text())["parameterValues"]
    params = [arg for v in values for arg in ("-p", f"{v['name']}={v['value']}")]
    cache = USER_DIR / "extensions" / ".user" / "user_default" / "faces_hands" / "cache"
    env = {k: v for k, v in os.environ.items() if k != "BLENDER_USER_RESOURCES"}
    wall, result = timed([openjd_cli, "run", bundle / "template.json", *params, "-p", f"CacheDir={cache}"],
                         env=env, cwd=folder)
    log = result.stdout + result.stderr
    (folder / "openjd_run.log").write_text(log)
    stamps = {label: _stamp(log, pattern) for label, pattern in
              (("env", r"openjd_env: FH_CACHE_DIR"), ("bake", r"Running step 'BakeRows'"),
               ("merge", r"Running step 'MergeReports'"))}
    doc = report(out)
    rows = [r for r in doc["rows"] if r["state"] == "done"]
    tasks = -(-doc["counts"]["rows"] // chunk)
    row_seconds = sum(r["seconds"] for r in rows)
    same = all((out / r["out"]).read_bytes() == (local / r["out"]).read_bytes() for r in rows
               if (local / r["out"]).exists())
    return {"openjd_check_ok": int(check.returncode == 0), "openjd_run_ok": int(result.returncode == 0),
            "openjd_rows_done": len(rows), "openjd_tasks": tasks, "openjd_wall_s": wall,
            "openjd_env_s": stamps["env"], "openjd_task_overhead_s": (stamps["merge"] - stamps["bake"] - row_seconds)
            / tasks, "openjd_merge_s": wall - stamps["merge"], "openjd_same_bytes": int(same)}


def _stamp(log: str, pattern: str) -> float:
    match = re.search(r"^(\d+):(\d+):([\d.]+)\s.*" + pattern, log, re.M)
    return int(match.group(1)) * 3600 + int(match.group(2)) * 60 + float(match.group(3)) if match else -1.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rows", type=int, default=200)
    parser.add_argument("--full", action="store_true", help="1,000 rows")
    parser.add_argument("--kill-rows", type=int, default=12)
    parser.add_argument("--openjd-rows", type=int, default=12)
    parser.add_argument("--chunk", type=int, default=4)
    parser.add_argument("--resume-rows", type=int, default=1000)
    parser.add_argument("--skip", default="", help="comma-separated parts to leave out: check,resume,start,"
                                                   "throughput,kill,openjd")
    parser.add_argument("--rig", help="mask: every row on the face-only head (default: the default character)")
    parser.add_argument("--rig-cache", choices=("warm", "cold", "off"), default="warm",
                        help="the built default rig in the user's cache folder for the throughput runs "
                             "(module docstring)")
    args = parser.parse_args()
    if args.rig_cache == "off":
        os.environ["FH_NO_RIG_CACHE"] = "1"
    if args.rig:
        RIG[:] = ["--rig", args.rig]
    rows = 1000 if args.full else args.rows
    skip = set(filter(None, args.skip.split(",")))
    folder = Path(tempfile.mkdtemp(prefix="fh-bench-jobs-"))
    figures = {"rows": rows, "cores": os.cpu_count(), "rig": args.rig or "character", "rig_cache": args.rig_cache}
    try:
        warm = manifest(folder / "warm.csv", 1, seed=1)          # fill the shape cache once
        timed(fh("jobs", warm, "--out-dir", folder / "warm"))
        if "check" not in skip:
            figures.update(check_100k(folder))
        if "resume" not in skip:
            figures.update(resume_at_scale(folder, args.resume_rows))
        if "start" not in skip:
            figures.update(start_cost(folder))
        path = manifest(folder / "lines.csv", rows)
        if "throughput" not in skip:
            figures.update(throughput(path, folder, args.rig_cache))
        if "kill" not in skip:
            figures.update(kill_one(manifest(folder / "kill.csv", args.kill_rows, seed=3), folder))
        if "openjd" not in skip:
            subset = folder / "subset.csv"
            subset.write_text("".join(path.read_text().splitlines(keepends=True)[:args.openjd_rows + 1]))
            figures.update(openjd(subset, folder, args.chunk, folder / "out1"))
    finally:
        if os.environ.get("FH_BENCH_KEEP") == "1":
            print(f"kept {folder}")
        else:
            shutil.rmtree(folder, ignore_errors=True)
    for key, value in figures.items():
        print(f"{key:28s} {value:.3f}" if isinstance(value, float) else f"{key:28s} {value}")
    print("RESULT " + " ".join(f"{k}={v:.3f}" if isinstance(v, float) else f"{k}={v}" for k, v in figures.items()))


if __name__ == "__main__":
    main()
