# SPDX-License-Identifier: GPL-3.0-or-later
"""Inner corners of a planar checkerboard in a photo (thesis 6.3.1: "intrinsic camera parameters are
estimated from images of a planar checkerboard pattern"), with numpy/scipy only.

1. *Saddle response*: where four squares meet the smoothed image is a saddle, so ``-(Ixx Iyy - Ixy^2)`` of its
   Hessian peaks there and nowhere on edges or flat squares; local maxima above a fraction of the strongest
   are candidates.
2. *Sub-pixel*: a quadratic surface fitted to the smoothed intensity around each candidate; its stationary
   point is the corner.
3. *Grid order*: the board's outer corners are the four hull vertices spanning the largest quadrilateral;
   the homography taking the grid's four outer corners onto them predicts every inner corner (a plane maps to
   the image by a homography; lens distortion only bends it a little), each prediction takes the nearest
   candidate, and the homography refitted to all of them predicts again.
"""
from __future__ import annotations

import itertools

import numpy as np
from scipy import ndimage
from scipy.spatial import ConvexHull

from ..core.errors import UserError

__all__ = ["find_corners", "homography", "apply_homography", "luminance"]


def luminance(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image, np.float64)
    if image.ndim == 2:
        return image
    return image[..., :3] @ np.array([0.2126, 0.7152, 0.0722])


