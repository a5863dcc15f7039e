# SPDX-License-Identifier: GPL-3.0-or-later
"""Reading a jobs manifest (CSV or JSON Lines) line by line, with every problem kept against its line.

A manifest is read once, in one pass and in bounded memory per row: each physical line is decoded on its
own, so a byte that is not UTF-8 or a NUL byte is reported on the line that holds it and the lines around
it are still read. A CSV record that spans several lines (a quoted line break) carries the number of the
line it starts on; a JSON Lines row is one line. Nothing here looks at what a row means
(:mod:`.rows` does); this module only turns the file into ``(line, {column: text})`` pairs.
"""
from __future__ import annotations

import csv
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

from ..core.errors import UserError

__all__ = ["COLUMNS", "REQUIRED", "MAX_ROWS", "MAX_FILE_BYTES", "Problem", "RawRow", "Reading", "read_manifest",
           "manifest_kind"]

#: every column a row may have; a header naming anything else is refused (a misspelt column would be ignored)
COLUMNS = ("action", "out", "text", "audio", "transcript", "voice", "rate", "style", "seed", "emotion",
           "animation", "live_link", "cues")
REQUIRED = ("action", "out")
MAX_ROWS = 1_000_000
MAX_FILE_BYTES = 1 << 30
MAX_CELL_CHARS = 100_000
_SUFFIXES = {".csv": "csv", ".jsonl": "jsonl", ".ndjson": "jsonl"}
NUL = bytes(1)


@dataclass(frozen=True)
class Problem:
    """One thing wrong with the manifest, at a line (1 = the first line; 0 = the file as a whole)."""
    line: int
    message: str

    def text(self, name: str) -> str:
        return f"{name}:{self.line}: {self.message}" if self.line else f"{name}: {self.message}"


@dataclass(frozen=True)
class RawRow:
    line: int
    cells: dict[str, str]


@dataclass
class Reading:
    """The rows of a manifest as text, and every problem found while reading it."""
    path: Path
    rows: list[RawRow] = field(default_factory=list)
    problems: list[Problem] = field(default_factory=list)
    overflow: bool = False

    def problem(self, line: int, message: str) -> None:
        self.problems.append(Problem(line, message))


def manifest_kind(path: Path) -> str:
    kind = _SUFFIXES.get(path.suffix.lower())
    if kind is None:
        raise UserError(f"{path.name}: a jobs manifest is a .csv or a .jsonl (JSON Lines) file")
    return kind


def read_manifest(path: str | os.PathLike) -> Reading:
    """Every row of the manifest at ``path`` with its line number, and every problem of the file (file-level
    problems that leave nothing to read raise :class:`UserError` at once)."""
    path = Path(path)
    kind = manifest_kind(path)
    if not path.is_file():
        raise UserError(f"jobs manifest {path} does not exist")
    size = path.stat().st_size
    if size > MAX_FILE_BYTES:
        raise UserError(f"{path.name} is {size / 2**30:.1f} GiB; a manifest may be at most "
                        f"{MAX_FILE_BYTES / 2**30:.0f} GiB: split it")
    reading = Reading(path)
    with open(path, "rb") as handle:
        lines = _decoded_lines(handle, reading)
        (_read_csv if kind == "csv" else _read_jsonl)(lines, reading)
    if not reading.rows and not reading.problems:
        reading.problem(0, "has no job rows (a header line, then one row per job)" if kind == "csv"
                        else "has no job rows (one JSON object per line)")
    return reading


