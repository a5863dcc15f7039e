# SPDX-License-Identifier: GPL-3.0-or-later
"""Bone-name maps between skeletons (``presets/character/bones.json``): one humanoid bone per row, named by
the VRM 1.0 humanoid, and what the character's skeletons (MPFB2 game-engine, default, the generated Rigify
rig's deforming bones), Mixamo, VRM and the WebXR hand joints call it. A map from skeleton A to B pairs the
names of every row both have (:func:`bone_pairs`).

Animation moves across by armature-space rotation (:func:`retarget_basis`): each mapped source bone's turn
relative to its rest, seen in armature space, is given to the target bone about its own rest frame, so
skeletons whose bones point or roll differently (Rigify's, Mixamo's) pose alike.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..core.errors import UserError
from ..core.presets import ANY, PresetFormat, read_preset, register_format
from . import mpfb2

__all__ = ["BONE_MAP", "BoneMap", "bone_map", "bone_pairs", "skeleton_bones", "unresolved", "retarget_basis"]

BONE_MAP = register_format(PresetFormat("faces_hands.bone_map", 1, required=("skeletons", "bones"), shape={
    "description": str, "skeletons": [str], "bone_lists": {str: [str]}, "bones": [{str: ANY}]}))
PRESET = "character/bones.json"
MPFB2_SKELETONS = ("game_engine", "default", "mixamo")
SIDES = ("left", "right", "")


@dataclass(frozen=True)
class BoneMap:
    skeletons: tuple[str, ...]
    rows: tuple[dict, ...]              # skeleton -> bone name (None where the skeleton lacks the bone)
    bone_lists: dict                    # skeleton -> every bone it has, for skeletons not read from MPFB2

    def column(self, skeleton: str) -> list[str]:
        if skeleton not in self.skeletons:
            raise UserError(f"the bone map has no skeleton {skeleton!r}; it has {', '.join(self.skeletons)}")
        return [row[skeleton] for row in self.rows if row.get(skeleton)]


def bone_map(document: dict | None = None) -> BoneMap:
    """The bone map preset (the artist's copy wins), checked: every row names its skeletons with strings
    or null, no name twice in a column."""
    data = document if document is not None else read_preset(PRESET, BONE_MAP.name)[0]
    skeletons = tuple(data["skeletons"])
    rows = []
    for number, row in enumerate(data["bones"], 1):
        unknown = [k for k in row if k not in skeletons]
        bad = [k for k, v in row.items() if v is not None and not isinstance(v, str)]
        if unknown or bad:
            raise UserError(f"{PRESET}: row {number} names {'unknown skeletons ' + str(unknown) if unknown else ''}"
                            f"{' non-text bones for ' + str(bad) if bad else ''}; fix the row")
        rows.append({k: row.get(k) for k in skeletons})
    for skeleton in skeletons:
        for side in SIDES:                 # a hand's joints may carry the same name on both sides (WebXR)
            names = [r[skeleton] for r in rows if r[skeleton] and _side(r) == side]
            twice = sorted({n for n in names if names.count(n) > 1})
            if twice:
                raise UserError(f"{PRESET}: the {skeleton} column names {twice[0]!r} twice")
    return BoneMap(skeletons, tuple(rows), {k: list(v) for k, v in data.get("bone_lists", {}).items()})


def _side(row: dict) -> str:
    """"left", "right" or "" (the midline) from the row's VRM name."""
    name = row.get("vrm") or ""
    return next((side for side in SIDES if side and name.startswith(side)), "")


def bone_pairs(source: str, target: str, table: BoneMap | None = None, side: str | None = None) -> dict[str, str]:
    """Source bone -> target bone for every row that names both (only the rows of ``side``, "left" or
    "right", when given: the hand joints' names repeat on both sides)."""
    table = table or bone_map()
    table.column(source), table.column(target)
    return {row[source]: row[target] for row in table.rows
            if row[source] and row[target] and (side is None or _side(row) == side)}


@lru_cache(maxsize=None)
def _mpfb2_bones(name: str) -> frozenset:
    skeleton = mpfb2.read_skeleton(name)
    if name == "rigify":
        return frozenset({f"DEF-{n}" for n in skeleton.names} | set(skeleton.meta.get("extra_bones", [])))
    return frozenset(skeleton.names)


def skeleton_bones(skeleton: str, table: BoneMap | None = None) -> frozenset:
    """Every bone ``skeleton`` has: MPFB2's from its rig file (Rigify: the generated rig's deforming bones),
    others from the preset's ``bone_lists``."""
    table = table or bone_map()
    if skeleton in MPFB2_SKELETONS or skeleton == "rigify":
        return _mpfb2_bones(skeleton)
    if skeleton not in table.bone_lists:
        raise UserError(f"{PRESET}: no bone list for the skeleton {skeleton!r}; add one under bone_lists")
    return frozenset(table.bone_lists[skeleton])


def unresolved(skeleton: str, table: BoneMap | None = None) -> list[str]:
    """Names the map gives ``skeleton`` that the skeleton does not have (an empty list: all resolve)."""
    table = table or bone_map()
    have = skeleton_bones(skeleton, table)
    return [name for name in table.column(skeleton) if name not in have]


def retarget_basis(source_rest: dict, source_posed: dict, target_rest: dict, target_parent: dict,
                   pairs: dict[str, str]) -> dict[str, np.ndarray]:
    """Pose-bone rotations (3x3 ``matrix_basis``) for the target bones of ``pairs``.

    ``source_rest``/``source_posed``: source bone -> armature-space 3x3 frame at rest / posed;
    ``target_rest``: target bone -> armature-space rest frame; ``target_parent``: target bone -> its parent
    (None for a root). Each target bone takes its source bone's armature-space turn ``posed @ rest.T``; its
    basis is that turn relative to what its nearest mapped ancestor already turned (module docstring)."""
    turns = {pairs[s]: np.asarray(source_posed[s]) @ np.asarray(source_rest[s]).T for s in pairs if s in source_posed}
    out = {}
    for bone, turn in turns.items():
        parent_turn, parent = np.eye(3), target_parent.get(bone)
        while parent is not None:
            if parent in turns:
                parent_turn = turns[parent]
                break
            parent = target_parent.get(parent)
        frame = np.asarray(target_rest[bone])
        out[bone] = frame.T @ parent_turn.T @ turn @ frame
    return out
