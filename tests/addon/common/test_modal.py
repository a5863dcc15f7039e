"""Modal paths (live simulation, long jobs) driven with stand-in window/event objects: the bpy module
has no window, so the operators' invoke/modal/cancel methods are called directly, as Blender would."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np


from conftest import addon_module


def _live_object(bpy):
    return bpy.context.window_manager.faces_hands_runtime.live_object


class FakeWindowManager:
    def __init__(self):
        self.timers, self.handlers, self.progress = [], [], []

    def event_timer_add(self, step, window=None):
        self.timers.append(step)
        return object()

    def event_timer_remove(self, timer):
        self.timers.pop()

    def modal_handler_add(self, operator):
        self.handlers.append(operator)

    def progress_begin(self, low, high):
        self.progress.append("begin")

    def progress_update(self, value):
        self.progress.append(value)

    def progress_end(self):
        self.progress.append("end")


def _context(bpy, wm):
    real = bpy.context
    wm.faces_hands_runtime = real.window_manager.faces_hands_runtime
    return SimpleNamespace(window=object(), window_manager=wm, scene=real.scene, active_object=real.active_object,
                           view_layer=real.view_layer,
                           workspace=SimpleNamespace(status_text_set=lambda text: None))


def _rig_and_operator(bpy, operator: str):
    """A new face rig, the operator class ``operator`` and a stand-in window manager and context."""
    bpy.ops.faces_hands.build_face_rig()
    wm = FakeWindowManager()
    return (bpy.context.active_object, getattr(addon_module("operators.face.operators"), operator), wm,
            _context(bpy, wm))


def test_live_simulation_start_step_and_stop(bpy_clean):
    bpy = bpy_clean
    rig, cls, wm, context = _rig_and_operator(bpy, "FH_OT_live_simulation")
    fake = SimpleNamespace(report=lambda *a: None, _timer=None)
    fake._stop = lambda ctx: cls._stop(fake, ctx)
    assert cls.invoke(fake, context, SimpleNamespace(type="NONE")) == {"RUNNING_MODAL"}
    assert _live_object(bpy) == rig.name and wm.handlers and wm.timers
    rig["fh.ctrl.jaw_open"] = 1.0
    for _ in range(10):
        assert cls.modal(fake, context, SimpleNamespace(type="TIMER")) == {"PASS_THROUGH"}
    sim = rig.data.shape_keys.key_blocks["FH Simulation"]
    moved = np.array([p.co[:] for p in sim.points]) - np.array([v.co[:] for v in rig.data.vertices])
    assert np.abs(moved).max() > 0.003
    # stopping finishes the operator: with UNDO, Blender pushes one undo step for the live shape key
    assert "UNDO" in cls.bl_options
    assert cls.modal(fake, context, SimpleNamespace(type="ESC")) == {"FINISHED"}
    assert _live_object(bpy) == "" and not wm.timers
    # the button again also stops it
    assert cls.invoke(fake, context, SimpleNamespace(type="NONE")) == {"RUNNING_MODAL"}
    assert cls.invoke(fake, context, SimpleNamespace(type="NONE")) == {"FINISHED"}
    assert cls.modal(fake, context, SimpleNamespace(type="TIMER")) == {"FINISHED"}
    assert not wm.timers


def test_bake_modal_progress_and_escape_leave_scene_unchanged(bpy_clean, monkeypatch):
    bpy = bpy_clean
    monkeypatch.setenv("FH_NO_SHAPE_CACHE", "1")        # simulate every shape: the bake takes several ticks
    rig, cls, wm, context = _rig_and_operator(bpy, "FH_OT_bake_face")
    fake = SimpleNamespace(report=lambda *a: None, _timer=None, _job=None, time_slice=0.01,
                           mode="EXPRESSIONS", expression_set="visemes")
    fake.make_job = lambda ctx: cls.make_job(fake, ctx)
    fake._finish_modal = lambda ctx: cls._finish_modal(fake, ctx)
    fake._report_done = lambda job, report: cls._report_done(fake, job, report)
    assert cls.invoke(fake, context, SimpleNamespace(type="NONE")) == {"RUNNING_MODAL"}
    for _ in range(3):
        assert cls.modal(fake, context, SimpleNamespace(type="TIMER")) == {"RUNNING_MODAL"}
    assert any(isinstance(p, int) and p > 0 for p in wm.progress), wm.progress
    assert cls.modal(fake, context, SimpleNamespace(type="ESC")) == {"CANCELLED"}
    assert wm.progress[-1] == "end" and not wm.timers
    assert rig.data.shape_keys is None, "a cancelled bake left shape keys behind"
    # run to the end: the keys appear
    assert cls.invoke(fake, context, SimpleNamespace(type="NONE")) == {"RUNNING_MODAL"}
    result = {"RUNNING_MODAL"}
    for _ in range(2000):
        result = cls.modal(fake, context, SimpleNamespace(type="TIMER"))
        if result != {"RUNNING_MODAL"}:
            break
    assert result == {"FINISHED"}
    assert "viseme_PP" in rig.data.shape_keys.key_blocks
