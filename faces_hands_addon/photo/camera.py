# SPDX-License-Identifier: GPL-3.0-or-later
"""The camera of a photograph (thesis 3.2.4: "rendering parameters such as camera position, image plane
position and rotation"): a pinhole with its principal point at the picture's centre, a focal length in
pixels, and the head's pose.

Frames: the model's (metres, Z up, the face looks along -Y, +X the character's left) and the camera's as in
computer vision (x right, y down, z forward into the picture). A model point ``X`` is at ``R X + t`` in the
camera and at ``(f x / z + cx, f y / z + cy)`` in the picture (pixel centres at +0.5). A head facing the
camera has ``R = FRONT``. :meth:`Camera.blender_matrix` gives the camera object's world matrix for Blender
(local -Z forward, +Y up) when the head stays at the origin.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Camera", "FRONT", "rotation", "focal_from_35mm", "focal_to_35mm", "yaw_pitch_roll", "skew"]

FRONT = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
DIAGONAL_35MM = float(np.hypot(36.0, 24.0))      # mm: what "35 mm equivalent" focal lengths refer to


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices: (..., 3) -> (..., 3, 3) with ``skew(a) @ b = a x b``."""
    v = np.asarray(v, np.float64)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def rotation(axis_angle: np.ndarray) -> np.ndarray:
    """Rodrigues: the rotation of an axis-angle vector (radians)."""
    w = np.asarray(axis_angle, np.float64)
    angle = float(np.linalg.norm(w))
    if angle < 1e-12:
        return np.eye(3) + skew(w)
    k = skew(w / angle)
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def focal_from_35mm(focal_35mm: float, width: int, height: int) -> float:
    """Pixels from a 35 mm equivalent focal length (it refers to the 43.3 mm diagonal)."""
    return float(focal_35mm) * float(np.hypot(width, height)) / DIAGONAL_35MM


def focal_to_35mm(focal_px: float, width: int, height: int) -> float:
    return float(focal_px) * DIAGONAL_35MM / float(np.hypot(width, height))


def yaw_pitch_roll(r: np.ndarray) -> tuple[float, float, float]:
    """Degrees the head is turned from facing the camera: yaw (about its up axis; positive: it looks towards
    the picture's left), pitch (about its left axis; positive: it looks down) and roll (about the viewing
    axis), from the rotation of the head relative to :data:`FRONT`."""
    relative = FRONT.T @ r                        # the head's rotation in its own frame
    forward = relative @ np.array([0.0, -1.0, 0.0])
    yaw = np.degrees(np.arctan2(-forward[0], -forward[1]))
    pitch = np.degrees(np.arcsin(np.clip(-forward[2], -1.0, 1.0)))
    left = relative @ np.array([1.0, 0.0, 0.0])
    roll = np.degrees(np.arctan2(left[2], np.hypot(left[0], left[1])))
    return float(yaw), float(pitch), float(roll)


@dataclass
class Camera:
    """A photograph's camera (module docstring); ``width`` x ``height`` the picture in pixels."""
    width: int
    height: int
    focal: float
    rotation: np.ndarray = field(default_factory=lambda: FRONT.copy())
    translation: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.6]))

    @property
    def centre(self) -> np.ndarray:
        return np.array([self.width / 2.0, self.height / 2.0])

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points, np.float64) @ self.rotation.T + self.translation

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, 2) pixel positions and (N,) depths of model points."""
        cam = self.to_camera(points)
        z = cam[:, 2]
        safe = np.where(np.abs(z) < 1e-9, 1e-9, z)
        return self.focal * cam[:, :2] / safe[:, None] + self.centre, z

    def view_directions(self, points: np.ndarray) -> np.ndarray:
        """Unit vectors from the camera to each model point, in model coordinates."""
        centre = -self.rotation.T @ self.translation
        d = np.asarray(points, np.float64) - centre
        return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)

    def position(self) -> np.ndarray:
        """The camera's centre in model coordinates."""
        return -self.rotation.T @ self.translation

    def blender_matrix(self) -> np.ndarray:
        """4x4 world matrix of a Blender camera that sees the head (at the origin) as the photo does."""
        out = np.eye(4)
        out[:3, :3] = self.rotation.T @ np.diag([1.0, -1.0, -1.0])
        out[:3, 3] = self.position()
        return out

    def lens_mm(self, sensor_mm: float = 36.0) -> float:
        """Blender's focal length for a sensor of ``sensor_mm`` fitted to the picture's long side."""
        return float(self.focal) * sensor_mm / float(max(self.width, self.height))

    def state(self) -> dict:
        return {"width": int(self.width), "height": int(self.height), "focal": float(self.focal),
                "rotation": np.asarray(self.rotation).round(12).tolist(),
                "translation": np.asarray(self.translation).round(12).tolist()}

    @classmethod
    def from_state(cls, state: dict) -> "Camera":
        return cls(int(state["width"]), int(state["height"]), float(state["focal"]),
                   np.asarray(state["rotation"], np.float64).reshape(3, 3),
                   np.asarray(state["translation"], np.float64).reshape(3))
