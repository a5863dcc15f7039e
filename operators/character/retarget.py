# SPDX-License-Identifier: GPL-3.0-or-later
"""*Retarget Character Animation*: the character's armature animation (the head on the neck, the hands'
fingers) keyed onto another armature through the bone map (``presets/character/bones.json``:
MPFB2 game-engine/default, the generated Rigify rig, Mixamo, VRM). Both skeletons are told by their bone
names; per frame each mapped target bone takes its source bone's armature-space turn
(``character.retarget.retarget_basis``), keyed as a quaternion. The target's other bones and keys stay."""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix

from ...faces_hands_addon.character.retarget import bone_map, bone_pairs
from ...faces_hands_addon.core.errors import UserError

__all__ = ["skeleton_of", "retarget_animation"]


def skeleton_of(armature, table=None) -> str:
    """The bone map's skeleton whose names the armature has most of (at least the neck and head)."""
    table = table or bone_map()
    names = {b.name for b in armature.data.bones}
    best = max(table.skeletons, key=lambda s: sum(1 for n in table.column(s) if n in names))
    pairs = {row["vrm"]: row[best] for row in table.rows if row.get(best)}
    if not {pairs.get("neck"), pairs.get("head")} <= names:
        raise UserError(f"'{armature.name}' names its bones like none of the bone map's skeletons "
                        f"({', '.join(table.skeletons)}); add a column for it to presets/character/bones.json")
    return best


def _frames(armature, bones) -> dict:
    return {b: np.array(armature.pose.bones[b].matrix)[:3, :3] for b in bones}


def retarget_animation(context, source, target, frames) -> int:
    """Key ``target``'s mapped bones at ``frames`` from ``source``'s pose there; returns the bones keyed."""
    if source == target:
        raise UserError("select another armature to retarget onto (the character's own is the source)")
    table = bone_map()
    pairs = {s: t for s, t in bone_pairs(skeleton_of(source, table), skeleton_of(target, table), table).items()
             if s in source.pose.bones and t in target.pose.bones}
    if not pairs:
        raise UserError(f"no bone of '{source.name}' maps to a bone of '{target.name}'")
    source_rest = {b: np.array(source.data.bones[b].matrix_local)[:3, :3] for b in pairs}
    target_rest = {b: np.array(target.data.bones[b].matrix_local)[:3, :3] for b in pairs.values()}
    parents = {b.name: (b.parent.name if b.parent else None) for b in target.data.bones}
    scene = context.scene
    kept = scene.frame_current
    from ...faces_hands_addon.character.retarget import retarget_basis
    try:
        for frame in frames:
            scene.frame_set(int(frame))
            basis = retarget_basis(source_rest, _frames(source, pairs), target_rest, parents, pairs)
            for bone, rotation in basis.items():
                pose_bone = target.pose.bones[bone]
                pose_bone.rotation_mode = "QUATERNION"
                pose_bone.rotation_quaternion = Matrix(rotation.tolist()).to_quaternion()
                pose_bone.keyframe_insert("rotation_quaternion", frame=int(frame), group=bone)
    finally:
        scene.frame_set(kept)
    return len(pairs)
