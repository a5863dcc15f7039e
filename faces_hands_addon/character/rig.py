# SPDX-License-Identifier: GPL-3.0-or-later
"""``CharacterRig``: one rig of rigs (:class:`..core.rig.Rig`) -- the body's armature, the face rig fitted to
the character's head and the two hand rigs in its hands -- so bakes, the live preview, jobs and export
treat the whole person as one.

* **Face** (thesis 3.1.2, "Creating New Animatable Head Models from the Template"): a
  :class:`..face.fitted.FittedFaceRig` on the character's own head and neck vertices (:mod:`.fitting`). Its
  skin positions go back into the whole body mesh (one mesh, as engines expect); beyond the fitted part the
  body stays at rest, and the fitted part's own border stays at rest too (the face rig does not move skin
  far from the face), so the head/neck seam shows no step. The character's own eyes, teeth and tongue
  move rigidly with the face rig's parts (gaze, jaw, tongue).
* **Head on the neck** (4.2.1, 4.3.5): ``head_pitch/yaw/roll`` spread over the neck and head bones
  (:mod:`.head`).
* **Hands** (6.2): a :class:`..hand.rig.HandRig` per side; its bones' turns, seen in the character's
  hand (:mod:`.hands`), pose the armature's wrist and finger bones. Its controls are the hand rig's
  muscles with the side's suffix (``flexor_digitorum_superficialis_index_L``).

* **Refitted to a morphed head** (3.2 -> 3.1.2: a new head from the morphable model is fitted again, as any
  new head is): the rig's rest is the morphed body while the Blender body keeps its own shape as its basis
  (the morph is a shape key on top of it). With a ``basis``, every output is the basis plus the simulated
  displacement from the morphed rest, so the rig's shapes are deltas that add to the morph key: basis +
  (morphed rest - basis) + (pose - morphed rest) = the pose on the morphed head.

Outputs: ``Pose.positions["skin"]`` = every vertex of the body mesh (float32, the character's coordinates,
rest space: the armature deforms it afterwards; the basis plus the displacement when refitted);
``Pose.transforms["bone:<name>"]`` = the pose bone's ``matrix_basis`` (4x4) for the bones the rig turns.
"""
from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import Mapping

import numpy as np

from ..anim.layers import mix
from ..core.controls import ControlSpec
from ..core.errors import UserError
from ..core.rig import BONE_ROLE, Pose, load_rig_bytes, read_rig_archive, save_rig, write_rig_archive
from . import CHARACTER_RIG_FORMAT
from .head import HEAD_CONTROLS, bone_eulers, bone_terms, euler_matrix, head_specs
from .hands import HandFit, fit_hand, hand_fit
from .model import Character, build_character

__all__ = ["CharacterRig", "BONE_PREFIX", "SIDES"]

BONE_PREFIX = BONE_ROLE
SIDES = {"L": "left", "R": "right"}
IDLE_TURN = 1e-6        # a relaxed hand whose bones turn less than this per frame is at rest: not simulated
LayerValues = Mapping[str, Mapping[str, float]]


class _Deferred:
    """A hand rig made the first time it is used (a worker copy's hands: a face bake never builds them)."""

    def __init__(self, make):
        self.make = make


_LAZY = (bytes, bytearray, _Deferred)


def _subset(layer_values: LayerValues, names, rename=None) -> dict:
    """The layer values of the controls ``names`` (renamed by ``rename``: character name -> own name)."""
    rename = rename or {}
    return {layer: {rename.get(k, k): v for k, v in values.items() if k in names}
            for layer, values in layer_values.items()}


