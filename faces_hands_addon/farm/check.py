# SPDX-License-Identifier: GPL-3.0-or-later
"""The whole manifest checked before any work, in one place: reading (:mod:`.manifest`), every row's
meaning and outputs (:mod:`.rows`), then which rows are current (:mod:`.resume`); every problem of every
line is listed, sorted by line, and nothing runs until there are none. Also the chunks of a farm job."""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from ..core.errors import UserError
from .manifest import Problem, read_manifest
from .rows import JobRow, RowChecks, check_rows

__all__ = ["CheckedManifest", "check_manifest", "problems_text", "chunk_starts", "chunk_of"]


@dataclass
class CheckedManifest:
    path: Path
    out_dir: Path
    rows: list[JobRow] = field(default_factory=list)
    problems: list[Problem] = field(default_factory=list)

    def counts(self) -> str:
        by_action: dict[str, int] = {}
        for row in self.rows:
            by_action[row.action] = by_action.get(row.action, 0) + 1
        return ", ".join(f"{count} {action}" for action, count in sorted(by_action.items()))


def check_manifest(path: str | os.PathLike, out_dir: str | os.PathLike, *, fps: float, max_frames: int,
                   voice_check: Callable[[str], None] | None = None,
                   rig: str | os.PathLike | None = None) -> CheckedManifest:
    """Read and check every row of the manifest at ``path`` for a run writing into ``out_dir``; relative
    inputs are read from the manifest's folder (``out_dir`` is the caller's to check: a folder, or one that
    can be made). Problems are collected, not raised (:func:`problems_text`)."""
    path, out_dir = Path(path), Path(out_dir)
    reading = read_manifest(path)
    checks = RowChecks(path.parent.resolve(), fps, max_frames, voice_check)
    inputs = {"the manifest": str(path)}
    if rig:
        inputs["the rig"] = str(rig)
    rows = check_rows(reading.rows, checks, out_dir, inputs, reading.problems)
    return CheckedManifest(path, out_dir, rows, sorted(reading.problems, key=lambda p: p.line))


def problems_text(name: str, problems: list[Problem]) -> str:
    """One line per problem, ``name:line: message``, in line order."""
    return "\n".join(problem.text(name) for problem in sorted(problems, key=lambda p: p.line))


def chunk_starts(rows: int, size: int) -> list[int]:
    """The first row (1 = the manifest's first row) of every chunk of ``size`` rows."""
    return list(range(1, rows + 1, max(1, size)))


def chunk_of(rows: list[JobRow], first: int, size: int) -> list[JobRow]:
    """Rows ``first`` .. ``first + size - 1`` (1 = the manifest's first row) of a checked manifest."""
    if size < 1:
        raise UserError(f"--chunk {size}: a chunk has at least one row")
    if not 1 <= first <= len(rows):
        raise UserError(f"--first-row {first} is outside the manifest's rows 1..{len(rows)}")
    return rows[first - 1:first - 1 + size]
