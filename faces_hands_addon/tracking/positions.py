# SPDX-License-Identifier: GPL-3.0-or-later
"""3D ball positions from one stereo pair's multi-exposure photos (thesis 6.3.3, "Reconstructing Flight
Positions"): silhouettes (:mod:`.ball`), epipolar matching of the ellipse centres, triangulation, the
predicted radius and the circle refinement per photo, stereo of the circle centres.

Inputs are distortion-corrected photos and their cameras (:meth:`.camera.Camera.undistorted`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .ball import Silhouette, find_silhouettes, neighbour_radius, refine_centre, split_merged
from .camera import Camera
from .stereo import match_pair, reprojection_errors, triangulate

__all__ = ["PairPositions", "ball_positions"]


@dataclass
class PairPositions:
    """Ball centres (N, 3) ordered along the flight, their image centres per camera ((N, 2) each), the
    silhouettes behind them, the reprojection error (pixels), what went wrong (plain sentences) and the two
    photos' foreground levels."""
    points: np.ndarray
    centres: list[np.ndarray]
    silhouettes: list[list[Silhouette]]
    ellipse_points: np.ndarray
    reprojection_px: float
    warnings: list[str] = field(default_factory=list)
    levels: tuple[float, float] = (0.0, 0.0)


def _split(image_value: np.ndarray, found, warnings: list[str], name: str) -> list[Silhouette]:
    regular = [s for s in found.silhouettes if not s.merged]
    out = []
    for s in found.silhouettes:
        radius = neighbour_radius(regular, s) if s.merged else None
        if radius:
            parts = split_merged(image_value, s, radius, found.threshold)
            if len(parts) == 2:
                warnings.append(f"{name}: two balls overlap near pixel ({s.centre[0]:.0f}, {s.centre[1]:.0f}); "
                                "separated by their circles")
            out += parts
        else:
            out.append(s)
    return out


def ball_positions(cameras: tuple[Camera, Camera], images: tuple[np.ndarray, np.ndarray], ball_radius: float,
                   flight_direction: np.ndarray, min_area: int = 20) -> PairPositions:
    """The ball positions seen by a stereo pair (module docstring). ``flight_direction`` orders them in time."""
    warnings: list[str] = []
    values = [np.max(img[..., :3], axis=-1) for img in images]
    found = [find_silhouettes(img, min_area) for img in images]
    sils = [_split(v, f, warnings, cam.name) for v, f, cam in zip(values, found, cameras)]
    centres = [np.array([s.centre for s in group]).reshape(-1, 2) for group in sils]
    radii = [np.median([s.axes[0] for s in group]) if group else 10.0 for group in sils]
    tolerance = max(3.0, 0.35 * float(np.mean(radii)))
    match = match_pair(cameras[0], cameras[1], centres[0], centres[1], tolerance=tolerance)
    for c, group in enumerate(sils):
        unmatched = len(group) - len(match.pairs)
        if unmatched > 0:
            warnings.append(f"{cameras[c].name}: {unmatched} ball silhouette(s) have no partner along the epipolar "
                            "line in the other camera of the pair (hidden or overlapping there)")
    if len(match.pairs) == 0:
        empty = np.zeros((0, 3))
        return PairPositions(empty, [np.zeros((0, 2))] * 2, [[], []], empty, float("nan"), warnings)
    rough = triangulate(list(cameras), [centres[0][match.pairs[:, 0]], centres[1][match.pairs[:, 1]]])
    points = rough
    for _ in range(2):        # the circles' stereo predicts the radii better than the ellipses' (half-moons)
        refined = [np.zeros((len(match.pairs), 2)) for _ in cameras]
        for n, (i, j) in enumerate(match.pairs):
            for c, k in enumerate((i, j)):
                s = sils[c][k]
                refined[c][n] = refine_centre(cameras[c], values[c], s, points[n], ball_radius, found[c].threshold)
                s.refined = refined[c][n]
        points = triangulate(list(cameras), refined)
    errors = np.nanmax(reprojection_errors(list(cameras), refined, points), axis=1)
    good = errors <= max(1.5, 4.0 * float(np.median(errors)))
    if not np.all(good):
        warnings.append(f"{cameras[0].name}/{cameras[1].name}: {int(np.sum(~good))} ball position(s) whose circles do "
                        "not meet in 3D (a wrong partner, two balls overlapping) were dropped")
        points, refined, match.pairs, rough = points[good], [r[good] for r in refined], match.pairs[good], rough[good]
    order = np.argsort(points @ np.asarray(flight_direction, np.float64))
    error = float(np.nanmean(errors[good]))
    chosen = [[sils[c][match.pairs[n, c]] for n in order] for c in range(2)]
    return PairPositions(points[order], [r[order] for r in refined], chosen, rough[order], error, warnings,
                         (found[0].threshold, found[1].threshold))
