# SPDX-License-Identifier: GPL-3.0-or-later
"""Mirror-symmetric landmarks on mirror-symmetric heads (thesis 3.1.2 "Creating New Animatable Head Models
from the Template": feature points "must be placed at corresponding locations on the target skin mesh").

Most modelled heads (the MakeHuman base mesh, SOMA-X) are exactly left/right symmetric, but the template
registration (:mod:`.nicp`) is not: on the MakeHuman neutral head a landmark and its mirror partner
disagreed by up to 9.5 mm (median 0.8 mm), and the head space the rig is built in (the similarity onto the
canonical face) came out rolled by 0.6 degrees. Every left/right pair of expressions then moved differently
(jawOpen 6 mm apart at the 95th percentile). So when the mesh is its own mirror image, the landmarks are
made mirror images too:

1. the symmetry plane is estimated from the landmark pairs (the canonical face's ``mirror`` map), then
   refined on the mesh itself: the face's vertices are reflected, their closest points on the mesh found,
   and the plane moved (Gauss-Newton on its tilt and offset) to bring the reflections onto the tangent
   planes there (a point-to-plane iterated closest point fit of the reflection);
2. the mesh counts as symmetric when the reflected face lies on the mesh: median gap at most
   ``MEDIAN_GAP`` and 90th percentile at most ``P90_GAP`` of the face width;
3. each landmark becomes the mean of itself and its partner reflected, projected onto the mesh.

Heads that are not symmetric (scans, sculpted asymmetry) keep their landmarks as registered.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..core import geometry

__all__ = ["SymmetryPlane", "symmetry_plane", "reflect", "symmetric_landmarks", "MEDIAN_GAP", "P90_GAP"]

MEDIAN_GAP = 0.003      # of the face width (~0.4 mm on a 14-cm face): the reflected face lies on the mesh
P90_GAP = 0.012         # of the face width (~1.7 mm)
FACE_REACH = 0.08       # of the face width: mesh vertices this close to a landmark are the face's
ITERATIONS = 10


@dataclass(frozen=True)
class SymmetryPlane:
    """The plane ``x . normal = offset`` (unit ``normal`` towards the character's left) and how well the
    face's reflection lies on the mesh (gaps as fractions of the face width)."""
    normal: np.ndarray
    offset: float
    median_gap: float
    p90_gap: float

    @property
    def symmetric(self) -> bool:
        return self.median_gap <= MEDIAN_GAP and self.p90_gap <= P90_GAP


def reflect(points: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """``points`` mirrored through the plane ``x . normal = offset``."""
    points = np.asarray(points, np.float64)
    return points - 2.0 * (points @ normal - offset)[..., None] * normal


def _plane_step(points: np.ndarray, normal: np.ndarray, offset: float, vertices: np.ndarray, faces: np.ndarray,
                triangle_normals: np.ndarray) -> tuple[np.ndarray, float]:
    """One Gauss-Newton step of the plane: the reflections of ``points`` onto the tangent planes of their
    closest mesh points. The normal tilts by ``a e1 + b e2`` and the offset moves by ``g``; with
    ``h = x . n - c`` the reflection ``x - 2 h n`` changes by ``-2 ((x . dn - g) n + h dn)``."""
    mirrored = reflect(points, normal, offset)
    closest, tri = geometry.closest_points(vertices, faces, mirrored)[:2]
    m = triangle_normals[tri]
    e1 = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    h = points @ normal - offset
    mn = m @ normal
    rows = np.stack([-2.0 * ((points @ e) * mn + h * (m @ e)) for e in (e1, e2)] + [2.0 * mn], axis=1)
    residual = np.einsum("ij,ij->i", mirrored - closest, m)
    a, b, g = np.linalg.lstsq(rows, -residual, rcond=None)[0]
    normal = normal + a * e1 + b * e2
    return normal / np.linalg.norm(normal), offset + float(g)


def symmetry_plane(landmarks: np.ndarray, mirror: np.ndarray, left: np.ndarray, vertices: np.ndarray,
                   faces: np.ndarray, face_width: float) -> SymmetryPlane:
    """The mesh's left/right symmetry plane near the face (module docstring, steps 1-2). ``mirror``: each
    landmark's partner; ``left``: the landmarks on the character's left (their partners on the right)."""
    landmarks = np.asarray(landmarks, np.float64)
    pairs = np.flatnonzero(left & (mirror != np.arange(len(mirror))))
    normal = (landmarks[pairs] - landmarks[mirror[pairs]]).sum(axis=0)
    normal /= max(float(np.linalg.norm(normal)), 1e-30)
    offset = float(np.median(0.5 * (landmarks + landmarks[mirror]) @ normal))
    used = np.unique(faces)
    near = cKDTree(landmarks).query(vertices[used], distance_upper_bound=FACE_REACH * face_width)[0]
    face = vertices[used[np.isfinite(near)]]
    if len(face) < 3:
        return SymmetryPlane(normal, offset, np.inf, np.inf)
    triangle_normals = geometry.face_normals(vertices, faces)
    for _ in range(ITERATIONS):
        normal, offset = _plane_step(face, normal, offset, vertices, faces, triangle_normals)
    gap = np.linalg.norm(geometry.closest_points(vertices, faces, reflect(face, normal, offset))[0]
                         - reflect(face, normal, offset), axis=1) / face_width
    return SymmetryPlane(normal, offset, float(np.median(gap)), float(np.percentile(gap, 90)))


def symmetric_landmarks(landmarks: np.ndarray, mirror: np.ndarray, plane: SymmetryPlane) -> np.ndarray:
    """Each landmark averaged with its partner's reflection (step 3, before the projection onto the mesh);
    landmarks on the midline land on the plane."""
    landmarks = np.asarray(landmarks, np.float64)
    return 0.5 * (landmarks + reflect(landmarks[mirror], plane.normal, plane.offset))
