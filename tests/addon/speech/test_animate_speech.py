"""Animate Speech on the default head: lip sync + behaviour + emotion from text and from a committed
recording, each layer its own channel group that exists, is not empty and can be muted; the job runs in
steps that Esc cancels with nothing written; bad input is one clear error with nothing written."""
from __future__ import annotations

from pathlib import Path
import threading
from types import SimpleNamespace

import numpy as np
import pytest

from conftest import addon_module

EXAMPLE = "Hi! ;-) Can you show me the way to the conference hall? :-)"
DATA = Path(__file__).resolve().parents[2] / "data" / "speech"
CLIP = DATA / "slt_ill_disposed"                  # Festival speech with its own labels (README there)


def _bag(rig):
    anim = rig.animation_data
    return anim.action.layers[0].strips[0].channelbag(anim.action_slot)


def _groups(rig) -> dict:
    """Group name -> its F-curves."""
    bag = _bag(rig)
    return {g.name: [fc for fc in bag.fcurves if fc.group == g] for g in bag.groups}


def _varying(fcurves) -> list:
    return [fc for fc in fcurves if len(fc.keyframe_points) > 1
            and np.ptp([k.co[1] for k in fc.keyframe_points]) > 1e-4]


def _check_mutable(bpy, rig, group_name: str) -> None:
    """Muting the group stops its curves from writing their property: a value set by hand survives a
    frame change; unmuted, the curve writes it again."""
    scene = bpy.context.scene
    bag = _bag(rig)
    group = bag.groups[group_name]
    fcurve = max(_varying([fc for fc in bag.fcurves if fc.group == group]),
                 key=lambda fc: np.ptp([k.co[1] for k in fc.keyframe_points]))
    frames = np.array([k.co[0] for k in fcurve.keyframe_points])
    values = np.array([k.co[1] for k in fcurve.keyframe_points])
    frame = int(round(frames[np.argmax(np.abs(values))]))
    marker = -0.123
    path, index = fcurve.data_path, fcurve.array_index

    def set_value(value):
        if path.startswith("["):
            rig[path[2:-2]] = value
        else:
            getattr(rig, path)[index] = value

    def get_value():
        return rig[path[2:-2]] if path.startswith("[") else getattr(rig, path)[index]
    assert bpy.ops.faces_hands.mute_speech_layer(layer=group_name, action="MUTE") == {"FINISHED"}
    assert group.mute
    set_value(marker)
    scene.frame_set(frame)
    assert get_value() == pytest.approx(marker), f"muted group {group_name} still drives {path}"
    assert bpy.ops.faces_hands.mute_speech_layer(layer=group_name) == {"FINISHED"}     # toggles back
    assert not group.mute
    scene.frame_set(frame + 1)
    scene.frame_set(frame)
    assert get_value() == pytest.approx(fcurve.evaluate(frame), abs=1e-5) and abs(get_value() - marker) > 1e-3


def _rig(bpy):
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 25, 1.0
    scene.frame_start = 1
    assert bpy.ops.faces_hands.build_face_rig() == {"FINISHED"}
    return bpy.context.active_object


def test_animate_speech_from_text_one_mutable_group_per_layer(bpy_clean):
    bpy = bpy_clean
    rig = _rig(bpy)
    rig["fh.ctrl.zygomaticus_major_L"] = 0.4
    rig.keyframe_insert('["fh.ctrl.zygomaticus_major_L"]', frame=3)     # the artist's key survives
    assert bpy.ops.faces_hands.animate_speech(source="TEXT", text=EXAMPLE, style="neutral", seed=3) == {"FINISHED"}
    groups = _groups(rig)
    for name, prefix in (("Speech", '["fh.speech.'), ("Behavior", '["fh.behavior.'), ("Emotion", '["fh.emotion.'),
                         ("Head", "delta_")):
        assert name in groups and groups[name], f"no {name} channel group"
        assert all(fc.data_path.startswith(prefix) for fc in groups[name]), name
        assert _varying(groups[name]), f"the {name} layer is flat"
        _check_mutable(bpy, rig, name)
    assert any(fc.data_path == '["fh.ctrl.zygomaticus_major_L"]' for fc in _bag(rig).fcurves)
    assert rig["fh_take_layers"] == "behavior emotion head"
    # the wink and the smile are on the emotion layer, the brows on the behaviour layer
    emotion = {fc.data_path for fc in groups["Emotion"]}
    assert '["fh.emotion.zygomaticus_major_L"]' in emotion
    # again with another seed: the take is replaced, not stacked; same group count
    counts = {k: len(v) for k, v in groups.items()}
    assert bpy.ops.faces_hands.animate_speech(source="TEXT", text=EXAMPLE, style="expressive", seed=4) == {"FINISHED"}
    assert {k: len(v) for k, v in _groups(rig).items() if v} == {k: v for k, v in counts.items() if v}
    assert len(bpy.context.scene.sequence_editor.strips) == 1


