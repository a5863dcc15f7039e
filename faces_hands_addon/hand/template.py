# SPDX-License-Identifier: GPL-3.0-or-later
"""A hand template: everything a hand rig is built from, computed once per set of presets (thesis 6.2.1
"The Reference Hand Model"): skeleton (joints, frames, DOFs, bone meshes), skin with skinning weights,
bone-plus-tissue masses, pseudo muscles (Table A.1), geometric-muscle grids and feature points.

:func:`reference_template` builds the reference hand from the vendored assets; :func:`warped_template`
applies a warp to every spatial part of a template (6.2.3 "Warping the Reference Hand Model", steps 1-5):
skin and bone meshes vertex by vertex, joint positions, tips and feature points directly, joint frames
re-oriented (:func:`.skeleton.reoriented_frames`), muscle grids moved and their muscles rebuilt on the new
skin; pseudo muscles keep their parameters. Masses and moments of inertia are recomputed from the new
geometry, which is why "the animation parameters have to be adapted to the warped hand model" (6.2.4).
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Callable

import numpy as np

from ..core.errors import UserError
from . import HAND_MESHES
from .features import feature_points
from .inertia import segment_masses
from .presets import MuscleSpec, geometric_specs, joints_preset, muscle_specs, preset_text
from .reference import build_skeleton
from .geometric import muscle_grids
from .skeleton import Skeleton, reoriented_frames
from .skin import SkinMesh, fit_reference_skin

__all__ = ["HandTemplate", "PresetTexts", "reference_template", "hand_template", "warped_template",
           "default_preset_texts", "MESHES", "DEFAULT_MESH"]

#: the standalone hand's skin: ``mpfb2`` the MPFB2 base mesh's hand (``character/hand_mesh.py``), ``tube`` the
#: reference skin of :mod:`.skin` (the WebXR hand shaped round the bones). The default stays ``tube`` until
#: the MPFB2 hand meets what the tube's tests hold it to (finger contact side by side, the fist's thumb on
#: the fingers, the hypothenar bulges); ``bench/hand.py`` measures both.
MESHES = ("mpfb2", "tube")
DEFAULT_MESH = "tube"


@dataclass(frozen=True)
class PresetTexts:
    """The preset files a template was built from (kept in saved rigs, so a rig rebuilds the same hand)."""
    joints: str
    muscles: str
    geometric: str


@dataclass
class HandTemplate:
    skeleton: Skeleton
    skin: SkinMesh
    masses: np.ndarray                   # (B,) kg
    muscles: list[MuscleSpec]
    geometric: list[dict]
    grids: list[np.ndarray]              # muscle grids on the skin, (rows, columns, 3) each
    features: dict[str, np.ndarray]      # the 26 source feature points
    friction: float
    capsule: float
    presets: PresetTexts

    @property
    def node_count(self) -> int:
        return len(self.skin.vertices)


def default_preset_texts() -> PresetTexts:
    return PresetTexts(preset_text("joints.json"), preset_text("muscles.json"), preset_text("geometric_muscles.json"))


@lru_cache(maxsize=4)
def _reference(texts: PresetTexts) -> HandTemplate:
    joints = joints_preset(texts.joints)
    skeleton = build_skeleton(joints)
    skin = fit_reference_skin(skeleton)
    geometric = geometric_specs(texts.geometric)
    grids = muscle_grids(geometric, skeleton, skin.vertices, skin.faces)
    return HandTemplate(skeleton, skin, segment_masses(skeleton, skin.vertices, skin.weights),
                        muscle_specs(texts.muscles), geometric, grids, feature_points(skeleton, skin.vertices),
                        joints.friction, joints.capsule_stiffness, texts)


def reference_template(texts: PresetTexts | None = None) -> HandTemplate:
    """The reference hand for ``texts`` (default: the presets as the user folder / extension has them).
    Built once per process for each version of the presets and shared read-only."""
    return _reference(texts or default_preset_texts())


@lru_cache(maxsize=4)
def _on_mesh(texts: PresetTexts, mesh: str) -> HandTemplate:
    module, _, function = HAND_MESHES[mesh].partition(":")
    return getattr(importlib.import_module(module), function)(_reference(texts))


def hand_template(texts: PresetTexts | None = None, mesh: str = DEFAULT_MESH) -> HandTemplate:
    """The hand for ``texts`` on the skin ``mesh`` (:data:`MESHES`); built once per process and shared."""
    if mesh not in MESHES:
        raise UserError(f"unknown hand mesh {mesh!r}; use one of {', '.join(MESHES)}")
    texts = texts or default_preset_texts()
    if mesh == "tube":
        return _reference(texts)
    if mesh not in HAND_MESHES:
        raise UserError(f"the hand mesh {mesh!r} comes with the character package; import "
                        "faces_hands_addon.character first")
    return _on_mesh(texts, mesh)


def warped_template(template: HandTemplate, warp: Callable[[np.ndarray], np.ndarray]) -> HandTemplate:
    """``template`` carried through ``warp`` ((M, 3) -> (M, 3)) as in 6.2.3 (module docstring)."""
    sk = template.skeleton
    names = list(sk.mesh_vertices)
    sizes = [len(sk.mesh_vertices[n]) for n in names]
    tips = list(sk.tips)
    features = list(template.features)
    grid_shapes = [g.shape for g in template.grids]
    everything = np.concatenate([template.skin.vertices, sk.position, sk.tail]
                                + [sk.mesh_vertices[n] for n in names] + [sk.tips[t][None] for t in tips]
                                + [template.features[f][None] for f in features]
                                + [g.reshape(-1, 3) for g in template.grids])
    moved = warp(everything)
    cut = np.cumsum([len(template.skin.vertices), len(sk.position), len(sk.tail)] + sizes
                    + [1] * len(tips) + [1] * len(features))
    parts = np.split(moved, cut)
    skin_vertices, position, tail = parts[0], parts[1], parts[2]
    meshes = dict(zip(names, parts[3:3 + len(names)]))
    rest = parts[3 + len(names):]
    new_tips = {t: rest[i][0] for i, t in enumerate(tips)}
    new_features = {f: rest[len(tips) + i][0] for i, f in enumerate(features)}
    flat_grids = rest[len(tips) + len(features)]
    grids = np.split(flat_grids, np.cumsum([int(np.prod(s[:2])) for s in grid_shapes])[:-1])
    grids = [g.reshape(s) for g, s in zip(grids, grid_shapes)]
    skeleton = sk.with_geometry(position, tail, reoriented_frames(sk.frame, position, tail), meshes, new_tips)
    skin = replace(template.skin, vertices=skin_vertices)
    return replace(template, skeleton=skeleton, skin=skin, masses=segment_masses(skeleton, skin_vertices, skin.weights),
                   grids=grids, features=new_features)
