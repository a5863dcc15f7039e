# SPDX-License-Identifier: GPL-3.0-or-later
"""The person of a photograph edited with the morphable model's attributes (thesis 3.2.4: "the extracted
face model can be modified and rendered back into the original image"; 3.2.2-3.2.3, 5.1.4): the fitted
coefficients become a face of the model's editor (:mod:`..morph.editing`, so attributes, constraints and
caricature work as on any morphable face), the edits run in the order given, and the result keeps what the
model could not say: the correction beyond the model is added back, and colour edits scale the photo's
texture by the ratio of the edited to the fitted albedo, so freckles and moles stay where they were.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..core.errors import UserError
from ..morph.editing import EditFace
from .texture import scaled_texture

__all__ = ["edited_head", "parse_edit"]

MAX_RATIO = 4.0


def parse_edit(text: str) -> tuple[str, float]:
    """``attribute=value`` (e.g. ``younger-older=0.6``) or ``caricature=level``."""
    name, sep, value = str(text).rpartition("=")
    if not sep or not name.strip():
        raise UserError(f"edit {text!r}: write attribute=value, e.g. younger-older=0.6 or caricature=1.4")
    try:
        return name.strip(), float(value)
    except ValueError:
        raise UserError(f"edit {text!r}: {value!r} is not a number") from None


def edited_head(result, edits: list[tuple[str, float]]):
    """A copy of ``result`` (:class:`.pipeline.PhotoHead`) with ``edits`` applied (module docstring)."""
    model = result.model
    if model.source is None:
        raise UserError("this head's model has no attributes to edit it with")
    beta = result.appearance[0].beta
    face = EditFace(model.source)
    face.run({"op": "create", "kind": "coefficients", "shape": result.shape.alpha.tolist(),
              "colour": None if beta is None else beta.tolist()})
    for name, value in edits:
        if name == "caricature":
            face.caricature(value)
        else:
            face.set_attribute(name, value, "both")
    vertices = face.shape + result.shape.correction
    texture = result.texture
    if face.colour is not None and beta is not None:
        ratio = np.clip(face.colour / np.maximum(model.albedo(beta), 1e-3), 1.0 / MAX_RATIO, MAX_RATIO)
        texture = scaled_texture(texture, model.uvs, model.triangles, ratio)
    shape = replace(result.shape, alpha=face.alpha.copy(), vertices=vertices)
    notes = result.notes + [f"edited: {', '.join(f'{n} {v:+g}' for n, v in edits)}"]
    return replace(result, shape=shape, texture=texture, notes=notes, mesh=None, rig=None)
