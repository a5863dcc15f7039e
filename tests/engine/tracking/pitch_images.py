"""Tiny synthetic photos for the tracker's tests, drawn with numpy (no Blender): a checkerboard seen by a
camera, lit discs of balls (full or side-lit half-moons)."""
from __future__ import annotations

import numpy as np

from faces_hands_addon.tracking.camera import Camera


def board_image(camera: Camera, board_to_world: np.ndarray, inner, square: float, supersample: int = 2) -> np.ndarray:
    """The photo ``camera`` (with its distortion) takes of a checkerboard (``inner`` corners, z = 0 plane of
    ``board_to_world``), grey surround, (H, W) in [0, 1]."""
    w, h = camera.size
    s = supersample
    us, vs = np.meshgrid((np.arange(w * s) + 0.5) / s, (np.arange(h * s) + 0.5) / s)
    rays = camera.rays(np.column_stack([us.ravel(), vs.ravel()]))
    centre = camera.centre
    normal, origin = board_to_world[:3, 2], board_to_world[:3, 3]
    depth = ((origin - centre) @ normal) / (rays @ normal)
    local = (centre + depth[:, None] * rays - origin) @ board_to_world[:3, :3]
    cols, rows = inner
    i, j = np.floor(local[:, 0] / square + 1), np.floor(local[:, 1] / square + 1)
    inside = (i >= 0) & (i <= cols) & (j >= 0) & (j <= rows) & (depth > 0)
    value = np.where(inside, np.where((i + j) % 2 == 0, 0.9, 0.05), 0.5)
    return value.reshape(h * s, w * s).reshape(h, s, w, s).mean(axis=(1, 3))


def sphere_image(camera: Camera, centres: np.ndarray, radius: float, light: np.ndarray | None = None,
                 ambient: float = 0.05, supersample: int = 2) -> np.ndarray:
    """White spheres on black as ``camera`` (pinhole) sees them, Lambert-lit from ``light`` (None: flat),
    (H, W, 3)."""
    w, h = camera.size
    s = supersample
    us, vs = np.meshgrid((np.arange(w * s) + 0.5) / s, (np.arange(h * s) + 0.5) / s)
    rays = camera.rays(np.column_stack([us.ravel(), vs.ravel()]), distorted=False)
    origin = camera.centre
    value = np.zeros(len(rays))
    nearest = np.full(len(rays), np.inf)
    for c in np.atleast_2d(centres):
        oc = origin - c
        b = rays @ oc
        disc = b * b - (oc @ oc - radius * radius)
        hit = disc >= 0
        t = -b - np.sqrt(np.where(hit, disc, 0.0))
        closer = hit & (t < nearest)
        nearest[closer] = t[closer]
        points = origin + t[:, None] * rays
        normal = (points - c) / radius
        if light is None:
            shade = np.ones(len(rays))
        else:
            to_light = light - points
            to_light /= np.linalg.norm(to_light, axis=1, keepdims=True)
            shade = ambient + (1 - ambient) * np.clip(np.sum(normal * to_light, axis=1), 0, 1)
        value[closer] = 0.92 * shade[closer]
    image = value.reshape(h * s, w * s).reshape(h, s, w, s).mean(axis=(1, 3))
    return np.repeat(image[..., None], 3, axis=2).astype(np.float32)
