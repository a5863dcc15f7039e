# SPDX-License-Identifier: GPL-3.0-or-later
"""Armatures of an export's temporary copies as files hold them (``export``).

* **Constraints become keys.** glTF and FBX carry bone keys, not Blender's constraints: an armature whose
  pose bones carry constraints (the hand's Table 6.4 Limit Rotation) would be sampled by the glTF exporter
  with one warning per bone, and written by FBX from the unconstrained keys. So every constrained bone of a
  copy gets one LINEAR key per exported frame of location, rotation quaternion and scale: its local
  transform *after* its constraints (``Object.convert_space`` from pose to local space), read while the
  scene plays those frames; then the copy's constraints go. The copy's action is its own (the original's
  keys are untouched).
* **A skinned original steps out of the exporter's way.** The glTF exporter walks every root object of the
  scene before it keeps the selected ones, and warns about any root skinned by an armature that is not its
  parent, as the hand's skin is in the scene (the rig object, its armature a child of it; the copies turn
  this round, ``export._chain``). While the file is written, the original's Armature modifiers lose their
  object; they get it back afterwards.
"""
from __future__ import annotations

import contextlib

import numpy as np
from mathutils import Matrix

from . import fcurves

__all__ = ["constrained_bones", "bake_constraints", "unskinned_originals"]

_BONE_PATHS = ("location", "rotation_euler", "rotation_quaternion", "rotation_axis_angle", "scale")


def constrained_bones(armature) -> list[str]:
    """Names of the pose bones of ``armature`` that carry constraints."""
    if armature.type != "ARMATURE" or armature.pose is None:
        return []
    return [bone.name for bone in armature.pose.bones if len(bone.constraints)]


def _local_matrices(context, armature, names, frames) -> dict[str, list]:
    """Bone name -> local matrix after constraints at each of ``frames`` (scene frames)."""
    scene = context.scene
    current = scene.frame_current
    out = {name: [] for name in names}
    try:
        for frame in frames:
            scene.frame_set(int(frame))
            for name in names:
                bone = armature.pose.bones[name]
                out[name].append(armature.convert_space(pose_bone=bone, matrix=bone.matrix, from_space="POSE",
                                                        to_space="LOCAL"))
    finally:
        scene.frame_set(current)
    return out


def bake_constraints(context, armature, frames) -> int:
    """Key every constrained bone of ``armature`` (an export copy with its own action) at ``frames`` with its
    constrained local transform and remove its constraints (module docstring); returns the number of bones."""
    names = constrained_bones(armature)
    if not names:
        return 0
    matrices = _local_matrices(context, armature, names, frames)
    bag = fcurves.existing_channelbag(armature)
    prefixes = tuple(f'pose.bones["{name}"].{path}' for name in names for path in _BONE_PATHS)
    for curve in [c for c in (bag.fcurves if bag is not None else ()) if c.data_path.startswith(prefixes)]:
        bag.fcurves.remove(curve)
    frames = np.asarray(frames, dtype=np.float64)
    curves = {}
    for name in names:
        parts = [m.decompose() for m in matrices[name]]
        quaternions = np.array([q[:] for _, q, _ in parts])
        for i in range(1, len(quaternions)):             # one hemisphere: no flip between neighbouring keys
            if np.dot(quaternions[i], quaternions[i - 1]) < 0:
                quaternions[i] = -quaternions[i]
        for path, values in (("location", np.array([t[:] for t, _, _ in parts])),
                             ("rotation_quaternion", quaternions), ("scale", np.array([s[:] for _, _, s in parts]))):
            for index in range(values.shape[1]):
                curves[f'pose.bones["{name}"].{path}', index] = (frames, values[:, index])
        bone = armature.pose.bones[name]
        bone.rotation_mode = "QUATERNION"
        bone.matrix_basis = matrices[name][0] if matrices[name] else Matrix.Identity(4)
        for constraint in list(bone.constraints):
            bone.constraints.remove(constraint)
    fcurves.write_curves(armature, curves, f"{armature.name} Export Pose", group="Pose")
    return len(names)


@contextlib.contextmanager
def unskinned_originals(originals):
    """While the block runs, the Armature modifiers of ``originals`` that name an armature which is not
    their parent have no object (module docstring)."""
    detached = []
    for obj in originals:
        if obj.type == "MESH":
            for modifier in obj.modifiers:
                if modifier.type == "ARMATURE" and modifier.object is not None and modifier.object is not obj.parent:
                    detached.append((modifier, modifier.object))
    try:
        for modifier, _ in detached:
            modifier.object = None
        yield
    finally:
        for modifier, armature in detached:
            modifier.object = armature
