"""Each muscle moves the face the way its anatomy says (thesis 3.1.1, 3.1.2 "Muscle Deformation");
canonical-face vertex ids keep their index in the skin (61/291 mouth corners, 13/14 inner lips, ...)."""
import numpy as np
import pytest

from faces_hands_addon.core.geometry import mirror_map
from faces_hands_addon.face.rig import build_default_rig

MM = 1000.0


@pytest.fixture(scope="module")
def rig():
    return build_default_rig("default")


def displacement(rig, controls, time=1.2):
    """Settle a fresh copy of the state under ``controls``; (N, 3) displacement in mm."""
    rest = rig.template.skin.vertices
    rig.reset_state()
    rig.reset_controls()
    rig.set_controls(controls)
    return (rig.settle(time).astype(np.float64) - rest) * MM


def test_zygomaticus_major_raises_the_mouth_corner_up_and_outward(rig):
    d = displacement(rig, {"zygomaticus_major_R": 1.0})
    assert d[61, 2] > 2.5 and d[61, 0] < -2.5             # right corner: up and towards -X (outward)
    assert np.linalg.norm(d[291]) < 0.3 * np.linalg.norm(d[61])
    d = displacement(rig, {"zygomaticus_major_L": 1.0})
    assert d[291, 2] > 2.5 and d[291, 0] > 2.5


def test_depressor_anguli_oris_lowers_the_mouth_corner(rig):
    d = displacement(rig, {"depressor_anguli_oris_L": 1.0, "depressor_anguli_oris_R": 1.0})
    assert d[61, 2] < -2.5 and d[291, 2] < -2.5


def test_frontalis_raises_the_brows(rig):
    d = displacement(rig, {"frontalis_inner_L": 1.0, "frontalis_inner_R": 1.0})
    assert d[107, 2] > 3.0 and d[336, 2] > 3.0            # inner brows
    d = displacement(rig, {"frontalis_outer_R": 1.0})
    assert d[105, 2] > 2.0 and abs(d[334, 2]) < 0.5       # only the right outer brow


def test_corrugator_pulls_the_brows_together_and_down(rig):
    d = displacement(rig, {"corrugator_supercilii_L": 1.0, "corrugator_supercilii_R": 1.0})
    rest = rig.template.skin.vertices * MM
    before = abs(rest[336, 0] - rest[107, 0])
    after = abs((rest[336] + d[336])[0] - (rest[107] + d[107])[0])
    assert after < before - 1.5                           # brows closer together
    assert d[105, 2] < 0 and d[334, 2] < 0                # and down


def test_procerus_pulls_the_glabella_down(rig):
    assert displacement(rig, {"procerus": 1.0})[9, 2] < -1.5


def test_orbicularis_oris_closes_the_lips_and_protrudes_them(rig):
    """The lips rest closed (issue 10); with the jaw a little open they part, and the orbicularis oris
    closes them again against it (ARKit jawOpen + mouthClose, a bilabial after an open vowel)."""
    rest = rig.template.skin.vertices * MM
    upper = rig.template.skin.contours["lips_inner_upper"]
    lower = rig.template.skin.contours["lips_inner_lower"]
    middle = slice(len(upper) // 2 - 3, len(upper) // 2 + 4)

    def gap(controls):
        pos = rest + displacement(rig, controls)
        return (pos[upper[middle], 2] - pos[lower[middle], 2]).max()
    assert np.abs(rest[upper[middle], 2] - rest[lower[middle], 2]).max() < 0.5      # closed at rest
    apart = gap({"jaw_open": 0.15})
    closed = gap({"jaw_open": 0.15, "orbicularis_oris_upper": 1.0, "orbicularis_oris_lower": 1.0})
    assert apart > 4.0 and closed < 1.0                   # the inner lip contours meet
    d = displacement(rig, {"orbicularis_oris_protrusion": 1.0})
    assert d[0, 1] < -2.0 and d[17, 1] < -2.0 and d[13, 1] < -2.5   # lips forward (-Y)
    d = displacement(rig, {"orbicularis_oris_protrusion": -1.0})
    assert d[13, 1] > 1.0                                             # retracted: back


def test_lip_raisers_and_depressors(rig):
    assert displacement(rig, {"levator_labii_superioris_R": 1.0})[39, 2] > 2.0
    assert displacement(rig, {"depressor_labii_inferioris_R": 1.0})[181, 2] < -2.0
    assert displacement(rig, {"mentalis_L": 1.0, "mentalis_R": 1.0})[199, 2] > 0.5   # chin skin up
    assert displacement(rig, {"risorius_R": 1.0})[61, 0] < -2.0                      # corner sideways


def test_left_and_right_muscles_are_mirror_symmetric(rig):
    mirror = mirror_map(rig.template.skin.vertices, 1e-7)
    assert np.all(mirror >= 0)
    for base in ("zygomaticus_major", "depressor_anguli_oris", "frontalis_inner", "orbicularis_oculi"):
        right = displacement(rig, {base + "_R": 1.0})
        left = displacement(rig, {base + "_L": 1.0})
        mirrored = left[mirror] * np.array([-1.0, 1.0, 1.0])
        assert np.abs(right - mirrored).max() < 0.05 * np.abs(right).max() + 0.1, base


def test_jaw_opens_the_mouth_moving_lower_lip_and_chin_not_the_forehead(rig):
    d = displacement(rig, {"jaw_open": 1.0})
    assert d[152, 2] < -15 and d[17, 2] < -10 and d[14, 2] < -10
    assert np.linalg.norm(d[[10, 151, 9, 107, 336]], axis=1).max() < 0.5
    transforms = rig.rigid_transforms()
    np.testing.assert_allclose(transforms["teeth_lower"], transforms["jaw"])
    np.testing.assert_allclose(transforms["teeth_upper"], np.eye(4))


def test_eyelid_close_closes_the_eye_and_gaze_turns_the_eyes(rig):
    rest = rig.template.skin.vertices * MM
    d = displacement(rig, {"eyelid_close_R": 1.0})
    pos = rest + d
    assert rest[159, 2] - rest[145, 2] > 5.0
    assert abs(pos[159, 2] - pos[145, 2]) < 1.5           # upper and lower margins meet
    assert np.linalg.norm(d[386]) < 0.5                   # the left eye stays open
    rig.reset_controls()
    rig.set_controls({"eye_yaw": 1.0})
    gaze = rig.rigid_transforms()["eye_L"][:3, :3] @ np.array([0.0, -1.0, 0.0])
    assert gaze[0] > 0.4                                  # looks to the character's left (+X)


def test_wrinkle_strengths_follow_their_muscles(rig):
    rig.reset_controls()
    assert all(v == 0 for v in rig.wrinkles().values())
    rig.set_controls({"frontalis_inner_L": 1.0, "frontalis_inner_R": 1.0, "corrugator_supercilii_L": 1.0})
    wrinkles = rig.wrinkles()
    assert wrinkles["forehead"] > 0.5 and 0 < wrinkles["brow_furrow"] < 1
    fibres = rig.muscle_fibres()
    assert {name for name, _, _ in fibres} == set(rig.template.muscles.names)
    assert all(line.shape[1] == 3 and line.dtype == np.float32 for _, line, _ in fibres)
