# SPDX-License-Identifier: GPL-3.0-or-later
"""The initial flight parameters and the optimal reference trajectory (thesis 6.3.3 "Reconstructing
Initial Flight Parameters" and "Validation", Table 6.6).

Measured: the initial velocity's direction is the line through the first two ball positions, its magnitude
their distance times the strobe frequency; spin axis and rate come from :mod:`.orientation`. The reference
trajectory is "an exact solution of (6.12) that minimizes the error both for the measured ball positions and
for the measured initial flight parameters using Powell's optimization method": the nine parameters (initial
position, velocity, spin vector) minimise

    sum_front |p(t_k) - P_k|^2 / s_p^2 + sum_back d(P_j, p)^2 / s_p^2
      + |p0 - P_0|^2 / s_p^2 + |v0 - v_meas|^2 / s_v^2 + |w - w_meas|^2 / s_w^2

where the front positions are at the known strobe times ``t_k = k / f_front``, the back positions (a second,
unsynchronised strobe) count by their distance to the curve, and the scales are measured from the input:
``s_p`` the scatter of the front positions about a parabola in time, ``s_v = sqrt(2) s_p f_front`` (a
difference of two positions), ``s_w`` the scatter of the per-flash spin estimates. Table 6.6's columns then
compare the reference with the measurements.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from ..core.errors import UserError
from .flight import BASEBALL, MPH, Ball, curve_distances, fly

__all__ = ["Measured", "measure_initial", "flash_indices", "fit_reference", "Reference", "table_row",
           "position_scatter"]


@dataclass
class Measured:
    """The measured initial flight parameters: first position, velocity (m/s), spin vector (rad/s)."""
    position: np.ndarray
    velocity: np.ndarray
    spin: np.ndarray


def flash_indices(points: np.ndarray) -> np.ndarray:
    """The strobe flash number of each of the ordered positions: consecutive unless a ball is missing, which
    shows as a gap of about twice (three times ...) the typical step."""
    if len(points) < 2:
        return np.zeros(len(points), np.int64)
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    typical = float(np.median(steps))
    return np.concatenate([[0], np.cumsum(np.maximum(1, np.round(steps / typical)))]).astype(np.int64)


def measure_initial(points: np.ndarray, strobe_hz: float, spin: np.ndarray) -> Measured:
    """6.3.3: direction from the first two positions, magnitude from their distance and the strobe frequency."""
    if len(points) < 2:
        raise UserError("fewer than two ball positions after release; the initial velocity needs two")
    k = flash_indices(points)
    velocity = (points[1] - points[0]) * strobe_hz / float(k[1] - k[0])
    return Measured(points[0].copy(), velocity, np.asarray(spin, np.float64))


def position_scatter(points: np.ndarray, times: np.ndarray) -> float:
    """The scatter (m) of positions about a parabola in time: the measurement noise of one position."""
    if len(points) < 4:
        return 0.005
    design = np.column_stack([np.ones_like(times), times, times ** 2])
    coefficients, *_ = np.linalg.lstsq(design, points, rcond=None)
    residual = points - design @ coefficients
    dof = max(len(points) - 3, 1)
    return float(max(np.sqrt(np.sum(residual ** 2) / (3 * dof)), 2e-4))


@dataclass
class Reference:
    position: np.ndarray
    velocity: np.ndarray
    spin: np.ndarray
    duration: float
    curve: np.ndarray
    curve_times: np.ndarray
    evaluations: int


def _conjugate_directions(residuals, step: float = 0.05) -> np.ndarray:
    """Powell's starting directions: the eigenvectors of the Gauss-Newton Hessian at the start (forward
    differences), each scaled to a unit change of the objective, so that the line searches are conjugate from
    the first sweep (with unit axes the spin, which moves the positions little, took ten sweeps)."""
    r0 = residuals(np.zeros(9))
    jacobian = np.column_stack([(residuals(step * e) - r0) / step for e in np.eye(9)])
    values, vectors = np.linalg.eigh(jacobian.T @ jacobian)
    return (vectors / np.sqrt(np.maximum(values, 1e-12))).T


def _duration(front: np.ndarray, back: np.ndarray, velocity: np.ndarray) -> float:
    last = np.vstack([front, back]) if len(back) else front
    reach = float(np.max((last - front[0]) @ velocity / max(velocity @ velocity, 1e-9)))
    return max(0.05, 1.15 * reach + 0.02)


def fit_reference(front: np.ndarray, front_times: np.ndarray, back: np.ndarray, measured: Measured,
                  spin_scatter: float, ball: Ball = BASEBALL) -> Reference:
    """Powell's method on the objective of the module docstring."""
    s_p = position_scatter(front, front_times)
    strobe = 1.0 / float(np.min(np.diff(front_times))) if len(front_times) > 1 else 80.0
    s_v = np.sqrt(2.0) * s_p * strobe
    s_w = max(spin_scatter, 1.0)
    duration = _duration(front, back, measured.velocity)
    scale = np.concatenate([np.full(3, s_p), np.full(3, s_v), np.full(3, s_w)])
    start = np.concatenate([measured.position, measured.velocity, measured.spin])
    count = [0]

    def residuals(z):
        x = start + z * scale
        count[0] += 1
        flight = fly(x[:3], x[3:6], x[6:], duration, ball, tolerance=1e-6)
        parts = [((flight.at(front_times) - front) / s_p).ravel()]
        if len(back):
            parts.append(curve_distances(back, flight.samples(5e-3)[1]) / s_p)
        return np.concatenate(parts + [z])

    def cost(z):
        r = residuals(z)
        return float(r @ r)

    result = minimize(cost, np.zeros(9), method="Powell",
                      options={"xtol": 0.02, "ftol": 1e-3, "maxfev": 2000, "direc": _conjugate_directions(residuals)})
    x = start + result.x * scale
    flight = fly(x[:3], x[3:6], x[6:], duration, ball)
    times, curve = flight.samples(1e-3)
    return Reference(x[:3], x[3:6], x[6:], duration, curve, times, count[0])


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b)), float(a @ b))))


def table_row(reference: Reference, measured: Measured, positions: np.ndarray) -> dict:
    """Table 6.6's columns: errors of the measured positions against the reference trajectory, and the
    measured initial parameters against the reference's."""
    distances = curve_distances(positions, reference.curve) if len(positions) else np.zeros(1)
    rpm = 60.0 / (2.0 * np.pi)
    return {"eps_avg_mm": 1000.0 * float(np.mean(distances)), "eps_max_mm": 1000.0 * float(np.max(distances)),
            "v0_angle_deg": _angle_deg(reference.velocity, measured.velocity),
            "v0_ref_mph": float(np.linalg.norm(reference.velocity)) / MPH,
            "v0_diff_mph": abs(float(np.linalg.norm(reference.velocity) - np.linalg.norm(measured.velocity))) / MPH,
            "axis_angle_deg": _angle_deg(reference.spin, measured.spin),
            "spin_ref_rpm": float(np.linalg.norm(reference.spin)) * rpm,
            "spin_diff_rpm": abs(float(np.linalg.norm(reference.spin) - np.linalg.norm(measured.spin))) * rpm}
