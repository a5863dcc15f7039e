"""The standalone hand on MPFB2's hand mesh (character/hand_mesh.py): the cut, the fitted skeleton and weights,
and the skin goals of the hand issue per preset pose: every skin edge within 0.6-1.6 of its rest length, no
skin triangle through another, the thenar bulge at full opponens contraction >= 2 mm. The limits are the
goals, never the latest measurement; the poses that miss a goal today are marked ``xfail(strict=True)`` with
the figure measured when they were marked (a pose that starts meeting its goal then fails, so the mark goes).
A left hand is the right one mirrored (every output times diag(-1, 1, 1)): its edge ratios and crossings
are the same numbers, so the right hand stands for both (MPFB2's left hand is its right one mirrored)."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.character import mpfb2
from faces_hands_addon.core import refine
from faces_hands_addon.character import hand_mesh as mpfb2_hand
from faces_hands_addon.hand import motion, skin_quality
from faces_hands_addon.hand.rig import build_hand_rig
from faces_hands_addon.hand.template import hand_template

STRETCH = (0.6, 1.6)         # the goal for every skin edge, posed over rest length
THENAR_FLOOR = 0.002         # m: the goal for the thenar bulge at full opponens contraction

# measured (right hand, MPFB2 mesh) when marked: stretch min-max, self-intersections
STRETCH_MISSED = {"computer_graphics_scientist": "0.49-1.43", "fist": "0.36-2.04", "pinch": "0.48-1.55",
                  "point": "0.30-1.70", "thumbs_up": "0.31-1.70"}
CROSSING_MISSED = {"fist": 228, "pinch": 155, "point": 135, "thumbs_up": 190}


@pytest.fixture(scope="module")
def rig():
    return build_hand_rig(mesh="mpfb2")


@pytest.fixture(scope="module")
def settled(rig):
    cache = {}

    def get(name):
        if name not in cache:
            pose = rig.settled_stages(motion.pose_stages(name, rig.muscle_names))
            cache[name] = pose.positions["skin"].astype(np.float64)
        return cache[name]
    return get


def test_the_mpfb2_hand_is_mpfb2s_hand_cut_at_a_wrist_ring(rig):
    template = hand_template(mesh="mpfb2")
    assert rig.mesh == "mpfb2" and rig.template is template
    skin = template.skin
    assert 1000 <= len(skin.vertices) <= 3000                  # 6.2.4: "approximately 1500 nodes"
    loops = refine.boundary_loops(skin.faces)
    assert len(loops) == 1 and skin.boundary.sum() == len(loops[0])   # one open ring, at the wrist
    wrist = template.skeleton.position[template.skeleton.index["wrist"]]
    assert np.all(skin.vertices[skin.boundary][:, 2] > wrist[2] + 0.02)   # the ring lies up the forearm
    assert skin.corner_uvs.shape == (len(skin.faces), 3, 2)
    assert 0.0 <= skin.corner_uvs.min() and skin.corner_uvs.max() <= 1.0
    # the UVs are MPFB2's own: the same corner UVs as the base mesh's faces the hand was cut from
    ids, _, corner_uvs = mpfb2_hand.cut_hand(*mpfb2_hand.hand_landmarks(template.skeleton)[1][[0, 1]])
    assert len(ids) == len(skin.vertices) and np.array_equal(corner_uvs, skin.corner_uvs)


def test_the_left_hand_is_mpfb2s_left_hand():
    """``side="left"`` mirrors the right hand in X: that is MPFB2's own left hand, vertex for vertex."""
    reference = hand_template(mesh="tube").skeleton
    right, left = (mpfb2_hand.hand_landmarks(reference, side)[1] for side in ("R", "L"))
    assert np.allclose(left * [-1.0, 1.0, 1.0], right)
    ids_r = mpfb2_hand.cut_hand(right[0], right[1], "R")[0]
    ids_l = mpfb2_hand.cut_hand(left[0], left[1], "L")[0]
    partner, _ = mpfb2.mirror_table()
    vertices = mpfb2.base_mesh().vertices
    assert sorted(partner[ids_r]) == sorted(ids_l)
    assert np.allclose(vertices[partner[ids_r]] * [-1.0, 1.0, 1.0], vertices[ids_r])


