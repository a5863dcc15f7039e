"""Modal paths (live simulation, long jobs) driven with stand-in window/event objects: the bpy module
has no window, so the operators' invoke/modal/cancel methods are called directly, as Blender would."""
from __future__ import annotations

import sys
from types import SimpleNamespace

import numpy as np


def _module(name):
    return sys.modules[f"bl_ext.user_default.faces_hands.operators.{name}"]


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
    return SimpleNamespace(window=object(), window_manager=wm, scene=real.scene, active_object=real.active_object,
                           view_layer=real.view_layer,
                           workspace=SimpleNamespace(status_text_set=lambda text: None))


def test_live_simulation_start_step_and_stop(bpy_clean):
    bpy = bpy_clean
    bpy.ops.faces_hands.build_face_rig()
    rig = bpy.context.active_object
    ops_face = _module("ops_face")
    cls = ops_face.FH_OT_live_simulation
    wm = FakeWindowManager()
    context = _context(bpy, wm)
    fake = SimpleNamespace(report=lambda *a: None, _timer=None)
    fake._stop = lambda ctx: cls._stop(fake, ctx)
    assert cls.invoke(fake, context, SimpleNamespace(type="NONE")) == {"RUNNING_MODAL"}
    assert ops_face.live_running() and wm.handlers and wm.timers
    rig["fh.ctrl.jaw_open"] = 1.0
    for _ in range(10):
        assert cls.modal(fake, context, SimpleNamespace(type="TIMER")) == {"PASS_THROUGH"}
    sim = rig.data.shape_keys.key_blocks["FH Simulation"]
    moved = np.array([p.co[:] for p in sim.points]) - np.array([v.co[:] for v in rig.data.vertices])
    assert np.abs(moved).max() > 0.003
    assert cls.modal(fake, context, SimpleNamespace(type="ESC")) == {"CANCELLED"}
    assert not ops_face.live_running() and not wm.timers
    # the button again also stops it
    assert cls.invoke(fake, context, SimpleNamespace(type="NONE")) == {"RUNNING_MODAL"}
    assert cls.invoke(fake, context, SimpleNamespace(type="NONE")) == {"FINISHED"}
    assert cls.modal(fake, context, SimpleNamespace(type="TIMER")) == {"CANCELLED"}
    assert not wm.timers


def test_bake_modal_progress_and_escape_leave_scene_unchanged(bpy_clean):
    bpy = bpy_clean
    bpy.ops.faces_hands.build_face_rig()
    rig = bpy.context.active_object
    ops_face = _module("ops_face")
    cls = ops_face.FH_OT_bake_face
    wm = FakeWindowManager()
    context = _context(bpy, wm)
    fake = SimpleNamespace(report=lambda *a: None, _timer=None, _job=None, time_slice=0.01,
                           mode="EXPRESSIONS", expression_set="visemes")
    fake.make_job = lambda ctx: cls.make_job(fake, ctx)
    fake._finish_modal = lambda ctx: cls._finish_modal(fake, ctx)
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
