"""Facial expressions of emotions (thesis 4.4.3): the six basic expressions as FACS-based control presets,
scaled expressions (Eqs. 4.6, 4.7: anxiety and panic are fear at other radii), mixed expressions between
the two angular neighbours (Eq. 4.9: interpolation by angle) and the antagonists of Table 4.6 (Eq. 4.10)."""
from __future__ import annotations

import json
import math

import pytest

from faces_hands_addon.core import presets
from faces_hands_addon.emotion import (BasicExpression, EmotionPoint, expression_for, face_specs, from_polar,
                                       load_model, load_words, mixed_expression)

R_FEAR = math.hypot(14.8, -44.4)          # Table 4.4
R_ANGER = math.hypot(34.0, -35.6)
R_JOY = math.hypot(17.3, 42.2)
ANGLE_JOY = math.degrees(math.atan2(17.3, 42.2))
ANGLE_FEAR = math.degrees(math.atan2(14.8, -44.4))
ANGLE_ANGER = math.degrees(math.atan2(34.0, -35.6))


@pytest.fixture(scope="module")
def model():
    return load_model()


@pytest.fixture(scope="module")
def basic():
    doc = json.loads((presets.SHIPPED_FOLDER / "emotion" / "basic_expressions.json").read_text(encoding="utf-8"))
    return {word: entry["controls"] for word, entry in doc["basic"].items()}


def test_basic_words_give_their_preset(model, basic):
    for word, controls in basic.items():
        assert expression_for(word, model) == pytest.approx(controls), word
    # same point in Table 4.4, same face
    assert expression_for("distress", model) == pytest.approx(basic["sorry-for"])
    assert expression_for("happy-for", model) == pytest.approx(basic["joy"])


def test_anxiety_and_panic_are_scaled_fear(model, basic):
    words = load_words()
    anxiety = expression_for("anxiety", model)
    ratio = words["anxiety"].radius / R_FEAR                         # Eq. 4.7: r_new / r_E
    assert ratio < 1 and set(anxiety) == set(basic["fear"])          # Eq. 4.6: M_new = M_e
    for control, value in basic["fear"].items():
        assert anxiety[control] == pytest.approx(ratio * value), control
    panic = expression_for("panic", model)
    ratio = words["panic"].radius / R_FEAR
    assert ratio > 1 and set(panic) == set(basic["fear"])
    for control, value in basic["fear"].items():
        assert panic[control] == pytest.approx(min(1.0, ratio * value)), control
    assert ratio * basic["fear"]["procerus"] < 1.0 and ratio * basic["fear"]["risorius_L"] > 1.0


def test_any_radius_on_a_basic_ray_scales_that_expression(model, basic):
    a, e = from_polar(ANGLE_ANGER, 0.5 * R_ANGER)
    half = expression_for((a, e), model)
    assert half == pytest.approx({k: 0.5 * v for k, v in basic["anger"].items()})


def test_a_mixed_emotion_interpolates_by_angle(model, basic):
    # between joy (22.3 deg) and surprise (90 deg); frontalis, orbicularis oculi and jaw have no antagonist
    for angle, radius in ((30.0, 40.0), (56.1, 60.0), (85.0, 20.0)):
        a, e = from_polar(angle, radius)
        mixed = expression_for((a, e), model)
        w_surprise = (angle - ANGLE_JOY) / (90.0 - ANGLE_JOY)
        w_joy = (90.0 - angle) / (90.0 - ANGLE_JOY)
        k_joy, k_surprise = radius / R_JOY, radius / 100.0
        assert mixed["frontalis_inner_L"] == pytest.approx(w_surprise * k_surprise * basic["surprise"]["frontalis_inner_L"])
        assert mixed["orbicularis_oculi_R"] == pytest.approx(w_joy * k_joy * basic["joy"]["orbicularis_oculi_R"])
        assert mixed["jaw_open"] == pytest.approx(w_joy * k_joy * basic["joy"]["jaw_open"]
                                                  + w_surprise * k_surprise * basic["surprise"]["jaw_open"])
    # the face moves steadily from one basic face to the other
    brows = [expression_for(from_polar(angle, 45.0), model)["frontalis_outer_R"] for angle in range(25, 90, 5)]
    assert brows == sorted(brows) and brows[0] < brows[-1]


