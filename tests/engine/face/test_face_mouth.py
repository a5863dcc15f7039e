"""Mouth details of the default head (thesis 3.1.2 "Muscle Deformation": the orbicularis oris contracts towards
a centre shifted along the protrusion axis; "Eyes, Teeth, Tongue": rigid parts driven by direct parameters).

Lip rounding: a rounded /u/ (orbicularis oris + protrusion) is a narrow, forward mouth with a small opening
that closes towards the corners, while the same contraction without protrusion (a bilabial closure) keeps
its width and closes the lips. Tongue: it rests inside the lower dental arch, so opening the jaw never shows
it through the lower incisors; tongue_out slides it out over them past the lips, tongue_tip_up lifts the tip
towards the alveolar ridge behind the upper incisors.

Skin nodes keep their MediaPipe canonical indices: 13 / 14 inner lips at the centre, 61 / 291 mouth corners,
0 / 17 outer lip centres. Axes (CONTRIBUTING.md): metres, Z up, the face looks along -Y.
"""
import numpy as np
import pytest
from scipy.spatial import Delaunay

from faces_hands_addon.face.expressions import expression_controls, load_expressions
from faces_hands_addon.face.rig import build_default_rig

MM = 1000.0
ROUNDED_U = {"orbicularis_oris_upper": 0.75, "orbicularis_oris_lower": 0.75, "orbicularis_oris_protrusion": 1.0,
             "jaw_open": 0.14}                                    # presets/speech/articulation.json, /uw/
CROWN_VERTICES = 2 + 7 * 12                                       # organs._box_tooth: an 8 x 12 UV sphere


@pytest.fixture(scope="module")
def rig():
    return build_default_rig("default")


def lips(rig, controls):
    p = rig.settled({"ctrl": controls}, 1.2).positions["skin"].astype(np.float64)
    rest = rig.template.skin.vertices
    upper = rig.template.skin.contours["lips_inner_upper"]
    lower = rig.template.skin.contours["lips_inner_lower"]
    return {"width": (p[291, 0] - p[61, 0]) * MM, "gap": (p[13, 2] - p[14, 2]) * MM,
            "gaps": (p[upper, 2] - p[lower, 2]) * MM,
            "forward": -(p[[0, 13, 14, 17], 1].mean() - rest[[0, 13, 14, 17], 1].mean()) * MM}