def test_animate_speech_from_audio_with_loudness_and_emotion(bpy_clean):
    bpy = bpy_clean
    rig = _rig(bpy)
    transcript = next(line.split("\t")[1] for line in CLIP.with_suffix(".tsv").read_text().splitlines()
                      if line.startswith("text\t"))
    assert bpy.ops.faces_hands.animate_speech(source="AUDIO", filepath=str(CLIP.with_suffix(".wav")),
                                              transcript=transcript, style="nodder", seed=1,
                                              emotion="joy") == {"FINISHED"}
    groups = _groups(rig)
    for name in ("Speech", "Behavior", "Emotion", "Head"):
        assert groups.get(name) and _varying(groups[name]) if name != "Emotion" else groups.get(name), name
        if name != "Emotion":          # a constant emotion for the whole take is flat on purpose
            _check_mutable(bpy, rig, name)
    strip = bpy.context.scene.sequence_editor.strips[0]
    assert Path(bpy.path.abspath(strip.sound.filepath)).name == CLIP.with_suffix(".wav").name


def test_bad_input_is_one_clear_error_and_nothing_is_written(bpy_clean, tmp_path):
    bpy = bpy_clean
    rig = _rig(bpy)
    with pytest.raises(RuntimeError, match="does not exist"):
        bpy.ops.faces_hands.animate_speech(source="AUDIO", filepath=str(tmp_path / "missing.wav"))
    with pytest.raises(RuntimeError, match="no text to speak"):
        bpy.ops.faces_hands.animate_speech(source="TEXT", text="   ")
    with pytest.raises(RuntimeError, match="(?i)style"):
        bpy.ops.faces_hands.animate_speech(source="TEXT", text="Hello.", style="no_such_style")
    with pytest.raises(RuntimeError, match="(?i)emotion"):
        bpy.ops.faces_hands.animate_speech(source="TEXT", text="Hello.", emotion="hungry")
    assert rig.animation_data is None
    bpy.ops.mesh.primitive_plane_add()
    plane = bpy.context.active_object
    plane.shape_key_add(name="Basis")
    plane.shape_key_add(name="viseme_aa")
    with pytest.raises(RuntimeError, match="needs a Faces & Hands face rig"):
        bpy.ops.faces_hands.animate_speech(source="TEXT", text="Hello.")


def test_progress_in_steps_and_esc_cancels_with_nothing_written(bpy_clean):
    bpy = bpy_clean
    rig = _rig(bpy)
    cls = addon_module("operators.speech.animate").FH_OT_animate_speech
    assert "UNDO" in cls.bl_options
    progress = []
    wm = SimpleNamespace(event_timer_add=lambda *a, **k: object(), event_timer_remove=lambda t: None,
                         modal_handler_add=lambda op: None, progress_begin=lambda a, b: None,
                         progress_update=progress.append, progress_end=lambda: None)
    context = SimpleNamespace(window=object(), window_manager=wm, scene=bpy.context.scene, active_object=rig,
                              workspace=SimpleNamespace(status_text_set=lambda text: None))
    reports = []
    fake = SimpleNamespace(report=lambda kind, text: reports.append(text), _timer=None, _job=None,
                           source="TEXT", text="Hello there, how are you?", filepath="", transcript="",
                           style="neutral", seed=0, emotion="", loudness=True, start_at_current=False,
                           time_slice=0.0)  # one step per tick, so every stage's progress is shown
    fake.make_job = lambda ctx: cls.make_job(fake, ctx)
    fake._finish_modal = lambda ctx: cls._finish_modal(fake, ctx)
    fake._report_done = lambda job, report: cls._report_done(fake, job, report)
    assert cls.invoke(fake, context, SimpleNamespace(type="NONE")) == {"RUNNING_MODAL"}
    # the take is made in a worker: the timer ticks return at once with the progress so far
    ticks = 0
    while not progress or progress[-1] < 60:
        assert cls.modal(fake, context, SimpleNamespace(type="TIMER")) == {"RUNNING_MODAL"}
        ticks += 1
        assert ticks < 3000, progress[-5:]
    assert all(p <= 60 for p in progress) and progress == sorted(progress)
    assert cls.modal(fake, context, SimpleNamespace(type="ESC")) == {"CANCELLED"}
    assert "cancelled" in reports[-1] and rig.animation_data is None
    # Esc while the worker is still busy: cancelled at once, its result dropped
    assert cls.invoke(fake, context, SimpleNamespace(type="NONE")) == {"RUNNING_MODAL"}
    job, release = fake._job, threading.Event()
    make_take = job.make_take
    job.make_take = lambda report: release.wait(60) and make_take(report)  # busy until released
    assert cls.modal(fake, context, SimpleNamespace(type="TIMER")) == {"RUNNING_MODAL"}
    assert cls.modal(fake, context, SimpleNamespace(type="ESC")) == {"CANCELLED"}
    release.set()
    job._thread.join(timeout=60)
    assert rig.animation_data is None and job.take is None
    # run to the end: the worker's progress up to 60, then 85, 100 and finished
    progress.clear()
    assert cls.invoke(fake, context, SimpleNamespace(type="NONE")) == {"RUNNING_MODAL"}
    result = {"RUNNING_MODAL"}
    for _ in range(3000):
        result = cls.modal(fake, context, SimpleNamespace(type="TIMER"))
        if result != {"RUNNING_MODAL"}:
            break
    assert result == {"FINISHED"} and progress[-3:] == [60, 85, 100], (result, progress[-5:], reports)
    assert "Behavior" in reports[-1] and rig.animation_data is not None
