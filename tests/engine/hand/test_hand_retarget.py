"""The hand's finger animation retargeted onto other hands through the bone map (presets/character/bones.json):
every mapped hand bone resolves on the MPFB2 game-engine and default skeletons, Mixamo's and a VRM-named one,
and a fist retargeted onto each bends every finger bone as far (within 2 degrees), about the same axis in
the hand's frame and towards the palm."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.character import body, skeleton as character_skeleton
from faces_hands_addon.character.hands import (FRAME_JOINTS, MIN_HAND_BONES, _frame, fit_hand, hand_bone_pairs,
                                               hand_skeleton_of, vrm_skeleton)
from faces_hands_addon.hand import motion
from faces_hands_addon.hand.rig import build_hand_rig

TARGETS = ("game_engine", "default", "mixamo", "vrm")
HAND_ROWS = 16                          # wrist, thumb 3, four fingers x 3 (VRM's humanoid hand)


@pytest.fixture(scope="module")
def skeletons():
    mesh = body.character_mesh()
    built = {name: character_skeleton.build_skeleton(name, mesh) for name in ("game_engine", "default", "mixamo")}
    built["vrm"] = vrm_skeleton(built["game_engine"])
    return built


@pytest.fixture(scope="module")
def fist():
    rig = build_hand_rig("right")
    pose = rig.settled_stages(motion.pose_stages("fist", rig.muscle_names))
    return rig, pose.transforms


def _angle(rotation: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(rotation) - 1) / 2, -1, 1))))


def _axis(rotation: np.ndarray) -> np.ndarray:
    axis = np.array([rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0], rotation[1, 0] - rotation[0, 1]])
    return axis / np.linalg.norm(axis)


@pytest.mark.parametrize("name", TARGETS)
def test_every_mapped_hand_bone_resolves(skeletons, name):
    skeleton = skeletons[name]
    for side in ("L", "R"):
        pairs = hand_bone_pairs(skeleton, side)
        assert len(pairs) == HAND_ROWS and set(pairs.values()) <= set(skeleton.names), (name, side)
        assert hand_skeleton_of(skeleton.names, side) == name


def test_an_armature_without_hand_bones_is_refused(skeletons):
    names = skeletons["mixamo"].names
    hand = [n for n in names if "RightHand" in n]
    with pytest.raises(UserError, match=f"needs all {MIN_HAND_BONES}"):
        hand_skeleton_of([n for n in names if n not in hand[:1]], "R")


@pytest.mark.parametrize("name", TARGETS)
def test_a_retargeted_fist_bends_the_targets_finger_bones_the_same_way(skeletons, fist, name):
    rig, transforms = fist
    skeleton = skeletons[name]
    fit = fit_hand(skeleton, rig, "R")
    posed = skeleton.posed(fit.basis(transforms))
    joints = rig.joints()
    own = _frame(*(joints[j][0] for j in FRAME_JOINTS))
    theirs = _frame(*(skeleton.heads[skeleton.index(fit.pairs[j])] for j in FRAME_JOINTS))
    wrist_s = np.asarray(transforms["wrist"])[:3, :3]
    wrist_t = skeleton.rest[skeleton.index(fit.pairs["wrist"])]
    wrist_t = posed[skeleton.index(fit.pairs["wrist"])][:3, :3] @ wrist_t[:3, :3].T
    curled = 0
    for source, target in fit.pairs.items():
        if source == "wrist":
            continue
        k = skeleton.index(target)
        bend_s = wrist_s.T @ np.asarray(transforms[source])[:3, :3]           # the bone's turn in the hand
        bend_t = wrist_t.T @ posed[k][:3, :3] @ skeleton.rest[k][:3, :3].T
        assert _angle(bend_t) == pytest.approx(_angle(bend_s), abs=2.0), (name, target)
        if _angle(bend_s) > 20:
            curled += 1
            assert np.dot(own.T @ _axis(bend_s), theirs.T @ _axis(bend_t)) > np.cos(np.radians(5)), (name, target)
            if source.startswith("thumb"):
                continue                           # the thumb turns across the palm, not into it
            tip_t = posed[k][:3, :3] @ np.linalg.inv(skeleton.rest[k][:3, :3]) @ (
                skeleton.tails[k] - skeleton.heads[k])
            moved = tip_t - (skeleton.tails[k] - skeleton.heads[k])
            assert np.dot(moved, theirs[:, 2]) * np.dot(
                np.asarray(transforms[source])[:3, :3] @ (joints[source][1] - joints[source][0])
                - (joints[source][1] - joints[source][0]), own[:, 2]) > 0, (name, target)   # towards the palm
    assert curled >= 10, name                      # the fist curls the fingers' phalanges
