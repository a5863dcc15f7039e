# SPDX-License-Identifier: GPL-3.0-or-later
"""Ball positions from multi-exposure photos (thesis 6.3.3 "Reconstructing Flight Positions").

Per photo: colour-based background subtraction gives a foreground mask; its connected regions are the ball
silhouettes (holes of dark markers filled); the boundary of each is made convex (correcting small
concavities, [Sla70]); regions below a size threshold are noise; an ellipse fitted to the boundary gives a
first centre. Per stereo pair: the centres are matched along epipolar lines and triangulated; from the 3D
position and the ball's real radius the radius of each silhouette is predicted; a circular Hough transform
with that known radius (a 2D search over centres only, [Bal81]) on the boundary points near the ellipse
centre refines each centre, which survives a partial silhouette (the back pair's side-lit half-moons, Fig.
6.29); stereo of the circle centres gives the final 3D positions.

Beyond the thesis: a silhouette that is a whole disc of the predicted size whose edges do not lie on one
circle keeps its ellipse centre (a lamp beside the camera darkens the limb gradually, which moves a circle
found on edges more than the ellipse); otherwise the boundary is found to sub-pixel precision along rays (the steepest fall nearest
the predicted radius, placed half way down it), and the Hough winner is polished by a least-squares circle of
the same radius through the boundary points that voted for it. On a whole disc ``profile=True`` places each
boundary point by a model of the brightness across the limb instead (:func:`.images.limb_profiles`): a lamp
beside the camera shades one side of the limb more steeply than the other, which moves a half-way crossing
inwards on that side and the circle's centre away from it (measured against the synthetic truth on the front
pair of seeds 11 and 12: the two cameras' centre offsets across the baseline differed by 0.14 px with the
crossing and by 0.05 px with the model). The pipeline uses it for the centres the ball's markers are measured
from; the positions keep the crossings (with the model there too, one synthetic knuckleball's front positions
went wrong and its spin came out at 2382 rpm instead of 60). Two balls whose silhouettes merged (overlapping exposures) are split by taking the two best
Hough circles of the region.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage
from scipy.spatial import ConvexHull, QhullError

from .camera import Camera
from .images import foreground_threshold, radial_edges, regions

__all__ = ["Silhouette", "find_silhouettes", "fit_ellipse", "hough_centre", "refine_centre", "BallDetections",
           "split_merged", "predicted_radius", "neighbour_radius", "bright_level"]


@dataclass
class Silhouette:
    """One ball silhouette in a photo: the ellipse centre, axes (pixels), hull points, area, and whether it
    looks like two merged balls."""
    centre: np.ndarray
    axes: np.ndarray
    boundary: np.ndarray
    area: int
    merged: bool = False
    region: object = None
    refined: np.ndarray | None = None


@dataclass
class BallDetections:
    silhouettes: list[Silhouette] = field(default_factory=list)
    threshold: float = 0.0


def fit_ellipse(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Direct least-squares ellipse (Fitzgibbon et al.) through (N >= 5, 2) points: (centre, semi-axes)."""
    mean = points.mean(axis=0)
    scale = max(float(np.std(points)), 1e-9)
    x, y = ((points - mean) / scale).T
    D = np.column_stack([x * x, x * y, y * y, x, y, np.ones_like(x)])
    S = D.T @ D
    C = np.zeros((6, 6))
    C[0, 2] = C[2, 0] = 2.0
    C[1, 1] = -1.0
    s1, s2, s3 = S[:3, :3], S[:3, 3:], S[3:, 3:]
    t = -np.linalg.solve(s3, s2.T)
    m = s1 + s2 @ t
    m = np.linalg.solve(C[:3, :3], m)
    values, vectors = np.linalg.eig(m)
    vectors = np.real(vectors)
    cond = 4 * vectors[0] * vectors[2] - vectors[1] ** 2
    good = np.flatnonzero(cond > 0)
    if len(good) == 0:
        return mean, np.array([np.nan, np.nan])
    a1 = vectors[:, good[0]]
    a, b, c, d, e, f = np.concatenate([a1, t @ a1])
    det = 4 * a * c - b * b
    cx, cy = (b * e - 2 * c * d) / det, (b * d - 2 * a * e) / det
    value = a * cx * cx + b * cx * cy + c * cy * cy + d * cx + e * cy + f
    eig = np.linalg.eigvalsh(np.array([[a, b / 2], [b / 2, c]]))
    axes = np.sqrt(np.maximum(-value / eig, 0.0)) if np.all(eig * -value > 0) else np.array([np.nan, np.nan])
    return mean + scale * np.array([cx, cy]), np.sort(axes * scale)[::-1]