def _decoded_lines(handle, reading: Reading) -> Iterator[str]:
    """The file's lines as text; a line that is not UTF-8 or holds a NUL byte is reported and given as an
    empty line (its row then fails on the problem already listed)."""
    for number, raw in enumerate(handle, start=1):
        if number == 1 and raw.startswith(b"\xef\xbb\xbf"):
            raw = raw[3:]                             # the byte-order mark spreadsheets write
        bad = False
        nul = raw.find(NUL)
        if nul >= 0:
            reading.problem(number, f"has a NUL byte (column {nul + 1}); a manifest is text")
            bad = True
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as error:
            reading.problem(number, f"is not UTF-8 (byte 0x{raw[error.start]:02x} at column {error.start + 1}); "
                                    "save the manifest as UTF-8")
            bad = True
        yield "\n" if bad else text


def _read_csv(lines: Iterator[str], reading: Reading) -> None:
    csv.field_size_limit(MAX_CELL_CHARS)
    reader = csv.reader(lines, strict=True)
    try:
        header = next(reader, None)
    except csv.Error as error:
        reading.problem(1, f"the header is not valid CSV ({error})")
        return
    if header is None:
        return
    columns = [name.strip().lower() for name in header]
    if not _header_ok(columns, reading):
        return
    start = reader.line_num + 1
    while True:
        try:
            cells = next(reader)
        except StopIteration:
            break
        except csv.Error as error:
            reading.problem(start, f"is not valid CSV ({error})")
            start = reader.line_num + 1
            continue
        line, start = start, reader.line_num + 1
        if not cells or (len(cells) == 1 and not cells[0].strip()):
            continue                                  # a blank line
        if len(cells) > len(columns):
            reading.problem(line, f"has {len(cells)} cells, the header names {len(columns)} columns")
            continue
        if _room_for(line, reading):
            reading.rows.append(RawRow(line, dict(zip(columns, [cell.strip() for cell in cells]))))


def _header_ok(columns: list[str], reading: Reading) -> bool:
    unknown = [name for name in columns if name not in COLUMNS]
    missing = [name for name in REQUIRED if name not in columns]
    twice = sorted({name for name in columns if columns.count(name) > 1})
    if unknown:
        reading.problem(1, f"unknown column(s) {', '.join(repr(n) for n in unknown)}; the columns are "
                           f"{', '.join(COLUMNS)}")
    if missing:
        reading.problem(1, f"no {' and no '.join(repr(n) for n in missing)} column: every row needs "
                           f"{' and '.join(REQUIRED)}")
    if twice:
        reading.problem(1, f"column(s) {', '.join(twice)} named twice")
    return not (unknown or missing or twice)


def _room_for(line: int, reading: Reading) -> bool:
    if len(reading.rows) < MAX_ROWS:
        return True
    if not reading.overflow:
        reading.problem(line, f"more than {MAX_ROWS:,} rows; split the manifest")
        reading.overflow = True
    return False


def _read_jsonl(lines: Iterator[str], reading: Reading) -> None:
    for line, text in enumerate(lines, start=1):
        if not text.strip():
            continue
        try:
            value = json.loads(text)
        except (ValueError, RecursionError) as error:
            reading.problem(line, f"is not JSON ({error})")
            continue
        if not isinstance(value, dict):
            reading.problem(line, "is not a JSON object ({\"action\": ..., \"out\": ...})")
            continue
        cells, wrong = {}, []
        for key, cell in value.items():
            name = str(key).strip().lower()
            if name not in COLUMNS:
                wrong.append(f"unknown key {key!r}")
            elif cell is None:
                continue
            elif isinstance(cell, (dict, list)) or isinstance(cell, str) and len(cell) > MAX_CELL_CHARS:
                wrong.append(f"{key!r} must be a short text or a number")
            else:
                cells[name] = (("true" if cell else "false") if isinstance(cell, bool) else str(cell)).strip()
        absent = [name for name in REQUIRED if name not in cells]
        if absent and not wrong:
            wrong.append(f"no {' and no '.join(repr(n) for n in absent)}")
        if wrong:
            reading.problem(line, "; ".join(wrong) + f" (the keys are {', '.join(COLUMNS)})")
        elif _room_for(line, reading):
            reading.rows.append(RawRow(line, cells))
