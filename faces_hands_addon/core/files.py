# SPDX-License-Identifier: GPL-3.0-or-later
"""Which files are the same file, in constant time per look-up: the check that no output replaces an
input or another output, for one command line or a manifest of 100,000 rows alike.

A file is known by its resolved path (its folder resolved once per folder, so a link anywhere above it is
followed; case-folded where the file system ignores case) and, when it exists, by its device and inode,
which also finds it under a second name (a hard or symbolic link to the file itself)."""
from __future__ import annotations

import os

__all__ = ["FileClaims", "inode_of"]


def inode_of(path) -> tuple[int, int] | None:
    """(device, inode) of an existing file (links followed), else None."""
    try:
        stat = os.stat(path)
    except (OSError, ValueError):
        return None
    return stat.st_dev, stat.st_ino


class FileClaims:
    """Files claimed by owners (a line, a row, a label); the first owner of a file keeps it."""

    def __init__(self, folders: dict[str, str] | None = None):
        """``folders``: resolved folders to share with other claims of the same check (folder -> real)."""
        self.paths: dict[str, object] = {}
        self.inodes: dict[tuple[int, int], object] = {}
        self._folders = {} if folders is None else folders

    def key(self, path) -> str:
        """The resolved, case-normalised path of ``path`` (its folder resolved once per folder)."""
        folder, name = os.path.split(os.path.abspath(os.path.expanduser(os.fspath(path))))
        real = self._folders.get(folder)
        if real is None:
            real = self._folders[folder] = os.path.realpath(folder)
        return os.path.normcase(os.path.join(real, name))

    def add(self, path, owner) -> None:
        self.paths.setdefault(self.key(path), owner)
        inode = inode_of(path)
        if inode is not None:
            self.inodes.setdefault(inode, owner)

    def owner(self, path):
        """The owner of ``path`` under any of its names, or None."""
        owner = self.paths.get(self.key(path))
        if owner is None and self.inodes:
            inode = inode_of(path)
            owner = self.inodes.get(inode) if inode is not None else None
        return owner
