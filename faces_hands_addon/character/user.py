# SPDX-License-Identifier: GPL-3.0-or-later
"""The face rig on an artist's own character: one body mesh skinned to an armature whose neck and head bones
a known skeleton names (:data:`.head.HEAD_CHAINS`: MPFB2's game-engine and default rigs, a generated Rigify
rig, Mixamo, VRM). The face rig is fitted through the face's own fitting (thesis 3.1.2) to the vertices the
head bone carries (its vertex group, weight >= :data:`HEAD_WEIGHT`); the head's shape keys go onto the whole
body mesh, the behaviour's head motion onto the neck and head bones (:mod:`.head`). The artist's mesh,
shape keys, modifiers and armature are kept as they are.

:func:`check_character` turns what is wrong with the input into one clear message before anything is fitted:
a body of several meshes, no armature, a skeleton without known neck and head bones, no vertex group for the
head bone, too little of the mesh on the head bone. Coordinates are the world's at the moment of the fit
(the armature may be rotated or scaled: its bones' world frames are used).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

from ..anim.layers import mix
from ..core.controls import ControlSpec
from ..core.errors import UserError
from ..core.rig import BONE_ROLE, Pose, load_rig_bytes, read_rig_archive, save_rig, write_rig_archive
from . import FITTED_CHARACTER_RIG_FORMAT
from .head import HEAD_CHAINS, bone_eulers, chain_terms, euler_matrix, head_specs

__all__ = ["HEAD_WEIGHT", "MIN_HEAD_VERTICES", "CharacterInput", "check_character", "head_chain_for",
           "FittedCharacterRig", "fit_character"]

HEAD_WEIGHT = 0.5          # a vertex the head bone carries at least this much is part of the fitted head
MIN_HEAD_VERTICES = 300    # fewer than this on the head bone cannot hold a face
CHAIN_ORDER = ("game_engine", "default", "rigify", "mixamo", "vrm")


@dataclass
class CharacterInput:
    """What the Blender side reads off the selection (plain data)."""
    meshes: list[str]                 # every mesh deformed by the armature (the body must be one)
    mesh: str | None                  # the mesh to rig
    armature: str | None              # the armature deforming it (None: none)
    bones: list[str]                  # the armature's bone names
    groups: list[str]                 # the mesh's vertex group names
    head_weights: dict                # head bone name -> (n,) weights of its vertex group (the ones present)
    vertex_count: int


def head_chain_for(bones) -> tuple[str, tuple]:
    """The first known head chain (skeleton name, chain) whose bones the armature all has."""
    have = set(bones)
    for key in CHAIN_ORDER:
        chain = HEAD_CHAINS[key]
        if all(bone in have for bone, _ in chain):
            return key, chain
    known = "; ".join(" + ".join(b for b, _ in HEAD_CHAINS[k]) for k in CHAIN_ORDER)
    raise UserError(f"the armature has no neck and head bones a known skeleton names ({known}); rename its neck "
                    "and head bones like one of these, or add your skeleton's names to presets/character/bones.json")


def check_character(data: CharacterInput) -> tuple[tuple, np.ndarray]:
    """The head chain and the head's vertex ids, or a UserError naming what is missing (module docstring)."""
    if data.mesh is None:
        raise UserError("select the character's body mesh (or its armature)")
    if data.armature is None:
        raise UserError(f"'{data.mesh}' is not deformed by an armature (no Armature modifier with an object); "
                        "a character's body is skinned to its skeleton")
    if len(data.meshes) > 1:
        names = ", ".join(f"'{m}'" for m in data.meshes[:5])
        raise UserError(f"the body is {len(data.meshes)} meshes skinned to '{data.armature}' ({names}): join the "
                        "body's meshes into one (select them, Ctrl+J) so the head's shape keys can live on it")
    _, chain = head_chain_for(data.bones)
    head_bone = chain[-1][0]
    if head_bone not in data.groups:
        raise UserError(f"'{data.mesh}' has no vertex group '{head_bone}' (the head bone's skin weights); weight "
                        "the head to its head bone (e.g. Parent with Automatic Weights) and fit again")
    weights = np.asarray(data.head_weights.get(head_bone, np.zeros(data.vertex_count)), np.float64)
    ids = np.flatnonzero(weights >= HEAD_WEIGHT)
    if len(ids) < MIN_HEAD_VERTICES:
        raise UserError(f"only {len(ids)} vertices of '{data.mesh}' follow the '{head_bone}' bone (at least "
                        f"{MIN_HEAD_VERTICES} needed for a face); check the head's skin weights")
    return chain, ids


