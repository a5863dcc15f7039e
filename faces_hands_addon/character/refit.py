# SPDX-License-Identifier: GPL-3.0-or-later
"""The character's face rig refitted after a morph edit (thesis 3.2 and 3.1.2): a head made with the
morphable model is a new head, and a new head gets the template fitted to it ("Creating New Animatable Head
Models from the Template"), as the character's own head did when it was built (:mod:`.fitting`).

* **Input, one way**: the morphed head is the model's own evaluation of the stored coefficients (the
  model's (n, 3) vertices, :func:`..morph.heads.character_vertices` puts them into the body); nothing is
  read back from a displayed mesh.
* **The refit**: the body with its head replaced is fitted like a new character (:func:`.fitting.fit_face`),
  its eyes moved onto the refitted rig's eyeballs (:func:`.fitting.placed_eyes`, so the lids close over
  them) and its brows painted from the refitted landmarks. The hands, their fits and controls are kept.
* **Reconciled with the body's shape keys**: the body keeps its own shape as basis; the refitted rig's rest
  (the morphed head, eyes placed) is what the morph key must hold, and every shape the rig makes is the
  basis plus its displacement from that rest (:class:`.rig.CharacterRig` ``basis``), so expression targets
  are deltas on top of the morph key and the artist's other keys are untouched.
* **The targets**: the body's keys that are baked targets (named expressions: ARKit, visemes, emotions; the
  muscle basis ``FH.<control>``) are baked again on the refitted rig (:func:`target_expressions`).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Iterable, Mapping

import numpy as np

from ..core.errors import UserError
from .fitting import FACE_SEED, brow_paint, fit_face, placed_eyes, run_stages

__all__ = ["morphed_body", "refit_stages", "refit_character_rig", "target_expressions", "EXPRESSION_SETS"]

EXPRESSION_SETS = ("arkit", "visemes", "named")
BASIS_PREFIX = "FH."


def _basis(rig) -> np.ndarray:
    return np.asarray(rig.morphed_rest if rig.basis is None else rig.basis, np.float64)


def morphed_body(rig, model, head: np.ndarray) -> np.ndarray:
    """The body's basis with its head replaced by ``head`` (the morph model's (n, 3) vertices); refused for a
    model of another topology, a head of the wrong size or with non-finite numbers."""
    from ..morph.heads import character_vertices, check_head_model
    check_head_model(model, f"model {getattr(model, 'name', '')!r}")
    head = np.asarray(head, np.float64)
    if head.shape != (model.vertex_count, 3):
        raise UserError(f"the morphed head has {head.shape[0] if head.ndim else 0} vertices; its model has "
                        f"{model.vertex_count}")
    if not np.all(np.isfinite(head)):
        raise UserError("the morphed head holds non-finite numbers; undo the last edit and refit again")
    return character_vertices(model, rig.character.mesh.base_index, _basis(rig), head)


def refit_stages(rig, model, head: np.ndarray, seed: int = FACE_SEED):
    """Refit ``rig`` (a :class:`.rig.CharacterRig`) to the morphed ``head`` in stages: a generator yielding
    ``(fraction, message)`` and, last, the refitted rig (module docstring). ``rig`` itself is not changed."""
    yield 0.0, "placing the morphed head on the body"
    basis = _basis(rig)
    mesh = replace(rig.character.mesh, vertices=morphed_body(rig, model, head), brows=None)
    character = replace(rig.character, mesh=mesh)
    yield 0.05, "fitting the face rig to the morphed head"
    face, ids = fit_face(character, seed=seed)
    yield 0.9, "placing the eyes under the refitted lids"
    mesh.vertices = placed_eyes(character, face)
    mesh.brows = brow_paint(mesh.vertices, face, ids)
    yield rig.with_face(character, face, ids, mesh.vertices, basis)


def refit_character_rig(rig, model, head: np.ndarray, progress=None, seed: int = FACE_SEED):
    """All stages of :func:`refit_stages`; ``progress(fraction, message)`` after each."""
    return run_stages(refit_stages(rig, model, head, seed), progress, "the face rig was not refitted")


def target_expressions(key_names: Iterable[str], specs: Mapping,
                       expressions: Mapping[str, Mapping[str, float]] | None = None) -> dict[str, dict]:
    """The body's keys that the rig baked, as name -> control dict to bake again: every key named like a
    named expression (``expressions``; default: the ARKit, viseme and named sets) and every muscle-basis
    key ``FH.<control>`` (the control at its full value, as ``anim.baking.basis_shapes`` bakes it). Other
    keys (the artist's, the morph, the simulation, per-frame caches) are not targets."""
    if expressions is None:
        from ..face.expressions import load_expressions
        expressions = {}
        for name in EXPRESSION_SETS:
            expressions.update(load_expressions(name))
    out = {}
    for name in key_names:
        if name in expressions:
            out[name] = dict(expressions[name])
        elif name.startswith(BASIS_PREFIX) and name[len(BASIS_PREFIX):] in specs:
            control = name[len(BASIS_PREFIX):]
            out[name] = {control: specs[control].full_value}
    return out
