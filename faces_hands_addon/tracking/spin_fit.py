# SPDX-License-Identifier: GPL-3.0-or-later
"""The spin from all balls at once in the photos (beyond thesis 6.3.3, which fits each ball's orientation
by Eq. 6.10 and averages the axes between successive balls, Eq. 6.11).

One constant angular velocity for the whole front sequence, ``R_k = exp(k w / f_s) R_0``, fitted by least
squares to where the markers were found in each photo of the pair (undistorted pixels): every detection is a
residual of its own, so a marker seen by both cameras counts twice and one seen near the limb, which moves
little in the picture when the ball turns, counts for little (in the 3D directions of :mod:`.orientation`
every marker weighed the same, and a marker near the limb is off by several degrees). Each detection is
predicted as the centre of gravity of its marker's picture: the marker's direction turned towards the camera
by the second-order foreshortening of :func:`.ball_markers.foreshorten`, put on the sphere and projected.
Which model marker a detection is, is re-decided from the current fit (the nearest of its type in the photo)
a few times; the loss is soft-L1 at the residuals' own robust scale (1.4826 MAD), so a mislabelled blob
does not pull.

The ball centres are fixed (the pipeline gives the silhouettes' circles, on a parabola in time). A centre off
by 0.2 mm along the pair's baseline turns every marker direction, hence the axis, by about 0.4 degrees, and
a stroboscope beside the cameras moved the silhouettes' centres by about that much while their outlines were
half-way crossings; the outline now comes from a model of the limb's brightness profile
(:func:`.images.limb_profiles`), which measures the shading's slope instead of assuming none. Freeing
one common shift along the baseline in this fit was measured on 16 synthetic pitches and not kept: it removed
such a bias on some sets and added as much scatter on others (mean axis error 0.34 degrees with it and without).

The axis uncertainty is reported: the covariance of the fit (Gauss-Newton, scaled by the residual variance)
projected across the axis, in degrees. Over a short flight a ball that hardly turns (a knuckleball's quarter
turn) has an axis the photos cannot fix; the number says so.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from .ball_markers import foreshorten
from .ball_model import BallModel
from .camera import Camera, rotation_from_vector, vector_from_rotation
from .orientation import Spin

__all__ = ["image_spin", "ImageSpin"]


class ImageSpin:
    """The fit's result: ``orientations`` (K, 3, 3), ``spin`` (:class:`.orientation.Spin`), ``axis_sigma_deg``,
    ``rate_sigma`` (rad/s), ``scale_px`` (residual scale) and ``count`` (detections used)."""

    def __init__(self, orientations, spin, axis_sigma_deg, rate_sigma, scale_px, count):
        self.orientations, self.spin = orientations, spin
        self.axis_sigma_deg, self.rate_sigma = float(axis_sigma_deg), float(rate_sigma)
        self.scale_px, self.count = float(scale_px), int(count)


def _rotations(x: np.ndarray, count: int) -> np.ndarray:
    r0 = rotation_from_vector(x[:3])
    return np.array([rotation_from_vector(x[3:6] * k) @ r0 for k in range(count)])


def image_spin(model: BallModel, cameras: tuple[Camera, Camera], detections: list[list[list[tuple[np.ndarray, int]]]],
               centres: np.ndarray, orientations: np.ndarray, spin: Spin, strobe_hz: float,
               spreads: list[float], rounds: int = 3) -> ImageSpin | None:
    """The joint fit of the module docstring. ``detections[k][c]``: (undistorted pixel, type index) of ball
    ``k`` in camera ``c``; ``centres`` (K, 3); ``orientations`` and ``spin`` the start (one per ball, from
    :func:`.orientation.rigid_spin`). None when fewer than 8 detections or the fit fails."""
    count = len(centres)
    rows = [(k, c, np.asarray(p, np.float64), int(t)) for k in range(count)
            for c, found in enumerate(detections[k]) for p, t in found]
    if len(rows) < 8 or count < 2:
        return None
    ks = np.array([r[0] for r in rows])
    cs = np.array([r[1] for r in rows])
    seen = np.array([r[2] for r in rows])
    types = np.array([r[3] for r in rows])
    spread = np.asarray(spreads, np.float64)[types]
    centres = np.asarray(centres, np.float64)

    def predict(x, index):
        rs = _rotations(x, count)
        out = np.empty((len(rows), 2))
        for c, cam in enumerate(cameras):
            m = cs == c
            if not np.any(m):
                continue
            middle = centres[ks[m]]
            towards = cam.centre - middle
            towards /= np.linalg.norm(towards, axis=1, keepdims=True)
            dirs = np.einsum("nij,nj->ni", rs[ks[m]], model.directions[index[m]])
            out[m] = cam.project(middle + model.radius * foreshorten(dirs, towards, spread[m]), distorted=False)
        return out

    def assign(x):
        rs = _rotations(x, count)
        index = np.zeros(len(rows), np.int64)
        for n, (k, c, pixel, t) in enumerate(rows):
            same = np.flatnonzero(model.types == t)
            dirs = model.directions[same] @ rs[k].T
            cam = cameras[c]
            facing = dirs @ (cam.centre - centres[k]) > 0
            pixels = cam.project(centres[k] + model.radius * dirs, distorted=False)
            index[n] = same[int(np.argmin(np.linalg.norm(pixels - pixel, axis=1) + np.where(facing, 0.0, 1e6)))]
        return index

    x = np.concatenate([vector_from_rotation(orientations[0]), spin.vector / strobe_hz])
    fit, scale = None, 1.0
    for _ in range(rounds):
        index = assign(x)

        def residuals(p):
            return (predict(p, index) - seen).ravel()
        scale = max(0.1, 1.4826 * float(np.median(np.abs(residuals(x)))))
        fit = least_squares(residuals, x, loss="soft_l1", f_scale=scale, method="trf", x_scale="jac")
        if not fit.success and fit.status <= 0:
            return None
        x = fit.x
    jacobian, r = fit.jac, fit.fun
    variance = float(r @ r) / max(len(r) - len(x), 1)
    covariance = np.linalg.pinv(jacobian.T @ jacobian) * variance
    w = x[3:6] * strobe_hz
    rate = float(np.linalg.norm(w))
    if rate <= 0:
        return None
    axis = w / rate
    cw = covariance[3:6, 3:6] * strobe_hz ** 2
    across = np.eye(3) - np.outer(axis, axis)
    axis_sigma = np.degrees(np.sqrt(max(float(np.trace(across @ cw @ across)), 0.0) / 2.0) / rate)
    rate_sigma = float(np.sqrt(max(float(axis @ cw @ axis), 0.0)))
    return ImageSpin(_rotations(x, count), Spin(axis, rate, spin.axes, spin.angles), axis_sigma, rate_sigma,
                     scale, len(rows))
