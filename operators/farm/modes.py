# SPDX-License-Identifier: GPL-3.0-or-later
"""What ``faces_hands jobs`` does once the manifest is checked: run it on local workers, serve as one of
those workers, run one farm task's chunk, merge a farm job's chunk reports, or write its OpenJD bundle."""
from __future__ import annotations

import json
import os
import sys
import time
import zipfile
from pathlib import Path

import bpy

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.farm.check import CheckedManifest
from ...faces_hands_addon.farm.openjd import (asset_references, job_template, openjd_run_command,
                                               parameter_values, write_bundle)
from ...faces_hands_addon.farm.report import RunReport, merge_reports, write_report
from ...faces_hands_addon.farm.resume import Plan, file_sha256, remove_stale_staging
from ...faces_hands_addon.farm.rows import FARM_FOLDER, REPORT_NAME, JobRow
from ..cli.interrupts import raise_pending
from .pool import Pool, ProgressLine, send
from .runner import RowRunner, extension_version, peak_rss_mb

__all__ = ["serve", "run_local", "run_chunk", "merge", "write_openjd"]

#: a worker in Blender's Python module (no Blender binary): enable the installed extension, run its CLI
_BOOT = """import os, sys
import bpy, addon_utils
module = sys.argv[1]
if not getattr(sys.modules.get(module), "_registered", False):
    addon_utils.enable(module, default_set=False)
code = sys.modules[module].operators.cli.main(sys.argv[2:])
sys.stdout.flush(); sys.stderr.flush(); os._exit(code)
"""


def _report_for(manifest: CheckedManifest, rows: int, workers: int) -> RunReport:
    report = RunReport(manifest.path.name, rows, workers, extension_version=extension_version())
    report.manifest_sha256 = file_sha256(manifest.path)
    return report


def _attempt(runner: RowRunner, row: JobRow, key: str, inputs: dict) -> tuple[dict | None, str]:
    """(timing, "") when the row was written, (None, reason) when it failed; an interrupt goes on."""
    try:
        return runner.run(row, key, inputs), ""
    except UserError as error:
        raise_pending()             # a signal that a Blender operator turned into an error is an interrupt
        return None, str(error)
    except Exception as error:  # a bug in one row must not cost the other rows
        raise_pending()
        return None, f"internal error: {type(error).__name__}: {error}"


def serve(args) -> int:
    """A worker of ``--workers``: rows from standard input, one at a time, answers on the protocol stream
    (the real standard output; everything else printed goes to standard error, the worker's log)."""
    sys.stdout.flush()
    protocol = os.fdopen(os.dup(sys.stdout.fileno()), "w", encoding="utf-8")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    runner = RowRunner(Path(args.out_dir), args.rig, args.fps)
    try:
        send(protocol, {"ready": True, "pid": os.getpid(), "staging": str(runner.staging), "rss_mb": peak_rss_mb()})
        for line in iter(sys.stdin.readline, ""):
            message = json.loads(line)
            if message.get("stop"):
                break
            row = JobRow.from_fields(message["row"])
            timing, reason = _attempt(runner, row, message["key"], message["inputs"])
            answer = {"done": row.line, **timing} if timing is not None else {"failed": reason}
            send(protocol, {**answer, "rss_mb": peak_rss_mb()})
    finally:
        runner.close()
    return 0


def _worker_command(args, out_dir: Path) -> list[str]:
    """How to start a worker: Blender itself (``-b -c faces_hands``), or, inside Blender's Python module,
    this Python with the installed extension enabled."""
    tail = ["jobs", "--serve", "--out-dir", str(out_dir.resolve()), "--fps", repr(float(args.fps))]
    tail += ["--rig", str(Path(args.rig).resolve())] if args.rig else []
    if bpy.app.binary_path:
        return [bpy.app.binary_path, "-b", "-c", "faces_hands", *tail]
    return [sys.executable, "-c", _BOOT, __package__.rsplit(".operators", 1)[0], *tail]


def run_local(args, manifest: CheckedManifest, plan: Plan) -> int:
    """Every row not current, on ``--workers`` processes; the report in the output folder."""
    out_dir = manifest.out_dir
    out_dir.mkdir(parents=True, exist_ok=True)
    remove_stale_staging(out_dir)
    workers = min(args.workers, max(1, len(plan.todo)))
    report = _report_for(manifest, len(manifest.rows), workers)
    report.skipped = {row.line: row.out for row in plan.current}
    path = Path(args.report) if args.report else out_dir / REPORT_NAME
    started = time.monotonic()
    try:
        if plan.todo:
            Pool(_worker_command(args, out_dir), workers, out_dir, report, dict(os.environ),
                 ProgressLine(args.quiet)).run(plan.todo)
    except KeyboardInterrupt:
        print(report.summary() + f"\ninterrupted: the rows not run are redone by the next run; report: {path}")
        raise
    finally:
        report.wall_s = time.monotonic() - started
        write_report(path, report)
    print(report.summary())
    print(f"report: {path}")
    return 1 if report.failed else 0