def test_the_skeleton_sits_on_mpfb2s_joint_centres(rig):
    """The RBF warp of 6.2.3 puts every reference joint centre and tip on MPFB2's (placed in the hand's
    frame), so the distances between joints are MPFB2's and the limits of Table 6.4 are kept."""
    template = hand_template(mesh="mpfb2")
    reference = hand_template(mesh="tube")
    ours = mpfb2_hand.hand_landmarks(template.skeleton)[0]
    _, theirs = mpfb2_hand.hand_landmarks(reference.skeleton)
    pairwise = lambda p: np.linalg.norm(p[:, None] - p[None], axis=2)       # noqa: E731
    assert np.allclose(pairwise(ours), pairwise(theirs), atol=1e-6)
    assert np.array_equal(template.skeleton.lower, reference.skeleton.lower)
    assert np.array_equal(template.skeleton.upper, reference.skeleton.upper)
    assert [m.name for m in template.muscles] == [m.name for m in reference.muscles]


def test_the_skin_weights_are_mpfb2s_renormalised_and_widened(rig):
    template = hand_template(mesh="mpfb2")
    sk, skin = template.skeleton, template.skin
    ids, faces, _ = mpfb2_hand.cut_hand(*mpfb2_hand.hand_landmarks(sk)[1][[0, 1]])
    raw = mpfb2_hand.mpfb2_weights(ids, sk)
    assert np.allclose(raw.sum(axis=1), 1.0)
    vertex, value = mpfb2.read_weights(mpfb2_hand.SOURCE_SKELETON)["finger3-3.R"]
    full = dict(zip(vertex.tolist(), value.tolist()))
    own = [k for k, v in enumerate(ids) if full.get(int(v), 0.0) > 0.99]
    distal = sk.index["middle-finger-phalanx-distal"]
    assert own and np.all(raw[own, distal] > 0.99)            # MPFB2's weights, on our bone
    assert np.allclose(skin.weights.sum(axis=1), 1.0) and not np.allclose(skin.weights, raw)
    assert (skin.weights > 0).sum(axis=1).max() <= 4                  # as every export plays it
    _, steps = mpfb2_hand.widened(raw, skin.vertices, faces, sk)
    assert 4 <= steps <= 40                 # a blend zone of a few rings of vertices, not one, not the hand
    forearm = sk.index["forearm"]
    assert np.all(skin.weights[skin.boundary, forearm] == 1.0)         # the ring moves with the forearm only
    tip = np.argmin(np.linalg.norm(skin.vertices - template.features["middle_tip"], axis=1))
    assert skin.weights[tip, distal] > 0.9                              # the pad still follows its bone
    owners = set(np.argmax(skin.weights, axis=1).tolist())
    assert {sk.index[n] for n in sk.names if n != "forearm"} <= owners     # every moving bone carries skin


def _poses(missed: dict, goal: str):
    return [pytest.param(name, marks=pytest.mark.xfail(strict=True, reason=f"measured {missed[name]} ({goal})"))
            if name in missed else name for name in motion.pose_names()]


@pytest.mark.parametrize("name", _poses(STRETCH_MISSED, f"goal {STRETCH[0]}-{STRETCH[1]}"))
def test_every_skin_edge_keeps_within_the_goal(rig, settled, name):
    ratios = skin_quality.edge_ratios(rig.rest_positions.astype(np.float64), settled(name), rig.faces)
    assert STRETCH[0] <= ratios.min() and ratios.max() <= STRETCH[1], (float(ratios.min()), float(ratios.max()))


@pytest.mark.parametrize("name", _poses(CROSSING_MISSED, "crossing triangle pairs, goal 0"))
def test_no_skin_triangle_passes_through_another(rig, settled, name):
    assert skin_quality.self_intersections(settled(name), rig.faces) == 0


def test_the_thenar_bulges_at_full_opponens_contraction(rig):
    assert skin_quality.thenar_bulge(rig) >= THENAR_FLOOR
