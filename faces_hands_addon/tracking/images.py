# SPDX-License-Identifier: GPL-3.0-or-later
"""Image operations of the tracking pipeline (thesis 6.3.2-6.3.3), numpy/scipy only: distortion correction,
background subtraction on the black studio, colour classes, connected regions above a minimum size and their
centroids, sub-pixel silhouette boundaries.

Images are float arrays (H, W, 3) in [0, 1], rows top to bottom; pixel centres at +0.5 as in
:mod:`.camera`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.special import erf

from .camera import Camera

__all__ = ["undistort_image", "foreground_threshold", "hsv", "Region", "regions", "colour_masks",
           "radial_edges", "limb_profiles", "COLOURS"]

#: colour classes (6.3.2: "a color interval for each marker type"): hue centre (degrees), minimum saturation,
#: minimum value; "black" is dark pixels inside a lit ball
COLOURS = {
    "red": (0.0, 0.55, 0.25), "green": (120.0, 0.55, 0.2), "blue": (240.0, 0.55, 0.2),
    "yellow": (60.0, 0.55, 0.3), "cyan": (180.0, 0.55, 0.3), "magenta": (300.0, 0.55, 0.3),
    "orange": (30.0, 0.55, 0.3),
}
HUE_HALF_WIDTH = 14.0


def undistort_image(image: np.ndarray, camera: Camera) -> np.ndarray:
    """The distortion-corrected photo (6.3.1): same size and K, each output pixel sampled (bilinear) where
    the lens put it."""
    h, w = image.shape[:2]
    v, u = np.mgrid[0:h, 0:w].astype(np.float64) + 0.5
    xy = np.stack([(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy], axis=-1)
    d = camera.distort_normalised(xy)
    su, sv = d[..., 0] * camera.fx + camera.cx - 0.5, d[..., 1] * camera.fy + camera.cy - 0.5
    out = np.empty_like(image, dtype=np.float32)
    for c in range(image.shape[2]):
        out[..., c] = ndimage.map_coordinates(image[..., c], [sv, su], order=1, mode="constant", cval=0.0)
    return out


def foreground_threshold(value: np.ndarray) -> float:
    """Brightness above which a pixel is foreground on the black studio (6.3.1: floor and walls in black
    cloth): Otsu's threshold of the value histogram, never below the background noise (median + 6 MAD)."""
    hist, edges = np.histogram(value, bins=256, range=(0.0, 1.0))
    p = hist / max(hist.sum(), 1)
    omega, mu = np.cumsum(p), np.cumsum(p * np.arange(256))
    between = (mu[-1] * omega - mu) ** 2 / np.maximum(omega * (1 - omega), 1e-12)
    otsu = float(edges[int(np.argmax(between)) + 1])
    median = float(np.median(value))
    noise = median + 6.0 * 1.4826 * float(np.median(np.abs(value - median)))
    return max(otsu, noise, 0.08)


