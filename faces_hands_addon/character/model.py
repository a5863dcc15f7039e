# SPDX-License-Identifier: GPL-3.0-or-later
"""The default character as plain data: its mesh (:mod:`.body`), its armature and skin weights
(:mod:`.skeleton`) and what its materials need (:data:`MATERIAL_SETTINGS`, eye UVs laid out for MPFB2's
procedural eye). The Blender side turns a :class:`Character` into objects; the rig of rigs
(:mod:`.rig`) fits the face and the hands into it.
"""
from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from ..core.errors import UserError
from . import mpfb2
from .body import MATERIALS, CharacterMesh, character_mesh
from .skeleton import MAX_INFLUENCES, CharacterSkeleton, build_skeleton

__all__ = ["SKELETONS", "Character", "build_character", "eye_frames", "EYE_UV_CENTRES", "material_settings"]

#: the skeletons a character can be built with (the Rigify meta-rig generates a Rigify control rig)
SKELETONS = ("game_engine", "default", "rigify")
#: where MPFB2's procedural eye material looks for each eye's iris in UV space (its ``CenterCoordinates``)
EYE_UV_CENTRES = {"L": (0.705, 0.7), "R": (0.295, 0.3)}
EYE_UV_RADIUS = 0.285            # the material's ``EyeballSize``: UV distance of the eyeball's equator


@dataclass
class Character:
    mesh: CharacterMesh
    skeleton: CharacterSkeleton

    @property
    def name(self) -> str:
        return f"MPFB2 {self.skeleton.name}"


def eye_frames(mesh: CharacterMesh) -> dict[str, tuple[np.ndarray, float]]:
    """Centre and radius of each of the character's own eyeballs (``"L"``, ``"R"``)."""
    out = {}
    for side in "LR":
        points = mesh.vertices[mesh.parts[f"eye_{side}"]]
        centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
        out[side] = (centre, float(np.median(np.linalg.norm(points - centre, axis=1))))
    return out


def _eye_uvs(mesh: CharacterMesh) -> np.ndarray:
    """Corner UVs of the eyes laid out as MPFB2's procedural eye expects: each eye a disc around its
    ``EYE_UV_CENTRES`` entry whose radius grows with the angle from the gaze (-Y) up to ``EYE_UV_RADIUS`` at
    the equator, so the material draws pupil, iris and sclera where the eye looks."""
    uvs = mesh.corner_uvs.copy()
    for side, (centre, _) in eye_frames(mesh).items():
        ids = mesh.parts[f"eye_{side}"]
        faces = np.flatnonzero(np.isin(mesh.quads, ids).all(axis=1))
        direction = mesh.vertices[mesh.quads[faces]] - centre
        direction /= np.linalg.norm(direction, axis=2, keepdims=True)
        polar = np.arccos(np.clip(-direction[..., 1], -1.0, 1.0))
        around = np.arctan2(direction[..., 2], direction[..., 0])
        radius = EYE_UV_RADIUS * polar / (0.5 * np.pi)
        u0, v0 = EYE_UV_CENTRES[side]
        uvs[faces, :, 0] = u0 + radius * np.cos(around)
        uvs[faces, :, 1] = v0 + radius * np.sin(around)
    return uvs


def build_character(skeleton: str = "game_engine", max_influences: int = MAX_INFLUENCES) -> Character:
    """The default character (MPFB2 base mesh, ``skeleton`` of :data:`SKELETONS`, skin weights with at most
    ``max_influences`` bones per vertex)."""
    if skeleton not in SKELETONS:
        raise UserError(f"unknown character skeleton {skeleton!r}; use one of {', '.join(SKELETONS)}")
    mesh = character_mesh()
    mesh.corner_uvs = _eye_uvs(mesh).astype(np.float32)
    return Character(mesh, build_skeleton(skeleton, mesh, max_influences=max_influences))


def material_settings() -> dict[str, dict]:
    """MPFB2's default skin (per region: body, lips, nails...) and eye settings, as shipped."""
    out = {}
    for key, name in (("skin", "enhanced_settings.default.json"), ("eye", "eye_settings.default.json")):
        path = mpfb2.MPFB2_DIR / "settings" / name
        try:
            out[key] = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as error:
            raise UserError(f"{name}: cannot read MPFB2's material settings ({error}); run `make assets`") from None
    return out


