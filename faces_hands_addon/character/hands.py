# SPDX-License-Identifier: GPL-3.0-or-later
"""The hand rigs (thesis 6.2) in the character's hands: each hand rig's bones are paired with the armature's
wrist and finger bones through the bone map (``presets/character/bones.json``, its ``webxr`` column), and
the hand rig's frame is turned onto the character's hand (wrist -> middle knuckle along the hand, little ->
index knuckle across it). Per frame, each hand bone's turn (rest -> pose, hand space) is seen in the
character's hand and given to its armature bone (:func:`.retarget.retarget_basis`).

The same fit retargets a hand rig's finger animation onto any armature named like one of the map's
skeletons (MPFB2 game-engine or default, Mixamo, VRM, Rigify's deforming bones): :func:`hand_skeleton_of`
tells the skeleton from the bone names, :func:`vrm_skeleton` names an MPFB2 skeleton's bones as a VRM
humanoid does (a VRM file's skeleton is any humanoid's, its bones known by these names).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import UserError
from .retarget import bone_map, bone_pairs, retarget_basis
from .skeleton import CharacterSkeleton

__all__ = ["HandFit", "fit_hand", "fit_hand_heads", "hand_fit", "hand_bone_pairs", "hand_skeleton_of",
           "vrm_skeleton", "MIN_HAND_BONES"]

MIN_HAND_BONES = 16          # the hand rows (wrist, 15 finger bones): a hand's armature names them all

SIDE_WORDS = {"L": "left", "R": "right"}
FRAME_JOINTS = ("wrist", "middle-finger-phalanx-proximal", "index-finger-phalanx-proximal",
                "pinky-finger-phalanx-proximal")


def _frame(wrist: np.ndarray, middle: np.ndarray, index: np.ndarray, little: np.ndarray) -> np.ndarray:
    """Columns: along the hand (wrist -> middle knuckle), across it (little -> index knuckle), palm normal."""
    along = middle - wrist
    along /= np.linalg.norm(along)
    across = index - little
    across -= along * float(np.dot(across, along))
    across /= np.linalg.norm(across)
    return np.column_stack([along, across, np.cross(along, across)])


def _armature_names(skeleton: CharacterSkeleton, names: dict[str, str]) -> dict[str, str]:
    """Bone map names -> the bones a character with this skeleton poses (a Rigify character poses its
    generated rig's controls, which carry the meta-rig's names: the map's DEF- names without the prefix)."""
    if skeleton.name == "rigify":
        return {k: v[4:] if v.startswith("DEF-") else v for k, v in names.items()}
    return names


def hand_bone_pairs(skeleton: CharacterSkeleton, side: str) -> dict[str, str]:
    """Hand rig bone (WebXR joint name) -> the character's bone, for the ``side`` ("L"/"R")."""
    table = bone_map()
    column = "rigify" if skeleton.name == "rigify" else skeleton.name
    pairs = bone_pairs("webxr", column, table, side=SIDE_WORDS[side])
    pairs = _armature_names(skeleton, pairs)
    missing = [bone for bone in pairs.values() if bone not in skeleton.names]
    if missing:
        raise UserError(f"the bone map names {missing[0]!r} for the {SIDE_WORDS[side]} hand, which the "
                        f"{skeleton.name} skeleton lacks; fix presets/character/bones.json")
    return pairs


@dataclass
class HandFit:
    """One hand rig in one of the character's hands (module docstring)."""
    side: str
    pairs: dict               # hand bone -> character bone
    turn: np.ndarray          # 3x3: hand space -> the character's armature space (rotation only)
    rest: dict                # character bone -> armature-space rest frame (3x3)
    parents: dict             # character bone -> parent bone (None for the root)

    def basis(self, transforms: dict) -> dict[str, np.ndarray]:
        """Pose-bone ``matrix_basis`` (4x4) of the paired bones for a hand pose's ``transforms``."""
        posed = {b: self.turn @ np.asarray(m)[:3, :3] @ self.turn.T for b, m in transforms.items() if b in self.pairs}
        rotations = retarget_basis({b: np.eye(3) for b in posed}, posed, self.rest, self.parents, self.pairs)
        out = {}
        for bone, rotation in rotations.items():
            matrix = np.eye(4)
            matrix[:3, :3] = rotation
            out[bone] = matrix
        return out


def hand_fit(skeleton: CharacterSkeleton, side: str, pairs: dict, turn: np.ndarray) -> HandFit:
    """A :class:`HandFit` from its pairs and turn (as saved) on ``skeleton``."""
    parents = {name: (skeleton.names[p] if p >= 0 else None) for name, p in zip(skeleton.names, skeleton.parents)}
    rest = {bone: skeleton.rest[skeleton.index(bone), :3, :3] for bone in pairs.values()}
    return HandFit(side, dict(pairs), np.asarray(turn, np.float64).reshape(3, 3), rest, parents)


def fit_hand(skeleton: CharacterSkeleton, hand, side: str) -> HandFit:
    """Pair ``hand`` (a hand rig of the same side) with the character's hand and turn its frame onto it."""
    return fit_hand_heads(skeleton, {name: joint[0] for name, joint in hand.joints().items()}, side)


def fit_hand_heads(skeleton: CharacterSkeleton, heads: dict, side: str) -> HandFit:
    """:func:`fit_hand` for a hand known by its bones' rest ``heads`` (WebXR joint name -> head, the hand's
    space): a hand rig's armature as Blender holds it."""
    pairs = hand_bone_pairs(skeleton, side)
    try:
        own = _frame(*(np.asarray(heads[name], np.float64) for name in FRAME_JOINTS))
        heads = [skeleton.heads[skeleton.index(pairs[name])] for name in FRAME_JOINTS]
    except KeyError as error:
        raise UserError(f"the hand rig or the bone map lacks the joint {error}; the hand cannot be placed") from None
    return hand_fit(skeleton, side, pairs, _frame(*heads) @ own.T)


def hand_skeleton_of(bone_names, side: str) -> str:
    """The bone map's skeleton (not ``webxr``) whose names for the ``side`` ("L"/"R") hand ``bone_names``
    has most of; refused below :data:`MIN_HAND_BONES`."""
    table = bone_map()
    names = set(bone_names)
    rows = [r for r in table.rows if r.get("webxr") and (r.get("vrm") or "").startswith(SIDE_WORDS[side])]
    counts = {s: sum(1 for r in rows if r.get(s) in names) for s in table.skeletons if s != "webxr"}
    best = max(counts, key=counts.get)
    if counts[best] < MIN_HAND_BONES:
        raise UserError(f"the armature names {counts[best]} of the {len(rows)} {SIDE_WORDS[side]} hand bones "
                        f"of any skeleton in the bone map ({', '.join(counts)}); retarget needs all "
                        f"{MIN_HAND_BONES} (add a column to presets/character/bones.json)")
    return best


def vrm_skeleton(skeleton: CharacterSkeleton) -> CharacterSkeleton:
    """``skeleton`` (an MPFB2 one) with every bone the map names for it renamed to its VRM humanoid name."""
    from dataclasses import replace
    table = bone_map()
    renamed = {r[skeleton.name]: r["vrm"] for r in table.rows if r.get(skeleton.name) and r.get("vrm")}
    return replace(skeleton, name="vrm", names=[renamed.get(n, n) for n in skeleton.names])