def test_rounded_lips_are_narrow_forward_and_open_in_the_middle(rig):
    rest = lips(rig, {})
    u = lips(rig, ROUNDED_U)
    assert u["width"] < 40.0 and u["width"] < rest["width"] - 8.0        # 49 mm at rest
    assert u["forward"] > 3.0
    assert 1.5 < u["gap"] < 6.0                                         # a small opening
    # rounded, not a slit: the opening narrows towards the corners (2nd contour node from each corner)
    gaps = u["gaps"]
    middle = gaps[len(gaps) // 2 - 2:len(gaps) // 2 + 3].mean()
    assert max(gaps[2], gaps[-3]) < 0.7 * middle


def test_rounding_needs_protrusion_bilabial_closure_keeps_its_width(rig):
    pressed = lips(rig, {"orbicularis_oris_upper": 1.0, "orbicularis_oris_lower": 1.0, "mentalis_L": 0.3,
                         "mentalis_R": 0.3})                           # /p b/
    u = lips(rig, ROUNDED_U)
    third = len(pressed["gaps"]) // 3
    assert pressed["gaps"][third:-third].max() < 1.0                   # closed
    assert pressed["width"] > u["width"] + 5.0
    protruded_only = lips(rig, {"orbicularis_oris_protrusion": 1.0})   # no contraction: no rounding
    assert protruded_only["width"] > lips(rig, {})["width"] - 1.0


# -- tongue ------------------------------------------------------------------------------------------------
def _hulls(part):
    v = part.vertices
    return [Delaunay(v[i:i + CROWN_VERTICES]) for i in range(0, len(v), CROWN_VERTICES)]


@pytest.fixture(scope="module")
def mouth(rig):
    parts = rig.template.organs.parts
    lower = parts["teeth_lower"].vertices
    upper = parts["teeth_upper"].vertices
    lower_front = lower[np.abs(lower[:, 0]) < 0.0025]      # mesial halves of the central incisors
    upper_front = upper[np.abs(upper[:, 0]) < 0.0025]
    return {"lower": _hulls(parts["teeth_lower"]), "upper": _hulls(parts["teeth_upper"]),
            "tongue": parts["tongue"].vertices,
            "lower_lingual": float(lower_front[:, 1].max()), "lower_edge": float(lower_front[:, 2].max()),
            "lower_root": float(lower_front[:, 2].min()),
            "upper_lingual": float(upper_front[:, 1].max()), "upper_edge": float(upper_front[:, 2].min())}


def _pose(rig, controls):
    rig.reset_controls()
    rig.set_controls(controls)
    return rig.rigid_transforms()


def _apply(matrix, points):
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def _inside(hulls, points) -> int:
    return int(sum((h.find_simplex(points) >= 0).sum() for h in hulls))


@pytest.mark.parametrize("tongue", [{}, {"tongue_back": 1.0}, {"tongue_tip_up": 1.0}])
def test_tongue_stays_behind_the_lower_incisors_over_a_jaw_sweep(rig, mouth, tongue):
    """The defect: the tongue tip poked through the lower incisors once the jaw opened."""
    for jaw in np.linspace(0.0, 1.0, 11):
        t = _pose(rig, {**tongue, "jaw_open": float(jaw)})
        world = _apply(t["tongue"], mouth["tongue"])
        in_jaw = _apply(np.linalg.inv(t["teeth_lower"]), world)      # lower teeth at rest
        assert _inside(mouth["lower"], in_jaw) == 0, jaw
        if jaw >= 0.1 or "tongue_tip_up" not in tongue:             # a raised tip needs the mouth open
            assert _inside(mouth["upper"], world) == 0, jaw
        # nothing in front of the central incisors' lingual face, at the height of their crowns
        front = (in_jaw[:, 2] > mouth["lower_root"]) & (np.abs(in_jaw[:, 0]) < 0.0025)
        assert np.all(in_jaw[front, 1] > mouth["lower_lingual"]), jaw


def test_tongue_rests_on_the_floor_of_the_mouth(rig, mouth):
    v = mouth["tongue"]
    tip = v[v[:, 1].argmin()]
    assert tip[2] < mouth["lower_edge"]                                 # tip below the incisal edge
    assert 0.0 < tip[1] - mouth["lower_lingual"] < 0.004                # just behind the incisors


def test_tongue_out_slides_over_the_lower_teeth_past_the_lips(rig, mouth):
    for out in (0.4, 0.7, 1.0):
        t = _pose(rig, {"tongue_out": out, "jaw_open": 0.3})
        in_jaw = _apply(np.linalg.inv(t["teeth_lower"]), _apply(t["tongue"], mouth["tongue"]))
        assert _inside(mouth["lower"], in_jaw) == 0, out
    pose = rig.settled({"ctrl": {"tongue_out": 1.0, "jaw_open": 0.3}}, 1.2)    # ARKit tongueOut
    positions, t = pose.positions["skin"], pose.transforms
    tip = _apply(t["tongue"], mouth["tongue"])[:, 1].min()
    assert tip < min(positions[13, 1], positions[14, 1], positions[17, 1]) - 0.003


def test_tongue_tip_up_reaches_behind_the_upper_incisors(rig, mouth):
    t = _pose(rig, {"tongue_tip_up": 0.9, "jaw_open": 0.13})        # viseme_DD
    world = _apply(t["tongue"], mouth["tongue"])
    tip = world[0]                                                   # the front pole of the tongue
    assert tip[2] > mouth["upper_edge"] + 0.006                       # up at the alveolar ridge
    assert tip[1] > mouth["upper_lingual"]                            # behind the upper incisors
    assert _inside(mouth["upper"], world) == 0


def test_th_puts_the_tip_between_the_teeth_without_entering_them(rig, mouth):
    t = _pose(rig, expression_controls(load_expressions("visemes")["viseme_TH"], rig.control_specs()))
    world = _apply(t["tongue"], mouth["tongue"])
    upper = rig.template.organs.parts["teeth_upper"].vertices
    assert world[0, 1] < upper[:, 1].min()                            # tip in front of the upper incisors
    assert _inside(mouth["upper"], world) == 0
    assert _inside(mouth["lower"], _apply(np.linalg.inv(t["teeth_lower"]), world)) == 0
