# SPDX-License-Identifier: GPL-3.0-or-later
"""Which files are the same file, in constant time per look-up: the check that no output replaces an
input or another output, for one command line or a manifest of 100,000 rows alike.

A file is known by its resolved path (its folder resolved once per folder, so a link anywhere above it is
followed; case-folded where the file system ignores case) and, when it exists, by its device and inode,
which also finds it under a second name (a hard or symbolic link to the file itself). Whether a file exists
is read from its folder's listing, taken once per folder (:class:`Folders`), so a check of 100,000 rows
costs a few system calls per folder instead of several per row."""
from __future__ import annotations

import os

from .errors import UserError

__all__ = ["FileClaims", "Folders", "inode_of"]


def inode_of(path) -> tuple[int, int] | None:
    """(device, inode) of an existing file (links followed), else None."""
    try:
        stat = os.stat(path)
    except (OSError, ValueError):
        return None
    return stat.st_dev, stat.st_ino


class Folders:
    """Folders resolved and listed once each, shared by every :class:`FileClaims` of one check (the files
    of a check do not change while it runs)."""

    def __init__(self):
        self.real: dict[str, str] = {}
        self._names: dict[str, tuple[frozenset, frozenset]] = {}
        self._writable: dict[str, bool | None] = {}
        self._verdicts: dict = {}
        self._cwd = os.getcwd()

    def split(self, path) -> tuple[str, str]:
        """(resolved folder, name) of ``path``; each folder is resolved once, as it was written."""
        folder, name = os.path.split(os.fspath(path))
        real = self.real.get(folder)
        if real is None:
            full = os.path.expanduser(folder) if folder.startswith("~") else folder
            real = self.real[folder] = os.path.realpath(os.path.normpath(os.path.join(self._cwd, full)))
        return real, name

    def key(self, real: str, name: str) -> str:
        """The case-normalised path of ``name`` in the resolved folder ``real``."""
        return os.path.normcase(real + name if real.endswith(os.sep) else real + os.sep + name)

    def listed(self, real: str, name: str) -> bool:
        """Is there an entry ``name`` (any case) in the resolved folder ``real`` (listed once)?"""
        listing = self._names.get(real)
        if listing is None:
            try:
                names = frozenset(os.listdir(real))
            except (OSError, ValueError):
                names = frozenset()
            listing = self._names[real] = (names, frozenset(n.casefold() for n in names))
        return name in listing[0] or name.casefold() in listing[1]

    def inode(self, real: str, name: str) -> tuple[int, int] | None:
        """(device, inode) of ``name`` in the resolved folder ``real`` when it is there, else None."""
        return inode_of(os.path.join(real, name)) if self.listed(real, name) else None

    def once(self, key, check) -> None:
        """Run ``check()`` once per ``key`` (a folder's verdict); a :class:`UserError` it raised is raised
        again for every later file of that folder."""
        if key not in self._verdicts:
            try:
                check()
                self._verdicts[key] = None
            except UserError as error:
                self._verdicts[key] = error
        if self._verdicts[key] is not None:
            raise self._verdicts[key]

    def writable(self, real: str) -> bool | None:
        """Can files be written into the resolved folder ``real`` (None: it does not exist)? Asked once."""
        if real not in self._writable:
            self._writable[real] = os.access(real, os.W_OK) if os.path.isdir(real) else None
        return self._writable[real]


class FileClaims:
    """Files claimed by owners (a line, a row, a label); the first owner of a file keeps it."""

    def __init__(self, folders: Folders | None = None):
        """``folders``: the folders resolved and listed for the whole check (shared with other claims)."""
        self.paths: dict[str, object] = {}
        self.inodes: dict[tuple[int, int], object] = {}
        self._folders = Folders() if folders is None else folders

    def key(self, path) -> str:
        """The resolved, case-normalised path of ``path`` (its folder resolved once per folder)."""
        return self._folders.key(*self._folders.split(path))

    def add(self, path, owner) -> None:
        self.add_at(*self._folders.split(path), owner)

    def owner(self, path):
        """The owner of ``path`` under any of its names, or None."""
        return self.owner_at(*self._folders.split(path))

    def add_at(self, real: str, name: str, owner) -> None:
        """:meth:`add` of a path already split by the shared :class:`Folders` (``Folders.split``)."""
        self.paths.setdefault(self._folders.key(real, name), owner)
        inode = self._folders.inode(real, name)
        if inode is not None:
            self.inodes.setdefault(inode, owner)

    def owner_at(self, real: str, name: str):
        """:meth:`owner` of a path already split by the shared :class:`Folders`."""
        owner = self.paths.get(self._folders.key(real, name))
        if owner is None and self.inodes:
            inode = self._folders.inode(real, name)
            owner = self.inodes.get(inode) if inode is not None else None
        return owner
