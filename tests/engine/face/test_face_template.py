"""The template head (thesis 3.1.2 "Skin", "Skull", "Building the Reference Head", "Eyes, Teeth, Tongue")."""

import numpy as np
import pytest

from faces_hands_addon import assets
from faces_hands_addon.core import geometry
from faces_hands_addon.face.expressions import expression_controls, expression_sets, load_expressions
from faces_hands_addon.face.rig import build_default_rig
from faces_hands_addon.face.skin import build_skin

ARKIT = (["browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight", "cheekPuff",
          "cheekSquintLeft", "cheekSquintRight", "jawForward", "jawLeft", "jawRight", "jawOpen", "mouthClose",
          "mouthFunnel", "mouthPucker", "mouthLeft", "mouthRight", "mouthRollLower", "mouthRollUpper",
          "mouthShrugLower", "mouthShrugUpper", "noseSneerLeft", "noseSneerRight", "tongueOut"]
         + [f"eye{p}{s}" for p in ("Blink", "LookDown", "LookIn", "LookOut", "LookUp", "Squint", "Wide")
            for s in ("Left", "Right")]
         + [f"mouth{p}{s}" for p in ("Dimple", "Frown", "LowerDown", "Press", "Smile", "Stretch", "UpperUp")
            for s in ("Left", "Right")])
VISEMES = [f"viseme_{v}" for v in ("sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "ih",
                                   "oh", "ou")]
MUSCLES = {"frontalis_inner", "frontalis_outer", "corrugator_supercilii", "orbicularis_oculi",
           "levator_labii_alaeque_nasi", "levator_labii_superioris", "zygomaticus_major", "zygomaticus_minor",
           "levator_anguli_oris", "risorius", "depressor_anguli_oris", "depressor_labii_inferioris", "mentalis"}


@pytest.fixture(scope="module")
def rig():
    return build_default_rig("default")


def test_skin_has_open_mouth_and_eyes_and_sensible_resolutions():
    face, contours = assets.canonical_face(), assets.face_contours().lines
    for resolution, low, high in (("default", 2000, 4000), ("10k", 9000, 13000)):
        skin = build_skin(face.vertices, face.faces, contours, resolution)
        assert low <= skin.node_count <= high
        for name in ("lips_inner_upper", "eye_L_upper", "eye_R_upper"):
            lower = name.replace("upper", "lower") if "lips" in name else name.replace("upper", "lower")
            ring = set(skin.contours[name].tolist()) | set(skin.contours[lower].tolist())
            covering = [f for f in skin.faces.tolist() if set(f) <= ring]
            assert covering == [], f"triangles still cover {name}"
        assert np.all(geometry.mirror_map(skin.vertices, 1e-7) >= 0)      # left/right symmetric
        assert np.all(np.isfinite(skin.vertices))


def test_template_parts_are_placed_inside_the_head(rig):
    t = rig.template
    skin = t.skin.vertices
    for side, sign in (("L", 1), ("R", -1)):
        centre = t.organs.eye_centres[side]
        assert np.sign(centre[0]) == sign                              # +X is the character's left
        assert 0.011 < t.organs.eye_radius < 0.013
    upper, lower = t.organs.parts["teeth_upper"].vertices, t.organs.parts["teeth_lower"].vertices
    stomion = 0.5 * (skin[13] + skin[14])
    assert upper[:, 1].min() > stomion[1] and lower[:, 1].min() > stomion[1]   # teeth behind the lips
    assert upper[:, 2].mean() > lower[:, 2].mean()
    pivot = t.bones.tmj_pivot
    assert pivot[1] > stomion[1] + 0.03 and pivot[2] > stomion[2] + 0.03      # TMJ behind and above the mouth
    # the lower face follows the jaw, the forehead the skull
    node_bone = t.attachment.node_bone
    assert node_bone[152] == 1 and node_bone[17] == 1 and node_bone[10] == 0 and node_bone[0] == 0


def test_muscle_layout_has_the_24_major_muscles_with_contributing_names(rig):
    names = set(rig.template.muscles.names)
    for base in MUSCLES:
        assert {base + "_L", base + "_R"} <= names
    assert {"procerus", "orbicularis_oris_upper", "orbicularis_oris_lower"} <= names
    assert len(names) >= 24
    specs = rig.control_specs()
    for name in ("orbicularis_oris_protrusion", "jaw_open", "jaw_yaw", "jaw_forward", "jaw_drop", "eye_yaw",
                 "eye_pitch", "eyelid_close_L", "eyelid_close_R", "tongue_tip_up", "tongue_back", "tongue_out"):
        assert name in specs


def test_expression_presets_cover_arkit_and_visemes_with_valid_controls(rig):
    assert {"arkit", "visemes", "named"} <= set(expression_sets())
    arkit, visemes = load_expressions("arkit"), load_expressions("visemes")
    assert sorted(arkit) == sorted(ARKIT) and len(arkit) == 52
    assert list(visemes) == VISEMES
    named = load_expressions("named")
    assert {"smile", "frown", "surprise"} <= set(named)
    for table in (arkit, visemes, named):
        for values in table.values():
            expression_controls(values, rig.specs)                     # raises on unknown names
