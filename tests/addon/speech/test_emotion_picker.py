"""The emotion picker on the default head: a word puts the point on the disk, Set Emotion writes exactly
the engine's expression into the rig's Emotion layer (and keys it on request), Use for Speech hands the
point to Animate Speech; without a face rig it is refused with nothing changed."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import addon_module
from ui_layout import CheckedLayout


def _rig(bpy):
    assert bpy.ops.faces_hands.build_face_rig() == {"FINISHED"}
    return bpy.context.active_object


def _emotion_layer(rig) -> dict:
    return {k[len("fh.emotion."):]: float(rig[k]) for k in rig.keys() if k.startswith("fh.emotion.")}


def test_word_point_expression_and_set_emotion(bpy_clean):
    bpy = bpy_clean
    rig = _rig(bpy)
    settings = bpy.context.scene.faces_hands
    emotion = addon_module("faces_hands_addon.emotion")
    settings.emotion_word = "anxiety"
    point = emotion.load_words()["anxiety"]
    assert (settings.emotion_activation, settings.emotion_evaluation) == pytest.approx(
        (point.activation, point.evaluation), abs=1e-4)
    expected = emotion.expression_for("anxiety")
    picker = addon_module("panels.emotion_picker")
    assert picker.picker_expression(settings) == pytest.approx(expected, abs=1e-5)
    preview = picker.disk_preview(settings)
    assert tuple(preview.image_size) == (128, 128)
    pixels = np.array(preview.image_pixels_float[:]).reshape(-1, 4)[:, :3]
    red = int(np.isclose(pixels, (1.0, 0.25, 0.2), atol=1e-3).all(axis=1).sum())
    assert red > 20, "the chosen point is drawn"
    assert bpy.ops.faces_hands.set_emotion() == {"FINISHED"}
    layer = _emotion_layer(rig)
    assert {k: v for k, v in layer.items() if v} == pytest.approx(expected, abs=1e-5)
    assert rig.animation_data is None, "Set Emotion without Key inserts no keys"
    # a slider move leaves the word: the menu says Custom, the point is the sliders'
    settings.emotion_evaluation = -80.0
    assert settings.emotion_word == "CUSTOM" and picker.picker_point(settings).word == ""
    bpy.context.scene.frame_set(12)
    assert bpy.ops.faces_hands.set_emotion(key=True) == {"FINISHED"}
    bag = addon_module("operators.adapters.fcurves").existing_channelbag(rig)
    keyed = [c for c in bag.fcurves if c.data_path.startswith('["fh.emotion.')]
    assert keyed and all(c.keyframe_points[0].co[0] == 12 for c in keyed)
    assert bpy.ops.faces_hands.use_emotion_for_speech() == {"FINISHED"}
    assert settings.speech_emotion == f"{settings.emotion_activation:g},-80"


def test_set_emotion_without_a_face_rig_is_refused(bpy_clean):
    bpy = bpy_clean
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.active_object
    keys = set(cube.keys())
    assert not bpy.ops.faces_hands.set_emotion.poll()
    cls = addon_module("operators.speech.emotion").FH_OT_set_emotion
    user_error = addon_module("faces_hands_addon.core.errors").UserError
    with pytest.raises(user_error, match="face rig"):
        cls.run(type("Op", (), {"key": False, "report": lambda *a: None})(), bpy.context)
    assert set(cube.keys()) == keys


def test_emotion_panel_draws_the_disk_the_expression_and_the_operators(bpy_clean):
    bpy = bpy_clean
    settings = bpy.context.scene.faces_hands
    settings.emotion_word = "joy"
    log = []
    bpy.types.FH_PT_emotion.draw(type("Panel", (), {"layout": CheckedLayout(bpy, log)})(), bpy.context)
    calls = [c[0] for c in log]
    assert "template_icon" in calls
    labels = [c[2].get("text", "") for c in log if c[0] == "label"]
    assert any(label.startswith("Angle 22 deg") for label in labels), labels
    values = addon_module("faces_hands_addon.emotion").expression_for("joy")
    top = max(abs(v) for v in values.values())
    assert any(k.replace("_", " ") in labels for k, v in values.items() if abs(v) == top)
    ops = [c[1][0] for c in log if c[0] == "operator"]
    assert ops.count("faces_hands.set_emotion") == 2 and "faces_hands.use_emotion_for_speech" in ops
