# SPDX-License-Identifier: GPL-3.0-or-later
"""The ball's painted markers in the front pair's photos (thesis 6.3.3): colour-based region detection
inside each ball silhouette, each marker put on the ball whose 3D position is closest.

The thesis triangulated the markers from the stereo pair. Here each marker's viewing ray meets the ball's
sphere (its centre and real radius are known by then), and the two cameras' markers of one type within a few
degrees of each other are merged: markers 3-10 pixels apart on a 20-pixel ball leave several candidates
along one epipolar line, and the sphere also places the markers that only one camera saw.
"""
from __future__ import annotations

import numpy as np

from .ball_model import BallModel
from .camera import Camera
from .images import colour_masks, hsv, regions

__all__ = ["markers_in_photo", "marker_directions", "ray_sphere"]


def markers_in_photo(image: np.ndarray, centre: np.ndarray, radius: float, model: BallModel) -> list[tuple[np.ndarray, int]]:
    """(pixel centroid, type index) of the markers inside one ball disc (``centre``, ``radius`` pixels)."""
    r = int(np.ceil(radius)) + 2
    x0, y0 = int(centre[0]) - r, int(centre[1]) - r
    x0c, y0c = max(x0, 0), max(y0, 0)
    patch = image[y0c:int(centre[1]) + r + 1, x0c:int(centre[0]) + r + 1, :3]
    if patch.size == 0:
        return []
    yy, xx = np.mgrid[0:patch.shape[0], 0:patch.shape[1]]
    inside = np.hypot(xx + x0c + 0.5 - centre[0], yy + y0c + 0.5 - centre[1]) < 0.9 * radius
    _, sat, val = hsv(patch)
    white = float(np.median(val[inside & (sat < 0.3)])) if np.any(inside & (sat < 0.3)) else 1.0
    masks = colour_masks(patch, [c for c in model.colours if c != "black"])
    if "black" in model.colours:
        masks["black"] = (val < 0.45 * white) & (sat < 0.5)
    min_area = max(2, int(0.015 * radius * radius))
    out = []
    for colour, mask in masks.items():
        for region in regions(mask & inside, min_area):
            out.append((region.centroid + [x0c, y0c], model.type_of_colour(colour)))
    return out


def ray_sphere(origin: np.ndarray, direction: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray | None:
    """The nearer intersection of a ray with a sphere (None if it misses)."""
    oc = origin - centre
    b = float(direction @ oc)
    disc = b * b - float(oc @ oc - radius * radius)
    if disc < 0:
        if disc < -(0.15 * radius) ** 2:
            return None
        disc = 0.0                                      # grazing the limb: the closest point
    return origin + (-b - np.sqrt(disc)) * direction


def marker_directions(cameras: list[Camera], detections: list[list[tuple[np.ndarray, int]]], centre: np.ndarray,
                      radius: float, merge_deg: float = 12.0) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions (n, 3) from the ball centre and type indices (n,) of one ball's markers, from the
    detections of each camera (module docstring)."""
    points, types = [], []
    for cam, found in zip(cameras, detections):
        if not found:
            continue
        rays = cam.rays(np.array([p for p, _ in found]), distorted=False)
        for ray, (_, t) in zip(rays, found):
            hit = ray_sphere(cam.centre, ray, centre, radius)
            if hit is not None:
                points.append((hit - centre) / radius)
                types.append(t)
    if not points:
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    dirs = np.array(points)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    types = np.array(types, np.int64)
    used = np.zeros(len(dirs), bool)
    merged, merged_types = [], []
    limit = np.cos(np.radians(merge_deg))
    for i in range(len(dirs)):
        if used[i]:
            continue
        group = np.flatnonzero(~used & (types == types[i]) & (dirs @ dirs[i] > limit))
        used[group] = True
        mean = dirs[group].mean(axis=0)
        merged.append(mean / np.linalg.norm(mean))
        merged_types.append(types[i])
    return np.array(merged), np.array(merged_types, np.int64)
