# SPDX-License-Identifier: GPL-3.0-or-later
"""The character rig built from the character (thesis 3.1.2, "Creating New Animatable Head Models from the
Template"): the face rig is fitted through the face's own fitting (:func:`..face.fitted.build_fitted_rig`) to
the character's head and neck -- its body vertices above :data:`.body.HEAD_FRACTION` of its height, in the
character's own coordinates (so the rig's outputs need no conversion) -- and the character's own eyes are
put where the fitted face rig has its eyeballs ("eyes, teeth and tongue can only be positioned and scaled
automatically"): each eye is moved and scaled about its centre onto the rig's eyeball, so the lids close
over it and it turns about its own centre. Teeth and tongue stay where the base mesh has them and move with
the rig's jaw and tongue. The hand rigs are the reference hand, one per side (:mod:`.hands`).
"""
from __future__ import annotations

import numpy as np

from ..core.errors import UserError
from .body import HEAD_FRACTION
from .model import Character, build_character, eye_frames

__all__ = ["head_submesh", "fit_face", "placed_eyes", "brow_paint", "build_character_rig", "rig_stages",
           "run_stages", "FACE_SEED"]

FACE_SEED = 0


def head_submesh(character: Character) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertex ids into the character's mesh, their positions, triangles over them) of the head and neck skin."""
    mesh = character.mesh
    body = mesh.parts["body"]
    z = mesh.vertices[body, 2]
    ids = body[z > z.min() + HEAD_FRACTION * (z.max() - z.min())]
    lookup = np.full(len(mesh.vertices), -1, np.int64)
    lookup[ids] = np.arange(len(ids))
    triangles = lookup[mesh.triangles]
    triangles = triangles[(triangles >= 0).all(axis=1)]
    return ids, mesh.vertices[ids], triangles


def fit_face(character: Character, progress=None, seed: int = FACE_SEED):
    """The fitted face rig on the character's head (:func:`head_submesh`) and the head's vertex ids."""
    from ..face.fitted import build_fitted_rig
    ids, vertices, triangles = head_submesh(character)
    rig = build_fitted_rig(vertices, triangles, seed=seed, progress=progress, forward="-Y", up="+Z")
    return rig, ids


def placed_eyes(character: Character, face) -> np.ndarray:
    """The character's vertices with each eye moved and scaled onto the face rig's eyeball (module docstring)."""
    vertices = character.mesh.vertices.copy()
    organs = face.fitted.template.organs
    scale = float(np.cbrt(abs(np.linalg.det(face.head_to_mesh[:3, :3]))))
    for side, (centre, radius) in eye_frames(character.mesh).items():
        if side not in organs.eye_centres:
            raise UserError(f"the fitted face rig has no {side} eye; fit the face again")
        target = face.to_mesh(np.asarray(organs.eye_centres[side])[None])[0]
        ids = character.mesh.parts[f"eye_{side}"]
        vertices[ids] = target + (vertices[ids] - centre) * (organs.eye_radius * scale / radius)
    return vertices


def brow_paint(vertices: np.ndarray, face, ids: np.ndarray) -> np.ndarray:
    """Per vertex of the character in [0, 1]: eyebrow hair painted on the skin (the base mesh has no brow
    geometry; MPFB2 adds brows as separate proxies). The band under each upper brow contour of the fitted
    face's landmarks, as the default head paints its brows (:func:`..face.appearance.brow_weights`), so the
    brows move with the skin in every shape."""
    from ..assets import face_contours
    from ..face.appearance import brow_weights
    contours = face_contours().lines
    head = vertices[ids]
    out = np.zeros(len(vertices))
    for side in "LR":
        line = face.landmarks[contours[f"eyebrow_{side}_upper"]]
        points = np.concatenate([head, line])
        weights = brow_weights(points, len(head) + np.arange(len(line)), np.ones(len(points)))[:len(head)]
        out[ids] = np.maximum(out[ids], weights)
    return out


def rig_stages(skeleton: str = "game_engine", hands: bool = True):
    """Build the character's rig in fixed stages (Rigify-like): a generator yielding ``(fraction, message)``
    after each stage and, last, the :class:`.rig.CharacterRig` (module docstring)."""
    from ..hand.rig import HandRig
    from ..hand.template import reference_template
    from .rig import CharacterRig
    yield 0.0, "building the character"
    character = build_character(skeleton)
    yield 0.05, "fitting the face rig to the head"
    face, ids = fit_face(character)
    character.mesh.vertices = placed_eyes(character, face)
    character.mesh.brows = brow_paint(character.mesh.vertices, face, ids)
    hand_rigs = {}
    if hands:
        template = reference_template()
        for fraction, (side, name) in zip((0.6, 0.8), (("L", "left"), ("R", "right"))):
            yield fraction, f"fitting the {name} hand"
            hand_rigs[side] = HandRig(template, name)
            hand_rigs[side].reset_state()
    yield 0.95, "composing the character rig"
    yield CharacterRig(character, face, ids, hand_rigs, character.mesh.vertices)


def build_character_rig(skeleton: str = "game_engine", progress=None, hands: bool = True):
    """The character (:func:`.model.build_character`) and its rig of rigs, all stages of :func:`rig_stages`;
    ``progress(fraction, message)`` is called after each."""
    return run_stages(rig_stages(skeleton, hands), progress, "the character rig was not built")


def run_stages(stages, progress, failure: str):
    """Drive a generator of ``(fraction, message)`` stages that ends by yielding its result; ``progress``
    (or None) is called with each stage; ``failure`` is the message if no result came."""
    for item in stages:
        if isinstance(item, tuple):
            if progress is not None:
                progress(*item)
        else:
            return item
    raise UserError(failure)