def find_silhouettes(image: np.ndarray, min_area: int) -> BallDetections:
    """Ball silhouettes in one (distortion-corrected) photo: foreground by brightness on black, dark-marker
    holes filled, regions of at least ``min_area`` pixels, convex hull of each boundary, ellipse fit."""
    value = np.max(image[..., :3], axis=-1)
    threshold = foreground_threshold(value)
    mask = ndimage.binary_fill_holes(value > threshold)
    out = BallDetections(threshold=threshold)
    for region in regions(mask, min_area):
        rows, cols = np.nonzero(region.mask ^ ndimage.binary_erosion(region.mask))
        boundary = np.column_stack([cols + region.box[1].start + 0.5, rows + region.box[0].start + 0.5])
        try:
            hull = boundary[ConvexHull(boundary).vertices]
        except (QhullError, ValueError):
            continue
        if len(hull) < 5:
            continue
        centre, axes = fit_ellipse(hull)
        if not np.all(np.isfinite(axes)):
            continue
        out.silhouettes.append(Silhouette(centre, axes, hull, region.area, region=region))
    for s in out.silhouettes:                 # against its neighbours: the balls shrink along the flight
        typical = _neighbour_median(out.silhouettes, s, lambda item: item.area)
        s.merged = typical is not None and s.area > 1.45 * typical and s.axes[0] > 1.5 * s.axes[1]
    return out


def _neighbour_median(silhouettes: list, s, value, count: int = 4) -> float | None:
    others = [o for o in silhouettes if o is not s]
    if len(others) < 2:
        return None
    others.sort(key=lambda o: float(np.linalg.norm(o.centre - s.centre)))
    return float(np.median([value(o) for o in others[:count]]))


def hough_centre(points: np.ndarray, radius: float, near: np.ndarray, search: float, cell: float = 0.25,
                 peaks: int = 1) -> list[np.ndarray]:
    """Circular Hough transform with a known ``radius``: every boundary point votes for the centres at that
    distance (a ring of cells), within ``search`` pixels of ``near``; the best ``peaks`` centres (apart by at
    least the radius)."""
    size = int(np.ceil(2 * search / cell)) + 1
    acc = np.zeros((size, size))
    angles = np.linspace(0.0, 2 * np.pi, max(32, int(2 * np.pi * radius / cell)), endpoint=False)
    ring = radius * np.column_stack([np.cos(angles), np.sin(angles)])
    origin = near - search
    for p in points:
        idx = np.round((p[None] + ring - origin) / cell).astype(np.int64)
        ok = np.all((idx >= 0) & (idx < size), axis=1)
        cells = np.unique(idx[ok], axis=0)
        acc[cells[:, 1], cells[:, 0]] += 1.0
    acc = ndimage.gaussian_filter(acc, 1.0)
    out = []
    for _ in range(peaks):
        iy, ix = np.unravel_index(int(np.argmax(acc)), acc.shape)
        if acc[iy, ix] <= 0:
            break
        centre = origin + np.array([ix, iy]) * cell
        out.append(centre)
        yy, xx = np.mgrid[0:size, 0:size]
        acc[(xx - ix) ** 2 + (yy - iy) ** 2 < (radius / cell) ** 2] = 0.0
    return out


def _polish(points: np.ndarray, radius: float, centre: np.ndarray, band: float = 1.0) -> np.ndarray:
    """Least-squares centre of a circle of known radius through the boundary points within ``band`` pixels
    of the Hough circle (Gauss-Newton)."""
    c = centre.copy()
    for _ in range(10):
        d = np.linalg.norm(points - c, axis=1)
        use = np.abs(d - radius) < band
        if use.sum() < 8:
            return centre
        u = (points[use] - c) / d[use][:, None]
        step, *_ = np.linalg.lstsq(-u, -(d[use] - radius), rcond=None)
        c = c + step
        if np.linalg.norm(step) < 1e-4:
            break
    return c


def _virtual_rotation(direction: np.ndarray) -> np.ndarray:
    """A rotation whose third row is ``direction`` (the virtual camera looking at the ball)."""
    z = direction / np.linalg.norm(direction)
    helper = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z])


