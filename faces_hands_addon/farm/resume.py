# SPDX-License-Identifier: GPL-3.0-or-later
"""Resume and idempotence: a sidecar beside every row's output, and a commit that never leaves half a row.

A row's **key** is a SHA-256 over what its outputs are made of: the row's options (the output names
included), the SHA-256 of each input file's content (not its path: a farm sees the same audio under
another folder), the rig, the frame rate, the extension's version and the engine's fingerprint (its code,
shipped presets and the artist's preset overrides). The **sidecar** (``<out>.fhjob.json``) records the key
and, per output, its size, modification time and SHA-256. A row is *current* when its sidecar is complete,
has the key the row has now and every output is there as recorded: a rerun skips it.

A worker writes a row's files into its own staging folder inside the output folder (same file system),
then commits: (1) the sidecar, marked incomplete, replaces the old one, so the files about to be replaced
are known to be this run's; (2) each output is renamed into place (``os.replace``: atomic); (3) the
complete sidecar replaces the incomplete one. A process killed at any point leaves every output either
old or new, never partial, and the row not current, so a rerun redoes exactly that row; what is left in its
staging folder is removed by the next run on the same machine.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import socket
from dataclasses import dataclass, field
from pathlib import Path

from ..core.errors import UserError
from .manifest import Problem
from .rows import FARM_FOLDER, JobRow

__all__ = ["SIDECAR_FORMAT", "RunIdentity", "InputHashes", "row_key", "Plan", "plan_rows", "read_sidecar",
           "commit_row", "staging_folder", "remove_stale_staging", "file_sha256"]

SIDECAR_FORMAT = "faces_hands.job_sidecar"
_BLOCK = 1 << 20
_MAX_SIDECAR_BYTES = 1 << 20


def file_sha256(path: str | os.PathLike) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(_BLOCK), b""):
            digest.update(block)
    return digest.hexdigest()


@dataclass(frozen=True)
class RunIdentity:
    """What every row of a run shares: the extension's version, the engine's fingerprint, the rig
    (``default`` or the SHA-256 of a rig file) and the frame rate."""
    extension_version: str
    engine: str
    rig: str
    fps: float


class InputHashes:
    """SHA-256 of input files, each read once per run."""

    def __init__(self):
        self._known: dict[str, str] = {}

    def __call__(self, path: str) -> str:
        digest = self._known.get(path)
        if digest is None:
            try:
                digest = self._known[path] = file_sha256(path)
            except OSError as error:
                raise UserError(f"cannot read {path}: {error.strerror}") from None
        return digest


def row_key(row: JobRow, run: RunIdentity, hashes: InputHashes) -> tuple[str, dict[str, str]]:
    """``(key, {input label: sha256})`` of ``row`` (see the module docstring)."""
    inputs = {"audio": hashes(row.audio)} if row.audio else {}
    fields = row.fields()
    for name in ("line", "audio", "audio_as_given"):
        fields.pop(name)
    blob = json.dumps({"row": fields, "inputs": inputs, "run": run.__dict__}, sort_keys=True,
                      separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest(), inputs


def read_sidecar(out_dir: Path, row: JobRow) -> dict | None:
    """The row's sidecar as written, or None (missing, not ours, unreadable)."""
    path = os.path.join(out_dir, row.sidecar)
    try:
        if os.path.getsize(path) > _MAX_SIDECAR_BYTES:
            return None
        with open(path, encoding="utf-8") as handle:
            doc = json.load(handle)
    except (OSError, ValueError):
        return None
    return doc if isinstance(doc, dict) and doc.get("format") == SIDECAR_FORMAT else None


class _Listing:
    """The names in each folder of the output folder, listed once (so a row whose files do not exist yet
    costs no file-system call); a name that differs only in case is asked of the file system (the same
    file where it ignores case)."""

    def __init__(self, out_dir: Path):
        self.root, self.folders = str(out_dir), {}

    def exists(self, name: str) -> bool:
        folder, _, base = name.rpartition("/")
        known = self.folders.get(folder)
        if known is None:
            try:
                names = set(os.listdir(os.path.join(self.root, folder)))
            except OSError:
                names = set()
            known = self.folders[folder] = (names, {n.casefold() for n in names})
        if base in known[0]:
            return True
        return base.casefold() in known[1] and os.path.lexists(os.path.join(self.root, name))


