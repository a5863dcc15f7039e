# SPDX-License-Identifier: GPL-3.0-or-later
"""Ctrl-C and SIGTERM for command-line runs, delivered even when Python swallows the first raise.

The signal handler raises at once (so ``with`` blocks clean up on the way out) and also records the
request: a raise that lands inside a callback from C (espeak-ng's synthesis callback, a Blender handler)
is printed and dropped by the caller, so every progress report and every jobs-CSV row raises the recorded
request again (``raise_pending``) until the command has stopped.
"""
from __future__ import annotations

import contextlib
import signal
import threading

__all__ = ["Terminated", "interruptible", "raise_pending", "clear"]


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C."""


_PENDING: list[KeyboardInterrupt] = []


def _on_signal(signum, frame):  # noqa: ARG001 - signal handler signature
    error = Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()
    _PENDING[:] = [error]
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
