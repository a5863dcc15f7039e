# SPDX-License-Identifier: GPL-3.0-or-later
"""Settled static shapes kept on disk, so a rig's expression targets are simulated once, not on every take.

A settled shape (``Rig.settled``: from rest, with fixed control values, for a fixed time) depends only on
the rig's stored data, the control values and the settle time and step: ``baking`` settles every shape from
the rest state. Its key is a SHA-256 of exactly those (the rig's ``identity`` names its stored data), plus
the cache format, a fingerprint of the engine's code and shipped presets (any change to the simulation
makes new keys) and numpy's version; a hit returns the very arrays the
simulation produced (stored losslessly as ``.npz`` without pickles), so an animation baked from cached
targets is byte-identical to one baked from fresh ones. The folder is the extension's user folder (the
operators hand it in); the oldest entries go when it passes ``MAX_BYTES``.

A process also keeps the entries it read or wrote in memory (at most ``MEMORY_BYTES``, the least recently
used go first): a jobs worker bakes every line with the same 211 targets, and reading them from disk again
cost 1.7 s a line. A kept entry is used only while its file is still there, unchanged (same size and
modification time), so the memory never answers what the folder would not; callers get copies.
"""
from __future__ import annotations

import collections
import functools
import hashlib
import json
import os
import tempfile
import zipfile
from pathlib import Path
from stat import S_ISREG
from typing import Callable, Mapping

import numpy as np

from ..core.presets import SHIPPED_FOLDER, user_folder
from ..core.rig import Pose

__all__ = ["ShapeCache", "FORMAT", "MAX_BYTES", "MEMORY_BYTES", "engine_fingerprint"]

FORMAT = 1
MAX_BYTES = 512 * 1024 * 1024
MEMORY_BYTES = 256 * 1024 * 1024    # entries kept in this process (module docstring)
_ENTRY_LIMIT = 64 * 1024 * 1024      # one shape's file; anything larger is not ours
_TMP_PREFIX = ".fh-shape-"           # an entry being written (renamed into place when whole)


def engine_fingerprint() -> str:
    """SHA-256 over the engine's Python files and shipped presets (hashed once) and the artist's preset
    overrides (hashed on every call: an edited preset makes new keys at once)."""
    digest = hashlib.sha256(_shipped_fingerprint().encode("ascii"))
    user = user_folder()
    if user is not None and Path(user).is_dir():
        _hash_tree(digest, Path(user))
    return digest.hexdigest()[:32]


def _hash_tree(digest, root: Path) -> None:
    for path in sorted(p for p in root.rglob("*") if p.suffix in (".py", ".json") and p.is_file()):
        digest.update(path.relative_to(root).as_posix().encode("utf-8") + b"\0" + path.read_bytes())


@functools.lru_cache(maxsize=1)
def _shipped_fingerprint() -> str:
    digest = hashlib.sha256()
    for root in (Path(__file__).resolve().parents[1], Path(SHIPPED_FOLDER)):
        _hash_tree(digest, root)
    return digest.hexdigest()


