# SPDX-License-Identifier: GPL-3.0-or-later
"""Camera calibration (thesis 6.3.1): intrinsics from photos of a planar checkerboard (Zhang's closed form from
the board's homographies, then Levenberg-Marquardt on the reprojection error with radial and tangential
distortion to second order [JKS95]) and extrinsics from a photo of a 3D calibration object with known points
(linear DLT with the intrinsics known, then Levenberg-Marquardt). "Camera position and orientation are
metrically calibrated": the object's points are in world metres, so the cameras are too.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from ..core.errors import UserError
from .camera import Camera, rotation_from_vector, vector_from_rotation
from .checkerboard import homography

__all__ = ["calibrate_intrinsics", "solve_pose", "board_points", "Intrinsics", "mean_reprojection"]


class Intrinsics:
    """The result of :func:`calibrate_intrinsics`: a camera at the origin and the mean reprojection error."""

    def __init__(self, camera: Camera, error_px: float, views: int):
        self.camera, self.error_px, self.views = camera, error_px, views


def board_points(inner: tuple[int, int], square: float) -> np.ndarray:
    """The board's inner corners (rows * columns, 3) in its own plane (z = 0), row by row, metres."""
    cols, rows = inner
    return np.array([[c * square, r * square, 0.0] for r in range(rows) for c in range(cols)])


def _v(h: np.ndarray, i: int, j: int) -> np.ndarray:
    a, b = h[:, i], h[:, j]
    return np.array([a[0] * b[0], a[0] * b[1] + a[1] * b[0], a[1] * b[1], a[2] * b[0] + a[0] * b[2],
                     a[2] * b[1] + a[1] * b[2], a[2] * b[2]])


def _zhang(homographies: list[np.ndarray]) -> np.ndarray:
    """Zhang's closed-form K (zero skew) from >= 3 plane homographies."""
    rows = []
    for h in homographies:
        rows += [_v(h, 0, 1), _v(h, 0, 0) - _v(h, 1, 1)]
    rows.append([0, 1, 0, 0, 0, 0])                      # zero skew
    _, _, vt = np.linalg.svd(np.array(rows))
    b11, b12, b22, b13, b23, b33 = vt[-1]
    if b11 < 0:
        b11, b12, b22, b13, b23, b33 = -vt[-1]
    v0 = (b12 * b13 - b11 * b23) / (b11 * b22 - b12 ** 2)
    lam = b33 - (b13 ** 2 + v0 * (b12 * b13 - b11 * b23)) / b11
    if lam / b11 <= 0 or lam * b11 / (b11 * b22 - b12 ** 2) <= 0:
        raise UserError("the checkerboard photos do not determine the camera; photograph the board at several "
                        "clearly different tilts")
    alpha = np.sqrt(lam / b11)
    beta = np.sqrt(lam * b11 / (b11 * b22 - b12 ** 2))
    u0 = -b13 * alpha ** 2 / lam
    return np.array([[alpha, 0, u0], [0, beta, v0], [0, 0, 1]])


