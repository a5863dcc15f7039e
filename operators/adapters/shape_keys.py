# SPDX-License-Identifier: GPL-3.0-or-later
"""Baked shapes (engine ``anim.baking``) written into shape keys, drivers and F-curves, for any rig.

Rig object and parts get the same key names: a rigid part that moves in a shape (a face's lower teeth and
tongue with the jaw, its eyes with the gaze) gets a shape key with its vertices in that pose, so game
engines that import only morph targets see it move too. Part objects keep an identity transform.
"""
from __future__ import annotations

import numpy as np
from mathutils import Matrix

from ...faces_hands_addon.anim.baking import BASIS_PREFIX
from ...faces_hands_addon.anim.layers import control_driver
from . import controls, fcurves
from .poses import SIM_KEY, SKIN
from .rig_store import parts, to_local

__all__ = ["HELPER_ROLES", "ensure_basis", "write_key", "rest_vertices", "part_positions", "commit_shapes",
           "commit_weights", "commit_animation", "remove_keys", "frame_range"]

MOVED_EPS = 1e-6
HELPER_ROLES = ("muscles", "landmarks")      # display helpers: never get shape keys
FRAME_PREFIX = f"{BASIS_PREFIX}frame_"


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


def rest_vertices(obj) -> np.ndarray:
    """The rest (reference key, else mesh) vertices of ``obj`` (N, 3) float32."""
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
    rest = rest_vertices(part) if rest is None else rest
    return (rest @ transform[:3, :3].T + transform[:3, 3]).astype(np.float32)


def _drive(block, obj, shape, specs) -> None:
    """The key's value = the mixed control (``anim.layers``) over the value it was baked at."""
    spec = specs[shape.control]
    expression = control_driver(shape.control, spec, spec.full_value,
                                controls.available_layers(obj, [shape.control]))
    controls.add_mixed_driver(block, "value", obj, expression)


def _shape_parts(obj) -> dict:
    return {role: part for role, part in parts(obj).items() if role not in HELPER_ROLES}


def commit_shapes(obj, shapes, specs=None) -> list[str]:
    """Write ``shapes`` (``BakedShape``) onto the rig object and its parts; with ``specs`` given, each key of
    a shape with a ``control`` is driven by that control (a muscle basis). Returns the key names written."""
    for part in parts(obj).values():
        part.matrix_basis = Matrix.Identity(4)
    part_objects = _shape_parts(obj)
    rests = {role: rest_vertices(part) for role, part in part_objects.items()}
    names = []
    sim = obj.data.shape_keys.key_blocks.get(SIM_KEY) if obj.data.shape_keys else None
    if sim is not None:
        sim.value = 0.0
    for shape in shapes:
        drive = specs is not None and shape.control is not None
        block = write_key(obj, shape.name, to_local(obj, shape.pose.positions[SKIN]), shape.value_range)
        block.value = 0.0
        if drive:
            _drive(block, obj, shape, specs)
        for role, part in part_objects.items():
            moved = part_positions(part, shape.pose.transforms.get(role, np.eye(4)), rests[role])
            if moved is None:
                continue
            part_block = write_key(part, shape.name, moved, shape.value_range)
            part_block.value = 0.0
            if drive:
                _drive(part_block, obj, shape, specs)
        names.append(shape.name)
    return names


def _mute_others(key, keep) -> None:
    """Mute the live simulation key and driven basis keys (they would add to the animation) unless kept."""
    for block in key.key_blocks:
        if (block.name == SIM_KEY or block.name.startswith(BASIS_PREFIX)) and not keep(block.name):
            block.mute = True


def commit_weights(obj, names: list[str], frames, weights: np.ndarray) -> None:
    """Animate the target keys ``names`` by ``weights`` (F, T) at ``frames`` on the rig object and every part
    that has the key, in one action per mesh; what would add to them is muted."""
    frames = np.asarray(frames, dtype=np.float64)
    for target in [obj, *_shape_parts(obj).values()]:
        key = target.data.shape_keys
        if key is None:
            continue
        wanted = set(names)
        _mute_others(key, lambda name: name in wanted)
        for name in wanted & set(key.key_blocks.keys()):
            key.key_blocks[name].driver_remove("value")        # a basis key driven by its control: now animated
            key.key_blocks[name].mute = False
        curves = {f'key_blocks["{name}"].value': (frames, weights[:, column])
                  for column, name in enumerate(names) if name in key.key_blocks}
        fcurves.remove_fcurves(key, tuple(f'key_blocks["{name}"]' for name in wanted) + (f'key_blocks["{FRAME_PREFIX}',))
        if curves:
            fcurves.write_curves(key, curves, action_name=f"{target.name} Weights", group="Weights")


def commit_animation(obj, shapes) -> list[str]:
    """Per-frame keys animated 0 -> 1 -> 0, so each frame shows exactly its simulated pose. The live
    simulation key and driven basis keys are muted so nothing is added twice."""
    names = commit_shapes(obj, shapes)
    frames = [int(name.rsplit("_", 1)[1]) for name in names]
    for target in [obj, *_shape_parts(obj).values()]:
        key = target.data.shape_keys
        if key is None:
            continue
        _mute_others(key, lambda name: name.startswith(FRAME_PREFIX))
        curves = {}
        for name, frame in zip(names, frames):
            if name not in key.key_blocks:
                continue
            keys_frames = [f for f in (frame - 1, frame, frame + 1) if frames[0] <= f <= frames[-1]]
            values = [1.0 if f == frame else 0.0 for f in keys_frames]
            curves[f'key_blocks["{name}"].value'] = (np.array(keys_frames, float), np.array(values))
        if curves:
            fcurves.remove_fcurves(key, (f'key_blocks["{FRAME_PREFIX}',))
            fcurves.write_curves(key, curves, action_name=f"{target.name} Baked", group="Baked frames")
    return names


def remove_keys(obj, prefix: str) -> int:
    """Remove shape keys whose name starts with ``prefix`` from the rig object and its parts."""
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
