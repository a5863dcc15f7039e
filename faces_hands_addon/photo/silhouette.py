# SPDX-License-Identifier: GPL-3.0-or-later
"""The silhouette term of the photo fit (thesis 3.2.4: the model is refined "until the difference between the
face in the original image and a rendering of the textured 3D face model is sufficiently small" -- where the
face turns away from the camera, that difference is its outline).

Each fit round, the model's occluding contour in a view is found: vertices of the face (not on the mesh's
own border) whose surface is seen edge-on (``|cos| <`` :data:`GRAZING`). For each, the picture is searched
along the contour's image normal, within :data:`SEARCH` inter-ocular distances, for the strongest colour edge
running along the contour (gradient of the blurred luminance, its direction within 45 degrees of the normal,
its strength above :data:`MIN_EDGE` times the region's median gradient); the vertex is then pulled along the
normal towards that edge (a point-to-line residual, weight ``1 / sigma_edge``). Vertices without such an edge
add nothing.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..core import geometry
from ..core.refine import boundary_loops
from .camera import Camera, skew

__all__ = ["EdgeMap", "contour_targets", "edge_residuals", "GRAZING", "SEARCH"]

GRAZING = 0.25
SEARCH = 0.08
MIN_EDGE = 4.0


@dataclass
class EdgeMap:
    """Gradients of a picture's blurred luminance inside ``window`` (x0, y0, x1, y1)."""
    gx: np.ndarray
    gy: np.ndarray
    window: tuple[int, int, int, int]
    typical: float

    @classmethod
    def of(cls, pixels_srgb: np.ndarray, landmarks: np.ndarray) -> "EdgeMap":
        """Edges around the face of ``landmarks`` (478, 3), blurred at 2 % of its inter-ocular distance."""
        h, w = pixels_srgb.shape[:2]
        xy = landmarks[:, :2]
        size = float(np.ptp(xy, axis=0).max())
        x0, y0 = np.maximum(np.floor(xy.min(axis=0) - 0.35 * size).astype(int), 0)
        x1, y1 = np.minimum(np.ceil(xy.max(axis=0) + 0.35 * size).astype(int), [w, h])
        grey = pixels_srgb[y0:y1, x0:x1] @ np.array([0.2126, 0.7152, 0.0722], np.float32)
        iod = float(np.linalg.norm(landmarks[468, :2] - landmarks[473, :2])) if len(landmarks) > 473 else size / 3
        grey = ndimage.gaussian_filter(grey, max(0.02 * iod, 0.7))
        gx, gy = ndimage.sobel(grey, axis=1) / 8.0, ndimage.sobel(grey, axis=0) / 8.0
        typical = float(np.median(np.hypot(gx, gy))) + 1e-6
        return cls(gx, gy, (int(x0), int(y0), int(x1), int(y1)), typical)

    def along(self, points: np.ndarray, normals: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """(P, S) edge strength across the normal at ``points + offsets[s] * normals`` (bilinear)."""
        samples = points[:, None, :] + offsets[None, :, None] * normals[:, None, :]
        coords = [samples[..., 1] - self.window[1] - 0.5, samples[..., 0] - self.window[0] - 0.5]
        gx = ndimage.map_coordinates(self.gx, coords, order=1, mode="nearest")
        gy = ndimage.map_coordinates(self.gy, coords, order=1, mode="nearest")
        across = np.abs(gx * normals[:, None, 0] + gy * normals[:, None, 1])
        aligned = across >= 0.7 * np.hypot(gx, gy)
        return np.where(aligned, across, 0.0)


def contour_targets(problem, index: int, camera: Camera, alpha: np.ndarray):
    """(vertex ids, edge points (K, 2), image normals (K, 2)) of view ``index`` (module docstring), or None."""
    view = problem.views[index]
    edges: EdgeMap | None = view.edges
    if edges is None:
        return None
    model = problem.model
    shape = model.shape(alpha) + getattr(problem, "correction", 0.0)
    normals = geometry.vertex_normals(shape, model.triangles)
    rays = camera.to_camera(shape)
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    cosine = -((normals @ camera.rotation.T) * rays).sum(axis=1)
    border = np.zeros(model.vertex_count, bool)
    for loop in boundary_loops(model.triangles):
        border[loop] = True
    ids = np.flatnonzero((np.abs(cosine) < GRAZING) & (cosine > -0.05) & ~border & model.face)
    if not len(ids):
        return None
    pixels = camera.project(shape[ids])[0]
    ahead = camera.project(shape[ids] + 0.002 * normals[ids])[0]
    image_normals = ahead - pixels
    image_normals /= np.maximum(np.linalg.norm(image_normals, axis=1, keepdims=True), 1e-9)
    reach = SEARCH * max(view.inter_ocular, 1.0)
    offsets = np.linspace(-reach, reach, 25)
    strength = edges.along(pixels, image_normals, offsets)
    best = strength.argmax(axis=1)
    good = strength[np.arange(len(ids)), best] > MIN_EDGE * edges.typical
    if not good.any():
        return None
    points = pixels[good] + offsets[best[good], None] * image_normals[good]
    return ids[good], points, image_normals[good]


def edge_residuals(problem, index: int, camera: Camera, alpha: np.ndarray, targets):
    """Residual rows (K,) and their Jacobian (K, 7 views + k) of the silhouette term."""
    ids, points, normals = targets
    model, s = problem.model, problem.settings
    rows = model.basis.reshape(model.vertex_count, 3, -1)[ids]
    shape = model.shape(alpha)[ids]
    cam = camera.to_camera(shape)
    z = cam[:, 2]
    uv = camera.focal * cam[:, :2] / z[:, None] + camera.centre
    scale = 1.0 / (s.sigma_edge * max(problem.views[index].inter_ocular, 1.0))
    residual = ((uv - points) * normals).sum(axis=1) * scale
    d_uv = np.zeros((len(ids), 2, 3))
    d_uv[:, 0, 0] = d_uv[:, 1, 1] = camera.focal / z
    d_uv[:, :, 2] = -camera.focal * cam[:, :2] / z[:, None] ** 2
    d_n = np.einsum("kj,kjc->kc", normals, d_uv)                                  # (K, 3)
    width = 7 * len(problem.views) + problem.k
    jac = np.zeros((len(ids), width))
    d_w = -skew(shape @ camera.rotation.T)
    jac[:, 7 * index:7 * index + 3] = np.einsum("kc,kcj->kj", d_n, d_w) * scale
    jac[:, 7 * index + 3:7 * index + 6] = d_n * scale
    jac[:, 7 * index + 6] = ((uv - camera.centre) * normals).sum(axis=1) * scale
    jac[:, 7 * len(problem.views):] = np.einsum("kc,kcj->kj", d_n @ camera.rotation, rows) * scale
    return residual, jac