def _pose_from_homography(K: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    m = np.linalg.inv(K) @ h
    scale = 1.0 / np.linalg.norm(m[:, 0])
    if (scale * m[:, 2])[2] < 0:
        scale = -scale
    r1, r2, t = scale * m[:, 0], scale * m[:, 1], scale * m[:, 2]
    u, _, vt = np.linalg.svd(np.column_stack([r1, r2, np.cross(r1, r2)]))
    R = u @ vt
    if np.linalg.det(R) < 0:
        R = u @ np.diag([1, 1, -1]) @ vt
    return R, t


def _residuals(params: np.ndarray, objects: list[np.ndarray], images: list[np.ndarray], size) -> np.ndarray:
    fx, fy, cx, cy, *dist = params[:8]
    out = []
    for k, (obj, img) in enumerate(zip(objects, images)):
        r, t = params[8 + 6 * k: 11 + 6 * k], params[11 + 6 * k: 14 + 6 * k]
        cam = Camera("board", size, fx, fy, cx, cy, dist, rotation_from_vector(r), t)
        out.append((cam.project(obj) - img).ravel())
    return np.concatenate(out)


def calibrate_intrinsics(views: list[np.ndarray], inner: tuple[int, int], square: float, size: tuple[int, int],
                         name: str = "camera") -> Intrinsics:
    """Intrinsics and distortion from the checkerboard corners found in >= 3 photos (``views``: (N, 2) each,
    row by row, as :func:`.checkerboard.find_corners` gives them)."""
    if len(views) < 3:
        raise UserError(f"{name}: {len(views)} checkerboard photos; calibration needs at least 3 at different tilts")
    obj = board_points(inner, square)
    hs = [homography(obj[:, :2], v) for v in views]
    K = _zhang(hs)
    params = [K[0, 0], K[1, 1], K[0, 2], K[1, 2], 0.0, 0.0, 0.0, 0.0]
    for h in hs:
        R, t = _pose_from_homography(K, h)
        params += list(vector_from_rotation(R)) + list(t)
    fit = least_squares(_residuals, np.array(params), method="lm", args=([obj] * len(views), views, size),
                        x_scale="jac", max_nfev=400)
    fx, fy, cx, cy, *dist = fit.x[:8]
    camera = Camera(name, size, fx, fy, cx, cy, dist)
    error = float(np.mean(np.linalg.norm(fit.fun.reshape(-1, 2), axis=1)))
    return Intrinsics(camera, error, len(views))


def solve_pose(camera: Camera, object_points: np.ndarray, pixels: np.ndarray, refine: bool = True) -> tuple[Camera, float]:
    """``camera`` (intrinsics known) placed in the world from >= 6 known non-coplanar ``object_points``
    (N, 3) seen at ``pixels`` (N, 2): DLT on undistorted normalised coordinates, then Levenberg-Marquardt.
    Returns the posed camera and its mean reprojection error (pixels)."""
    object_points = np.asarray(object_points, np.float64)
    if len(object_points) < 6:
        raise UserError(f"{camera.name}: only {len(object_points)} points of the calibration object were found; "
                        "at least 6 must be visible")
    xy = camera.normalised(pixels)
    rows = []
    for (X, Y, Z), (x, y) in zip(object_points, xy):
        rows.append([X, Y, Z, 1, 0, 0, 0, 0, -x * X, -x * Y, -x * Z, -x])
        rows.append([0, 0, 0, 0, X, Y, Z, 1, -y * X, -y * Y, -y * Z, -y])
    _, _, vt = np.linalg.svd(np.array(rows))
    m = vt[-1].reshape(3, 4)
    u, s, wt = np.linalg.svd(m[:, :3])
    scale = 1.0 / np.mean(s)
    R = u @ wt
    if np.linalg.det(R) < 0:
        R, scale = -R, -scale
    t = scale * m[:, 3]
    if np.mean(camera.with_pose(R, t).depth(object_points)) < 0:
        R, t = np.diag([-1.0, -1.0, 1.0]) @ R, np.diag([-1.0, -1.0, 1.0]) @ t
    if abs(np.linalg.det(R) - 1.0) > 1e-6:
        raise UserError(f"{camera.name}: the calibration object's points are coplanar or misidentified")
    if not refine:
        posed = camera.with_pose(R, t)
        return posed, float(np.mean(np.linalg.norm(posed.project(object_points) - pixels, axis=1)))

    def residual(p):
        return (camera.with_pose(rotation_from_vector(p[:3]), p[3:]).project(object_points) - pixels).ravel()

    fit = least_squares(residual, np.concatenate([vector_from_rotation(R), t]), method="lm")
    posed = camera.with_pose(rotation_from_vector(fit.x[:3]), fit.x[3:])
    return posed, float(np.mean(np.linalg.norm(fit.fun.reshape(-1, 2), axis=1)))


def mean_reprojection(camera: Camera, points: np.ndarray, pixels: np.ndarray) -> float:
    return float(np.mean(np.linalg.norm(camera.project(points) - pixels, axis=1)))
