# SPDX-License-Identifier: GPL-3.0-or-later
"""The fitted head as the mesh the face rig animates (thesis 3.1.2 "Creating New Animatable Head Models from
the Template": the rig is fitted to the head, whatever it is). A model on MediaPipe's canonical topology
covers the mouth and both eyes with triangles, so its lips could never part nor its lids open: those
triangles go (the vertices of the inner-lip and eye contours keep their places, as in the template skin), and
the mesh is refined once by Loop subdivision so the lips and lids have enough vertices to bend. Other
topologies (a model of whole heads) are used as they are. Everything is a sparse matrix from the model's
vertices, so UVs and any per-vertex data follow the same map.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np
from scipy import sparse

from ..assets import face_contours
from ..core import refine
from .head_model import HeadModel

__all__ = ["RigMesh", "rig_mesh", "CANONICAL"]

CANONICAL = "mediapipe_canonical_468"


@dataclass
class RigMesh:
    """``matrix`` (N, n) from the model's vertices to the mesh's, ``triangles`` (M, 3), ``uvs`` (N, 2), and
    ``landmarks`` (468,) the mesh vertices of MediaPipe's landmarks (subdivision keeps old vertices' ids)."""
    matrix: sparse.csr_matrix
    triangles: np.ndarray
    uvs: np.ndarray
    landmarks: np.ndarray

    def vertices(self, model_vertices: np.ndarray) -> np.ndarray:
        return np.asarray(self.matrix @ np.asarray(model_vertices, np.float64))


def _openings(triangles: np.ndarray) -> np.ndarray:
    """The canonical face's triangles without those that cover the mouth and the eyes."""
    contours = face_contours().lines
    lips = np.concatenate([contours["lips_inner_upper"], contours["lips_inner_lower"][1:-1]])
    covered = [set(np.asarray(lips).tolist()), set(np.asarray(contours["eye_L"]).tolist()),
               set(np.asarray(contours["eye_R"]).tolist())]
    keep = [not any(set(t.tolist()) <= c for c in covered) for t in triangles]
    return triangles[np.asarray(keep)]


@lru_cache(maxsize=4)
def _canonical_rig_mesh(triangles_bytes: bytes, count: int, uvs_bytes: bytes, levels: int) -> RigMesh:
    triangles = np.frombuffer(triangles_bytes, np.int64).reshape(-1, 3)
    uvs = np.frombuffer(uvs_bytes, np.float64).reshape(-1, 2)
    faces = _openings(triangles)
    matrix = sparse.identity(count, format="csr")
    for _ in range(levels):
        step, faces = refine.loop_subdivision(matrix.shape[0], faces)
        matrix = (step @ matrix).tocsr()
    return RigMesh(matrix, np.asarray(faces, np.int64), np.asarray(matrix @ uvs), np.arange(468))


def rig_mesh(model: HeadModel, levels: int = 1) -> RigMesh:
    """The rig's mesh of ``model`` (module docstring); ``levels`` of Loop subdivision for the canonical
    topology."""
    if model.topology != CANONICAL:
        n = model.vertex_count
        return RigMesh(sparse.identity(n, format="csr"), np.asarray(model.triangles, np.int64), model.uvs,
                       np.asarray(model.landmarks, np.int64))
    mesh = _canonical_rig_mesh(np.ascontiguousarray(model.triangles, np.int64).tobytes(), model.vertex_count,
                               np.ascontiguousarray(model.uvs, np.float64).tobytes(), int(levels))
    return replace(mesh, landmarks=np.asarray(model.landmarks, np.int64))
