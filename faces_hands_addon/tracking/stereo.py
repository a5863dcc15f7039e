# SPDX-License-Identifier: GPL-3.0-or-later
"""Stereo geometry of the tracking system (thesis 6.3.2, Fig. 6.27): epipolar lines, correspondences along
them, triangulation.

All functions take pixel coordinates of the *photos* (distorted) and calibrated :class:`.camera.Camera`s;
they undistort internally (6.3.1: "each multi-exposure image is distortion-corrected prior to any further
processing"), so an epipolar line is a straight line in normalised coordinates.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from .camera import Camera

__all__ = ["essential", "epipolar_distances", "triangulate", "match_pair", "reprojection_errors",
           "Correspondence"]


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def essential(first: Camera, second: Camera) -> np.ndarray:
    """E with ``x2^T E x1 = 0`` for normalised homogeneous coordinates of the same world point."""
    R = second.R @ first.R.T
    t = second.t - R @ first.t
    return _skew(t) @ R


def epipolar_distances(first: Camera, second: Camera, pixels1: np.ndarray, pixels2: np.ndarray) -> np.ndarray:
    """(N1, N2) symmetric distances, in pixels of the second camera's undistorted image, between each point of
    the second photo and the epipolar line of each point of the first (and vice versa, averaged)."""
    x1 = np.column_stack([first.normalised(pixels1), np.ones(len(pixels1))])
    x2 = np.column_stack([second.normalised(pixels2), np.ones(len(pixels2))])
    E = essential(first, second)
    lines2 = x1 @ E.T                      # (N1, 3) lines in image 2
    lines1 = x2 @ E                        # (N2, 3) lines in image 1
    algebraic = x1 @ E.T @ x2.T            # (N1, N2) = x2^T E x1
    d2 = np.abs(algebraic) / np.linalg.norm(lines2[:, :2], axis=1)[:, None] * second.fx
    d1 = np.abs(algebraic) / np.linalg.norm(lines1[:, :2], axis=1)[None, :] * first.fx
    return 0.5 * (d1 + d2)


def triangulate(cameras: list[Camera], pixels: list[np.ndarray], refine: bool = True) -> np.ndarray:
    """World points (N, 3) seen at ``pixels[c][n]`` in each camera ``c`` (NaN rows: not seen there): linear
    (DLT on normalised coordinates) then, with ``refine``, Gauss-Newton on the reprojection error."""
    count = len(pixels[0])
    out = np.full((count, 3), np.nan)
    normal = [cam.normalised(p) if len(p) else np.zeros((0, 2)) for cam, p in zip(cameras, pixels)]
    poses = [np.column_stack([cam.R, cam.t]) for cam in cameras]
    for n in range(count):
        rows = []
        for c, xy in enumerate(normal):
            if np.all(np.isfinite(xy[n])):
                rows += [xy[n, 0] * poses[c][2] - poses[c][0], xy[n, 1] * poses[c][2] - poses[c][1]]
        if len(rows) < 4:
            continue
        _, _, vt = np.linalg.svd(np.array(rows))
        point = vt[-1, :3] / vt[-1, 3]
        if refine:
            point = _refine(point, [(poses[c], normal[c][n]) for c in range(len(cameras))
                                    if np.all(np.isfinite(normal[c][n]))])
        out[n] = point
    return out


def _refine(point: np.ndarray, views: list, steps: int = 5) -> np.ndarray:
    for _ in range(steps):
        residual, jacobian = [], []
        for pose, xy in views:
            pc = pose[:, :3] @ point + pose[:, 3]
            z = pc[2]
            residual += [pc[0] / z - xy[0], pc[1] / z - xy[1]]
            jacobian += [(pose[0, :3] - pc[0] / z * pose[2, :3]) / z, (pose[1, :3] - pc[1] / z * pose[2, :3]) / z]
        J, r = np.array(jacobian), np.array(residual)
        step, *_ = np.linalg.lstsq(J, -r, rcond=None)
        point = point + step
        if np.linalg.norm(step) < 1e-10:
            break
    return point


def reprojection_errors(cameras: list[Camera], pixels: list[np.ndarray], points: np.ndarray) -> np.ndarray:
    """(N, C) pixel distances between ``pixels`` and the projections of ``points`` (NaN where not seen)."""
    out = np.full((len(points), len(cameras)), np.nan)
    for c, cam in enumerate(cameras):
        seen = np.all(np.isfinite(pixels[c]), axis=1) & np.all(np.isfinite(points), axis=1)
        if np.any(seen):
            out[seen, c] = np.linalg.norm(cam.project(points[seen]) - pixels[c][seen], axis=1)
    return out


class Correspondence:
    """Pairs (i, j) of detections in two photos of a stereo pair, found along epipolar lines."""

    def __init__(self, pairs: np.ndarray, distances: np.ndarray):
        self.pairs, self.distances = pairs, distances


def match_pair(first: Camera, second: Camera, pixels1: np.ndarray, pixels2: np.ndarray,
               classes1: np.ndarray | None = None, classes2: np.ndarray | None = None,
               tolerance: float = 3.0, depth_range: tuple[float, float] = (0.2, 60.0)) -> Correspondence:
    """Correspondences between detections of the same class whose symmetric epipolar distance is below
    ``tolerance`` pixels and whose triangulated point lies in front of both cameras within ``depth_range``
    metres; each detection used at most once (the assignment with the smallest total distance)."""
    if len(pixels1) == 0 or len(pixels2) == 0:
        return Correspondence(np.zeros((0, 2), np.int64), np.zeros(0))
    cost = epipolar_distances(first, second, pixels1, pixels2)
    if classes1 is not None:
        cost = np.where(np.asarray(classes1)[:, None] == np.asarray(classes2)[None, :], cost, np.inf)
    allowed = cost <= tolerance
    if not np.any(allowed):
        return Correspondence(np.zeros((0, 2), np.int64), np.zeros(0))
    i, j = np.nonzero(allowed)
    pts = triangulate([first, second], [pixels1[i], pixels2[j]], refine=False)
    depth_ok = np.all([(cam.depth(pts) > depth_range[0]) & (cam.depth(pts) < depth_range[1])
                       for cam in (first, second)], axis=0)
    allowed[i[~depth_ok], j[~depth_ok]] = False
    big = 1e6
    rows, cols = linear_sum_assignment(np.where(allowed, cost, big))
    keep = allowed[rows, cols]
    pairs = np.column_stack([rows[keep], cols[keep]]).astype(np.int64)
    return Correspondence(pairs, cost[rows[keep], cols[keep]])
