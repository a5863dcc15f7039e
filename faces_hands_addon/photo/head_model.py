# SPDX-License-Identifier: GPL-3.0-or-later
"""What the photo work needs of a morphable model (thesis 3.2.1, 3.2.4): its shape and colour PCA, its mesh
and UVs, the vertex of each of MediaPipe's 468 face landmarks, its left/right vertex map and the vertices of
the face (where a photo's colours go). Everything downstream (fit, texture, rendering, the rig) reads only
this, so a model of whole heads (e.g. on MPFB2's topology) plugs in by giving its ``landmarks`` (468 vertex
ids in MediaPipe's order) and a ``face`` segment; nothing else changes.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import geometry
from ..core.errors import UserError
from ..morph.model import MorphableModel

__all__ = ["HeadModel", "MESH_LANDMARKS"]

MESH_LANDMARKS = 468


@dataclass
class HeadModel:
    """``mean`` (n, 3) metres, ``basis`` (3n, k) orthonormal, ``sd`` (k,) (3.2.1); ``colour_*`` the same for
    linear albedo (or None); ``triangles`` (m, 3); ``uvs`` (n, 2); ``landmarks`` (468,) vertex ids;
    ``mirror`` (n,) the mirror vertex of each vertex; ``face`` (n,) the face region; ``name`` for reports;
    ``source`` the morphable model itself (its attributes edit a fitted person, 3.2.2-3.2.3)."""
    name: str
    mean: np.ndarray
    basis: np.ndarray
    sd: np.ndarray
    triangles: np.ndarray
    uvs: np.ndarray
    landmarks: np.ndarray
    mirror: np.ndarray
    face: np.ndarray
    colour_mean: np.ndarray | None = None
    colour_basis: np.ndarray | None = None
    colour_sd: np.ndarray | None = None
    topology: str = ""
    source: MorphableModel | None = None

    @classmethod
    def from_morphable(cls, model: MorphableModel) -> "HeadModel":
        """The photo view of a :class:`..morph.model.MorphableModel` (refused when it lacks UVs or the 468
        landmark vertices, or is not left/right symmetric at its mean)."""
        n = model.vertex_count
        if model.uvs is None:
            raise UserError(f"model {model.name!r} has no UVs; a photo's texture needs them")
        landmarks = np.asarray(model.landmarks if model.landmarks is not None else [], np.int64).ravel()
        if landmarks.shape != (MESH_LANDMARKS,) or landmarks.min() < 0 or landmarks.max() >= n:
            raise UserError(f"model {model.name!r} does not name the vertex of each of MediaPipe's "
                            f"{MESH_LANDMARKS} face landmarks (its 'landmarks' entry); it cannot be fitted to a photo")
        mean = model.mean_vertices()
        mirror = geometry.mirror_map(mean, tolerance=1e-3 * float(np.ptp(mean[:, 0])))
        if np.any(mirror < 0):
            raise UserError(f"model {model.name!r} is not left/right symmetric at its mean; the photo's hidden side "
                            "is filled from the mirrored side, which needs a symmetric model")
        face = np.asarray(model.segments.get("face", np.ones(n, bool)), bool)
        colour = model.colour
        return cls(model.name, mean, model.shape.basis, model.shape.sd, np.asarray(model.triangles, np.int64),
                   np.asarray(model.uvs, np.float64), landmarks, mirror, face,
                   None if colour is None else colour.mean.reshape(-1, 3),
                   None if colour is None else colour.basis, None if colour is None else colour.sd,
                   str(model.info.get("topology", "")), model)

    @property
    def vertex_count(self) -> int:
        return int(self.mean.shape[0])

    @property
    def components(self) -> int:
        return int(self.sd.shape[0])

    def shape(self, alpha: np.ndarray) -> np.ndarray:
        """(n, 3) vertices of coefficients ``alpha`` (3.2.1: ``s = s_mean + U alpha``)."""
        return self.mean + (self.basis @ np.asarray(alpha, np.float64)).reshape(-1, 3)

    def landmark_basis(self) -> tuple[np.ndarray, np.ndarray]:
        """(468, 3) mean and (468, 3, k) basis rows of the landmark vertices."""
        rows = self.basis.reshape(self.vertex_count, 3, -1)
        return self.mean[self.landmarks], rows[self.landmarks]

    def albedo(self, beta: np.ndarray | None) -> np.ndarray:
        """(n, 3) linear albedo of colour coefficients ``beta`` (the mean without them; mid skin without a
        colour model)."""
        if self.colour_mean is None:
            return np.full((self.vertex_count, 3), 0.45)
        if beta is None:
            return self.colour_mean.copy()
        return self.colour_mean + (self.colour_basis @ np.asarray(beta, np.float64)).reshape(-1, 3)
