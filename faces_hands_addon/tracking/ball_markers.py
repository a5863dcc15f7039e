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
from .meshes import shape_inside
from .images import colour_masks, hsv, regions

__all__ = ["markers_in_photo", "marker_directions", "ray_sphere", "spread", "unforeshorten", "foreshorten"]


def markers_in_photo(image: np.ndarray, centre: np.ndarray, radius: float, model: BallModel) -> list[tuple[np.ndarray, int]]:
    """(pixel centroid, type index) of the markers inside one ball disc (``centre``, ``radius`` pixels)."""
    r = int(np.ceil(radius)) + 2
    x0, y0 = int(centre[0]) - r, int(centre[1]) - r
    x0c, y0c = max(x0, 0), max(y0, 0)
    patch = image[y0c:int(centre[1]) + r + 1, x0c:int(centre[0]) + r + 1, :3]
    if patch.size == 0:
        return []
    yy, xx = np.mgrid[0:patch.shape[0], 0:patch.shape[1]]
    inside = np.hypot(xx + x0c + 0.5 - centre[0], yy + y0c + 0.5 - centre[1]) < 0.97 * radius
    _, sat, val = hsv(patch)
    white = float(np.median(val[inside & (sat < 0.3)])) if np.any(inside & (sat < 0.3)) else 1.0
    masks = colour_masks(patch, [c for c in model.colours if c != "black"], min_saturation=0.3)
    if "black" in model.colours:
        masks["black"] = (val < 0.3 * white) & (sat < 0.5)
    min_area = max(2, int(0.006 * radius * radius))
    reach = model.marker_size / model.radius * radius       # one marker's width in pixels
    out = []
    for colour, mask in masks.items():
        found = regions(mask & inside, min_area)
        for group in _near_groups([r.centroid for r in found], reach):
            areas = np.array([found[i].area for i in group], float)
            centroid = np.sum([found[i].centroid * a for i, a in zip(group, areas)], axis=0) / areas.sum()
            out.append((centroid + [x0c, y0c], model.type_of_colour(colour)))
    return out


def _near_groups(points: list, reach: float) -> list[list[int]]:
    """Indices grouped where points lie within ``reach`` of each other: the pieces of one marker (a ring seen
    edge-on shows as two arcs)."""
    groups: list[list[int]] = []
    for i, p in enumerate(points):
        for group in groups:
            if any(np.linalg.norm(p - points[j]) < reach for j in group):
                group.append(i)
                break
        else:
            groups.append([i])
    return groups


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


def spread(shape: str, size: float, radius: float) -> float:
    """The mean squared angular distance (rad^2) of a marker's area from its centre along one direction."""
    t = np.linspace(-0.6 * size, 0.6 * size, 121)
    x, y = np.meshgrid(t, t)
    inside = shape_inside(shape, x.ravel(), y.ravel(), 0.5 * size)
    return float(np.mean(x.ravel()[inside] ** 2)) / radius ** 2


def unforeshorten(direction: np.ndarray, towards: np.ndarray, spread_rad2: float) -> np.ndarray:
    """The marker's direction from where its picture's centre of gravity put it. A patch on a sphere, seen at
    ``theta`` from the line of sight, is foreshortened more on its far side, so the centre of gravity of its
    picture sits at ``sin(theta_seen) = sin(theta) (1 - 1.5 E)`` (E = :func:`spread`, to second order): the
    direction is turned back away from the camera by the difference (about 1 degree at 45 degrees for a
    16 mm marker on a baseball)."""
    cosine = float(np.clip(direction @ towards, -1.0, 1.0))
    seen = np.arccos(cosine)
    if seen < 1e-6:
        return direction
    theta = np.arcsin(min(np.sin(seen) / (1.0 - 1.5 * spread_rad2), 1.0))
    side = direction - cosine * towards
    side /= np.linalg.norm(side)
    return np.cos(theta) * towards + np.sin(theta) * side


def foreshorten(directions: np.ndarray, towards: np.ndarray, spread_rad2) -> np.ndarray:
    """Where the picture's centre of gravity puts markers whose centres are at ``directions`` (n, 3), seen
    along ``towards`` (n, 3 or 3): the inverse of :func:`unforeshorten`, ``sin(theta_seen) = sin(theta)
    (1 - 1.5 E)`` with ``E`` = ``spread_rad2`` (n or scalar)."""
    d = np.atleast_2d(np.asarray(directions, np.float64))
    w = np.broadcast_to(np.asarray(towards, np.float64), d.shape)
    cosine = np.clip(np.sum(d * w, axis=1), -1.0, 1.0)
    sine = np.sqrt(np.maximum(1.0 - cosine ** 2, 0.0))
    seen = np.arcsin(np.clip(sine * (1.0 - 1.5 * np.asarray(spread_rad2, np.float64)), -1.0, 1.0))
    side = d - cosine[:, None] * w
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-12)
    return np.cos(seen)[:, None] * w + np.sin(seen)[:, None] * side


def marker_directions(cameras: list[Camera], detections: list[list[tuple[np.ndarray, int]]], centre: np.ndarray,
                      radius: float, merge_deg: float = 12.0, limb_deg: float = 62.0,
                      spreads: list[float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions (n, 3) from the ball centre and type indices (n,) of one ball's markers, from the
    detections of each camera (module docstring). A marker seen more than ``limb_deg`` from the camera's line
    of sight is dropped (near the limb a marker is a sliver); with ``spreads`` (per type, :func:`spread`) the
    foreshortening of the others is undone (:func:`unforeshorten`)."""
    points, types = [], []
    for cam, found in zip(cameras, detections):
        if not found:
            continue
        rays = cam.rays(np.array([p for p, _ in found]), distorted=False)
        for ray, (_, t) in zip(rays, found):
            hit = ray_sphere(cam.centre, ray, centre, radius)
            towards = (cam.centre - centre) / np.linalg.norm(cam.centre - centre)
            if hit is not None and (hit - centre) @ towards > radius * np.cos(np.radians(limb_deg)):
                direction = (hit - centre) / np.linalg.norm(hit - centre)
                points.append(direction if spreads is None else unforeshorten(direction, towards, spreads[t]))
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