class CharacterRig:
    """The whole person as one rig (module docstring). ``hands`` maps a side ("L"/"R") to its hand rig, or to
    that rig's saved bytes: a hand is rebuilt only when its controls are used (speech never needs one), its
    controls and its fit into the character's hand are known without it (``hand_specs``, ``fits``). ``basis``:
    the body's own vertices when the rig was refitted to a morphed rest (module docstring), else None."""

    kind = "character"

    def __init__(self, character: Character, face, head_ids: np.ndarray, hands: dict | None = None,
                 rest_vertices: np.ndarray | None = None, hand_specs: dict | None = None, fits: dict | None = None,
                 basis: np.ndarray | None = None):
        self.character = character
        self.face = face
        self.head_ids = np.asarray(head_ids, np.int64)
        self._hands = dict(hands or {})
        self._rest = np.asarray(character.mesh.vertices if rest_vertices is None else rest_vertices, np.float64)
        self.basis = None if basis is None else np.asarray(basis, np.float64)
        if self.basis is not None and self.basis.shape != self._rest.shape:
            raise UserError("the character's basis and its morphed rest have different vertex counts")
        self.identity = ""
        self.warnings = list(getattr(face, "warnings", []))
        self.terms = bone_terms(character.skeleton)
        self.hand_specs = dict(hand_specs) if hand_specs else {side: self.hand(side).control_specs()
                                                                for side in self._hands}
        self.fits: dict[str, HandFit] = dict(fits) if fits else {
            side: fit_hand(character.skeleton, self.hand(side), side) for side in self._hands}
        self._face_specs = face.control_specs()
        self._hand_names = {side: {f"{m}_{side}": m for m in specs} for side, specs in self.hand_specs.items()}
        specs = dict(self._face_specs)
        specs.update(head_specs())
        for side, names in self._hand_names.items():
            for name, muscle in names.items():
                spec = self.hand_specs[side][muscle]
                specs[name] = ControlSpec(name, spec.minimum, spec.maximum, spec.default, f"hand_{side}", spec.kind,
                                          f"{SIDES[side]} hand: {spec.description}", spec.units)
        self.specs = specs
        self._own = {name: spec for name, spec in specs.items() if name not in self._face_specs}
        self._organs = self._organ_table()
        self._hand_idle = {side: True for side in self._hands}
        self._hand_last: dict[str, dict] = {}

    def hand(self, side: str):
        """The hand rig of ``side`` ("L"/"R"), rebuilt from its saved bytes (or, in a worker copy, copied) the
        first time it is needed."""
        hand = self._hands[side]
        if isinstance(hand, _Deferred):
            hand = self._hands[side] = hand.make()
        elif isinstance(hand, (bytes, bytearray)):
            hand = self._hands[side] = load_rig_bytes(hand)
        return hand

    def _hand_moving(self, side: str, values: dict) -> bool:
        specs = self.hand_specs[side]
        return any(values[name] != specs[muscle].default for name, muscle in self._hand_names[side].items())

    # -- the rig protocol -----------------------------------------------------------------------------
    def control_specs(self) -> dict[str, ControlSpec]:
        return dict(self.specs)

    def reset(self) -> None:
        self.face.reset()
        for side, hand in self._hands.items():
            if not isinstance(hand, _LAZY):
                hand.reset()
        self._hand_idle = {side: True for side in self._hands}
        self._hand_last = {}

    def rest_pose(self) -> Pose:
        transforms = {BONE_PREFIX + bone: np.eye(4) for bone in self._turned_bones()}
        return Pose({"skin": self.rest_positions}, transforms)

    def _mixed(self, layer_values: LayerValues) -> dict:
        """The mixed values (4.3.5) of the head's and the hands' controls (the face mixes its own); unknown
        layers and control names are refused as :func:`..anim.layers.mix` refuses them."""
        for values in layer_values.values():
            unknown = [name for name in values if name not in self.specs]
            if unknown:
                mix({"ctrl": {unknown[0]: 0.0}}, self.specs)
        return mix({layer: {k: v for k, v in values.items() if k in self._own}
                    for layer, values in layer_values.items()}, self._own)

    def step(self, layer_values: LayerValues, dt: float) -> Pose:
        """Mix the layers (4.3.5), advance the face and the hands one frame of ``dt`` seconds, return the pose.
        A hand whose muscles are relaxed and whose bones have stopped turning is not simulated."""
        values = self._mixed(layer_values)
        face_pose = self.face.step(_subset(layer_values, self._face_specs), dt)
        hand_turns = {}
        for side in self._hands:
            moving = self._hand_moving(side, values)
            if moving or not self._hand_idle[side]:
                names = self._hand_names[side]
                turns = self.hand(side).step_bones(_subset(layer_values, names, names), dt)   # the body skins it
                last = self._hand_last.get(side, {})
                still = bool(last) and all(np.allclose(turns[b], last[b], atol=IDLE_TURN) for b in last)
                self._hand_idle[side], self._hand_last[side] = not moving and still, turns
                hand_turns[side] = turns
        return self._pose(face_pose, values, hand_turns)

    def settled(self, layer_values: LayerValues, max_time: float = 1.5, dt: float = 1 / 24) -> Pose:
        """The static pose from rest: the face and each hand settle (a hand whose muscles are all relaxed
        stays at rest without simulating)."""
        values = self._mixed(layer_values)
        face_pose = self.face.settled(_subset(layer_values, self._face_specs), max_time, dt)
        hand_turns = {}
        for side in self._hands:
            if self._hand_moving(side, values):
                names = self._hand_names[side]
                hand_turns[side] = self.hand(side).settled(_subset(layer_values, names, names), max_time,
                                                           dt).transforms
        return self._pose(face_pose, values, hand_turns)

    def worker_copy(self) -> "CharacterRig":
        """A copy at rest for another thread; its hands are copied only when its hand controls are used
        (copying a hand rig rebuilds it: seconds, for shapes of the face that never move a hand)."""
        hands = {side: hand if isinstance(hand, _LAZY) else _Deferred(hand.worker_copy)
                 for side, hand in self._hands.items()}
        copy = CharacterRig(self.character, self.face.worker_copy(), self.head_ids, hands, self._rest,
                            self.hand_specs, self.fits, self.basis)
        copy.identity = self.identity
        return copy

    def with_face(self, character: Character, face, head_ids: np.ndarray, rest_vertices: np.ndarray,
                  basis: np.ndarray | None) -> "CharacterRig":
        """The same hands (rigs, controls, fits) with another face rig on another rest (a refit)."""
        return CharacterRig(character, face, head_ids, dict(self._hands), rest_vertices, self.hand_specs, self.fits,
                            basis)

    # -- outputs ----------------------------------------------------------------------------------------
    @property
    def rest_positions(self) -> np.ndarray:
        """The body's own vertices (its basis): the morphed rest's basis when refitted, else the rest."""
        return (self._rest if self.basis is None else self.basis).astype(np.float32)

    @property
    def morphed_rest(self) -> np.ndarray:
        """The rest the face rig was fitted to (float64; the basis when never refitted to a morph)."""
        return self._rest

    @property
    def faces(self) -> np.ndarray:
        return self.character.mesh.quads

    @property
    def focus_vertices(self) -> np.ndarray:
        """The head: the face rig's vertices and the eyes, teeth and tongue (what a face's contact sheet frames)."""
        return np.union1d(self.head_ids, np.concatenate(list(self._organs.values())))

    def _turned_bones(self) -> list[str]:
        bones = list(self.terms)
        for fit in self.fits.values():
            bones += list(fit.pairs.values())
        return bones

    def _organ_table(self) -> dict[str, np.ndarray]:
        mesh = self.character.mesh
        return {role: mesh.parts[role] for role in ("eye_L", "eye_R", "teeth_upper", "teeth_lower", "tongue")}

    def _pose(self, face_pose: Pose, values: dict, hand_turns: dict) -> Pose:
        skin = self._rest.copy()
        skin[self.head_ids] = face_pose.positions["skin"]
        rigid = self.face.rigid_transforms()
        for role, ids in self._organs.items():
            matrix = rigid[role]
            skin[ids] = self._rest[ids] @ matrix[:3, :3].T + matrix[:3, 3]
        transforms = {BONE_PREFIX + bone: euler_matrix(angles)
                      for bone, angles in bone_eulers({k: values[k] for k in HEAD_CONTROLS}, self.terms).items()}
        for side, fit in self.fits.items():
            if side in hand_turns:
                for bone, basis in fit.basis(hand_turns[side]).items():
                    transforms[BONE_PREFIX + bone] = basis
            else:
                transforms.update({BONE_PREFIX + bone: np.eye(4) for bone in fit.pairs.values()})
        if self.basis is not None:
            skin = self.basis + (skin - self._rest)
        return Pose({"skin": np.ascontiguousarray(skin, dtype=np.float32)}, transforms)

    # -- persistence ------------------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write the rig (.npz, no pickle): the skeleton it was built with, the fitted face rig's and the hand
        rigs' own archives, the hands' controls and fits, the body's rest vertices. :meth:`load` rebuilds the
        same rig (the hands only when they are used)."""
        meta = {"format": CHARACTER_RIG_FORMAT, "skeleton": self.character.skeleton.name,
                "hands": {side: {"pairs": fit.pairs, "turn": fit.turn.ravel().tolist(),
                                 "controls": {n: asdict(sp) for n, sp in self.hand_specs[side].items()}}
                          for side, fit in self.fits.items()},
                "warnings": self.warnings}
        arrays = {"face_rig": np.frombuffer(save_rig(self.face), np.uint8), "head_ids": self.head_ids,
                  "rest_vertices": self._rest}
        if self.basis is not None:
            arrays["basis_vertices"] = self.basis
        for side, hand in self._hands.items():
            data = hand if isinstance(hand, (bytes, bytearray)) else save_rig(self.hand(side))
            arrays[f"hand_rig_{side}"] = np.frombuffer(bytes(data), np.uint8)
        write_rig_archive(path, meta, arrays)

    @classmethod
    def load(cls, path: str | Path) -> "CharacterRig":
        meta, arrays = read_rig_archive(path, CHARACTER_RIG_FORMAT, "character rig",
                                        ("face_rig", "head_ids", "rest_vertices"), ("hand_rig_", "basis_"))
        try:
            character = build_character(meta["skeleton"])
            face = load_rig_bytes(arrays["face_rig"].tobytes())
            saved_hands = dict(meta.get("hands", {}))
            hands = {side: arrays[f"hand_rig_{side}"].tobytes() for side in saved_hands}
            specs = {side: {n: ControlSpec(**sp) for n, sp in entry["controls"].items()}
                     for side, entry in saved_hands.items()}
            fits = {side: hand_fit(character.skeleton, side, entry["pairs"], entry["turn"])
                    for side, entry in saved_hands.items()}
        except (KeyError, TypeError, ValueError) as error:
            raise UserError(f"{path}: the saved character rig is incomplete ({error})") from None
        if arrays["rest_vertices"].shape != character.mesh.vertices.shape:
            raise UserError(f"{path}: the saved character does not match this extension's character; build it again")
        character.mesh.vertices = np.array(arrays["rest_vertices"], np.float64)
        basis = arrays.get("basis_vertices")
        if basis is not None and basis.shape != character.mesh.vertices.shape:
            raise UserError(f"{path}: the saved character's basis does not match its rest; build it again")
        rig = cls(character, face, arrays["head_ids"], hands, arrays["rest_vertices"], specs, fits, basis)
        rig.warnings = list(meta.get("warnings", rig.warnings))
        return rig
