# SPDX-License-Identifier: GPL-3.0-or-later
"""The hand's long work as jobs (``bases.jobs``): build a hand (reference or from a photo) and bake it
(bone rotations to an Action, corrective shape keys and their weights). Each computes in ``step`` without
touching the scene and writes Blender data only in ``commit``, so cancelling leaves the scene as it was."""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix

from ...faces_hands_addon.anim.layers import mix
from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.hand import bake as hand_bake
from ..adapters import fcurves, shape_keys
from ..bases.jobs import Job
from ..adapters.rig_store import get_rig
from ..adapters.takes import take_for_bake
from ..adapters.timing import frame_duration, scene_fps
from .objects import EULER_ORDER, armature_of, create_hand_objects, rest_bone_matrices

__all__ = ["BuildHandJob", "BakeHandJob", "MAX_FRAMES", "ACTION_NAME", "write_indexed_curves"]

MAX_FRAMES = 5000
ACTION_NAME = "FH Hand Motion"


class BuildHandJob(Job):
    """The reference hand, or the hand of a photo (``photo``: a checked photo-points dict), as objects."""

    label = "Building hand rig"

    def __init__(self, name: str, side: str = "right", photo: dict | None = None, mesh: str | None = None):
        self.name, self.side, self.photo, self.mesh, self.rig = name, side, photo, mesh, None

    def step(self) -> float:
        from ...faces_hands_addon.hand.rig import build_hand_rig
        from ...faces_hands_addon import character  # noqa: F401  (registers the MPFB2 hand mesh)
        from ...faces_hands_addon.hand.template import DEFAULT_MESH
        self.rig = build_hand_rig(self.side, self.photo, mesh=self.mesh or DEFAULT_MESH)
        return 1.0

    def commit(self, context) -> str:
        obj = create_hand_objects(context, self.rig, self.name)
        for other in context.view_layer.objects.selected:
            other.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        source = "from the photo" if self.photo else "reference hand"
        return (f"Built {self.side} hand rig '{obj.name}' ({source}): {self.rig.template.node_count} skin nodes, "
                f"{self.rig.hand.network.springs.count} springs, {len(self.rig.control_specs())} muscles")


class BakeHandJob(Job):
    """Simulate the animated contractions over the frame range; commit bone keys on the armature and the fixed
    set of corrective shape keys with their weights keyed per frame (:mod:`...faces_hands_addon.hand.bake`)."""

    def __init__(self, context, obj):
        self.obj_name = obj.name
        self.rig = get_rig(obj, "hand")
        if armature_of(obj) is None:
            raise UserError(f"'{obj.name}' has lost its armature; rebuild the hand rig")
        specs = self.rig.control_specs()
        frames = shape_keys.frame_range(context.scene)
        if len(frames) > MAX_FRAMES:
            raise UserError(f"{len(frames)} frames is too long for one bake; bake at most {MAX_FRAMES} frames")
        take, start = take_for_bake(obj, context.scene, specs)
        table = take.table(specs, frames, scene_fps(context.scene), start)
        self.frames = list(frames)
        self.contractions = np.array([[mix(table.at(i), specs)[m] for m in self.rig.muscle_names]
                                      for i in range(len(frames))])
        self.dt = frame_duration(context.scene)
        self.label = f"Baking {len(frames)} hand frames"
        self.correctives: list = []
        self._shapes = hand_bake.corrective_shapes(self.rig)
        self._frames = None
        self.states: list = []
        self.total = len(frames) + 27

    def step(self) -> float:
        if self._shapes is not None:
            shape = next(self._shapes, None)
            if shape is not None:
                self.correctives.append(shape)
                return min(len(self.correctives) / self.total, 0.999)
            self._shapes = None
            self._frames = hand_bake.simulate_frames(self.rig, self.contractions, self.dt)
        state = next(self._frames, None)
        if state is None:
            return 1.0
        self.states.append(state)
        return min((len(self.correctives) + len(self.states)) / self.total, 0.999)

    def commit(self, context) -> str:
        obj = bpy.data.objects[self.obj_name]
        arm = armature_of(obj)
        names = self.rig.skeleton.names
        rest = rest_bone_matrices(arm, names)
        frames = np.array(self.frames, dtype=np.float64)
        curves = {}
        eulers = np.zeros((len(self.states), len(names), 3))
        for f, state in enumerate(self.states):
            basis = hand_bake.bone_basis(rest, self.rig.skeleton.parent, state.transforms)
            for b in range(len(names)):
                eulers[f, b] = Matrix(basis[b].tolist()).to_euler(EULER_ORDER)[:]
        for b, name in enumerate(names):
            arm.pose.bones[name].rotation_mode = EULER_ORDER
            for axis in range(3):
                curves[(f'pose.bones["{name}"].rotation_euler', axis)] = (frames, eulers[:, b, axis])
        write_indexed_curves(arm, curves, ACTION_NAME)
        shape_keys.ensure_basis(obj)
        for c in self.correctives:
            shape_keys.write_key(obj, c.name, c.positions)
        weights = np.array([hand_bake.corrective_weights(self.correctives, s.angles, s.contraction)
                            for s in self.states])
        key = obj.data.shape_keys
        shared = arm.animation_data.action                # one Action, two slots: one clip for engines
        key_anim = key.animation_data or key.animation_data_create()
        if key_anim.action is not shared:
            key_anim.action = shared
        fcurves.write_curves(key, {f'key_blocks["{c.name}"].value': (frames, weights[:, i])
                                   for i, c in enumerate(self.correctives)}, ACTION_NAME)
        sim = key.key_blocks.get("FH Simulation")
        if sim is not None:
            sim.value = 0.0
        return (f"Baked {len(self.states)} frames: {len(names)} bones keyed on '{arm.name}', "
                f"{len(self.correctives)} corrective shape keys on '{obj.name}'")


def write_indexed_curves(id_block, curves: dict, action_name: str) -> None:
    """(data_path, index) -> (frames, values) F-curves in the object's layered action (replacing old ones)."""
    fcurves.write_curves(id_block, {}, action_name)          # makes the action, slot and channelbag
    bag = fcurves.existing_channelbag(id_block)
    for (path, index), (frames, values) in curves.items():
        for old in [fc for fc in bag.fcurves if fc.data_path == path and fc.array_index == index]:
            bag.fcurves.remove(old)
        curve = bag.fcurves.new(path, index=index)
        count = len(frames)
        curve.keyframe_points.add(count)
        curve.keyframe_points.foreach_set("co", np.column_stack([frames, values]).astype(np.float32).ravel())
        curve.update()
