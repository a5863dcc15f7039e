# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands jobs MANIFEST``: a manifest of speak/lipsync rows checked whole before any work, then run
by local workers (``--workers N``), one farm task's chunk (``--first-row``), the farm job's merged report
(``--merge-reports``) or written as an Open Job Description bundle (``--openjd DIR``)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ...faces_hands_addon.anim.timing import check_fps
from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.farm.check import CheckedManifest, check_manifest, chunk_of, problems_text
from ...faces_hands_addon.farm.resume import Plan, plan_rows
from ..bases.bake import MAX_FRAMES
from ..adapters.outputs import check_output_dir
from . import modes
from .runner import run_identity

__all__ = ["Jobs", "COMMANDS"]

MAX_WORKERS = 64


def _arguments(parser) -> None:
    parser.add_argument("manifest", nargs="?", help="the jobs manifest: .csv (a header line, then one row per job) "
                        "or .jsonl (one JSON object per line); columns: action (speak or lipsync), out, and text "
                        "(speak) or audio [+ transcript] (lipsync); optional voice, rate, style, seed, emotion, "
                        "animation, live_link, cues")
    parser.add_argument("--out-dir", help="the output folder: every 'out' is relative to it and nothing is "
                                          "written outside it (default: the manifest's folder)")
    parser.add_argument("--check", action="store_true",
                        help="only check the manifest: list every bad line, count the rows already current")
    parser.add_argument("--workers", type=int, default=1,
                        help="Blender processes taking rows from one queue (default 1; one per core at most "
                             "pays off: each row uses about one core)")
    parser.add_argument("--rig", help="a .blend with a face rig for every row (default: the default head, built "
                                      "once per worker)")
    parser.add_argument("--fps", type=float, default=30.0, help="frame rate of the animations (default 30)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace outputs that exist although no jobs run wrote them (never an input)")
    parser.add_argument("--report", help="where the JSON report goes (default: jobs_report.json in the output "
                                         "folder)")
    parser.add_argument("--openjd", metavar="DIR", help="write an Open Job Description job bundle for a farm "
                                                        "into DIR instead of running (needs --extension-zip)")
    parser.add_argument("--chunk", type=int, default=25, help="rows per farm task (default 25)")
    parser.add_argument("--extension-zip", help="with --openjd: the extension zip the farm's workers install")
    parser.add_argument("--blender", default="blender",
                        help="with --openjd: Blender on the farm's workers (default: 'blender' on their PATH)")
    parser.add_argument("--first-row", type=int,
                        help="run one chunk: --chunk rows from this row on (1 = the first row); a farm task")
    parser.add_argument("--merge-reports", action="store_true",
                        help="merge the chunk reports of a farm job into one report (the job's last step)")
    parser.add_argument("--serve", action="store_true", help=argparse.SUPPRESS)    # a worker of --workers


def checked(args) -> CheckedManifest:
    """The manifest checked whole; every bad line is printed and nothing runs while there is one."""
    from ...faces_hands_addon.speech.espeak import check_voice
    try:
        check_fps(args.fps)
    except UserError:
        raise UserError(f"--fps {args.fps} is outside 1..240") from None
    if args.rig and (not Path(args.rig).is_file() or Path(args.rig).suffix.lower() != ".blend"):
        raise UserError(f"--rig {args.rig}: give an existing .blend file with a face rig")
    manifest = Path(args.manifest)
    out_dir = check_output_dir(args.out_dir or manifest.parent)
    result = check_manifest(manifest, out_dir, fps=args.fps, max_frames=MAX_FRAMES,
                            voice_check=check_voice, rig=args.rig)
    _refuse(manifest, result.problems)
    return result


def planned(args, rows, manifest: CheckedManifest, overwrite: bool | None = None) -> Plan:
    """Which of ``rows`` are current; outputs in the way refuse the run like bad lines."""
    plan = plan_rows(rows, manifest.out_dir, run_identity(args.rig, args.fps),
                     args.overwrite if overwrite is None else overwrite)
    _refuse(manifest.path, plan.problems)
    return plan


def _refuse(manifest: Path, problems) -> None:
    if problems:
        print(problems_text(manifest.name, problems), file=sys.stderr, flush=True)
        lines = len({problem.line for problem in problems})
        raise UserError(f"{manifest.name}: {lines} bad line{'s' if lines != 1 else ''} (listed above); nothing was "
                        "run: fix them and run again")


def _check_numbers(args) -> None:
    if not 1 <= args.workers <= MAX_WORKERS:
        raise UserError(f"--workers {args.workers}: give 1..{MAX_WORKERS}")
    if args.chunk < 1:
        raise UserError(f"--chunk {args.chunk}: a chunk has at least one row")
    chosen = [name for name, on in (("--check", args.check), ("--openjd", args.openjd),
                                     ("--first-row", args.first_row is not None),
                                     ("--merge-reports", args.merge_reports)) if on]
    if len(chosen) > 1:
        raise UserError(f"{' and '.join(chosen)} do different things; give one of them")


class Jobs:
    NAME = "jobs"
    HELP = ("run a manifest of speak/lipsync rows (CSV or JSON Lines): checked whole first, on N local "
            "workers, resumable; or an Open Job Description bundle for a farm")

    @staticmethod
    def add_arguments(parser):
        _arguments(parser)

    @staticmethod
    def run(args, progress) -> int:
        _check_numbers(args)
        if args.serve:
            return modes.serve(args)
        if not args.manifest:
            raise UserError("give the jobs manifest (a .csv or .jsonl file)")
        manifest = checked(args)
        if args.openjd:
            return modes.write_openjd(args, manifest)
        if args.merge_reports:
            return modes.merge(args, manifest, planned(args, manifest.rows, manifest, overwrite=True))
        if args.first_row is not None:
            rows = chunk_of(manifest.rows, args.first_row, args.chunk)
            return modes.run_chunk(args, manifest, planned(args, rows, manifest), progress)
        plan = planned(args, manifest.rows, manifest)
        if args.check:
            print(f"{manifest.path.name}: {len(manifest.rows)} rows OK ({manifest.counts()}); "
                  f"{len(plan.current)} already current (a run skips them), {len(plan.todo)} to run; "
                  f"outputs in {manifest.out_dir}")
            return 0
        return modes.run_local(args, manifest, plan)


COMMANDS = [Jobs]
