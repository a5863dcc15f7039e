# SPDX-License-Identifier: GPL-3.0-or-later
"""Dialogue at studio scale: jobs manifests of thousands of rows, run by local workers or on a farm.

* :mod:`.manifest` -- a CSV or JSON Lines manifest read line by line (encoding and NUL problems per line).
* :mod:`.rows` -- what each row means, its outputs inside the output folder, all checked in linear time.
* :mod:`.check` -- the whole manifest checked before any work, every bad line listed; farm chunks.
* :mod:`.resume` -- row keys, sidecars, the all-or-nothing commit of a row, stale staging.
* :mod:`.report` -- the run's report (JSON and summary), the progress line, merged chunk reports.
* :mod:`.openjd` -- the Open Job Description job bundle of a manifest.

Engine only: no Blender. The operators (``operators/farm``) run the rows in Blender processes.
"""
from .check import CheckedManifest, check_manifest, chunk_of, chunk_starts, problems_text
from .manifest import COLUMNS, Problem
from .report import RunReport, merge_reports, progress_line
from .resume import RunIdentity, commit_row, plan_rows
from .rows import ACTIONS, JobRow

__all__ = ["CheckedManifest", "check_manifest", "chunk_of", "chunk_starts", "problems_text", "COLUMNS", "Problem",
           "RunReport", "merge_reports", "progress_line", "RunIdentity", "commit_row", "plan_rows", "ACTIONS",
           "JobRow"]