def hsv(image: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hue (degrees), saturation and value of an RGB image."""
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    value = np.max(image[..., :3], axis=-1)
    low = np.min(image[..., :3], axis=-1)
    chroma = value - low
    saturation = np.where(value > 0, chroma / np.maximum(value, 1e-12), 0.0)
    safe = np.maximum(chroma, 1e-12)
    hue = np.where(value == r, ((g - b) / safe) % 6.0, np.where(value == g, (b - r) / safe + 2.0, (r - g) / safe + 4.0))
    return np.where(chroma > 0, hue * 60.0, 0.0), saturation, value


def colour_masks(image: np.ndarray, names, min_saturation: float | None = None) -> dict[str, np.ndarray]:
    """One boolean mask per named colour class of :data:`COLOURS` (``min_saturation`` overrides the classes'
    own: paint on a white ball blends with the white at its edges)."""
    hue, sat, val = hsv(image)
    out = {}
    for name in names:
        centre, min_sat, min_val = COLOURS[name]
        min_sat = min_sat if min_saturation is None else min_saturation
        distance = np.abs((hue - centre + 180.0) % 360.0 - 180.0)
        out[name] = (distance < HUE_HALF_WIDTH) & (sat >= min_sat) & (val >= min_val)
    return out


@dataclass
class Region:
    """A connected image region: centroid (x, y pixels), area (pixels), bounding slices, its mask."""
    centroid: np.ndarray
    area: int
    box: tuple
    mask: np.ndarray


def regions(mask: np.ndarray, min_area: int, weights: np.ndarray | None = None) -> list[Region]:
    """Connected regions (8-neighbourhood) of ``mask`` with at least ``min_area`` pixels; centroid = centre of
    gravity (weighted by ``weights`` if given), 6.3.2."""
    labels, count = ndimage.label(mask, structure=np.ones((3, 3)))
    out = []
    for index, box in enumerate(ndimage.find_objects(labels), start=1):
        if box is None:
            continue
        local = labels[box] == index
        area = int(local.sum())
        if area < min_area:
            continue
        rows, cols = np.nonzero(local)
        w = np.ones(area) if weights is None else weights[box][local]
        w = w / max(w.sum(), 1e-12)
        centroid = np.array([np.sum((cols + box[1].start + 0.5) * w), np.sum((rows + box[0].start + 0.5) * w)])
        out.append(Region(centroid, area, box, local))
    return out


def radial_edges(value: np.ndarray, centre: np.ndarray, radius: float, level: float, count: int = 120,
                 reach: float = 1.6, nearest: bool = False, profile: bool = False) -> np.ndarray:
    """Sub-pixel silhouette boundary: along ``count`` rays from ``centre`` (searched out to ``reach * radius``)
    the steepest fall of the (bilinear) brightness from above ``level`` towards the background, placed where the
    brightness crosses half way between the two sides of the fall; the outermost such fall, or with ``nearest`` the one
    nearest to ``radius`` (a dark marker on the ball, a neighbouring ball and a shadow's soft edge are then not
    taken for the outline). A steepest fall does not depend on how brightly the lit part shines, where a
    brightness level would move with the strobe's light across the ball. ``profile=True`` then moves each
    crossing to the limb of :func:`limb_profiles`. (K, 2) points."""
    angles = np.linspace(0.0, 2 * np.pi, count, endpoint=False)
    steps = np.arange(0.0, reach * radius, 0.25)
    directions = np.column_stack([np.cos(angles), np.sin(angles)])
    xy = centre[None, None, :] + steps[None, :, None] * directions[:, None, :]
    samples = ndimage.map_coordinates(value, [xy[..., 1].ravel() - 0.5, xy[..., 0].ravel() - 0.5], order=1,
                                      mode="constant").reshape(count, len(steps))
    slope = np.diff(samples, axis=1)                        # between steps i and i + 1
    out, rays, where = [], [], []
    for k in range(count):
        d = slope[k]
        dips = np.flatnonzero((d[1:-1] < d[:-2]) & (d[1:-1] <= d[2:])) + 1
        dips = dips[(-d[dips] > 0.25 * max(-d.min(), 1e-9)) & (samples[k, dips] >= level)]
        if len(dips) == 0:
            continue
        positions = steps[dips] + 0.125
        i = int(dips[np.argmin(np.abs(positions - radius))]) if nearest else int(dips[-1])
        lo, hi = max(i - 6, 0), min(i + 7, len(steps) - 1)
        half = 0.5 * (samples[k, lo] + samples[k, hi])      # half way between the two sides of that fall
        run = samples[k, lo:hi + 1]
        j = np.flatnonzero((run[:-1] >= half) & (run[1:] < half))
        if len(j) == 0:
            continue
        j = int(j[np.argmin(np.abs(j + lo - i))]) + lo
        a, b = samples[k, j], samples[k, j + 1]
        rays.append(k)
        where.append(steps[j] + (a - half) / max(a - b, 1e-12) * 0.25)
    where = np.array(where)
    if profile and len(rays):
        where = limb_profiles(samples[rays], steps, where)
    out = centre + where[:, None] * directions[rays] if len(rays) else np.zeros((0, 2))
    return np.asarray(out).reshape(-1, 2)


def limb_profiles(samples: np.ndarray, steps: np.ndarray, start: np.ndarray, half_width: float = 4.0,
                  iterations: int = 12) -> np.ndarray:
    """The limb along each ray (row of ``samples`` at radii ``steps``), the boundary points of 6.3.3's circle
    fit, from a model of its brightness profile: a step from the ball's shading to the background ``b``, the
    shading taken as linear across the limb (``L0`` at the limb, slope ``s`` inwards), blurred by a Gaussian
    of width ``sigma`` (the lens, the pixel and the resampling):
    ``b + L0 Phi(u) + s sigma (u Phi(u) + phi(u))`` with ``u = (e - r) / sigma``, fitted by damped
    Gauss-Newton within ``half_width`` pixels of ``start`` (the half-way crossings; the synthetic photos'
    limbs fall over about 2 px, and a 2 px window gave poorer fits than 4 or 5). A lamp beside the camera
    lights one side of the limb more steeply than the other; a crossing half way between the two sides of
    the fall then lands inside the limb by an amount that grows with that slope, where the limb ``e`` of the
    model does not depend on it. A ray whose fit fails or wanders keeps its crossing."""
    spacing = float(steps[1] - steps[0])
    n = int(round(half_width / spacing))
    centre_index = np.clip(np.round((start - steps[0]) / spacing).astype(np.int64), n, len(steps) - n - 1)
    window = centre_index[:, None] + np.arange(-n, n + 1)[None]
    r = steps[window]
    y = np.take_along_axis(samples, window, axis=1)
    b = y[:, -3:].mean(axis=1)
    x = np.column_stack([start, np.full(len(start), 0.7), y[:, :3].mean(axis=1) - b, np.zeros(len(start)), b])
    damping = 1e-3
    sqrt2 = np.sqrt(2.0)

    def model(x):
        e, sigma, l0, s, b = x.T
        sigma = np.maximum(sigma, 0.05)
        u = (e[:, None] - r) / sigma[:, None]
        cdf = 0.5 * (1.0 + erf(u / sqrt2))
        pdf = np.exp(-0.5 * u * u) / np.sqrt(2 * np.pi)
        ramp = u * cdf + pdf
        f = b[:, None] + l0[:, None] * cdf + s[:, None] * sigma[:, None] * ramp
        du = l0[:, None] * pdf + s[:, None] * sigma[:, None] * cdf
        jac = np.stack([du / sigma[:, None], -du * u / sigma[:, None] + s[:, None] * ramp, cdf,
                        sigma[:, None] * ramp, np.ones_like(u)], axis=-1)
        return f, jac

    f, jac = model(x)
    cost = np.sum((f - y) ** 2, axis=1)
    for _ in range(iterations):
        jtj = np.einsum("nki,nkj->nij", jac, jac)
        jtr = np.einsum("nki,nk->ni", jac, y - f)
        jtj = jtj + damping * np.eye(5)[None] * (np.trace(jtj, axis1=1, axis2=2)[:, None, None] / 5 + 1e-9)
        try:
            step = np.linalg.solve(jtj, jtr[..., None])[..., 0]
        except np.linalg.LinAlgError:
            break
        trial = x + step
        f_new, jac_new = model(trial)
        new_cost = np.sum((f_new - y) ** 2, axis=1)
        better = new_cost < cost
        x[better], cost[better] = trial[better], new_cost[better]
        f[better], jac[better] = f_new[better], jac_new[better]
    e, sigma, l0 = x[:, 0], x[:, 1], x[:, 2]
    ok = np.isfinite(e) & (np.abs(e - start) < 1.5) & (sigma > 0.1) & (sigma < 2.5) & (l0 > 0)
    return np.where(ok, e, start)

