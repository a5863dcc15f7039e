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
    return (rig.relax(time).astype(np.float64) - rest) * MM


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


def test_protruded_lips_come_forward_as_a_whole(rig):
    """Protrusion carries the red lip out to its outline (the vermilion border, canonical 0 and 17) nearly as
    far as its inner edge (13, 14): the lips move as a body, and the skin around them follows less (3.1.2
    "Muscle Deformation": the centre shifted "gradually"; a taper starting at the inner edge left the outline
    with half the travel, and mouthFunnel, viseme_oh/ou/CH/RR short of their protrusion on most heads)."""
    d = displacement(rig, {"orbicularis_oris_protrusion": 1.0})
    for outline, inner in ((0, 13), (17, 14)):
        assert d[outline, 1] < 0.7 * d[inner, 1] < 0.0, (outline, d[outline, 1], d[inner, 1])
    chin = rig.template.skin.vertices[:, 2] * MM < rig.template.skin.vertices[17, 2] * MM - 15.0
    assert np.abs(d[chin, 1]).max() < 0.5 * abs(d[17, 1])           # the chin stays


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
    # the live display's flat arrays are the fibres, point for point, with each fibre's contraction
    points, contraction = rig.muscle_display()
    assert np.array_equal(points, np.concatenate([line for _, line, _ in fibres]))
    assert np.array_equal(contraction, np.concatenate([np.full(len(line), value, np.float32)
                                                       for _, line, value in fibres]))


def _reference_deform(m, contraction, protrusion, jaw):
    """The muscle deformation muscle by muscle, written as the thesis lists the steps (3.1.2 "Muscle
    Deformation": contraction, jaw, connections, stretch, bulge): the reference the whole-array version
    of ``MuscleSystem.deform`` must agree with."""
    def carry(points):
        return points @ jaw[:3, :3].T + jaw[:3, 3]
    contraction, protrusion = np.clip(contraction, 0.0, 1.0), float(np.clip(protrusion, -1.0, 1.0))
    share = m.jaw_carry[:, None]                   # each point goes this share of the way with the jaw
    carried = m.rest + share * (carry(m.rest) - m.rest)
    on_jaw = m.jaw_carry > 0.5
    normal = m.normal.copy()
    normal[on_jaw] = m.normal[on_jaw] @ jaw[:3, :3].T
    points, own = carried.copy(), np.ones(len(m.rest))
    for index, spec in enumerate(m.specs):
        sl, (rows, cols), c = m.slice(index), m.shapes[index], contraction[index]
        if spec.kind == "linear" and c > 0:
            s, rest = m.arclength[index], m.rest[sl].reshape(rows, cols, 3)
            target = s * (1.0 - c * spec.max_shortening)
            seg = np.clip((s[None, :, :] <= target[:, None, :]).sum(axis=1) - 1, 0, rows - 2)
            col = np.arange(cols)[None, :]
            t = np.clip((target - s[seg, col]) / np.maximum(s[seg + 1, col] - s[seg, col], 1e-12), 0, 1)[..., None]
            flat = (rest[seg, col] * (1 - t) + rest[seg + 1, col] * t).reshape(-1, 3)
            flat += share[sl] * (carry(flat) - flat)
            points[sl], own[sl] = flat, 1.0 - c * spec.max_shortening
    for sources, targets, fade, axes in m.pushes:      # bunched tissue pushes what lies beyond it
        points[targets] += fade[:, None] * ((points[sources] - carried[sources]).mean(axis=0) * axes)
    for index, spec in enumerate(m.specs):
        sl, (rows, cols), c = m.slice(index), m.shapes[index], contraction[index]
        if spec.kind != "linear" and m.centres[index] is not None:
            oris = spec.group == "oris"
            centre = 0.5 * (m.centres[index] + carry(m.centres[index][None])[0]) if oris else m.centres[index]
            axes = m.mouth_axes if oris else np.eye(3)
            local = (points[sl].reshape(rows, cols, 3) - centre) @ axes.T
            squeeze, rounding = m.fibre_squeeze[index], c * max(protrusion, 0.0) if oris else 0.0
            sx = 1.0 - c * squeeze[0][None, :] - rounding * squeeze[2][None, :]
            sz = (1.0 - c * squeeze[1][None, :]) * np.clip(1.0 - rounding * squeeze[3], 0.0, 1.0)
            local[..., 0] *= sx
            local[..., 2] *= sz
            if oris and protrusion != 0.0:
                travel = spec.protrusion[0] if protrusion > 0 else spec.protrusion[1]
                outer = 0.0 if protrusion > 0 else 0.5         # pulled back, the outer fibre goes half as far
                red = spec.red_lip_columns * spec.refine[1]      # out to the vermilion border: as the innermost
                profile = np.concatenate([np.ones(red), np.linspace(1.0, outer, cols - red)])
                local[..., 1] -= protrusion * travel * profile[None, :]
            points[sl] = (local @ axes + centre).reshape(-1, 3)
            own[sl] = np.broadcast_to(0.5 * (sx + sz), (rows, cols)).ravel()
    before, moved = points.copy(), points.copy()
    weight = 1.0 + 8.0 * contraction[m.muscle_of_point]
    for _, pts in m.groups:
        w = weight[pts][:, None]
        moved[pts] = (w * before[pts]).sum(0) / w.sum() + m.rest[pts] - (w * m.rest[pts]).sum(0) / w.sum()
    points = before.copy()
    for index, prop in enumerate(m.propagation):
        if prop is not None:
            points[m.slice(index)] += prop[1] @ (moved - before)[m.slice(index)][prop[0]]
    thickness = m.thickness_rest.copy()
    for index, spec in enumerate(m.specs):
        sl, (rows, cols) = m.slice(index), m.shapes[index]
        length = np.linalg.norm(np.diff(points[sl].reshape(rows, cols, 3), axis=0), axis=-1).sum(0)
        expected = m.fibre_length[index] * own[sl].reshape(rows, cols).mean(0)
        stretch = np.clip(np.maximum(length, 1e-9) / np.maximum(expected, 1e-9), 0.25, 4.0)
        profile = np.sin(np.pi * m.position_along[index]) if spec.kind == "linear" else 1.0
        grow = 1.0 + spec.bulge * contraction[index] * profile
        thickness[sl] = (m.thickness_rest[sl].reshape(rows, cols) * grow / np.sqrt(stretch)).ravel()
    return points + normal * (thickness - m.thickness_rest)[:, None], thickness


def test_whole_array_deformation_matches_the_muscle_by_muscle_reference(rig):
    """``MuscleSystem.deform`` treats all linear muscles, connections and bulges at once (no Python loop
    over muscles); it computes what the step-by-step reference computes, to rounding."""
    m = rig.template.muscles
    rng = np.random.default_rng(11)
    for trial in range(40):
        contraction = rng.uniform(0.0, 1.0, len(m.names)) * (rng.uniform(size=len(m.names)) < 0.6)
        protrusion = rng.uniform(-1.0, 1.0) if trial % 3 else 0.0
        rig.reset_controls()
        rig.set_controls({"jaw_open": rng.uniform(0, 1), "jaw_yaw": rng.uniform(-1, 1)})
        jaw = rig.jaw_transform()
        state = m.deform(contraction, protrusion, jaw)
        surface, thickness = _reference_deform(m, contraction, protrusion, jaw)
        assert np.abs(state.points - surface).max() < 1e-12
        assert np.abs(state.thickness - thickness).max() < 1e-12
        if trial == 1:
            assert np.abs(state.points - m.rest).max() > 1e-3          # the muscles did move
