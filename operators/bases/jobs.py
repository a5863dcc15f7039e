# SPDX-License-Identifier: GPL-3.0-or-later
"""Long work as a sequence of small steps (no Blender types here): run modally in the UI
(:class:`.modal.JobOperator`: progress bar, ESC cancels) or to completion (:func:`run_job`: scripts,
``blender -b``, the command line with a text progress bar).

A :class:`Job` computes in ``step()`` without touching the user's data and only writes Blender data in
``commit()``, so cancelling at any point (ESC, an error) leaves the scene exactly as it was.
"""
from __future__ import annotations


class Job:
    """Override ``step`` (returns progress in [0, 1], 1 when the computation is done), ``commit``
    (writes Blender data, returns a report string) and, where needed, ``cleanup``."""

    label = "Working"
    #: what the user should know about the result (shown as warnings after the report)
    warnings: tuple[str, ...] = ()

    def step(self) -> float:  # pragma: no cover - abstract
        raise NotImplementedError

    def commit(self, context) -> str:  # pragma: no cover - abstract
        raise NotImplementedError

    def cleanup(self) -> None:
        """Free temporary state (called after commit and after cancel)."""


def run_job(job: Job, context, progress=None) -> str:
    """Run ``job`` to the end; ``progress(fraction, message)`` is called as it advances."""
    try:
        fraction = 0.0
        while fraction < 1.0:
            fraction = float(job.step())
            if progress is not None:
                progress(fraction, job.label)
        return job.commit(context)
    finally:
        job.cleanup()
