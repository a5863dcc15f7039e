"""Preset files: every shipped preset has a format header and passes its validator; the user's copy wins
over the shipped one; broken files are refused with a message that names the file and the problem."""
from __future__ import annotations

import json

import numpy as np
import pytest

from faces_hands_addon import UserError, emotion  # noqa: F401  (emotion registers its formats)
from faces_hands_addon.behavior import loudness as behavior_loudness  # noqa: F401  (registers the loudness format)
from faces_hands_addon.behavior import styles as behavior_styles  # noqa: F401  (registers the behaviour format)
from faces_hands_addon.character import retarget as character_retarget  # noqa: F401  (registers the bone map)
from faces_hands_addon.core import presets
from faces_hands_addon.face.expressions import load_expressions
from faces_hands_addon.face.rig import build_default_rig
from faces_hands_addon.hand import presets as hand_presets  # noqa: F401  (registers the hand formats)
from faces_hands_addon.morph import population as morph_population  # noqa: F401  (registers the morph formats)
from faces_hands_addon.speech import missing_words  # noqa: F401  (registers the transcript check's format)
from faces_hands_addon.performance import priority  # noqa: F401  (registers the speech priority's format)
from faces_hands_addon.speech.articulation import class_controls, load_articulation
from faces_hands_addon.tracking import ball_model, glove, setup  # noqa: F401  (the pitch formats)

FORMATS = {"expressions": "faces_hands.expressions", "face/landmarks": "faces_hands.face_landmarks",
           "face/muscles": "faces_hands.face_muscles", "speech/transcript_check": "faces_hands.transcript_check",
           "speech": "faces_hands.speech_targets",
           "morph/segments": "faces_hands.morph_segments", "morph/population": "faces_hands.morph_population",
           "morph/attributes": "faces_hands.morph_attributes",
           "hand/joints": "faces_hands.hand_joints", "hand/muscles": "faces_hands.hand_muscles",
           "hand/geometric_muscles": "faces_hands.hand_geometric_muscles", "hand/poses": "faces_hands.hand_poses",
           "emotion/emotion_words": "faces_hands.emotion_words",
           "emotion/basic_expressions": "faces_hands.emotion_expressions",
           "behavior/styles": "faces_hands.behavior_styles", "behavior/loudness": "faces_hands.loudness",
           "performance/speech_priority": "faces_hands.speech_priority",
           "character/bones": "faces_hands.bone_map",
           "tracking/ball": "faces_hands.pitch_ball", "tracking/glove": "faces_hands.pitch_glove",
           "tracking/pitches": "faces_hands.pitch_types", "tracking/setup": "faces_hands.pitch_setup"}


def _format_of(relative: str) -> str:
    fmt = next((fmt for prefix, fmt in FORMATS.items() if relative.startswith(prefix)), None)
    assert fmt is not None, f"{relative}: a shipped preset this test does not know; add its folder to FORMATS"
    return fmt


@pytest.fixture
def user_folder(tmp_path):
    """The preset override folder set to ``tmp_path``; afterwards the folder the session had (the add-on
    sets one at registration: leaving None behind broke the preferences test in the same process)."""
    before = presets.user_folder()
    presets.set_user_folder(tmp_path)
    yield tmp_path
    presets.set_user_folder(before)


def test_every_shipped_preset_has_a_header_and_validates(built_extension):
    folder = built_extension / "presets"
    assert presets.SHIPPED_FOLDER.resolve() == folder.resolve(), "the engine reads presets from elsewhere"
    files = sorted(folder.rglob("*.json"))
    assert len(files) >= 7
    for path in files:
        relative = path.relative_to(folder).as_posix()
        doc = presets.parse_preset(path.read_text(encoding="utf-8"), relative, _format_of(relative))
        assert doc["format"] == _format_of(relative) and doc["version"] == 1, relative


