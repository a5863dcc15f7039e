"""The fast subset of the shape audit (bench/shapes.py, issue 10) on the default head: each ARKit look key
turns its own eye only, eyeBlink closes the lids fully (0 mm lid gap, no iris point visible from the
front), the brows rise and fall as far as real brows (FACS AU1/AU2/AU4; targets in bench/shape_targets.md),
lids fold nowhere, and the audit's neutral measures what the template is (lids open, no folded triangle)."""
import pytest

from faces_hands_addon.face.audit_targets import TARGETS, audit_shapes, check
from faces_hands_addon.face.expressions import load_expressions
from faces_hands_addon.face.rig import build_default_rig

SUBSET = ("eyeLookInLeft", "eyeLookOutRight", "eyeLookUpLeft", "eyeLookDownLeft", "eyeBlinkLeft", "eyeBlinkRight",
          "browInnerUp", "browOuterUpLeft", "browDownLeft")


@pytest.fixture(scope="module")
def report():
    expressions = {**load_expressions("arkit"), **load_expressions("visemes")}
    return audit_shapes(build_default_rig("default"), expressions, SUBSET)


def test_every_arkit_shape_and_viseme_has_targets():
    expressions = {**load_expressions("arkit"), **load_expressions("visemes")}
    assert len(expressions) == 67
    assert set(expressions) <= set(TARGETS)


def test_look_keys_move_only_their_own_eye(report):
    for name in ("eyeLookInLeft", "eyeLookOutRight", "eyeLookUpLeft"):
        figures, failed = report["rows"][name]
        assert not [f for f in failed if f.startswith(("yaw", "pitch"))], (name, failed)
    left_in = report["rows"]["eyeLookInLeft"][0]
    assert left_in["yaw_L"] < -15 and abs(left_in["yaw_R"]) < 0.5


def test_blink_closes_fully(report):
    for name, side in (("eyeBlinkLeft", "L"), ("eyeBlinkRight", "R")):
        figures, _ = report["rows"][name]
        assert figures[f"gap_{side}"] == 0.0, name
        assert figures[f"iris_{side}"] == 0, f"{name}: {figures[f'iris_{side}']:.0f} iris points visible"
    assert report["neutral"]["gap_L"] > 5.0 and report["neutral"]["iris_L"] > 50


def test_brows_rise_like_real_brows(report):
    figures, failed = report["rows"]["browInnerUp"]
    assert not [f for f in failed if f.startswith("brow")], failed          # AU1: >= 5 mm both sides
    outer = report["rows"]["browOuterUpLeft"][0]
    # AU2: the outer frontalis reaches the brow's tail (3.4 mm before it did, 1.6 mm before the audit)
    assert outer["brow_out_L"] >= 5.0 and abs(outer["brow_out_R"]) < 0.5


def test_brows_lower_and_lids_fold_nowhere(report):
    """AU4 lowers the inner brow 2.5 mm; the lids close and look down without folding at the canthi."""
    assert report["rows"]["browDownLeft"][0]["brow_in_L"] <= -2.5
    for name in ("eyeBlinkLeft", "eyeBlinkRight", "eyeLookDownLeft"):
        assert report["rows"][name][0]["inverted"] == 0, name


MOUTH = ("viseme_sil", "viseme_FF", "jawOpen", "cheekPuff", "mouthLeft", "mouthRight", "mouthShrugLower",
         "mouthRollUpper", "mouthFunnel")


@pytest.fixture(scope="module")
def mouth_report():
    expressions = {**load_expressions("arkit"), **load_expressions("visemes")}
    return audit_shapes(build_default_rig("default"), expressions, MOUTH)


@pytest.mark.parametrize("name", MOUTH)
def test_mouth_shapes_meet_their_targets(mouth_report, name):
    """The closed neutral (lips touching, no tooth shown), /f/ with the lower lip at the upper incisors,
    the jaw open 38-52 mm between the incisors without a folded triangle, puffed cheeks (buccinator and
    air pressure), the lip ring pulled sideways, the chin raiser, a lip roll and a funnel: every check of
    the audit passes (each failed on the open-mouthed template)."""
    figures, failed = mouth_report["rows"][name]
    assert not failed, (name, failed)


def test_silence_is_held_to_the_rest_the_head_was_modelled_with():
    """viseme_sil (every muscle at 0: the face at rest) is checked against the rest mesh as modelled: a head
    modelled with parted lips (6.5 mm apart, 3 mm of upper teeth shown) passes when silence keeps that, and
    fails when the rig opens the lips or shows the teeth further (beyond the 0.5 mm sample step); a head
    modelled with its lips together is held to the 1 mm / 0.5 mm limits as before."""
    def figures(gap, upper, lower=0.0):
        return {"lip_gap": gap, "upper_show": upper, "lower_show": lower, "inverted": 0.0, "lip_in_teeth": 0.0,
                "move99": 0.0, "asym95": 0.0}
    parted = figures(6.5, 3.0)
    assert check("viseme_sil", figures(6.5, 3.0), parted, None, parted) == []
    assert check("viseme_sil", figures(6.9, 3.5), parted, None, parted) == []
    failed = check("viseme_sil", figures(7.2, 4.0), parted, None, parted)
    assert [f.split("=")[0] for f in failed] == ["lip_gap", "upper_show"], failed
    sealed = figures(0.2, 0.0)
    assert check("viseme_sil", figures(1.0, 0.5), sealed, None, sealed) == []
    failed = check("viseme_sil", figures(1.2, 1.0), sealed, None, sealed)
    assert [f.split("=")[0] for f in failed] == ["lip_gap", "upper_show"], failed
    assert len(check("viseme_sil", figures(6.5, 3.0), parted, None)) == 2      # without the rest: from 0
