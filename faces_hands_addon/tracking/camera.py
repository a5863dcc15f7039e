# SPDX-License-Identifier: GPL-3.0-or-later
"""The camera model of the tracking system (thesis 6.3.1): a pinhole camera for short focal lengths [HS96]
with radial and tangential lens distortion to second order [JKS95].

Image coordinates are pixels, ``u`` to the right and ``v`` down, the centre of the top-left pixel at
(0.5, 0.5). The camera frame looks along +z with x right and y down; a world point ``X`` (metres, Z up) is
at ``x_c = R X + t`` in it. Normalised coordinates ``(x, y) = (x_c / z_c, y_c / z_c)`` are distorted as

    r^2 = x^2 + y^2
    x_d = x (1 + k1 r^2 + k2 r^4) + 2 p1 x y + p2 (r^2 + 2 x^2)
    y_d = y (1 + k1 r^2 + k2 r^4) + p1 (r^2 + 2 y^2) + 2 p2 x y

and ``u = fx x_d + cx``, ``v = fy y_d + cy``. Undistortion inverts this by fixed-point iteration.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import UserError

__all__ = ["Camera", "rotation_from_vector", "vector_from_rotation", "look_at"]


def rotation_from_vector(r: np.ndarray) -> np.ndarray:
    """Rodrigues: the rotation matrix of the rotation vector ``r`` (axis * angle, radians)."""
    r = np.asarray(r, np.float64)
    angle = float(np.linalg.norm(r))
    if angle < 1e-15:
        return np.eye(3)
    k = r / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def vector_from_rotation(m: np.ndarray) -> np.ndarray:
    """The rotation vector (axis * angle) of a rotation matrix, angle in [0, pi]."""
    m = np.asarray(m, np.float64)
    cosine = np.clip((np.trace(m) - 1.0) / 2.0, -1.0, 1.0)
    angle = float(np.arccos(cosine))
    axis = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
    if angle < 1e-12:
        return 0.5 * axis
    if np.pi - angle < 1e-6:                          # axis from the symmetric part
        s = (m + np.eye(3)) / 2.0
        k = np.sqrt(np.clip(np.diag(s), 0, None))
        i = int(np.argmax(k))
        k = s[:, i] / max(k[i], 1e-12)
        return k / np.linalg.norm(k) * angle
    return axis / (2.0 * np.sin(angle)) * angle


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """The world -> camera rotation of a camera at ``eye`` looking at ``target`` (image up ~ ``up``)."""
    z = np.asarray(target, np.float64) - np.asarray(eye, np.float64)
    z /= np.linalg.norm(z)
    x = np.cross(z, np.asarray(up, np.float64))
    if np.linalg.norm(x) < 1e-9:
        x = np.cross(z, [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z])


@dataclass
class Camera:
    """Intrinsics (``fx, fy, cx, cy`` pixels; ``distortion`` = k1, k2, p1, p2), extrinsics ``R`` (3, 3) and
    ``t`` (3,) (world -> camera) and the image size ``(width, height)``."""
    name: str
    size: tuple[int, int]
    fx: float
    fy: float
    cx: float
    cy: float
    distortion: np.ndarray = field(default_factory=lambda: np.zeros(4))
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    t: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        self.distortion = np.asarray(self.distortion, np.float64).reshape(4)
        self.R = np.asarray(self.R, np.float64).reshape(3, 3)
        self.t = np.asarray(self.t, np.float64).reshape(3)
        self.size = (int(self.size[0]), int(self.size[1]))

    # -- matrices ----------------------------------------------------------------------------------
    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def P(self) -> np.ndarray:
        """The 3x4 projection matrix of the undistorted image."""
        return self.K @ np.column_stack([self.R, self.t])

    @property
    def centre(self) -> np.ndarray:
        """The optical centre in world coordinates."""
        return -self.R.T @ self.t

    def undistorted(self) -> "Camera":
        """The same camera for its distortion-corrected image (no distortion left)."""
        return Camera(self.name, self.size, self.fx, self.fy, self.cx, self.cy, np.zeros(4), self.R, self.t)

    def with_pose(self, R: np.ndarray, t: np.ndarray) -> "Camera":
        return Camera(self.name, self.size, self.fx, self.fy, self.cx, self.cy, self.distortion.copy(), R, t)

    # -- projection --------------------------------------------------------------------------------
    def distort_normalised(self, xy: np.ndarray) -> np.ndarray:
        k1, k2, p1, p2 = self.distortion
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        radial = 1.0 + k1 * r2 + k2 * r2 * r2
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        return np.stack([xd, yd], axis=-1)

    def undistort_normalised(self, xy_d: np.ndarray, iterations: int = 20) -> np.ndarray:
        xy = np.array(xy_d, np.float64)
        if not np.any(self.distortion):
            return xy
        for _ in range(iterations):
            xy = xy + (xy_d - self.distort_normalised(xy))
        return xy

    def camera_points(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points, np.float64) @ self.R.T + self.t

    def project(self, points: np.ndarray, distorted: bool = True) -> np.ndarray:
        """Pixel coordinates (N, 2) of world ``points`` (N, 3); ``distorted=False``: in the undistorted image."""
        pc = self.camera_points(np.atleast_2d(points))
        xy = pc[:, :2] / pc[:, 2:3]
        if distorted:
            xy = self.distort_normalised(xy)
        return np.column_stack([self.fx * xy[:, 0] + self.cx, self.fy * xy[:, 1] + self.cy])

    def depth(self, points: np.ndarray) -> np.ndarray:
        return self.camera_points(np.atleast_2d(points))[:, 2]

    def normalised(self, pixels: np.ndarray, distorted: bool = True) -> np.ndarray:
        """Normalised undistorted image coordinates (N, 2) of ``pixels`` (N, 2)."""
        pixels = np.atleast_2d(np.asarray(pixels, np.float64))
        xy = np.column_stack([(pixels[:, 0] - self.cx) / self.fx, (pixels[:, 1] - self.cy) / self.fy])
        return self.undistort_normalised(xy) if distorted else xy

    def undistort_pixels(self, pixels: np.ndarray) -> np.ndarray:
        """Where ``pixels`` of the photo lie in the distortion-corrected image (same K)."""
        xy = self.normalised(pixels)
        return np.column_stack([self.fx * xy[:, 0] + self.cx, self.fy * xy[:, 1] + self.cy])

    def rays(self, pixels: np.ndarray, distorted: bool = True) -> np.ndarray:
        """Unit world directions (N, 3) of the rays through ``pixels``."""
        xy = self.normalised(pixels, distorted)
        d = np.column_stack([xy, np.ones(len(xy))]) @ self.R
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    # -- files -------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {"name": self.name, "size": list(self.size), "fx": float(self.fx), "fy": float(self.fy),
                "cx": float(self.cx), "cy": float(self.cy), "distortion": [float(v) for v in self.distortion],
                "rotation": [[float(v) for v in row] for row in self.R], "translation": [float(v) for v in self.t]}

    @classmethod
    def from_dict(cls, doc: dict, where: str = "camera") -> "Camera":
        try:
            camera = cls(str(doc["name"]), tuple(doc["size"]), float(doc["fx"]), float(doc["fy"]), float(doc["cx"]),
                         float(doc["cy"]), doc.get("distortion", [0, 0, 0, 0]), doc.get("rotation", np.eye(3)),
                         doc.get("translation", [0, 0, 0]))
        except (KeyError, TypeError, ValueError) as error:
            raise UserError(f"{where}: a camera needs name, size [w, h], fx, fy, cx, cy, distortion [k1, k2, p1, "
                            f"p2], rotation (3x3) and translation (3) ({error})") from None
        values = np.concatenate([[camera.fx, camera.fy, camera.cx, camera.cy], camera.distortion,
                                 camera.R.ravel(), camera.t])
        if not np.all(np.isfinite(values)) or camera.fx <= 0 or camera.fy <= 0 or min(camera.size) < 1:
            raise UserError(f"{where}: camera {camera.name!r} has a non-finite or non-positive parameter")
        if abs(np.linalg.det(camera.R) - 1.0) > 1e-3:
            raise UserError(f"{where}: camera {camera.name!r}: rotation is not a rotation matrix")
        return camera