class FittedCharacterRig:
    """The face rig on an artist's character (module docstring): ``rest`` the whole mesh (world coordinates
    at the fit), ``head_ids`` the fitted part, ``terms`` the head chain's Euler terms."""

    kind = "character"

    def __init__(self, face, rest: np.ndarray, head_ids: np.ndarray, terms: dict):
        self.face, self.terms = face, terms
        self._rest = np.asarray(rest, np.float64)
        self.head_ids = np.asarray(head_ids, np.int64)
        self.identity = ""
        self.warnings = list(getattr(face, "warnings", []))
        self._face_specs = face.control_specs()
        self._head = head_specs()
        self.specs = {**self._face_specs, **self._head}

    @property
    def rest_positions(self) -> np.ndarray:
        return self._rest.astype(np.float32)

    @property
    def focus_vertices(self) -> np.ndarray:
        return self.head_ids

    def control_specs(self) -> dict[str, ControlSpec]:
        return dict(self.specs)

    def _split(self, layer_values):
        for values in layer_values.values():
            unknown = [name for name in values if name not in self.specs]
            if unknown:
                mix({"ctrl": {unknown[0]: 0.0}}, self.specs)
        face = {layer: {k: v for k, v in values.items() if k in self._face_specs} for layer, values in layer_values.items()}
        head = mix({layer: {k: v for k, v in values.items() if k in self._head}
                    for layer, values in layer_values.items()}, self._head)
        return face, head

    def _pose(self, face_pose: Pose, head: dict) -> Pose:
        skin = self._rest.copy()
        skin[self.head_ids] = face_pose.positions["skin"]
        bones = {BONE_ROLE + bone: euler_matrix(angles) for bone, angles in bone_eulers(head, self.terms).items()}
        return Pose({"skin": skin.astype(np.float32)}, bones)

    def step(self, layer_values, dt: float) -> Pose:
        face, head = self._split(layer_values)
        return self._pose(self.face.step(face, dt), head)

    def settled(self, layer_values, max_time: float = 1.5, dt: float = 1 / 24) -> Pose:
        face, head = self._split(layer_values)
        return self._pose(self.face.settled(face, max_time, dt), head)

    def reset(self) -> None:
        self.face.reset()

    def rest_pose(self) -> Pose:
        return Pose({"skin": self.rest_positions}, {BONE_ROLE + bone: np.eye(4) for bone in self.terms})

    def worker_copy(self) -> "FittedCharacterRig":
        copy = FittedCharacterRig(self.face.worker_copy(), self._rest, self.head_ids, self.terms)
        copy.identity = self.identity
        return copy

    def save(self, path: str | Path) -> None:
        meta = {"format": FITTED_CHARACTER_RIG_FORMAT, "terms": self.terms, "warnings": self.warnings}
        write_rig_archive(path, meta, {"face_rig": np.frombuffer(save_rig(self.face), np.uint8),
                                       "rest_vertices": self._rest, "head_ids": self.head_ids})

    @classmethod
    def load(cls, path: str | Path) -> "FittedCharacterRig":
        meta, arrays = read_rig_archive(path, FITTED_CHARACTER_RIG_FORMAT, "character rig",
                                        ("face_rig", "rest_vertices", "head_ids"))
        try:
            terms = {bone: [[(str(c), float(w)) for c, w in axis] for axis in axes] for bone, axes in meta["terms"].items()}
        except (KeyError, TypeError, ValueError) as error:
            raise UserError(f"{path}: the saved character rig is incomplete ({error})") from None
        rig = cls(load_rig_bytes(arrays["face_rig"].tobytes()), arrays["rest_vertices"], arrays["head_ids"], terms)
        rig.warnings = list(meta.get("warnings", rig.warnings))
        return rig


def fit_character(data: CharacterInput, vertices: np.ndarray, triangles: np.ndarray, frames: Mapping,
                  progress=None) -> FittedCharacterRig:
    """Check ``data`` and fit the face rig to the head part of the mesh (``vertices`` world coordinates,
    ``triangles`` over them; ``frames``: bone -> world-space 3x3 rest frame of the armature's bones)."""
    from ..face.fitted import build_fitted_rig
    chain, ids = check_character(data)
    lookup = np.full(len(vertices), -1, np.int64)
    lookup[ids] = np.arange(len(ids))
    local = lookup[np.asarray(triangles, np.int64)]
    local = local[(local >= 0).all(axis=1)]
    face = build_fitted_rig(np.asarray(vertices, np.float64)[ids], local, seed=0, progress=progress)
    return FittedCharacterRig(face, vertices, ids, chain_terms(chain, frames))