class ShapeCache:
    """A folder of settled shapes; ``ShapeCache(None)`` caches nothing (every call computes)."""

    def __init__(self, folder: str | os.PathLike | None):
        self.folder = Path(folder) if folder else None
        self.fingerprint = engine_fingerprint() if self.folder else ""
        self.hits = self.misses = 0

    def key(self, identity: str, values: Mapping, settle_time: float, dt: float) -> str:
        blob = json.dumps({"format": FORMAT, "engine": self.fingerprint, "numpy": np.__version__,
                           "rig": identity, "values": _plain(values), "time": settle_time, "dt": dt},
                          sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(blob.encode("utf-8")).hexdigest()[:40]

    def settled(self, rig, values: Mapping, settle_time: float, dt: float, compute: Callable[[], Pose]) -> Pose:
        """The cached pose for (rig, values, time, step), or ``compute()`` stored for next time."""
        path, pose = self.lookup(rig, values, settle_time, dt)
        if pose is None:
            pose = compute()
            self.store(path, pose)
        return pose

    def lookup(self, rig, values: Mapping, settle_time: float, dt: float) -> tuple[Path | None, Pose | None]:
        """``(where the pose belongs, the cached pose or None)``; the place is None when nothing is cached
        (no folder, or a rig without an identity)."""
        identity = getattr(rig, "identity", "")
        if self.folder is None or not identity:
            return None, None
        path = self.folder / f"{self.key(identity, values, settle_time, dt)}.npz"
        pose = _read(path)
        if pose is not None:
            self.hits += 1
        else:
            self.misses += 1
        return path, pose

    def store(self, path: Path | None, pose: Pose) -> None:
        """Keep ``pose`` at the place :meth:`lookup` named (nothing for None)."""
        if path is not None:
            _write(path, pose)
            self._prune()

    def _prune(self) -> None:
        """Remove the oldest entries past ``MAX_BYTES``. Several processes share the folder (jobs workers):
        another's file in the making is left alone, and one that vanishes meanwhile is skipped."""
        entries = []
        for entry in self.folder.glob("*.npz"):
            if entry.name.startswith(_TMP_PREFIX):
                continue
            try:
                stat = entry.stat()
            except OSError:
                continue
            entries.append((stat.st_mtime, stat.st_size, entry))
        entries.sort(key=lambda item: item[0])
        total = sum(size for _, size, _ in entries)
        for _, size, entry in entries:
            if total <= MAX_BYTES:
                break
            total -= size
            entry.unlink(missing_ok=True)


def _plain(values):
    if isinstance(values, Mapping):
        return {str(k): _plain(v) for k, v in values.items()}
    return float(values)


class _Kept:
    """The entries this process read or wrote, by path, with the file's (size, mtime) they belong to."""

    def __init__(self, limit: int):
        self.limit, self.size = limit, 0
        self.entries: collections.OrderedDict = collections.OrderedDict()

    def get(self, path: Path, stamp) -> Pose | None:
        entry = self.entries.get(path)
        if entry is None or entry[0] != stamp:
            return None
        self.entries.move_to_end(path)
        return _copy(entry[1])

    def put(self, path: Path, stamp, pose: Pose) -> None:
        self.drop(path)
        kept = _copy(pose)
        size = _nbytes(kept)
        if size > self.limit:
            return
        self.entries[path] = (stamp, kept, size)
        self.size += size
        while self.size > self.limit:
            _, (_, _, dropped) = self.entries.popitem(last=False)
            self.size -= dropped

    def drop(self, path: Path) -> None:
        entry = self.entries.pop(path, None)
        if entry is not None:
            self.size -= entry[2]


_KEPT = _Kept(MEMORY_BYTES)


def _copy(pose: Pose) -> Pose:
    return Pose({k: a.copy() for k, a in pose.positions.items()}, {k: a.copy() for k, a in pose.transforms.items()})


def _nbytes(pose: Pose) -> int:
    return sum(a.nbytes for group in (pose.positions, pose.transforms) for a in group.values())


def _stamp(path: Path):
    """(size, modification time in ns) of the file at ``path``, or None when there is none."""
    try:
        stat = path.stat()
    except OSError:
        return None
    return (stat.st_size, stat.st_mtime_ns) if S_ISREG(stat.st_mode) else None


def _read(path: Path) -> Pose | None:
    """The pose stored at ``path``, or None when it is missing or not a sound entry (then it is recomputed)."""
    stamp = _stamp(path)
    if stamp is None:
        _KEPT.drop(path)
        return None
    kept = _KEPT.get(path, stamp)
    if kept is not None:
        return kept
    pose = _read_file(path)
    if pose is not None:
        _KEPT.put(path, stamp, pose)
    return pose


def _read_file(path: Path) -> Pose | None:
    try:
        if not path.is_file() or path.stat().st_size > _ENTRY_LIMIT:
            return None
        with np.load(path, allow_pickle=False) as data:
            pose = Pose()
            for name in data.files:
                group, _, role = name.partition("/")
                array = data[name]
                if not np.all(np.isfinite(array)):
                    return None
                (pose.positions if group == "positions" else pose.transforms)[role] = array
            return pose
    except (OSError, ValueError, zipfile.BadZipFile, KeyError, EOFError):
        return None


def _write(path: Path, pose: Pose) -> None:
    """Store ``pose`` at ``path`` (written aside, then renamed: a reader never sees half a file)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays = {f"positions/{role}": a for role, a in pose.positions.items()}
        arrays.update({f"transforms/{role}": a for role, a in pose.transforms.items()})
        handle, tmp = tempfile.mkstemp(prefix=_TMP_PREFIX, suffix=".npz", dir=path.parent)
    except OSError:
        return                                   # a read-only or full cache folder only costs time
    try:
        with os.fdopen(handle, "wb") as stream:
            np.savez(stream, **arrays)
        os.replace(tmp, path)
        stamp = _stamp(path)
        if stamp is not None:
            _KEPT.put(path, stamp, pose)
    except OSError:
        pass
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
