# SPDX-License-Identifier: GPL-3.0-or-later
"""Skinned rigs in Blender, for every rig kind: an armature object from a rig's bones
(:class:`...faces_hands_addon.core.skinning.Bone`), the skin's vertex groups from its weights, and the
Armature modifier that joins them. Exports (``export``) then write the armature as the file's root with the
skin as its child, bones, weights and keys included."""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Vector

__all__ = ["build_armature", "set_vertex_groups", "deform_with"]


def build_armature(context, name: str, bones, collection, parent=None):
    """A new armature object ``name`` in ``collection`` (parented to ``parent``) with ``bones`` at rest, in
    their order (a bone's parent may come after it)."""
    data = bpy.data.armatures.new(name)
    arm = bpy.data.objects.new(name, data)
    collection.objects.link(arm)
    arm.parent = parent
    view_layer = context.view_layer
    previous = view_layer.objects.active
    view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    try:
        for bone in bones:
            edit = data.edit_bones.new(bone.name)
            edit.head, edit.tail = Vector(bone.head), Vector(bone.tail)
            edit.align_roll(Vector(bone.z_axis))
            edit.use_deform = bone.deform
        for bone in bones:
            if bone.parent is not None:
                data.edit_bones[bone.name].parent = data.edit_bones[bone.parent]
    finally:
        bpy.ops.object.mode_set(mode="OBJECT")
        view_layer.objects.active = previous
    return arm


def set_vertex_groups(obj, names, weights: np.ndarray, threshold: float = 1e-4) -> None:
    """One vertex group per name of ``names`` on the mesh object ``obj`` with that column of ``weights``
    (vertices x names; weights at or below ``threshold`` left out, values rounded to 1e-4 so vertices with
    equal weights are added together)."""
    weights = np.asarray(weights, dtype=np.float64)
    for column, name in enumerate(names):
        values = weights[:, column]
        index = np.flatnonzero(values > threshold)
        if not len(index):
            continue
        group = obj.vertex_groups.new(name=name)
        rounded = np.round(values[index], 4)
        for value in np.unique(rounded):
            group.add(index[rounded == value].tolist(), float(value), "REPLACE")


def deform_with(obj, armature, name: str = "Armature"):
    """An Armature modifier on ``obj`` driven by ``armature`` (its vertex groups name the bones)."""
    modifier = obj.modifiers.new(name, "ARMATURE")
    modifier.object = armature
    return modifier
