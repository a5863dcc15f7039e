# SPDX-License-Identifier: GPL-3.0-or-later
"""The live preview of any rig: each tick reads the control layers as animated now, lets the engine mix
and simulate one frame (``rig.step``), and writes the pose (``poses.push_pose``). The running preview is
named in the window manager's runtime settings (``faces_hands_runtime.live_object``), which panels read to
draw the button state; Esc, the button again or a vanished object stop it. Stopping finishes the operator,
so its UNDO option pushes one undo step for everything the preview wrote (the live shape key)."""
from __future__ import annotations

import time

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..adapters import controls
from ..adapters.poses import push_pose
from ..adapters.rig_store import get_rig, rig_of
from ..adapters.timing import frame_duration

__all__ = ["live_step", "live_object", "LiveSimulationOperator"]


def live_step(context, obj, after_push=None, dt: float | None = None) -> float:
    """One live-preview tick on the rig object ``obj``; ``after_push(obj, rig)`` adds what a rig kind shows
    beyond its pose. Returns the milliseconds it took."""
    started = time.perf_counter()
    rig = get_rig(obj)
    pose = rig.step(controls.layer_values(obj, rig.control_specs()), dt or frame_duration(context.scene))
    push_pose(obj, pose)
    if after_push is not None:
        after_push(obj, rig)
    return (time.perf_counter() - started) * 1000.0


def _runtime(context):
    return getattr(context.window_manager, "faces_hands_runtime", None)


def live_object(context) -> str:
    """The name of the rig object being previewed live ('' when none)."""
    runtime = _runtime(context)
    return runtime.live_object if runtime is not None else ""


class LiveSimulationOperator:
    """Operator mixin: a modal timer running :func:`live_step` on the active rig. Subclasses may define
    ``after_push(obj, rig)``."""

    _timer = None
    after_push = None

    def execute(self, context):
        self.report({"ERROR"}, "live simulation needs a Blender window; use Bake in background mode")
        return {"CANCELLED"}

    def invoke(self, context, event):
        runtime = _runtime(context)
        if runtime is not None and runtime.live_object:
            runtime.live_object = ""          # the running modal operator sees this and stops
            return {"FINISHED"}
        obj = rig_of(context.active_object)
        try:
            get_rig(obj)
        except UserError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        if context.window is None or runtime is None:
            return self.execute(context)
        runtime.live_object = obj.name
        self._timer = context.window_manager.event_timer_add(1 / 30, window=context.window)
        context.window_manager.modal_handler_add(self)
        context.workspace.status_text_set("Faces & Hands live simulation (Esc to stop)")
        return {"RUNNING_MODAL"}

    def _stop(self, context):
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None
        context.workspace.status_text_set(None)
        runtime = _runtime(context)
        if runtime is not None:
            runtime.live_object = ""

    def modal(self, context, event):
        name = live_object(context)
        obj = bpy.data.objects.get(name) if name else None
        if event.type == "ESC" or obj is None:
            self._stop(context)
            return {"FINISHED"}                   # one undo step for what the preview wrote
        if event.type == "TIMER":
            try:
                live_step(context, obj, getattr(self, "after_push", None))
            except UserError as error:
                self.report({"ERROR"}, str(error))
                self._stop(context)
                return {"CANCELLED"}
        return {"PASS_THROUGH"}

    def cancel(self, context):
        self._stop(context)
