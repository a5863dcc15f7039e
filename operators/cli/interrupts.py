# SPDX-License-Identifier: GPL-3.0-or-later
"""Ctrl-C and SIGTERM for command-line runs, delivered even when Python swallows the first raise.

The signal handler raises at once (so ``with`` blocks clean up on the way out) and also records the
request: a raise that lands inside a callback from C (espeak-ng's synthesis callback, a Blender handler)
is printed and dropped by the caller, so every progress report and every jobs-CSV row raises the recorded
request again (``raise_pending``) until the command has stopped.

Creating and removing a command's temporary folder must not be cut in half, so there the signal is only
recorded (``deferred``) and raised once the folder is made or gone; every temporary file of a command lives
under that one folder (``private_temp_root``), so nothing a nested cleanup missed outlives the command.
"""
from __future__ import annotations

import contextlib
import shutil
import signal
import tempfile
import threading

__all__ = ["Terminated", "interruptible", "raise_pending", "clear", "deferred", "private_temp_root"]


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C."""


_PENDING: list[KeyboardInterrupt] = []
_DEFERRING = [0]     # how many ``deferred`` blocks are open


def _on_signal(signum, frame):  # noqa: ARG001 - signal handler signature
    error = Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()
    _PENDING[:] = [error]
    if not _DEFERRING[0]:
        raise error


def raise_pending() -> None:
    """Raise the interrupt a signal asked for, if any (a no-op otherwise)."""
    if _PENDING:
        raise type(_PENDING[0])()


def clear() -> None:
    _PENDING.clear()


@contextlib.contextmanager
def interruptible():
    """SIGINT and SIGTERM raise while the block runs (the previous handlers, e.g. Blender's, are put back
    afterwards); only possible in the main thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    clear()
    for sig in previous:
        signal.signal(sig, _on_signal)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)


@contextlib.contextmanager
def deferred():
    """A signal during the block is only recorded, and raised when the outermost such block ends."""
    _DEFERRING[0] += 1
    try:
        yield
    finally:
        _DEFERRING[0] -= 1
    if not _DEFERRING[0]:
        raise_pending()


@contextlib.contextmanager
def private_temp_root(prefix: str = "fh-run-"):
    """Point Python's ``tempfile`` at a new folder for the block and remove that folder, with all it holds,
    however the block ends (a signal cannot land between making or removing it and recording that)."""
    previous = tempfile.tempdir
    with deferred():
        root = tempfile.mkdtemp(prefix=prefix)
        tempfile.tempdir = root
    try:
        yield root
    finally:
        with deferred():
            tempfile.tempdir = previous
            shutil.rmtree(root, ignore_errors=True)
