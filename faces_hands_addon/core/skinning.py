# SPDX-License-Identifier: GPL-3.0-or-later
"""Skinned rigs handed to Blender: bones (:class:`Bone`, which an armature is built from) and skin weights as
every client plays them, at most four bones per vertex.

glTF 2.0 stores four influences per vertex in ``JOINTS_0``/``WEIGHTS_0``; further sets are optional and
three.js, like most game engines, reads only the first. A rig that deforms with a fifth influence in Blender
would play differently everywhere else, so the weights a rig hands to Blender (and un-skins with, for its
corrective shapes) keep each vertex's four largest influences, renormalised to sum to 1 (linear blend
skinning, the skinning of thesis 6.2.1).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MAX_INFLUENCES", "limit_influences", "Bone"]

MAX_INFLUENCES = 4


def limit_influences(weights: np.ndarray, count: int = MAX_INFLUENCES) -> np.ndarray:
    """``weights`` (vertices x bones) with each row's ``count`` largest entries kept and renormalised to the
    row's original sum; rows without weight stay zero."""
    weights = np.asarray(weights, dtype=np.float64)
    if weights.shape[1] <= count:
        return weights.copy()
    keep = np.argpartition(-weights, count - 1, axis=1)[:, :count]
    limited = np.zeros_like(weights)
    rows = np.arange(len(weights))[:, None]
    limited[rows, keep] = weights[rows, keep]
    total, kept = weights.sum(axis=1, keepdims=True), limited.sum(axis=1, keepdims=True)
    scale = np.divide(total, kept, out=np.zeros_like(total), where=kept > 0)
    return limited * scale


@dataclass(frozen=True)
class Bone:
    """One bone as a rig hands it to Blender (an armature and its skin's vertex groups): ``head`` and
    ``tail`` in the rig's output coordinates at rest, ``z_axis`` the direction the bone's local Z points
    (its roll), ``parent`` the parent bone's name (``None`` for a root), ``deform`` whether it moves skin."""
    name: str
    head: tuple[float, float, float]
    tail: tuple[float, float, float]
    z_axis: tuple[float, float, float]
    parent: str | None = None
    deform: bool = True