def homography(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The 3x3 homography taking ``source`` (N, 2) onto ``target`` (N, 2), normalised DLT (N >= 4)."""
    def normaliser(p):
        mean = p.mean(axis=0)
        scale = np.sqrt(2.0) / max(np.mean(np.linalg.norm(p - mean, axis=1)), 1e-12)
        return np.array([[scale, 0, -scale * mean[0]], [0, scale, -scale * mean[1]], [0, 0, 1]])
    ts, tt = normaliser(source), normaliser(target)
    s = apply_homography(ts, source)
    t = apply_homography(tt, target)
    rows = []
    for (x, y), (u, v) in zip(s, t):
        rows.append([-x, -y, -1, 0, 0, 0, u * x, u * y, u])
        rows.append([0, 0, 0, -x, -y, -1, v * x, v * y, v])
    _, _, vt = np.linalg.svd(np.array(rows))
    h = np.linalg.inv(tt) @ vt[-1].reshape(3, 3) @ ts
    return h / h[2, 2]


def apply_homography(h: np.ndarray, points: np.ndarray) -> np.ndarray:
    p = np.column_stack([points, np.ones(len(points))]) @ h.T
    return p[:, :2] / p[:, 2:3]


def _candidates(gray: np.ndarray, sigma: float, fraction: float, spacing: int) -> tuple[np.ndarray, np.ndarray]:
    smooth = ndimage.gaussian_filter(gray, sigma)
    gy, gx = np.gradient(smooth)
    gyy, gyx = np.gradient(gy)
    gxy, gxx = np.gradient(gx)
    response = -(gxx * gyy - gxy * gyx)
    peak = response == ndimage.maximum_filter(response, size=spacing)
    strong = response > fraction * max(float(response.max()), 1e-12)
    rows, cols = np.nonzero(peak & strong)
    border = 3
    keep = (rows >= border) & (cols >= border) & (rows < gray.shape[0] - border) & (cols < gray.shape[1] - border)
    return np.column_stack([cols[keep], rows[keep]]).astype(np.float64), smooth


def _subpixel(smooth: np.ndarray, points: np.ndarray, half: int = 2) -> np.ndarray:
    """Stationary point of a quadratic fitted to the smoothed image in a (2 half + 1)^2 window."""
    dy, dx = np.mgrid[-half:half + 1, -half:half + 1]
    design = np.column_stack([dx.ravel() ** 2, dx.ravel() * dy.ravel(), dy.ravel() ** 2, dx.ravel(), dy.ravel(),
                              np.ones(dx.size)])
    pinv = np.linalg.pinv(design)
    out = points.copy()
    for k, (x, y) in enumerate(points.astype(int)):
        patch = smooth[y - half:y + half + 1, x - half:x + half + 1]
        if patch.shape != dx.shape:
            continue
        a, b, c, d, e, _ = pinv @ patch.ravel()
        det = 4 * a * c - b * b
        if abs(det) < 1e-12:
            continue
        offset = np.array([(-2 * c * d + b * e) / det, (b * d - 2 * a * e) / det])
        if np.all(np.abs(offset) <= 1.0):
            out[k] = [x + offset[0] + 0.5, y + offset[1] + 0.5]       # pixel centres at +0.5
        else:
            out[k] = [x + 0.5, y + 0.5]
    return out


def _x_junctions(smooth: np.ndarray, points: np.ndarray, radius: float) -> np.ndarray:
    """Keep the candidates that look like a checkerboard corner: on a circle around it the image is point
    symmetric (opposite samples alike) and changes by a quarter turn (a T-junction at the board's rim or a
    blob is not)."""
    angles = np.linspace(0.0, 2 * np.pi, 16, endpoint=False)
    offsets = radius * np.column_stack([np.cos(angles), np.sin(angles)])
    xy = points[:, None, :] - 0.5 + offsets[None]
    ring = ndimage.map_coordinates(smooth, [xy[..., 1].ravel(), xy[..., 0].ravel()], order=1,
                                   mode="nearest").reshape(len(points), 16)
    symmetric = np.mean(np.abs(ring - np.roll(ring, 8, axis=1)), axis=1)
    quarter = np.mean(np.abs(ring - np.roll(ring, 4, axis=1)), axis=1)
    contrast = np.ptp(ring, axis=1)
    return points[(quarter > 2.5 * symmetric) & (contrast > 0.25)]


def _outer_quad(points: np.ndarray) -> np.ndarray:
    hull = points[ConvexHull(points).vertices]
    if len(hull) > 12:                                  # keep the sharpest hull vertices
        turn = []
        for i in range(len(hull)):
            a, b = hull[i - 1] - hull[i], hull[(i + 1) % len(hull)] - hull[i]
            turn.append(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b) + 1e-12))
        hull = hull[np.sort(np.argsort(turn)[-12:])]
    best, best_area = None, -1.0
    for quad in itertools.combinations(range(len(hull)), 4):
        q = hull[list(quad)]
        area = 0.5 * abs(np.dot(q[:, 0], np.roll(q[:, 1], -1)) - np.dot(q[:, 1], np.roll(q[:, 0], -1)))
        if area > best_area:
            best, best_area = q, area
    return best


def _edge_counts(quad: np.ndarray, points: np.ndarray, spacing: float) -> list[int]:
    counts = []
    for i in range(4):
        a, b = quad[i], quad[(i + 1) % 4]
        d = b - a
        n = np.array([-d[1], d[0]]) / np.linalg.norm(d)
        along = (points - a) @ d / (d @ d)
        counts.append(int(np.sum((np.abs((points - a) @ n) < 0.3 * spacing) & (along > -0.1) & (along < 1.1))))
    return counts


def find_corners(image: np.ndarray, inner: tuple[int, int], sigma: float | None = None) -> np.ndarray:
    """The ``inner = (columns, rows)`` inner corners of a checkerboard in ``image`` as (rows * columns, 2)
    pixel positions, row by row. A UserError when the board is not found completely."""
    cols, rows = inner
    gray = luminance(image)
    gray = (gray - gray.min()) / max(float(np.ptp(gray)), 1e-12)
    sigma = sigma or max(1.0, min(gray.shape) / 400.0)
    for fraction in (0.15, 0.05, 0.02):
        points, smooth = _candidates(gray, sigma, fraction, max(5, int(4 * sigma)))
        points = _x_junctions(smooth, _subpixel(smooth, points), 2.5 * sigma)
        if len(points) >= cols * rows:
            found = _grid(points, cols, rows)
            if found is not None:
                return found
    raise UserError(f"no {cols}x{rows} checkerboard found in the photo; the whole board must be visible, "
                    "sharp and lit")


def _grid(points: np.ndarray, cols: int, rows: int) -> np.ndarray | None:
    if len(points) < 4:
        return None
    tree_d = np.sort(np.linalg.norm(points[:, None] - points[None], axis=2), axis=1)[:, 1]
    spacing = float(np.median(tree_d))
    quad = _outer_quad(points)
    counts = _edge_counts(quad, points, spacing)
    if abs(counts[0] - cols) + abs(counts[2] - cols) > abs(counts[1] - cols) + abs(counts[3] - cols):
        quad = np.roll(quad, -1, axis=0)
    grid = np.array([[c, r] for r in range(rows) for c in range(cols)], np.float64)
    outer = np.array([[0, 0], [cols - 1, 0], [cols - 1, rows - 1], [0, rows - 1]], np.float64)
    h = homography(outer, quad)
    for _ in range(3):
        predicted = apply_homography(h, grid)
        d = np.linalg.norm(predicted[:, None] - points[None], axis=2)
        nearest = np.argmin(d, axis=1)
        if np.any(d[np.arange(len(grid)), nearest] > 0.35 * spacing) or len(set(nearest)) < len(grid):
            return None
        h = homography(grid, points[nearest])
    return points[nearest]
