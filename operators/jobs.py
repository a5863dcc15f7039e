# SPDX-License-Identifier: GPL-3.0-or-later
"""Long work as a sequence of small steps, run modally (progress bar, ESC cancels) or to completion.

A :class:`Job` computes in ``step()`` without touching the user's data and only writes Blender data
in ``commit()``, so cancelling at any point (ESC, an error) leaves the scene exactly as it was.
The same job runs three ways: modal in the UI (``invoke``), straight through in ``execute`` (scripts,
``blender -b``), and from the command line with a text progress bar.
"""
from __future__ import annotations

import time

from ..faces_hands_addon.errors import UserError
from .hardened import HardenedOperator


class Job:
    """Override ``step`` (returns progress in [0, 1], 1 when the computation is done), ``commit``
    (writes Blender data, returns a report string) and, where needed, ``cleanup``."""

    label = "Working"

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


class JobOperator(HardenedOperator):
    """Operator mixin: subclasses implement ``make_job(context) -> Job``.

    In the UI, ``invoke`` runs the job from a timer (Blender stays responsive), shows a progress
    bar and a status-bar message, and ESC cancels. ``execute`` runs the same job straight through.
    """

    _timer = None
    _job: Job | None = None
    time_slice = 0.05  # seconds of work per timer tick

    def make_job(self, context) -> Job:  # pragma: no cover - abstract
        raise NotImplementedError

    def run(self, context):
        report = run_job(self.make_job(context), context)
        self.report({"INFO"}, report)
        return {"FINISHED"}

    def invoke(self, context, event):
        if context.window is None:  # background mode or scripts: no event loop
            return self.execute(context)
        try:
            self._job = self.make_job(context)
        except UserError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.progress_begin(0, 100)
        context.workspace.status_text_set(f"{self._job.label}... (Esc to cancel)")
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _finish_modal(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        context.workspace.status_text_set(None)

    def modal(self, context, event):
        if event.type == "ESC":
            self._finish_modal(context)
            self._job.cleanup()
            self.report({"WARNING"}, f"{self._job.label} cancelled; nothing was changed")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            deadline = time.perf_counter() + self.time_slice
            fraction = 0.0
            while time.perf_counter() < deadline:
                fraction = float(self._job.step())
                if fraction >= 1.0:
                    break
            context.window_manager.progress_update(int(fraction * 100))
            if fraction < 1.0:
                return {"RUNNING_MODAL"}
            report = self._job.commit(context)
        except UserError as error:
            self._finish_modal(context)
            self._job.cleanup()
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        except Exception as error:
            self._finish_modal(context)
            self._job.cleanup()
            self.report({"ERROR"}, f"Internal error ({type(error).__name__}: {error}); see the console")
            raise
        self._finish_modal(context)
        self._job.cleanup()
        self.report({"INFO"}, report)
        return {"FINISHED"}