def test_the_neighbours_wrap_round_the_disk(model, basic):
    # satisfaction (Table 4.4: -14.9, 33.1) lies between sorry-for (203.2 deg) and joy (382.3 deg)
    angle_sorry = math.degrees(math.atan2(-17.2, -40.1)) % 360.0
    angle = math.degrees(math.atan2(-14.9, 33.1)) % 360.0
    radius = math.hypot(-14.9, 33.1)
    w_joy = (angle - angle_sorry) / (ANGLE_JOY + 360.0 - angle_sorry)
    mixed = expression_for("satisfaction", model)
    assert mixed["orbicularis_oculi_L"] == pytest.approx(w_joy * radius / R_JOY * basic["joy"]["orbicularis_oculi_L"])
    r_sorry = math.hypot(-17.2, -40.1)
    assert mixed["corrugator_supercilii_L"] == pytest.approx(
        (1 - w_joy) * radius / r_sorry * basic["sorry-for"]["corrugator_supercilii_L"])


def _basic(word, angle, radius, controls):
    a, e = from_polar(angle, radius)
    return BasicExpression(word, word, "", EmotionPoint(a, e, 0.0, word), controls)


def test_antagonists_cancel_as_eq_4_10_says():
    same = {"zygomaticus_major_L": ("zygomaticus_major_L",), "depressor_anguli_oris_L": ("depressor_anguli_oris_L",),
            "orbicularis_oris_upper": ("orbicularis_oris_upper", "orbicularis_oris_lower"),
            "orbicularis_oris_lower": ("orbicularis_oris_upper", "orbicularis_oris_lower"),
            "risorius_L": ("risorius_L", "risorius_R"), "risorius_R": ("risorius_L", "risorius_R")}
    opposite = {"zygomaticus_major_L": ("depressor_anguli_oris_L",), "depressor_anguli_oris_L": ("zygomaticus_major_L",),
                "orbicularis_oris_upper": same["risorius_L"], "orbicularis_oris_lower": same["risorius_L"],
                "risorius_L": same["orbicularis_oris_upper"], "risorius_R": same["orbicularis_oris_upper"]}
    e1 = _basic("one", 10.0, 50.0, {"zygomaticus_major_L": 0.6, "orbicularis_oris_upper": 0.5,
                                    "orbicularis_oris_lower": 0.3, "procerus": 0.4})
    e2 = _basic("two", 70.0, 25.0, {"depressor_anguli_oris_L": 0.4, "risorius_L": 0.1, "risorius_R": 0.1})
    out = mixed_expression(e1, e2, 40.0, 50.0, same, opposite)      # r_new/r_1 = 1, r_new/r_2 = 2
    # zygomaticus: S+ = 0.6, S- = 2 * 0.4 = 0.8 -> the antagonist wins, 0; depressor: S+ 0.8 > S- 0.6
    assert out["zygomaticus_major_L"] == 0.0
    assert out["depressor_anguli_oris_L"] == pytest.approx((0.8 - 0.6) / 0.8 * 0.8)
    # orbicularis oris: S+ = 0.8, S- = 2 * (0.1 + 0.1) = 0.4, shared 0.5 : 0.3
    assert out["orbicularis_oris_upper"] == pytest.approx((0.8 - 0.4) / 0.8 * 0.5)
    assert out["orbicularis_oris_lower"] == pytest.approx((0.8 - 0.4) / 0.8 * 0.3)
    assert out["risorius_L"] == 0.0 and out["risorius_R"] == 0.0
    assert out["procerus"] == pytest.approx(0.5 * 0.4)               # Eq. 4.9, halfway in angle
    # equal net contractions cancel completely
    e3 = _basic("three", 70.0, 50.0, {"depressor_anguli_oris_L": 0.6})
    out = mixed_expression(e1, e3, 40.0, 50.0, same, opposite)
    assert out["zygomaticus_major_L"] == 0.0 and out["depressor_anguli_oris_L"] == 0.0