@pytest.mark.parametrize("edit, message", [
    (lambda text: text[:-3], "not valid JSON \\(line"),
    (lambda text: text.replace('"format": "faces_hands.expressions",', ""), "no \"format\" header"),
    (lambda text: text.replace('"version": 1', '"version": 9'), "version 9 is newer"),
    (lambda text: text.replace('"faces_hands.expressions"', '"faces_hands.face_muscles"'), "not 'faces_hands"),
    (lambda text: text.replace('"jaw_open": 0.08', '"jaw_open": NaN', 1), "NaN is not a number"),
    (lambda text: text.replace('"jaw_open": 0.08', '"jaw_open": "wide"', 1), "jaw_open.*must be a number"),
])
def test_broken_user_preset_is_refused_with_a_clear_message(user_folder, edit, message):
    shipped = (presets.SHIPPED_FOLDER / "expressions" / "named.json").read_text(encoding="utf-8")
    broken = edit(shipped)
    assert broken != shipped
    (user_folder / "expressions").mkdir()
    (user_folder / "expressions" / "named.json").write_text(broken, encoding="utf-8")
    with pytest.raises(UserError, match=message) as error:
        load_expressions("named")
    assert "named.json" in str(error.value)


def test_user_copy_overrides_the_shipped_preset(user_folder):
    doc = json.loads((presets.SHIPPED_FOLDER / "expressions" / "named.json").read_text(encoding="utf-8"))
    doc["expressions"]["smile"]["jaw_open"] = 0.5
    (user_folder / "expressions").mkdir()
    (user_folder / "expressions" / "named.json").write_text(json.dumps(doc), encoding="utf-8")
    assert load_expressions("named")["smile"]["jaw_open"] == 0.5
    presets.set_user_folder(None)
    assert load_expressions("named")["smile"]["jaw_open"] == 0.08


def test_edited_face_preset_gives_a_new_template(user_folder):
    default = build_default_rig("coarse")
    doc = json.loads((presets.SHIPPED_FOLDER / "face" / "muscles.json").read_text(encoding="utf-8"))
    frontalis = next(m for m in doc["muscles"] if m["name"] == "frontalis_inner_R")
    shipped = frontalis["max_shortening"]
    frontalis["max_shortening"] = 0.5 * shipped                     # an artist makes the brow raiser weaker
    (user_folder / "face").mkdir()
    (user_folder / "face" / "muscles.json").write_text(json.dumps(doc), encoding="utf-8")
    edited = build_default_rig("coarse")
    index = default.template.muscles.names.index("frontalis_inner_R")
    assert default.template.muscles.specs[index].max_shortening == shipped
    assert edited.template.muscles.specs[index].max_shortening == 0.5 * shipped
    lift = [r.settled({"ctrl": {"frontalis_inner_R": 1.0}}, 0.6).positions["skin"] - r.rest_positions
            for r in (default, edited)]
    assert np.abs(lift[0]).max() > 1.2 * np.abs(lift[1]).max()
    assert "faces_hands.face_muscles" in edited.template.inputs.muscles_json   # the rig keeps what it was built from


def test_viseme_mouth_shapes_come_from_the_speech_classes():
    visemes, articulation = load_expressions("visemes"), load_articulation()
    doc = json.loads((presets.SHIPPED_FOLDER / "expressions" / "visemes.json").read_text(encoding="utf-8"))
    for name, entry in doc["expressions"].items():
        assert set(entry) <= {"from_speech", "controls"}, f"{name} copies its mouth shape instead of naming it"
        expected = class_controls(entry["from_speech"])
        expected.update(entry.get("controls", {}))
        assert visemes[name] == expected
    assert visemes["viseme_PP"]["orbicularis_oris_upper"] == articulation.targets[
        articulation.row_of["p"], articulation.parameters.index("orbicularis_oris_upper")]


def test_unknown_speech_class_is_named(user_folder):
    doc = json.loads((presets.SHIPPED_FOLDER / "expressions" / "visemes.json").read_text(encoding="utf-8"))
    doc["expressions"]["viseme_PP"]["from_speech"] = "bilabial"
    (user_folder / "expressions").mkdir()
    (user_folder / "expressions" / "visemes.json").write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(UserError, match="no articulation class 'bilabial'"):
        load_expressions("visemes")
