# SPDX-License-Identifier: GPL-3.0-or-later
"""Whole files kept by key in a cache folder, checked before use: the built default character's .blend (a
jobs worker or a ``speak`` without a rig file opens it instead of building the character again) and a
rig's still GLB (read instead of exported again).

An entry is two files. The content is stored under a name that carries its own SHA-256
(``<key>.<sha16>.bin``); the entry's record ``<key>.json`` names that file, its size and full SHA-256, the
cache format and the key with the parts it was made from. Both are written aside and renamed into place
(a reader never sees half a file), the content first: a record always names a whole file. Workers that
build the same entry at the same time each rename their own content and record; the last record wins and
names a file that is whole, the other content file is left unnamed and removed later (``_prune``).

A look-up trusts nothing it has not checked: a record that does not parse, names another key or format,
names a file that is missing, of another size or whose bytes hash to another SHA-256 is reported (the
caller says so and builds again, then stores the new build over it). The key is a SHA-256 over every
part that decides the content's bytes (the caller's: the extension's installed files, Blender's version,
the frame rate, the options); :func:`tree_fingerprint` hashes an installed folder for it. No pickles:
the record is JSON, the content is copied byte for byte.
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
import re
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

__all__ = ["FileCache", "Fetched", "FORMAT", "cache_key", "tree_fingerprint"]

FORMAT = 1
_TMP_PREFIX = ".fh-file-"            # content or a record being written (renamed into place when whole)
_ENTRY_LIMIT = 1024 * 1024 * 1024    # a content file larger than this is not ours
_ORPHAN_AGE_S = 600.0                # an unnamed content file younger than this may be a writer's in the making
_KEY = re.compile(r"^[0-9a-f]{40}$")


def cache_key(parts: Mapping) -> str:
    """SHA-256 (40 hex digits) of ``parts`` (plain JSON values) with the cache format."""
    blob = json.dumps({"format": FORMAT, **parts}, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()[:40]


@functools.lru_cache(maxsize=8)
def tree_fingerprint(root: str, skip: tuple = ("__pycache__",), by_size: tuple = ("wheels",)) -> str:
    """SHA-256 over every file under ``root`` (path and bytes), hashed once per process; folders named in
    ``skip`` are left out (compiled bytecode a run writes), those in ``by_size`` count by name and size
    only (the bundled wheels: their names carry their versions)."""
    digest = hashlib.sha256()
    base = Path(root)
    for folder, names, files in os.walk(base):
        names[:] = sorted(n for n in names if n not in skip)
        relative = Path(folder).relative_to(base)
        sized = bool(relative.parts) and relative.parts[0] in by_size
        for name in sorted(files):
            path = Path(folder) / name
            if name.endswith((".pyc", ".pyo")) or not path.is_file():
                continue
            digest.update((relative / name).as_posix().encode("utf-8") + b"\0")
            if sized:
                digest.update(str(path.stat().st_size).encode("ascii") + b"\0")
            else:
                digest.update(hashlib.sha256(path.read_bytes()).digest())
    return digest.hexdigest()


@dataclass(frozen=True)
class Fetched:
    """A look-up: ``hit`` when the entry was sound and copied out; ``problem`` says why an entry that was
    there could not be used ("" when there was none)."""
    hit: bool
    problem: str = ""


class FileCache:
    """Entries in ``folder`` (created on the first store); at most ``keep`` entries, the oldest go first."""

    def __init__(self, folder: str | os.PathLike, keep: int = 8):
        self.folder = Path(folder)
        self.keep = int(keep)

    def record_path(self, key: str) -> Path:
        return self.folder / f"{key}.json"

    def read(self, key: str) -> tuple[bytes | None, str]:
        """``(the entry's bytes, "")`` when its record and bytes check out, else ``(None, why)`` (``why`` is ""
        when there is no entry)."""
        record = self.record_path(key)
        if not _KEY.match(key) or not record.is_file():
            return None, ""
        try:
            doc = json.loads(record.read_text(encoding="utf-8"))
            name, size, sha = str(doc["file"]), int(doc["size"]), str(doc["sha256"])
            if doc.get("format") != FORMAT or doc.get("key") != key:
                return None, "its record is for another key or format"
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            return None, "its record is not readable"
        if name != f"{key}.{sha[:16]}.bin" or not 0 < size <= _ENTRY_LIMIT:
            return None, "its record names no file of this entry"
        try:
            data = (self.folder / name).read_bytes()
        except OSError:
            return None, f"{name} is missing"
        if len(data) != size or hashlib.sha256(data).hexdigest() != sha:
            return None, f"{name} does not match its checksum"
        try:
            os.utime(record)                     # the entries used last are the ones kept (``_prune``)
        except OSError:
            pass
        return data, ""

    def fetch(self, key: str, destination: str | os.PathLike) -> Fetched:
        """Copy the entry ``key`` to ``destination`` when its record and bytes check out (:meth:`read`)."""
        data, problem = self.read(key)
        if data is None:
            return Fetched(False, problem)
        Path(destination).write_bytes(data)
        return Fetched(True)

    def store(self, key: str, source: str | os.PathLike, parts: Mapping | None = None) -> Path | None:
        """Keep a copy of the file ``source`` as the entry ``key`` (:meth:`store_bytes`)."""
        try:
            data = Path(source).read_bytes()
        except OSError:
            return None
        return self.store_bytes(key, data, parts)

    def store_bytes(self, key: str, data: bytes, parts: Mapping | None = None) -> Path | None:
        """Keep ``data`` as the entry ``key`` (over any entry there); returns the record, None when the folder
        cannot be written (a cache only saves time)."""
        if not _KEY.match(key):
            raise ValueError(f"not a cache key: {key!r}")
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError:
            return None
        sha = hashlib.sha256(data).hexdigest()
        name = f"{key}.{sha[:16]}.bin"
        doc = {"format": FORMAT, "key": key, "file": name, "size": len(data), "sha256": sha,
               "parts": dict(parts or {})}
        try:
            _write_aside(self.folder / name, data)
            _write_aside(self.record_path(key), json.dumps(doc, indent=1, sort_keys=True, default=str).encode())
        except OSError:
            return None
        self._prune()
        return self.record_path(key)

    def remove(self, key: str) -> None:
        """Forget the entry ``key`` (its content goes with the next prune)."""
        self.record_path(key).unlink(missing_ok=True)

    def _prune(self) -> None:
        """Keep the newest ``keep`` records; remove content no record names (once old enough not to be a
        concurrent writer's, between its two renames) and temporary files a killed writer left."""
        records = []
        for path in self.folder.glob("*.json"):
            try:
                records.append((path.stat().st_mtime, path))
            except OSError:
                continue
        records.sort(reverse=True)
        named = set()
        for rank, (_, path) in enumerate(records):
            if rank >= self.keep:
                path.unlink(missing_ok=True)
                continue
            try:
                named.add(str(json.loads(path.read_text(encoding="utf-8"))["file"]))
            except (OSError, ValueError, KeyError, TypeError):
                continue
        now = time.time()
        for path in list(self.folder.glob("*.bin")) + list(self.folder.glob(_TMP_PREFIX + "*")):
            if path.name in named:
                continue
            try:
                if now - path.stat().st_mtime > _ORPHAN_AGE_S:
                    path.unlink(missing_ok=True)
            except OSError:
                continue


def _write_aside(path: Path, data: bytes) -> None:
    """``data`` written to a temporary name in ``path``'s folder, then renamed to ``path``."""
    handle, tmp = tempfile.mkstemp(prefix=_TMP_PREFIX, dir=path.parent)
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
