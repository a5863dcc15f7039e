# SPDX-License-Identifier: GPL-3.0-or-later
"""Write output files all-or-nothing: a failed or cancelled job leaves no half-written file behind.

Every file moved into place is recorded in a ledger, so an interrupted command can say exactly what it
wrote (``written_since``); ``refuse_collisions`` makes sure no output ever replaces one of the inputs."""
from __future__ import annotations

import contextlib
import errno
import os
import shutil
import tempfile
from pathlib import Path

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.core.files import FileClaims, Folders


def check_output_path(path: str | os.PathLike, suffixes: tuple[str, ...], folders: Folders | None = None) -> Path:
    """Validate an output path before any work starts, so a path problem is a message and not a failure
    after the work: a name with a known suffix, not empty, not a folder or a special file, no symbolic
    link loop, in a folder that takes a new file (missing folders are made when the file is written).
    ``folders``: the folders of a whole jobs CSV (``core.files.Folders``): each folder is looked at once."""
    text = os.fspath(path) if path is not None else ""
    if not str(text).strip():
        raise UserError("the output path is empty; name a file")
    if "\0" in str(text):
        raise UserError(f"the output path {text!r} contains a NUL byte")
    out = Path(text).expanduser()
    if out.suffix.lower() not in suffixes:
        raise UserError(f"output {out} must end with one of {', '.join(suffixes)}")
    if folders is not None:
        real, name = folders.split(out)
        if folders.listed(real, name):
            full = os.path.join(real, name)
            if os.path.isdir(full):
                raise UserError(f"output {out} is a directory; give a file name")
            if not os.path.isfile(full):
                raise UserError(f"output {out} exists and is not a regular file (or is a link that leads nowhere)")
        folders.once(("takes files", real), lambda: _check_folder_takes_files(Path(real), out))
        return out
    try:
        os.stat(out)             # a symlink loop is ELOOP on every Python (3.13's resolve() no longer raises)
    except OSError as error:
        if error.errno == errno.ELOOP:
            raise UserError(f"output {out} is a symbolic link that points back to itself") from None
    resolved = out.resolve()
    if resolved.is_dir():
        raise UserError(f"output {out} is a directory; give a file name")
    if resolved.exists() and not resolved.is_file():
        raise UserError(f"output {out} exists and is not a regular file")
    _check_folder_takes_files(resolved.parent, out)
    return out


def _check_folder_takes_files(folder: Path, out: Path) -> None:
    """The folder of ``out`` takes a new file: it exists, or can be made (the missing folders are made only
    when the finished file is moved into place, :func:`atomic_output`) under the nearest existing folder,
    where a file can be made (tried: permissions, read-only disks and pseudo file systems all answer the
    same way)."""
    existing = folder
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        raise UserError(f"{existing} is a file, so the folder {out.parent} for {out.name} cannot be made")
    try:
        with tempfile.NamedTemporaryFile(dir=existing, prefix=".fh-write-test-"):
            pass
    except OSError as error:
        raise UserError(f"cannot write into {existing}: {error.strerror or error}") from None


def check_output_dir(path: str | os.PathLike) -> Path:
    """Validate an output folder before any work starts: it may exist (as a folder) or be creatable."""
    out = Path(path).expanduser()
    if out.exists() and not out.is_dir():
        raise UserError(f"output folder {out} exists and is not a folder")
    probe = out
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise UserError(f"cannot create output folder {out}: {probe} is a file")
    if not os.access(probe, os.W_OK):
        raise UserError(f"cannot write into {probe}")
    return out


_LEDGER: list[Path] = []


def ledger_mark() -> int:
    """A bookmark in the ledger of written files (see ``written_since``)."""
    return len(_LEDGER)


def written_since(mark: int) -> list[Path]:
    """The files moved into place since ``mark``, in the order they were written."""
    return list(_LEDGER[mark:])


def note_written(paths) -> None:
    """Record files another process moved into place for this command (a jobs worker's rows), so an
    interrupted command names them too."""
    _LEDGER.extend(Path(p) for p in paths)


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """``a`` and ``b`` name the same file (same resolved path, or the same inode through a link)."""
    a, b = Path(a).expanduser(), Path(b).expanduser()
    if a.resolve() == b.resolve():
        return True
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def refuse_collisions(outputs: dict[str, Path], inputs: dict[str, Path], folders=None) -> None:
    """Refuse when an output would replace an input or another output (``label -> path`` each); every
    path is resolved once (``FileClaims``; ``folders``: the ``core.files.Folders`` shared by the rows of a
    jobs CSV), not once per pair."""
    known = FileClaims(folders)
    for label, source in inputs.items():
        if source is not None:
            known.add(source, (True, label, source))
    for label, path in outputs.items():
        if path is None:
            continue
        owner = known.owner(path)
        if owner is not None:
            is_input, other_label, other = owner
            if is_input:
                raise UserError(f"{label} {path} would replace the input {other_label} {other}; "
                                "choose another output name")
            raise UserError(f"{label} and {other_label} are the same file {path}")
        known.add(path, (False, label, path))


@contextlib.contextmanager
def atomic_output(final_path: str | os.PathLike):
    """Yield a temporary path with the same suffix; move it to ``final_path`` only on success."""
    final_path = Path(final_path)
    tmp_dir = Path(tempfile.mkdtemp(prefix="fh-out-"))
    tmp_path = tmp_dir / final_path.name
    try:
        yield tmp_path
        if not tmp_path.exists():
            raise RuntimeError(f"nothing was written to {tmp_path}")
        final_path.parent.mkdir(parents=True, exist_ok=True)
        try:
            shutil.move(str(tmp_path), str(final_path))
        except OSError as error:
            raise UserError(f"cannot write {final_path}: {error.strerror or error}") from None
        _LEDGER.append(final_path)
    finally:
        shutil.rmtree(tmp_dir, ignore_errors=True)


def written(paths) -> str:
    """One line per written file with its size, for the CLI's 'what I wrote' report."""
    lines = []
    for path in paths:
        path = Path(path)
        size = path.stat().st_size if path.exists() else 0
        lines.append(f"wrote {path} ({size / 1024:.0f} KiB)")
    return "\n".join(lines)