def _is_current(out_dir: Path, row: JobRow, key: str, doc: dict | None) -> bool:
    if not doc or not doc.get("complete") or doc.get("key") != key:
        return False
    outputs = doc.get("outputs")
    if not isinstance(outputs, dict) or set(outputs) != set(row.outputs()):
        return False
    for name, record in outputs.items():
        try:
            stat = os.stat(os.path.join(out_dir, name))
        except OSError:
            return False
        if not isinstance(record, dict) or (stat.st_size, stat.st_mtime_ns) != (record.get("bytes"),
                                                                                record.get("mtime_ns")):
            return False
    return True


@dataclass
class Plan:
    """The rows to run (with their keys), the rows already current, and outputs that are in the way."""
    todo: list[tuple[JobRow, str, dict]] = field(default_factory=list)
    current: list[JobRow] = field(default_factory=list)
    problems: list[Problem] = field(default_factory=list)


def plan_rows(rows: list[JobRow], out_dir: Path, run: RunIdentity, overwrite: bool = False) -> Plan:
    """Which rows are current and which to run; an existing output that no sidecar of this manifest
    claims was not written by a jobs run and is refused (kept) unless ``overwrite``."""
    plan, hashes, listing = Plan(), InputHashes(), _Listing(out_dir)
    for row in rows:
        try:
            key, inputs = row_key(row, run, hashes)
        except UserError as error:
            plan.problems.append(Problem(row.line, str(error)))
            continue
        names = row.outputs() + (row.sidecar,)
        present = [name for name in names if listing.exists(name)]
        doc = read_sidecar(out_dir, row) if row.sidecar in present else None
        if _is_current(out_dir, row, key, doc):
            plan.current.append(row)
            continue
        ours = set(doc.get("outputs") or ()) | {row.sidecar} if doc else set()
        foreign = [name for name in present if name not in ours]
        if foreign and not overwrite:
            plan.problems.append(Problem(row.line, f"{', '.join(foreign)} exist(s) and a jobs run did not write "
                                                   "them; move them away or pass --overwrite"))
            continue
        plan.todo.append((row, key, inputs))
    return plan


def staging_folder(out_dir: Path) -> Path:
    """This process's staging folder inside the output folder (same file system: renames are atomic)."""
    return out_dir / FARM_FOLDER / "staging" / f"{socket.gethostname()}-{os.getpid()}"


def remove_stale_staging(out_dir: Path) -> list[Path]:
    """Remove the staging folders of this machine's processes that are gone (a killed worker's); returns
    them. Folders of other machines (a shared output folder on a farm) are left to those machines."""
    root = out_dir / FARM_FOLDER / "staging"
    removed = []
    host = socket.gethostname()
    for folder in sorted(root.glob(f"{host}-*")) if root.is_dir() else ():
        pid = folder.name[len(host) + 1:]
        if pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    if os.name != "posix":
        return True                                   # no cheap, harmless probe: keep the folder
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _write_json(path: Path, doc: dict, staging: Path) -> None:
    tmp = staging / (path.name + ".tmp")
    tmp.write_text(json.dumps(doc, indent=1, sort_keys=True), encoding="utf-8")
    path.parent.mkdir(parents=True, exist_ok=True)
    os.replace(tmp, path)


def commit_row(out_dir: Path, row: JobRow, key: str, inputs: dict, staged: dict[str, Path], staging: Path,
               extension_version: str) -> dict:
    """Move the row's staged files into place and write its sidecar (the module docstring's three steps);
    returns the complete sidecar."""
    missing = [name for name in row.outputs() if name not in staged or not staged[name].is_file()]
    if missing:
        raise UserError(f"the row wrote no {', '.join(missing)}")
    digests = {name: file_sha256(staged[name]) for name in row.outputs()}
    doc = {"format": SIDECAR_FORMAT, "version": 1, "complete": False, "key": key, "line": row.line,
           "extension_version": extension_version, "inputs": inputs, "row": row.fields(),
           "outputs": {name: {} for name in row.outputs()}}
    sidecar = out_dir / row.sidecar
    _write_json(sidecar, doc, staging)
    for name in row.outputs():
        final = out_dir / name
        final.parent.mkdir(parents=True, exist_ok=True)
        os.replace(staged[name], final)
    for name in row.outputs():
        stat = (out_dir / name).stat()
        doc["outputs"][name] = {"bytes": stat.st_size, "mtime_ns": stat.st_mtime_ns, "sha256": digests[name]}
    doc["complete"] = True
    _write_json(sidecar, doc, staging)
    return doc