def test_anger_and_fear_mouths_oppose(model, basic):
    # anger presses the lips (orbicularis oris), fear stretches them (risorius): Table 4.6 antagonists
    angle, radius = 0.5 * (ANGLE_ANGER + ANGLE_FEAR), 48.0
    mixed = expression_for(from_polar(angle, radius), model)
    k_anger, k_fear = radius / R_ANGER, radius / R_FEAR
    s_lips = k_anger * (basic["anger"]["orbicularis_oris_upper"] + basic["anger"]["orbicularis_oris_lower"])
    s_stretch = k_fear * (basic["fear"]["risorius_L"] + basic["fear"]["risorius_R"])
    assert s_stretch > s_lips
    assert mixed["orbicularis_oris_upper"] == 0.0 and mixed["orbicularis_oris_lower"] == 0.0
    assert mixed["risorius_L"] == pytest.approx((s_stretch - s_lips) / s_stretch * k_fear * basic["fear"]["risorius_L"])


def test_the_antagonists_are_table_4_6(model):
    assert model.opposite["zygomaticus_major_L"] == ("depressor_anguli_oris_L",)
    assert model.opposite["zygomaticus_major_R"] == ("depressor_anguli_oris_R",)
    assert set(model.opposite["risorius_L"]) == {"orbicularis_oris_upper", "orbicularis_oris_lower"}
    assert set(model.same["risorius_L"]) == {"risorius_L", "risorius_R"}
    assert set(model.opposite["mentalis_R"]) == {"depressor_labii_inferioris_L", "depressor_labii_inferioris_R"}
    assert "frontalis_inner_L" not in model.opposite


def test_every_word_and_many_points_give_a_face_within_bounds(model):
    specs = face_specs()
    points = list(load_words()) + [from_polar(angle, radius) for angle in range(0, 360, 7)
                                   for radius in (5.0, 50.0, 100.0)] + [(100.0, -100.0), (-100.0, 100.0)]
    for emotion in points:
        face = expression_for(emotion, model)
        assert face, emotion
        for control, value in face.items():
            spec = specs[control]
            assert math.isfinite(value) and spec.minimum <= value <= spec.maximum, (emotion, control, value)
    assert expression_for((0.0, 0.0), model) == {}


def test_same_emotion_same_face(model):
    for emotion in ("reproach", (12.5, -3.25), "panic"):
        assert expression_for(emotion, model) == expression_for(emotion, load_model())
    words = load_words()
    assert expression_for("hope", model) == expression_for((words["hope"].activation, words["hope"].evaluation), model)


# FACS action units of each basic expression (presets/SOURCES.md) -> the rig muscles that must move
ACTION_UNITS = {
    "joy": {"orbicularis_oculi_L", "zygomaticus_major_L"},                                   # 6 + 12
    "sorry-for": {"frontalis_inner_L", "corrugator_supercilii_L", "depressor_anguli_oris_L"},  # 1 + 4 + 15
    "surprise": {"frontalis_inner_L", "frontalis_outer_L", "jaw_open"},                      # 1 + 2 + 26
    "fear": {"frontalis_inner_L", "frontalis_outer_L", "corrugator_supercilii_L", "risorius_L", "jaw_open"},
    "anger": {"corrugator_supercilii_L", "procerus", "orbicularis_oculi_L", "orbicularis_oris_upper"},  # 4 7 23
    "hate": {"levator_labii_alaeque_nasi_L", "depressor_anguli_oris_L", "depressor_labii_inferioris_L"},  # 9 15 16
}


def test_basic_expressions_move_their_action_units(basic):
    specs = face_specs()
    for word, muscles in ACTION_UNITS.items():
        assert all(basic[word].get(m, 0.0) >= 0.2 for m in muscles), word
        assert all(name in specs for name in basic[word]), word
        right = {m[:-2] + "_R" for m in muscles if m.endswith("_L")}
        assert all(basic[word][m] == basic[word][m[:-2] + "_L"] for m in right), word   # symmetric


def test_sadness_and_surprise_brows_are_at_least_as_strong_as_the_named_ones(basic):
    named = json.loads((presets.SHIPPED_FOLDER / "expressions" / "named.json").read_text(encoding="utf-8"))
    named = named["expressions"]
    brow = ("frontalis_inner_L", "frontalis_outer_L", "corrugator_supercilii_L", "procerus")
    for mine, theirs in (("sorry-for", "sadness"), ("surprise", "surprise")):
        assert all(basic[mine].get(m, 0.0) >= named[theirs].get(m, 0.0) for m in brow), mine
    assert sum(basic["sorry-for"].get(m, 0.0) for m in brow) >= sum(named["sadness"].get(m, 0.0) for m in brow) + 0.5
