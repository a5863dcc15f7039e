# SPDX-License-Identifier: GPL-3.0-or-later
"""Ball orientation and spin (thesis 6.3.3, "Reconstructing Initial Flight Parameters").

For the ``n`` ball positions after release, in temporal order, the orientation ``R_k`` minimises Eq. 6.10

    E_k = w1 sum_{i in M_k} Delta_marker(i)^2 + w2 sum_{a in x,y,z} Delta_axis(a)^2

with Powell's method, starting from the prediction ``R_pred``: ``R_{k-1}`` turned further by the last
rotation (axis ``w_{k-2,k-1}``, angle ``delta_{k-2,k-1}``). ``Delta_marker(i)`` is the angle between the
reconstructed marker ``i`` (its direction from the ball centre) and the closest model marker of the same
type; ``Delta_axis(a)`` the angle between the ball's axis ``a`` and the same axis of the prediction. The
first two positions have no prediction: ``w2 = 0`` there, and the search starts from every rotation that
puts two reconstructed markers onto two model markers of their types at the same angle apart (the thesis
allowed a manual initialisation instead). A position with no marker keeps its prediction.

The relative rotation ``R_k R_{k-1}^T`` gives axis ``w_{k-1,k}`` and angle ``delta_{k-1,k}`` [MLS94]; the
spin is Eq. 6.11, ``f = f_s / n * sum delta`` (printed in the thesis as ``1 / (f_s n) sum delta``, which is
not a frequency: ``delta`` is per flash, so it is multiplied by the flashes per second), and the initial axis
is the mean of the axes.

Beyond the thesis, :func:`anchored_start` chooses the first two orientations by how well a constant spin from
them explains every ball's markers, and :func:`rigid_spin` refines all orientations at once under the same flight model (constant
axis and rate: ``R_k = exp(k w / f_s) R_0``) on the markers' assignments from the sequence.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, minimize

from .ball_model import BallModel
from .camera import rotation_from_vector, vector_from_rotation

__all__ = ["marker_angles", "energy", "fit_orientation", "orient_sequence", "relative_rotation", "spin_from",
           "Spin", "rigid_spin", "initial_candidates", "anchored_start"]


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))


def marker_angles(R: np.ndarray, model: BallModel, directions: np.ndarray, types: np.ndarray) -> np.ndarray:
    """Delta_marker of Eq. 6.10 for each reconstructed marker (radians)."""
    if len(directions) == 0:
        return np.zeros(0)
    world = model.directions @ R.T
    angles = _angle(directions[:, None, :], world[None, :, :])
    angles = np.where(types[:, None] == model.types[None, :], angles, np.inf)
    return angles.min(axis=1)


def energy(R: np.ndarray, model: BallModel, directions, types, predicted: np.ndarray | None, w1: float,
           w2: float) -> float:
    """Eq. 6.10 for orientation ``R`` (ball frame -> world)."""
    e = w1 * float(np.sum(marker_angles(R, model, directions, types) ** 2))
    if predicted is not None and w2 > 0:
        e += w2 * float(np.sum(_angle(R.T, predicted.T) ** 2))    # rows of R^T are the ball's axes
    return e


def initial_candidates(model: BallModel, directions: np.ndarray, types: np.ndarray,
                       tolerance: float = np.radians(12.0)) -> list[np.ndarray]:
    """Rotations that put two reconstructed markers onto two model markers of their types with the same
    angle between them (Kabsch on the pair and their cross product)."""
    out = []
    for i in range(len(directions)):
        for k in range(i + 1, len(directions)):
            seen = _angle(directions[i], directions[k])
            for a in np.flatnonzero(model.types == types[i]):
                for b in np.flatnonzero(model.types == types[k]):
                    if a == b or abs(_angle(model.directions[a], model.directions[b]) - seen) > tolerance:
                        continue
                    src = np.stack([model.directions[a], model.directions[b],
                                    np.cross(model.directions[a], model.directions[b])])
                    dst = np.stack([directions[i], directions[k], np.cross(directions[i], directions[k])])
                    u, _, vt = np.linalg.svd(dst.T @ src)
                    d = np.sign(np.linalg.det(u @ vt))
                    out.append(u @ np.diag([1.0, 1.0, d]) @ vt)
    return out


def fit_orientation(model: BallModel, directions: np.ndarray, types: np.ndarray, start: np.ndarray,
                    predicted: np.ndarray | None, w1: float = 1.0, w2: float = 0.0) -> tuple[np.ndarray, float]:
    """Powell's method on Eq. 6.10 from ``start`` (a local rotation vector about ``start`` as the three
    parameters, which has no gimbal lock where Euler angles do). Returns (R, E)."""
    def cost(p):
        return energy(rotation_from_vector(p) @ start, model, directions, types, predicted, w1, w2)

    result = minimize(cost, np.zeros(3), method="Powell", options={"xtol": 1e-6, "ftol": 1e-12, "maxfev": 4000})
    return rotation_from_vector(result.x) @ start, float(result.fun)


def relative_rotation(first: np.ndarray, second: np.ndarray) -> tuple[np.ndarray, float]:
    """Axis (world, unit) and angle (radians) of ``second first^T`` [MLS94]."""
    v = vector_from_rotation(second @ first.T)
    angle = float(np.linalg.norm(v))
    return (v / angle if angle > 0 else np.array([0.0, 0.0, 1.0])), angle


def _global_start(model, directions, types, w1) -> np.ndarray:
    candidates = initial_candidates(model, directions, types)
    if not candidates:
        return np.eye(3)
    scored = sorted(candidates, key=lambda R: energy(R, model, directions, types, None, w1, 0.0))[:6]
    fits = [fit_orientation(model, directions, types, R, None, w1, 0.0) for R in scored]
    return min(fits, key=lambda f: f[1])[0]


def _robust_energy(R, model, directions, types, cap: float = np.radians(15.0)) -> float:
    return float(np.sum(np.minimum(marker_angles(R, model, directions, types), cap) ** 2))


def anchored_start(model: BallModel, observations: list[tuple[np.ndarray, np.ndarray]],
                   keep: int = 10) -> tuple[np.ndarray, np.ndarray] | None:
    """The first orientation and the rotation per flash that explain the whole sequence best (beyond the
    thesis' independent start of the first two balls, which a ball with two or three markers can mislead):
    for two successive balls with at least two markers, every pair of their candidate orientations
    (:func:`initial_candidates`, the ``keep`` best of each) gives a rotation per flash; the pair whose constant
    spin fits the markers of all balls best wins. None when no two successive balls have two markers."""
    best = None
    for k in range(len(observations) - 1):
        (da, ta), (db, tb) = observations[k], observations[k + 1]
        if len(da) < 2 or len(db) < 2:
            continue
        ranked = []
        for d, t in ((da, ta), (db, tb)):
            cands = initial_candidates(model, d, t)
            ranked.append(sorted(cands, key=lambda R: energy(R, model, d, t, None, 1.0, 0.0))[:keep])
        for Ra in ranked[0]:
            for Rb in ranked[1]:
                step = Rb @ Ra.T
                turn = vector_from_rotation(step)
                first = rotation_from_vector(-turn * k) @ Ra
                score = sum(_robust_energy(rotation_from_vector(turn * j) @ first, model, d, t)
                            for j, (d, t) in enumerate(observations))
                if best is None or score < best[0]:
                    best = (score, first, turn)
        if best is not None:
            break
    return None if best is None else (best[1], best[2])


def orient_sequence(model: BallModel, observations: list[tuple[np.ndarray, np.ndarray]], w1: float = 1.0,
                    w2: float = 0.1, anchored: bool = True) -> list[np.ndarray]:
    """Orientations of the ball at its successive positions (module docstring): ``observations[k]`` =
    (marker directions (n, 3) from the ball centre, their type indices (n,)). With ``anchored``, the first two
    start from :func:`anchored_start` instead of their own markers alone."""
    out: list[np.ndarray] = []
    start = anchored_start(model, observations) if anchored else None
    for k, (directions, types) in enumerate(observations):
        if k < 2 and start is not None:
            predicted = rotation_from_vector(start[1] * k) @ start[0]
            out.append(fit_orientation(model, directions, types, predicted, predicted, w1, w2)[0]
                       if len(directions) else predicted)
            continue
        if k < 2:
            out.append(_global_start(model, directions, types, w1))
            continue
        axis, angle = relative_rotation(out[k - 2], out[k - 1])
        predicted = rotation_from_vector(axis * angle) @ out[k - 1]
        if len(directions) == 0:
            out.append(predicted)
            continue
        out.append(fit_orientation(model, directions, types, predicted, predicted, w1, w2)[0])
    return out


@dataclass
class Spin:
    """Eq. 6.11's spin: ``axis`` (unit, world), ``rate`` (rad/s), per-step axes and angles."""
    axis: np.ndarray
    rate: float
    axes: np.ndarray
    angles: np.ndarray

    @property
    def vector(self) -> np.ndarray:
        return self.axis * self.rate

    @property
    def rpm(self) -> float:
        return self.rate * 60.0 / (2.0 * np.pi)


def spin_from(orientations: list[np.ndarray], strobe_hz: float) -> Spin:
    """Eq. 6.11 (rate = strobe frequency x mean angle per flash) and the mean axis of successive orientations."""
    if len(orientations) < 2:
        return Spin(np.array([0.0, 0.0, 1.0]), 0.0, np.zeros((0, 3)), np.zeros(0))
    steps = [relative_rotation(a, b) for a, b in zip(orientations[:-1], orientations[1:])]
    axes = np.array([s[0] for s in steps])
    angles = np.array([s[1] for s in steps])
    reference = axes[int(np.argmax(angles))]
    axes = axes * np.where(axes @ reference < 0, -1.0, 1.0)[:, None]
    mean = np.sum(axes * angles[:, None], axis=0)
    axis = mean / max(np.linalg.norm(mean), 1e-12)
    return Spin(axis, float(strobe_hz * angles.mean()), axes, angles)


def rigid_spin(model: BallModel, observations: list[tuple[np.ndarray, np.ndarray]], orientations: list[np.ndarray],
               spin: Spin, strobe_hz: float) -> tuple[np.ndarray, Spin]:
    """All orientations at once under a constant spin (module docstring): ``R_k = exp(k w / f_s) R_0``, fitted
    to every marker's angle from its model marker (assignments from ``orientations``). Returns the refined
    orientations (K, 3, 3) and spin."""
    pairs = []
    for k, ((directions, types), R) in enumerate(zip(observations, orientations)):
        world = model.directions @ R.T
        for d, t in zip(directions, types):
            same = np.flatnonzero(model.types == t)
            pairs.append((k, d, same[int(np.argmin(_angle(d[None], world[same])))]))
    if len(pairs) < 4:
        return np.array(orientations), spin
    ks = np.array([p[0] for p in pairs], np.float64)
    seen = np.array([p[1] for p in pairs])
    model_dirs = model.directions[[p[2] for p in pairs]]

    def rotations(x):
        r0, w = rotation_from_vector(x[:3]), x[3:]
        return [rotation_from_vector(w * k / strobe_hz) @ r0 for k in range(len(observations))]

    def residual(x):
        rs = rotations(x)
        predicted = np.array([rs[int(k)] @ m for k, m in zip(ks, model_dirs)])
        return np.cross(predicted, seen).ravel()

    x0 = np.concatenate([vector_from_rotation(orientations[0]), spin.vector])
    fit = least_squares(residual, x0, method="trf", loss="soft_l1", f_scale=np.radians(0.7))
    refined = np.array(rotations(fit.x))
    rate = float(np.linalg.norm(fit.x[3:]))
    axis = fit.x[3:] / max(rate, 1e-12)
    return refined, Spin(axis, rate, spin.axes, spin.angles)
