# SPDX-License-Identifier: GPL-3.0-or-later
"""Engine animation tracks -> F-curves in a layered (slotted) Action (Blender 4.4+ API).

Blender 5.0 removed the legacy ``Action.fcurves``; everything here goes through
``action.layers[..].strips[..].channelbag(slot)``, which exists in 4.5 LTS and 5.x alike.
Writing a take replaces only the F-curves whose data paths the take owns; keys the artist made on any
other property are never touched.
"""
from __future__ import annotations

import bpy
import numpy as np


def _channelbag(id_block, action_name: str):
    """The channelbag of ``id_block``'s action slot, creating action, slot, layer and strip as needed."""
    anim = id_block.animation_data or id_block.animation_data_create()
    action = anim.action
    if action is None:
        action = bpy.data.actions.new(action_name)
        anim.action = action
    slot = anim.action_slot
    if slot is None:
        slot = action.slots.new(id_type=id_block.id_type, name=id_block.name)
        anim.action_slot = slot
    layer = action.layers[0] if len(action.layers) else action.layers.new("Layer")
    strip = layer.strips[0] if len(layer.strips) else layer.strips.new(type="KEYFRAME")
    return strip.channelbag(slot, ensure=True)


def existing_channelbag(id_block):
    anim = id_block.animation_data
    if anim is None or anim.action is None or anim.action_slot is None:
        return None
    for layer in anim.action.layers:
        for strip in layer.strips:
            bag = strip.channelbag(anim.action_slot)
            if bag is not None:
                return bag
    return None


def remove_fcurves(id_block, data_path_prefixes: tuple[str, ...]) -> int:
    """Remove the F-curves whose data path starts with one of the prefixes; returns how many."""
    bag = existing_channelbag(id_block)
    if bag is None:
        return 0
    doomed = [fc for fc in bag.fcurves if fc.data_path.startswith(data_path_prefixes)]
    for fcurve in doomed:
        bag.fcurves.remove(fcurve)
    return len(doomed)


def write_curves(id_block, curves: dict, action_name: str,
                 group: str = "Faces & Hands", interpolation: str = "LINEAR") -> list:
    """Write ``data_path -> (frames, values)`` as F-curves (replacing curves with the same path); a key
    ``(data_path, index)`` names one element of an array property (``("delta_location", 2)``).

    Keys are set with ``foreach_set`` (no Python loop over keys)."""
    bag = _channelbag(id_block, action_name)
    existing = {(fc.data_path, fc.array_index): fc for fc in bag.fcurves}
    group_obj = bag.groups.get(group) if hasattr(bag, "groups") else None
    if group_obj is None and hasattr(bag, "groups"):
        group_obj = bag.groups.new(group)
    written = []
    interpolation_id = bpy.types.Keyframe.bl_rna.properties["interpolation"].enum_items[interpolation].value
    for key, (frames, values) in curves.items():
        data_path, index = key if isinstance(key, tuple) else (key, 0)
        if (data_path, index) in existing:
            bag.fcurves.remove(existing[data_path, index])
        fcurve = bag.fcurves.new(data_path, index=index)
        if group_obj is not None:
            fcurve.group = group_obj
        frames = np.asarray(frames, dtype=np.float32)
        values = np.asarray(values, dtype=np.float32)
        count = len(frames)
        fcurve.keyframe_points.add(count)
        fcurve.keyframe_points.foreach_set("co", np.column_stack([frames, values]).ravel())
        fcurve.keyframe_points.foreach_set("interpolation", np.full(count, interpolation_id, dtype=np.int32))
        fcurve.update()
        written.append(fcurve)
    return written
