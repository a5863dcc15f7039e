# SPDX-License-Identifier: GPL-3.0-or-later
"""Baking a simulated hand for game engines (no Blender here): bone rotations per frame for an Action on a
standard armature, and the skin's deformation beyond skinning as a *fixed* set of corrective shapes whose
weights follow the joint angles and the muscles' bulge (never one shape per frame).

* :func:`unskinned` maps simulated (posed) skin positions back through the inverse of each node's blended
  bone transform, so a shape key in rest space reproduces them under the armature's linear blend skinning.
* :func:`corrective_shapes`: one shape per flexion DOF (the skin settled with only that joint bent to
  :data:`BEND_FRACTION` of its Table 6.4 range, minus what skinning alone gives) and one per geometric muscle
  (bulge at full contraction, joints straight). Names: ``FH.flex.<bone>``, ``FH.bulge.<muscle>``.
* :func:`corrective_weights`: flexion keys weigh ``clamp(angle / key angle)``, bulge keys the contraction of
  the muscle's pseudo-muscle twin.
* :func:`bone_basis` turns the engine's rest -> pose bone transforms into each bone's local (parent- and
  rest-relative) matrix, what Blender's pose bones and glTF joints animate.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

__all__ = ["BEND_FRACTION", "Corrective", "unskinned", "corrective_shapes", "corrective_weights", "bone_basis",
           "simulate_frames", "FrameState"]

BEND_FRACTION = 0.8


@dataclass
class Corrective:
    name: str
    positions: np.ndarray      # (N, 3) rest-space skin with this correction (output coordinates)
    kind: str                  # "flex" or "bulge"
    index: int                 # DOF index (flex) or pseudo-muscle index (bulge)
    full: float                # the angle (radians) or contraction at which the weight is 1


@dataclass
class FrameState:
    angles: np.ndarray         # (D,) joint angles, radians
    transforms: np.ndarray     # (B, 4, 4) rest -> pose, output coordinates
    contraction: np.ndarray    # (M,)


def unskinned(rig, positions: np.ndarray, transforms: np.ndarray) -> np.ndarray:
    """Rest-space positions whose linear blend skinning by ``transforms`` (B, 4, 4) gives ``positions``."""
    weights = rig.skin_weights()
    flat = transforms[:, :3, :].reshape(len(transforms), 12)
    blended = (weights @ flat).reshape(-1, 3, 4)
    local = positions - blended[:, :, 3]
    return np.linalg.solve(blended[:, :, :3], local[:, :, None])[:, :, 0]


def _flexion_dofs(rig) -> list[int]:
    sk = rig.skeleton
    return [k for k, d in enumerate(sk.dofs) if d.kind == "flexion" and rig.pseudo.dynamic[k] and d.upper > 0.2]


def corrective_shapes(rig, settle_time: float = 0.8) -> Iterator[Corrective]:
    """The fixed set of corrective shapes (module docstring); the rig's state is reset afterwards."""
    sk = rig.skeleton
    saved = dict(rig.controls)
    try:
        rig.reset()
        rest = rig.rest_positions.astype(np.float64)
        for k in _flexion_dofs(rig):
            angles = np.zeros(sk.dof_count)
            angles[k] = BEND_FRACTION * sk.dofs[k].upper
            pose = rig.pose_joints(angles, settle_time)
            transforms = rig.transforms(rig.joint_angles)
            delta = unskinned(rig, pose.positions["skin"].astype(np.float64), transforms) - rest
            yield Corrective(f"FH.flex.{sk.names[sk.dofs[k].bone]}", (rest + delta).astype(np.float32), "flex", k,
                             float(angles[k]))
        for m, name in enumerate(rig.geometric.names):
            rig.reset()
            twin = int(rig.geometric.pseudo[m])
            rig.controls[rig.muscle_names[twin]] = 1.0
            pose = rig.pose_joints(np.zeros(sk.dof_count), settle_time)
            yield Corrective(f"FH.bulge.{name}", pose.positions["skin"], "bulge", twin, 1.0)
    finally:
        rig.reset()
        rig.set_controls(saved, strict=False)


def corrective_weights(correctives: list[Corrective], angles: np.ndarray, contraction: np.ndarray) -> np.ndarray:
    """(K,) weight of every corrective shape for joint ``angles`` and ``contraction`` values."""
    out = np.empty(len(correctives))
    for i, c in enumerate(correctives):
        value = angles[c.index] if c.kind == "flex" else contraction[c.index]
        out[i] = np.clip(value / c.full, 0.0, 1.0)
    return out


def bone_basis(rest_bones: np.ndarray, parent: np.ndarray, transforms: np.ndarray) -> np.ndarray:
    """(B, 4, 4) local matrices ``A_b^-1 (M_parent^-1 M_b) A_b`` of bones with rest matrices ``rest_bones`` (armature
    space) for the rest -> pose ``transforms`` ``M`` (the same space)."""
    relative = transforms.copy()
    has_parent = parent >= 0
    relative[has_parent] = np.linalg.inv(transforms[parent[has_parent]]) @ transforms[has_parent]
    return np.linalg.inv(rest_bones) @ relative @ rest_bones


def simulate_frames(rig, contractions: np.ndarray, dt: float, settle_first: bool = True) -> Iterator[FrameState]:
    """Simulate the rig through rows of ``contractions`` (F, M), one frame of ``dt`` each, from rest (settled at
    the first row when ``settle_first``); yields every frame's state."""
    rig.reset()
    names = rig.muscle_names
    if settle_first and len(contractions):
        rig.set_controls(dict(zip(names, contractions[0])))
        rig.relax(1.0, dt)
    for row in contractions:
        rig.set_controls(dict(zip(names, row)))
        rig.step_frame(dt)
        yield FrameState(rig.joint_angles, rig.transforms(), rig.contraction_vector())