def run_chunk(args, manifest: CheckedManifest, plan: Plan, progress) -> int:
    """One farm task: its rows in this process (the rig built once), a chunk report for the merge step.
    A failed row is in the report; the task itself succeeds (the merge step fails the job)."""
    out_dir = manifest.out_dir
    out_dir.mkdir(parents=True, exist_ok=True)
    report = _report_for(manifest, len(plan.todo) + len(plan.current), 1)
    report.skipped = {row.line: row.out for row in plan.current}
    path = out_dir / FARM_FOLDER / "reports" / f"rows-{args.first_row:07d}.json"
    started = time.monotonic()
    runner = RowRunner(out_dir, args.rig, args.fps, progress) if plan.todo else None
    try:
        for index, (row, key, inputs) in enumerate(plan.todo):
            print(f"openjd_progress: {100.0 * index / len(plan.todo):.1f}", flush=True)
            timing, reason = _attempt(runner, row, key, inputs)
            if timing is None:
                report.fail(row.line, row.out, reason)
                print(f"line {row.line} ({row.out}): failed: {reason}", flush=True)
            else:
                report.done[row.line] = {"out": row.out, **timing, "worker": 1}
                print(f"line {row.line} ({row.out}): done in {timing['seconds']:.1f} s", flush=True)
    finally:
        if runner is not None:
            runner.close()
        report.wall_s = time.monotonic() - started
        report.worker_peak_rss_mb[f"rows-{args.first_row}"] = peak_rss_mb() or 0.0
        write_report(path, report)
    print(report.summary(), flush=True)
    return 0


def merge(args, manifest: CheckedManifest, plan: Plan) -> int:
    """The farm job's last step: one report from the chunk reports and the sidecars; fails when a row did."""
    folder = manifest.out_dir / FARM_FOLDER / "reports"
    digest = file_sha256(manifest.path)
    parts = []
    for path in sorted(folder.glob("rows-*.json")) if folder.is_dir() else ():
        try:
            part = RunReport.from_json(path.read_text(encoding="utf-8"))
        except (OSError, ValueError, KeyError, TypeError):
            print(f"skipping {path.name}: not a chunk report", file=sys.stderr)
            continue
        if part.manifest_sha256 == digest:
            parts.append(part)
    merged = merge_reports(manifest.path.name, {row.line: row.out for row in manifest.rows},
                           {row.line for row in plan.current}, parts)
    merged.manifest_sha256 = digest
    path = Path(args.report) if args.report else manifest.out_dir / REPORT_NAME
    write_report(path, merged)
    print(merged.summary())
    print(f"report: {path}")
    return 1 if merged.failed else 0


def _check_zip(path: str | None) -> Path:
    if not path:
        raise UserError("--openjd needs --extension-zip ZIP: the extension zip the farm's workers install")
    zip_path = Path(path)
    try:
        with zipfile.ZipFile(zip_path) as archive:
            archive.getinfo("blender_manifest.toml")
    except (OSError, zipfile.BadZipFile, KeyError):
        raise UserError(f"--extension-zip {zip_path}: not an extension zip (no blender_manifest.toml in it)") from None
    return zip_path.resolve()


def write_openjd(args, manifest: CheckedManifest) -> int:
    """The manifest as an OpenJD job bundle in ``--openjd DIR``; prints how to run and submit it."""
    zip_path = _check_zip(args.extension_zip)
    folder = Path(args.openjd)
    rig = Path(args.rig).resolve() if args.rig else None
    template = job_template(manifest.path.name, len(manifest.rows), args.chunk, float(args.fps), rig is not None)
    values = parameter_values(manifest.path.resolve(), manifest.out_dir.resolve(), zip_path, args.blender,
                              args.chunk, float(args.fps), rig)
    inputs = [manifest.path.resolve(), zip_path] + ([rig] if rig else []) + sorted(
        {Path(row.audio) for row in manifest.rows if row.audio})
    written = write_bundle(folder, template, values, asset_references(inputs, manifest.out_dir.resolve()))
    tasks = -(-len(manifest.rows) // args.chunk)
    print(f"wrote the OpenJD job bundle {folder}: {len(manifest.rows)} rows in {tasks} tasks of up to "
          f"{args.chunk} rows ({', '.join(p.name for p in written)})")
    print(f"check it:  openjd check {folder / 'template.json'}")
    print("run it here:  " + " ".join(_quoted(part) for part in openjd_run_command(folder, values)))
    print(f"submit it to Deadline Cloud:  deadline bundle submit {folder}")
    return 0


def _quoted(text: str) -> str:
    import shlex
    return shlex.quote(text)
