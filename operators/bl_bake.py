# SPDX-License-Identifier: GPL-3.0-or-later
"""Writing baked shapes (engine ``face.baking``) into shape keys, drivers and F-curves.

Skin and rigid parts get the same key names: a part that moves in a shape (lower teeth and tongue with
the jaw, eyes with the gaze) gets a shape key with its vertices at that pose, so game engines that
import only morph targets see teeth, tongue and eyes move too. Part objects keep an identity transform.
"""
from __future__ import annotations

import numpy as np
from mathutils import Matrix

from . import bl_anim, bl_controls
from .bl_face import PART_ROLE, SIM_KEY, parts, skin_to_local

MOVED_EPS = 1e-6


def ensure_basis(obj):
    if obj.data.shape_keys is None:
        obj.shape_key_add(name="Basis", from_mix=False)
    return obj.data.shape_keys


def write_key(obj, name: str, positions: np.ndarray, value_range=(0.0, 1.0)):
    """Create or overwrite shape key ``name`` with absolute ``positions`` (N, 3)."""
    key = ensure_basis(obj)
    block = key.key_blocks.get(name) or obj.shape_key_add(name=name, from_mix=False)
    block.slider_min, block.slider_max = float(min(value_range[0], 0.0)), float(max(value_range[1], 1.0))
    block.points.foreach_set("co", np.ascontiguousarray(positions, dtype=np.float32).ravel())
    return block


def _rest_vertices(obj) -> np.ndarray:
    key = obj.data.shape_keys
    out = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
    if key is not None and key.reference_key is not None:
        key.reference_key.points.foreach_get("co", out)
    else:
        obj.data.vertices.foreach_get("co", out)
    return out.reshape(-1, 3)


def part_positions(part, transform: np.ndarray, rest: np.ndarray | None = None):
    """Vertices of a rigid part moved by ``transform`` (None when it does not move)."""
    transform = np.asarray(transform, dtype=np.float64)
    if np.abs(transform - np.eye(4)).max() < MOVED_EPS:
        return None
    rest = _rest_vertices(part) if rest is None else rest
    return (rest @ transform[:3, :3].T + transform[:3, 3]).astype(np.float32)


def _sum_driver(block, obj, control: str) -> None:
    """``block.value`` = sum of the control's layers (the key's slider range clamps it)."""
    block.driver_remove("value")
    driver = block.driver_add("value").driver
    driver.type = "SUM"
    for layer in bl_controls.LAYERS:
        prop = bl_controls.prop_name(control, layer)
        if prop not in obj.keys():
            continue
        var = driver.variables.new()
        var.name = layer
        var.type = "SINGLE_PROP"
        var.targets[0].id_type = "OBJECT"
        var.targets[0].id = obj
        var.targets[0].data_path = f'["{prop}"]'


def reset_part_transforms(obj) -> None:
    for part in parts(obj).values():
        part.matrix_basis = Matrix.Identity(4)


def commit_shapes(obj, shapes, drive: bool, rig=None) -> list[str]:
    """Write ``shapes`` (BakedShape) onto the skin and the parts; with ``drive`` (basis mode) each key is
    driven by its control. Returns the key names written."""
    reset_part_transforms(obj)
    part_objects = {role: part for role, part in parts(obj).items() if role != "muscles"}
    rests = {role: _rest_vertices(part) for role, part in part_objects.items()}
    names = []
    sim = obj.data.shape_keys.key_blocks.get(SIM_KEY) if obj.data.shape_keys else None
    if sim is not None:
        sim.value = 0.0
    for shape in shapes:
        positions = skin_to_local(obj, rig, shape.positions) if rig is not None else shape.positions
        block = write_key(obj, shape.name, positions, shape.value_range)
        block.value = 0.0
        if drive and shape.control:
            _sum_driver(block, obj, shape.control)
        for role, part in part_objects.items():
            moved = part_positions(part, shape.transforms.get(role, np.eye(4)), rests[role])
            if moved is None:
                continue
            part_block = write_key(part, shape.name, moved, shape.value_range)
            part_block.value = 0.0
            if drive and shape.control:
                _sum_driver(part_block, obj, shape.control)
        names.append(shape.name)
    return names


def commit_animation(obj, shapes, scene, rig=None) -> list[str]:
    """Per-frame keys animated 0 -> 1 -> 0, so each frame shows exactly its simulated pose. The live
    simulation key and driven basis keys are muted so nothing is added twice."""
    names = commit_shapes(obj, shapes, drive=False, rig=rig)
    frames = [int(name.rsplit("_", 1)[1]) for name in names]
    for target in [obj, *[p for p in parts(obj).values() if p.get(PART_ROLE) != "muscles"]]:
        key = target.data.shape_keys
        if key is None:
            continue
        for block in key.key_blocks:
            if block.name.startswith("FH.") and not block.name.startswith("FH.frame_") or block.name == SIM_KEY:
                block.mute = True
        curves = {}
        for name, frame in zip(names, frames):
            if name not in key.key_blocks:
                continue
            keys_frames = [f for f in (frame - 1, frame, frame + 1) if frames[0] <= f <= frames[-1]]
            values = [1.0 if f == frame else 0.0 for f in keys_frames]
            curves[f'key_blocks["{name}"].value'] = (np.array(keys_frames, float), np.array(values))
        if curves:
            bl_anim.remove_fcurves(key, ('key_blocks["FH.frame_',))
            bl_anim.write_curves(key, curves, action_name=f"{target.name} Baked", group="Baked frames")
    return names


def remove_keys(obj, prefix: str) -> int:
    """Remove shape keys whose name starts with ``prefix`` from the skin and its parts."""
    removed = 0
    for target in [obj, *parts(obj).values()]:
        key = getattr(target.data, "shape_keys", None)
        if key is None:
            continue
        for block in [b for b in key.key_blocks if b.name.startswith(prefix)]:
            block.driver_remove("value")
            target.shape_key_remove(block)
            removed += 1
    return removed


def frame_range(scene) -> list[int]:
    return list(range(scene.frame_start, scene.frame_end + 1))