def refine_centre(camera: Camera, image_value: np.ndarray, silhouette: Silhouette, approximate: np.ndarray,
                  ball_radius: float, level: float, ellipse_fallback: bool = True, profile: bool = False) -> np.ndarray:
    """The silhouette's centre (undistorted pixels) with the image radius predicted from the approximate 3D
    position ``approximate`` and the ball's real radius (6.3.3): sub-pixel boundary points, circular Hough with
    that known radius, polished (module docstring). The search runs in a virtual camera turned to look at the
    ball, where a sphere's outline is exactly a circle of radius ``f tan(asin(R / d))`` around the image of
    its centre (off the axis of the real camera it is an ellipse, elongated by 1 / cos of the angle).
    ``ellipse_fallback=False`` keeps the circle even for a whole disc with a soft limb: the ellipse of the
    thresholded disc leans towards the lit side, which the marker directions of 6.3.3 feel (they are taken
    from the centre) more than the ball's position does. ``profile=True``: on a whole disc the boundary points
    come from the limb's brightness model (module docstring) rather than the half-way crossing."""
    f = 0.5 * (camera.fx + camera.fy)
    ray = camera.R @ (approximate - camera.centre)
    distance = float(np.linalg.norm(ray))
    radius = f * np.tan(np.arcsin(min(ball_radius / distance, 0.99)))
    image_radius = predicted_radius(camera, approximate, ball_radius)
    whole = silhouette.axes[0] < 1.12 * silhouette.axes[1] and abs(silhouette.axes.mean() / image_radius - 1) < 0.12
    reach = 1.0 + max(silhouette.axes[0] / image_radius, 1.0)
    edges = radial_edges(image_value, silhouette.centre, image_radius, level, count=180, reach=reach, nearest=True,
                         profile=profile and whole)
    if len(edges) < 8:
        return silhouette.centre
    turn = _virtual_rotation(ray)

    def to_virtual(pixels):
        d = np.column_stack([(pixels[:, 0] - camera.cx) / camera.fx, (pixels[:, 1] - camera.cy) / camera.fy,
                             np.ones(len(pixels))]) @ turn.T
        return f * d[:, :2] / d[:, 2:3]

    virtual = to_virtual(edges)
    start = to_virtual(silhouette.centre[None])[0]
    search = max(radius, silhouette.axes[0]) * 1.2
    centre = _polish(virtual, radius, hough_centre(virtual, radius, start, search)[0])
    d = np.abs(np.linalg.norm(virtual - centre, axis=1) - radius)
    if ellipse_fallback and whole and float(np.sqrt(np.mean(d[d < 1.0] ** 2))) > 0.3:
        return silhouette.centre          # a whole disc with a soft limb: its ellipse is the better outline
    d = turn.T @ np.array([centre[0] / f, centre[1] / f, 1.0])
    return np.array([camera.fx * d[0] / d[2] + camera.cx, camera.fy * d[1] / d[2] + camera.cy])


def split_merged(image_value: np.ndarray, silhouette: Silhouette, radius: float, level: float) -> list[Silhouette]:
    """Two balls whose silhouettes merged (two exposures overlapping): the two best circles of the typical
    image ``radius`` in the region, each a silhouette of its own."""
    reach = 1.0 + silhouette.axes[0] / radius
    edges = radial_edges(image_value, silhouette.centre, radius, level, count=240, reach=reach, nearest=True)
    centres = [_polish(edges, radius, c) for c in
               hough_centre(edges, radius, silhouette.centre, silhouette.axes[0] * 1.2, peaks=2)]
    support = [np.mean(np.abs(np.linalg.norm(edges - c, axis=1) - radius) < 1.0) for c in centres]
    if len(centres) < 2 or min(support) < 0.25:              # not two balls (a side-lit half-moon, say)
        silhouette.merged = False
        return [silhouette]
    return [Silhouette(c, np.array([radius, radius]), silhouette.boundary, silhouette.area // 2, merged=True,
                       region=silhouette.region) for c in centres]


def neighbour_radius(silhouettes: list, s) -> float | None:
    """The typical image radius (semi-minor axis) of the silhouettes near ``s``."""
    return _neighbour_median(silhouettes, s, lambda item: item.axes[1])


def bright_level(value: np.ndarray, s: Silhouette) -> float:
    """Half the brightness of the ball's lit part: the level at which its outline is found."""
    region = s.region
    pixels = value[region.box][region.mask]
    return 0.5 * float(np.percentile(pixels, 90)) if pixels.size else 0.5


def predicted_radius(camera: Camera, point: np.ndarray, ball_radius: float) -> float:
    """The image radius (pixels) of a ball of ``ball_radius`` metres centred at ``point`` (6.3.3)."""
    depth = float(camera.depth(point[None])[0])
    distance = float(np.linalg.norm(point - camera.centre))
    angle = np.arcsin(min(ball_radius / max(distance, 1e-9), 1.0))
    return float(0.5 * (camera.fx + camera.fy) * np.tan(angle) * distance / max(depth, 1e-9))
