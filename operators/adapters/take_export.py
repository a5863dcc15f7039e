# SPDX-License-Identifier: GPL-3.0-or-later
"""A baked take written as GLB from the still rig and the take's own clip (``anim.glb_clip``), for rigs whose
export Blender would sample frame by frame: a character (its head turns on the neck bones by drivers).

The still GLB (skin, targets, armature, materials; no animation) comes from Blender's exporter; a jobs worker
keeps it for the next line while its key holds: the rig file's identity (path, size, modification time), the
targets written on the skin (names and the engine's data of each), the parts exported and the scene's unit. It
is also kept in the user's cache folder (``core.file_cache``, checked before use), keyed by the rig file's
SHA-256 instead of its path, those same parts, the installed extension and Blender's version: the next worker
on the same rig file and targets (the default character every worker copies from the cache) reads it instead
of exporting it (Blender's exporter writes the same bytes in every process). The clip comes from the engine's
data: the weights bake's fitted weights and the take's head turn (``character.head.head_turns``). Anything
this cannot write the same (a bone moved by a constraint, a driver on anything but the head chain's rotation,
an object keyed to move) takes Blender's exporter.
"""
from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

import bpy
import numpy as np

from ...faces_hands_addon.anim.glb_clip import Clip, add_clip, euler_quaternions
from . import export_transforms as transforms, paths
from .fcurves import existing_channelbag
from .export import ExportOptions, export_objects, export_rig, exported_keys
from .outputs import atomic_output, check_output_path

__all__ = ["clip_of_bake", "can_write_clip", "write_take_glb"]

_STILL: dict = {}          # key -> still GLB bytes (the last one only)


def can_write_clip(obj, roles, terms, target_names) -> bool:
    """True when the export of ``obj`` (and its parts of ``roles``) moves only by the clip this module
    writes: the weights of ``target_names`` (any other shape key the export writes neither keyed nor driven),
    and drivers on the rotations of the head chain's bones (``terms``); no object moved by keys, drivers,
    constraints or its parents."""
    objects = export_objects(obj, roles)
    armatures = [o for o in objects if o.type == "ARMATURE"]
    if len(armatures) != 1 or not terms:
        return False
    chain_paths = {f'pose.bones["{bone}"].rotation_euler' for bone in terms}
    names = set(target_names)
    for other in objects:
        anim = other.animation_data
        if transforms.moves(other) or transforms.moved_by_others(other) or transforms.ancestors_move(other):
            return False
        if other.type == "MESH":
            if any(_moving_key(other, name) for name in set(exported_keys(other)) - names):
                return False
        elif other.type == "ARMATURE":
            if anim is not None and anim.action is not None:
                return False                  # bones keyed by the artist
            if any(pose_bone.constraints for pose_bone in other.pose.bones):
                return False
            if any(curve.data_path not in chain_paths for curve in (anim.drivers if anim is not None else ())):
                return False
            if any(bone not in other.pose.bones or other.pose.bones[bone].rotation_mode != "XYZ" for bone in terms):
                return False
        else:
            return False
    return True


def _moving_key(mesh, name: str) -> bool:
    """Is the shape key ``name`` of ``mesh`` keyed or driven? (One that is neither holds its value: the
    still file's default weight, which the clip keeps for targets it does not name.)"""
    key = mesh.data.shape_keys
    path = f'key_blocks["{name}"].value'
    anim = key.animation_data if key is not None else None
    if anim is None:
        return False
    if any(d.data_path == path for d in anim.drivers):
        return True
    bag = existing_channelbag(key)
    return bag is not None and any(curve.data_path == path for curve in bag.fcurves)


def clip_of_bake(obj, roles, name: str, fit, table, fps: float, terms=None, specs=None, head=(),
                  start_frame: float = 0.0) -> Clip:
    """The clip of a weights bake: ``fit`` (``anim.weights.WeightFit``) on every exported mesh that has its
    targets, at the frames of ``table`` (from 0 s), and the head chain's turn from ``table`` and the take's
    ``head`` tracks (``terms``/``specs`` of a character rig; the take starting at ``start_frame``)."""
    from ...faces_hands_addon.character.head import head_turns
    frames = np.asarray(table.frames, np.float64)
    times = (frames - frames[0]) / float(fps)
    weights = {}
    for mesh in [o for o in export_objects(obj, roles) if o.type == "MESH"]:
        keys = getattr(mesh.data, "shape_keys", None)
        present = set(keys.key_blocks.keys()) if keys is not None else set()
        columns = {n: fit.weights[:, k] for k, n in enumerate(fit.names) if n in present}
        if columns:
            weights[mesh.name] = columns
    rotations = {}
    if terms:
        turns = head_turns(table, specs, terms, head, fps, start_frame)
        rotations = {bone: euler_quaternions(angles) for bone, angles in turns.items()}
    return Clip(name, times, weights, rotations)


def _still_key(obj, roles, fit_key: str) -> str | None:
    """The key of the still GLB of ``obj`` (module docstring), or None when its file is not saved."""
    path = bpy.data.filepath
    if not path:
        return None
    try:
        stat = os.stat(path)
    except OSError:
        return None
    units = bpy.context.scene.unit_settings
    blob = repr((path, stat.st_size, stat.st_mtime_ns, obj.name, tuple(sorted(roles)), fit_key,
                 units.system, float(units.scale_length)))
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()


def _kept_still(context, obj, roles, fit_key: str) -> bytes:
    """The still GLB from the user's cache folder (module docstring), else exported and kept there."""
    cache = paths.still_cache()
    if cache is None:
        return _still(context, obj, roles)
    units = bpy.context.scene.unit_settings
    key, parts = paths.built_file_key("still glb", {
        "rig_file": _file_sha256(bpy.data.filepath), "object": obj.name, "roles": sorted(roles),
        "targets": fit_key, "units": [units.system, float(units.scale_length)]})
    still, problem = cache.read(key)
    if still is not None:
        return still
    if problem:
        print(f"warning: the cached still GLB ({cache.record_path(key)}) cannot be used: {problem}; "
              f"exporting it again")
    still = _still(context, obj, roles)
    cache.store_bytes(key, still, parts)
    return still


def _file_sha256(path: str) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _still(context, obj, roles) -> bytes:
    folder = tempfile.mkdtemp(prefix="fh-still-")
    path = Path(folder) / "still.glb"
    try:
        export_rig(context, obj, str(path), roles, ExportOptions(animation=False))
        return path.read_bytes()
    finally:
        path.unlink(missing_ok=True)
        os.rmdir(folder)


def write_take_glb(context, obj, out, roles, clip: Clip, targets_key: str) -> Path:
    """Write ``clip`` on the still GLB of ``obj`` to ``out`` (atomic); ``targets_key``: a digest of the
    targets the bake wrote on the skin (part of the still's key)."""
    out = check_output_path(str(out), (".glb",))
    key = _still_key(obj, roles, targets_key)
    still = _STILL.get(key) if key is not None else None
    if still is None:
        still = _kept_still(context, obj, roles, targets_key) if key is not None else _still(context, obj, roles)
        _STILL.clear()
        if key is not None:
            _STILL[key] = still
    with atomic_output(out) as tmp:
        Path(tmp).write_bytes(add_clip(still, clip))
    return out
