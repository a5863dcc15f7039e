# SPDX-License-Identifier: GPL-3.0-or-later
"""Engine rigs stored on Blender objects, for every rig kind.

A rig is one collection holding the **rig object** (it carries the controls and the engine state) and,
parented to it, its parts (a face: skull, jaw, eyes, teeth, tongue, muscle display), each marked with its
role. The engine rig is stored in the rig object as the bytes of its ``save`` (an ``.npz`` without pickles,
:func:`...faces_hands_addon.core.rig.save_rig`) with its kind and identity, and rebuilt on demand once per
session: a live tick compares the stored identity string with the cached rig's (no hashing per tick).
"""
from __future__ import annotations

import json

import numpy as np

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.core.rig import load_rig_bytes, rig_identity, save_rig
from ...names import OUTPUT_TO_LOCAL, PART_ROLE, RIG_CONTROLS, RIG_DATA, RIG_ID, RIG_KIND, RIG_MARKER

__all__ = ["RIG_MARKER", "RIG_DATA", "RIG_KIND", "RIG_ID", "RIG_CONTROLS", "OUTPUT_TO_LOCAL", "PART_ROLE",
           "store_rig", "get_rig", "adopt_rig", "is_rig", "rig_of", "parts", "find_rig", "output_to_local", "to_local",
           "to_world", "rig_controls"]


_cache: dict[int, tuple[str, object]] = {}


def store_rig(obj, rig) -> None:
    """Store ``rig`` on ``obj`` (data, kind, identity, control list) and cache it for this session."""
    data = save_rig(rig)
    if RIG_DATA in obj.keys():
        del obj[RIG_DATA]          # re-assigning a bytes property in place can truncate it at a NUL
    obj[RIG_DATA] = data
    obj[RIG_MARKER] = 1
    obj[RIG_KIND] = rig.kind
    obj[RIG_ID] = rig.identity
    obj[RIG_CONTROLS] = json.dumps([[name, spec.group, spec.kind] for name, spec in rig.control_specs().items()])
    _cache[obj.session_uid] = (rig.identity, rig)


def get_rig(obj, kind: str | None = None):
    """The engine rig of a rig object (of ``kind``, if given), rebuilt from its stored bytes once per
    session and whenever the stored data changed (undo, another file)."""
    if obj is None or not obj.get(RIG_MARKER) or RIG_DATA not in obj.keys():
        raise UserError("select a Faces & Hands rig (build one with 'Build Default Face Rig')")
    stored_kind = obj.get(RIG_KIND, "face")
    if kind is not None and stored_kind != kind:
        raise UserError(f"'{obj.name}' is a {stored_kind} rig; select a {kind} rig")
    identity = obj.get(RIG_ID) or "unnamed"          # rigs stored before identities existed
    cached = _cache.get(obj.session_uid)
    if cached is not None and cached[0] == identity:
        return cached[1]
    data = bytes(obj[RIG_DATA])
    rig = load_rig_bytes(data, identity if identity != "unnamed" else rig_identity(data))
    _cache[obj.session_uid] = (identity, rig)
    return rig


def adopt_rig(obj, rig) -> None:
    """Use the engine ``rig``, already loaded, for ``obj``, which stores the same rig (same identity): a
    batch worker that reopens one rig file for every row then loads the engine rig once, not per row."""
    if obj.get(RIG_ID) != rig.identity:
        raise UserError(f"'{obj.name}' stores another rig than the one loaded")
    _cache[obj.session_uid] = (rig.identity, rig)


def is_rig(obj, kind: str | None = None) -> bool:
    """Is ``obj`` a rig object (of ``kind``)? (A face rig is its skin mesh; other kinds may be armatures.)"""
    return (obj is not None and bool(obj.get(RIG_MARKER))
            and (kind is None or obj.get(RIG_KIND, "face") == kind))


def rig_of(obj):
    """The rig object for ``obj`` itself or one of its parts (None if neither)."""
    while obj is not None and not is_rig(obj):
        obj = obj.parent
    return obj


def parts(obj) -> dict:
    """Role -> part object of a rig object."""
    return {child[PART_ROLE]: child for child in obj.children if PART_ROLE in child.keys()}


def find_rig(objects, name: str | None = None, kind: str | None = None):
    """The first rig object among ``objects`` (named ``name``, of ``kind``), or a UserError."""
    rigs = [o for o in objects if is_rig(o, kind) and (not name or o.name == name)]
    if not rigs:
        raise UserError(f"no Faces & Hands {kind or ''} rig in this file".replace("  ", " ")
                        + (f" named {name!r}" if name else ""))
    return rigs[0]


def rig_controls(obj) -> list[tuple[str, str, str]]:
    """(name, group, kind) of every control of a rig object, from its stored list (no engine needed)."""
    try:
        return [tuple(entry) for entry in json.loads(obj.get(RIG_CONTROLS, "[]"))]
    except (TypeError, ValueError):
        return []


def output_to_local(obj) -> np.ndarray:
    """4x4 from the rig's output coordinates to ``obj``'s local coordinates: identity unless the rig was
    fitted to a mesh in world space (then ``inv(M0)``, the mesh's world matrix when it was fitted)."""
    stored = obj.get(OUTPUT_TO_LOCAL)
    if stored is not None and len(stored) == 16:
        return np.array(stored, dtype=np.float64).reshape(4, 4)
    return np.eye(4)


def to_local(obj, positions) -> np.ndarray:
    """Positions in the rig's output coordinates -> ``obj``'s local space, float32 for ``foreach_set``."""
    matrix = output_to_local(obj)
    positions = np.asarray(positions, dtype=np.float64)
    if np.abs(matrix - np.eye(4)).max() < 1e-12:
        return np.ascontiguousarray(positions, dtype=np.float32)
    return np.ascontiguousarray(positions @ matrix[:3, :3].T + matrix[:3, 3], dtype=np.float32)


def to_world(obj, points) -> np.ndarray:
    """Points in the rig's output coordinates -> world coordinates now (the object may have moved)."""
    matrix = np.asarray(obj.matrix_world, dtype=np.float64) @ output_to_local(obj)
    return np.asarray(points, dtype=np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
