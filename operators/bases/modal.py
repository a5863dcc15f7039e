# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators that run a :class:`.jobs.Job`: modal in the UI (a timer keeps Blender responsive, a progress
bar and a status-bar message show how far it is, ESC cancels and leaves the scene as it was) and straight
through in ``execute`` (scripts, ``blender -b``)."""
from __future__ import annotations

import time

from ...faces_hands_addon.core.errors import UserError
from .hardened import HardenedOperator
from .jobs import Job, run_job


class JobOperator(HardenedOperator):
    """Operator mixin: subclasses implement ``make_job(context) -> Job``.

    In the UI, ``invoke`` runs the job from a timer (Blender stays responsive), shows a progress
    bar and a status-bar message, and ESC cancels. ``execute`` runs the same job straight through.
    """

    _timer = None
    _job: Job | None = None
    time_slice = 0.05  # seconds of work per timer tick (at least one step; 0: one step per tick)

    def make_job(self, context) -> Job:  # pragma: no cover - abstract
        raise NotImplementedError

    def run(self, context):
        job = self.make_job(context)
        report = run_job(job, context)
        self._report_done(job, report)
        return {"FINISHED"}

    def _report_done(self, job: Job, report: str) -> None:
        """The job's one-line report, then each of its warnings (``Job.warnings``) as a warning."""
        self.report({"INFO"}, report)
        for warning in job.warnings:
            print(f"warning: {warning}")
            self.report({"WARNING"}, warning)

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
            while True:  # at least one step per tick; a time slice of 0 means exactly one
                fraction = float(self._job.step())
                if fraction >= 1.0 or time.perf_counter() >= deadline:
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
        self._report_done(self._job, report)
        return {"FINISHED"}
