# SPDX-License-Identifier: GPL-3.0-or-later
"""The registration template: MediaPipe's canonical face, whose 468 vertices ARE the 468 landmarks.

Thesis 3.1.2 "Creating New Animatable Head Models from the Template": the reference head carries
landmarks "at anthropometrically meaningful positions" and feature points "must be placed at corresponding
locations on the target skin mesh". Registering the whole canonical face onto the target gives all 468
correspondences at once (Amberg et al. 2007 style template fitting) instead of placing them by hand.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.spatial import cKDTree

from .. import assets

__all__ = ["FaceTemplate", "face_template", "LEFT_TRAGUS", "RIGHT_TRAGUS", "NOSE_TIP"]

LEFT_TRAGUS, RIGHT_TRAGUS = 454, 234   # widest face-oval points (character's left +X / right -X)
NOSE_TIP = 1
# Elliptic (x, z) region of the template used for the rough depth-image search: eyes, nose, mouth, chin
# and inner cheeks, leaving out the temples and the pre-auricular sides that hair, ears or a tight mask
# crop may hide. Centre and half-axes in canonical metres.
_MATCH_CENTRE_Z = -0.005
_MATCH_HALF_AXES = (0.065, 0.085)


@dataclass(frozen=True)
class FaceTemplate:
    """Canonical face in project axes (metres, Z up, looking along -Y, +X = character's left)."""
    vertices: np.ndarray          # (468, 3)
    faces: np.ndarray             # (898, 3)
    edges: np.ndarray             # (E, 2) unique undirected edges
    mirror: np.ndarray            # (468,) index of the X-mirrored landmark
    contours: dict                # name -> landmark index polyline (assets.face_contours)
    match_region: np.ndarray      # (468,) bool, vertices used by the rough depth-image search
    width: float                  # tragus-to-tragus distance (|v[454] - v[234]|)

    @property
    def count(self) -> int:
        return len(self.vertices)


@lru_cache(maxsize=1)
def face_template() -> FaceTemplate:
    """Load (once) the canonical face and derive what the fitter needs from it."""
    mesh = assets.canonical_face()
    vertices = np.ascontiguousarray(mesh.vertices, np.float64)
    faces = np.asarray(mesh.faces, np.int64)
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    e.sort(axis=1)
    edges = np.unique(e, axis=0)
    _, mirror = cKDTree(vertices).query(vertices * (-1.0, 1.0, 1.0))
    contours = {k: v.copy() for k, v in assets.face_contours().lines.items()}
    ax, az = _MATCH_HALF_AXES
    match = (vertices[:, 0] / ax) ** 2 + ((vertices[:, 2] - _MATCH_CENTRE_Z) / az) ** 2 < 1.0
    width = float(np.linalg.norm(vertices[LEFT_TRAGUS] - vertices[RIGHT_TRAGUS]))
    for array in (vertices, faces, edges, mirror, match):
        array.setflags(write=False)
    return FaceTemplate(vertices, faces, edges, np.asarray(mirror, np.int64), contours, match, width)
