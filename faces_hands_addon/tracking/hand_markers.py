# SPDX-License-Identifier: GPL-3.0-or-later
"""Glove markers in the hand photos, in 3D (thesis 6.3.2 "Tracking Hand Positions").

Background subtraction (the studio, clothes and glove skin are black, the reflective markers bright), a colour
interval per marker colour, connected regions above a minimum size, their centres of gravity; correspondences
along epipolar lines within each stereo pair (the left and the right pair are separate pairs), triangulation
per pair, and a marker reconstructed by both pairs averaged. Then "an automatic approach that clusters 3D
marker positions into separate hand clusters" (proposed in 6.3.2): single-linkage clusters, one per hand
exposure, split where markers are farther apart than any two neighbouring markers on one hand.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.cluster.hierarchy import fcluster, linkage

from .camera import Camera
from .images import colour_masks, foreground_threshold, regions
from .stereo import match_pair, triangulate

__all__ = ["Markers2D", "find_markers", "pair_markers", "merge_pairs", "cluster_hands", "Markers3D"]


@dataclass
class Markers2D:
    pixels: np.ndarray          # (N, 2) undistorted pixel centroids
    colours: np.ndarray         # (N,) colour index
    areas: np.ndarray


@dataclass
class Markers3D:
    points: np.ndarray          # (N, 3)
    colours: np.ndarray         # (N,)
    seen_by: list = field(default_factory=list)   # per point: the pairs that reconstructed it


def find_markers(image: np.ndarray, colours: list[str], min_area: int = 3) -> Markers2D:
    """Coloured marker regions in one (distortion-corrected) photo."""
    value = np.max(image[..., :3], axis=-1)
    bright = value > foreground_threshold(value)
    pixels, labels, areas = [], [], []
    for index, (name, mask) in enumerate(colour_masks(image, colours).items()):
        for region in regions(mask & bright, min_area, weights=value):
            pixels.append(region.centroid)
            labels.append(index)
            areas.append(region.area)
    return Markers2D(np.array(pixels).reshape(-1, 2), np.array(labels, np.int64), np.array(areas, np.int64))


def pair_markers(cameras: tuple[Camera, Camera], found: tuple[Markers2D, Markers2D], tolerance: float = 2.0,
                 depth_range: tuple[float, float] = (0.3, 8.0)) -> Markers3D:
    """Markers of one stereo pair: same colour, along the epipolar line, triangulated."""
    match = match_pair(cameras[0], cameras[1], found[0].pixels, found[1].pixels, found[0].colours,
                       found[1].colours, tolerance=tolerance, depth_range=depth_range)
    if len(match.pairs) == 0:
        return Markers3D(np.zeros((0, 3)), np.zeros(0, np.int64))
    i, j = match.pairs[:, 0], match.pairs[:, 1]
    points = triangulate(list(cameras), [found[0].pixels[i], found[1].pixels[j]])
    return Markers3D(points, found[0].colours[i])


def merge_pairs(per_pair: list[Markers3D], radius: float = 0.006) -> Markers3D:
    """One marker list: a marker reconstructed by several pairs (same colour, closer than ``radius``) is
    averaged (6.3.2)."""
    points = [p for m in per_pair for p in m.points]
    colours = [c for m in per_pair for c in m.colours]
    source = [k for k, m in enumerate(per_pair) for _ in m.points]
    if not points:
        return Markers3D(np.zeros((0, 3)), np.zeros(0, np.int64))
    points, colours, source = np.array(points), np.array(colours), np.array(source)
    used = np.zeros(len(points), bool)
    out, out_c, seen = [], [], []
    for i in range(len(points)):
        if used[i]:
            continue
        near = np.flatnonzero(~used & (colours == colours[i]) & (np.linalg.norm(points - points[i], axis=1) < radius))
        group = [near[0]]
        for k in near[1:]:                              # one point per pair
            if source[k] not in source[group]:
                group.append(k)
        used[group] = True
        out.append(points[group].mean(axis=0))
        out_c.append(colours[i])
        seen.append(sorted(set(int(s) for s in source[group])))
    return Markers3D(np.array(out), np.array(out_c, np.int64), seen)


def cluster_hands(markers: Markers3D, link: float, span: float | None = None) -> list[np.ndarray]:
    """Indices of the markers of each hand exposure: single-linkage clusters split at ``link`` metres, then
    clusters joined, nearest first, while the union still fits in one hand (no two markers farther apart than
    ``span``: a finger whose markers are hidden can leave a gap wider than ``link``). Clusters of fewer than 3
    markers are dropped."""
    if len(markers.points) < 3:
        return []
    labels = fcluster(linkage(markers.points, method="single"), t=link, criterion="distance")
    groups = [np.flatnonzero(labels == k) for k in np.unique(labels)]
    if span is not None:
        groups = _join(markers.points, groups, span)
    return [g for g in groups if len(g) >= 3]


def _join(points: np.ndarray, groups: list[np.ndarray], span: float) -> list[np.ndarray]:
    while len(groups) > 1:
        best = None
        for a in range(len(groups)):
            for b in range(a + 1, len(groups)):
                gap = float(np.min(np.linalg.norm(points[groups[a]][:, None] - points[groups[b]][None], axis=2)))
                union = points[np.concatenate([groups[a], groups[b]])]
                width = float(np.max(np.linalg.norm(union[:, None] - union[None], axis=2)))
                if width <= span and (best is None or gap < best[0]):
                    best = (gap, a, b)
        if best is None:
            return groups
        _, a, b = best
        groups = [g for k, g in enumerate(groups) if k not in (a, b)] + [np.concatenate([groups[a], groups[b]])]
    return groups
