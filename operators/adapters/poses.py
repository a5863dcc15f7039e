# SPDX-License-Identifier: GPL-3.0-or-later
"""A rig's :class:`...faces_hands_addon.core.rig.Pose` written into Blender: the deforming parts' positions
into a dedicated shape key (``FH Simulation``; the base mesh is never touched) and the rigid parts' 4x4
transforms onto the part objects."""
from __future__ import annotations

import numpy as np
from mathutils import Matrix

from .rig_store import parts, to_local

__all__ = ["SIM_KEY", "SKIN", "simulation_key", "push_pose", "set_simulation_key_value"]

SIM_KEY = "FH Simulation"
SKIN = "skin"           # the pose role of the rig object's own mesh


def simulation_key(obj):
    """The dedicated shape key the live simulation writes (created with a Basis if needed)."""
    if obj.data.shape_keys is None:
        obj.shape_key_add(name="Basis", from_mix=False)
    key = obj.data.shape_keys.key_blocks.get(SIM_KEY)
    if key is None:
        key = obj.shape_key_add(name=SIM_KEY, from_mix=False)
    key.value = 1.0
    return key


def set_simulation_key_value(obj, value: float) -> None:
    """Show (1) or hide (0) the simulation key of ``obj`` and its parts, where there is one."""
    for target in (obj, *parts(obj).values()):
        key = getattr(target.data, "shape_keys", None)
        block = key.key_blocks.get(SIM_KEY) if key is not None else None
        if block is not None:
            block.value = float(value)


def push_pose(obj, pose) -> None:
    """Write ``pose`` onto the rig object ``obj``: positions of role :data:`SKIN` (and of deforming parts)
    into their simulation keys, transforms onto the parts with those roles."""
    by_role = parts(obj)
    for role, positions in pose.positions.items():
        target = obj if role == SKIN else by_role.get(role)
        if target is None:
            continue
        key = simulation_key(target)
        key.points.foreach_set("co", to_local(obj, positions).ravel())
        target.data.update()
    for role, part in by_role.items():
        if role in pose.transforms:
            part.matrix_basis = Matrix(np.asarray(pose.transforms[role], dtype=float).tolist())
