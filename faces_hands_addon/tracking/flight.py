# SPDX-License-Identifier: GPL-3.0-or-later
"""Ball flight (thesis 6.3.3 "Validation", Eq. 6.12): gravity, drag and the Magnus force on a spinning
baseball, integrated with the Dormand-Prince 5(4) pair (scipy's ``RK45``; the thesis used DOPRI5 [HNW93]).

``m dv/dt = m g + F_D(v) + F_M(v)`` with

* ``F_D = -1/2 C_D(Re) rho A |v|^2 v/|v|``, ``C_D`` the thesis' quartic in the Reynolds number
  ``Re = rho |v| d / mu`` (fitted by the thesis to [Ada02] and [AMH01]);
* ``F_M = 1/2 C_L rho A |v|^2 (w x v)/|w x v|``, ``C_L = 1.5 r |w| / |v|`` ([AMH01]; ``w`` in rad/s), the
  spin axis and rate constant during the flight (footnote 3 of 6.3.3).

The lift coefficient is a function of the spin factor ``S = r |w| / |v|``; :data:`LIFT_MODELS` names the
choices and :class:`Ball` carries one (``presets/tracking/ball.json``, key ``lift``):

* ``"thesis"``: ``C_L = 1.5 S``, Eq. 6.12 as printed (the specification, the default);
* ``"sawicki2003"``: ``C_L = 1.5 S`` up to ``S = 0.1`` and ``0.09 + 0.6 S`` above, the bilinear fit of
  G. S. Sawicki, M. Hubbard and W. J. Stronge, "How to hit home runs", Am. J. Phys. 71 (2003) 1152, to
  measured lift of pitched and wind-tunnel baseballs (Alaways' trajectories of pitched balls, the data
  behind [AMH01], and the wind tunnel of Watts and Ferrer 1987). The thesis' line is its low-spin branch:
  at a pitch's ``S`` of 0.15-0.25 it gives about 0.7 of the thesis' lift.
  A. M. Nathan, "The effect of spin on the flight of a baseball", Am. J. Phys. 76 (2008) 119, measured
  ``C_L`` from high-speed video of the trajectories (``S`` 0.09-0.6) and found it to depend on ``S`` alone,
  not on the speed; ``bench/pitch_physics.py`` sets both models against published curve figures.

The quartic is a fit over the drag crisis of a baseball: read outside it, it climbs to 2.23 at rest and turns
up again past its minimum. :func:`drag_coefficient` holds it at Adair's subcritical 0.5 below the Reynolds
number where the quartic reaches 0.5, and at its minimum above the minimum (:data:`RE_RANGE`), so every pitch
speed gets a drag coefficient inside the fitted curve.

Units: metres, seconds, kilograms, radians; Z up. :func:`fly` integrates a flight; :func:`curve_distances`
measures points against a trajectory as Table 6.6 does (Euclidean distance to the curve, no timing needed).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from ..core.errors import UserError

__all__ = ["Ball", "Air", "BASEBALL", "SEA_LEVEL", "reynolds", "drag_coefficient", "lift_coefficient", "acceleration",
           "fly", "Flight", "curve_distances", "CD_COEFFICIENTS", "RE_RANGE", "MPH", "RPM", "GRAVITY", "LIFT_MODELS",
           "spin_factor"]

MPH = 0.44704                     # m/s per mile per hour
RPM = 2.0 * np.pi / 60.0          # rad/s per revolution per minute
GRAVITY = np.array([0.0, 0.0, -9.81])
#: Eq. 6.12's drag polynomial, C_D(Re) = sum c_k Re^k (6.3.3 "Validation")
CD_COEFFICIENTS = (2.23, -0.28342e-4, 0.13179e-9, -0.25083e-15, 0.17083e-21)
SUBCRITICAL_CD = 0.5              # a baseball's drag coefficient below the drag crisis [Ada02]
LIFT_SLOPE = 1.5                  # C_L = 1.5 r |w| / |v| [AMH01]


def _lift_thesis(s):
    return LIFT_SLOPE * s


def _lift_sawicki(s):
    return np.where(s <= 0.1, LIFT_SLOPE * s, 0.09 + 0.6 * s)


#: C_L as a function of the spin factor S = r |w| / |v|, by name (module docstring)
LIFT_MODELS = {"thesis": _lift_thesis, "sawicki2003": _lift_sawicki}


@dataclass(frozen=True)
class Ball:
    """A regulation baseball: 5-5.25 oz, 9-9.25 in around (Official Baseball Rules 3.01); ``lift`` names its
    C_L(S) in :data:`LIFT_MODELS`."""
    mass: float = 0.145           # kg
    radius: float = 0.0366        # m
    lift: str = "thesis"

    def __post_init__(self):
        if self.lift not in LIFT_MODELS:
            raise UserError(f"unknown lift model {self.lift!r}; choose one of {', '.join(LIFT_MODELS)}")

    @property
    def area(self) -> float:
        return float(np.pi * self.radius ** 2)


@dataclass(frozen=True)
class Air:
    density: float = 1.2          # kg/m^3 [Ada02]
    viscosity: float = 1.81e-5    # Pa s (dynamic, 20 C)


BASEBALL = Ball()
SEA_LEVEL = Air()


def _quartic(re):
    return sum(c * np.asarray(re, np.float64) ** k for k, c in enumerate(CD_COEFFICIENTS))


def _fit_range() -> tuple[float, float]:
    """Where the quartic is the drag crisis: from C_D = 0.5 down to its minimum."""
    minimum = float(minimize_scalar(_quartic, bounds=(1.0e5, 3.0e5), method="bounded").x)
    start = float(brentq(lambda re: _quartic(re) - SUBCRITICAL_CD, 1.0e4, minimum))
    return start, minimum


RE_RANGE = _fit_range()


def reynolds(speed, ball: Ball = BASEBALL, air: Air = SEA_LEVEL):
    return air.density * np.asarray(speed, np.float64) * 2.0 * ball.radius / air.viscosity


def drag_coefficient(re):
    """C_D of Eq. 6.12 at Reynolds number ``re`` (held at the ends of :data:`RE_RANGE`, module docstring)."""
    return _quartic(np.clip(re, *RE_RANGE))


def spin_factor(speed, spin_rate, ball: Ball = BASEBALL):
    """S = r |w| / |v|, ``spin_rate`` in rad/s."""
    return ball.radius * np.asarray(spin_rate, np.float64) / np.maximum(speed, 1e-9)


def lift_coefficient(speed, spin_rate, ball: Ball = BASEBALL):
    """C_L of ``ball.lift`` (the thesis: 1.5 r |w| / |v| [AMH01]), ``spin_rate`` in rad/s."""
    return LIFT_MODELS[ball.lift](spin_factor(speed, spin_rate, ball))


def acceleration(velocity: np.ndarray, spin: np.ndarray, ball: Ball = BASEBALL, air: Air = SEA_LEVEL,
                 gravity: np.ndarray = GRAVITY) -> np.ndarray:
    """dv/dt of Eq. 6.12 for ``velocity`` (3,) m/s and spin vector ``spin`` (3,) rad/s (right-hand rule)."""
    v = np.asarray(velocity, np.float64)
    w = np.asarray(spin, np.float64)
    speed = float(np.sqrt(v @ v))
    if speed == 0.0:
        return np.asarray(gravity, np.float64).copy()
    pressure = 0.5 * air.density * ball.area * speed * speed / ball.mass
    drag = -drag_coefficient(reynolds(speed, ball, air)) * pressure * v / speed
    cross = np.array([w[1] * v[2] - w[2] * v[1], w[2] * v[0] - w[0] * v[2], w[0] * v[1] - w[1] * v[0]])
    norm = float(np.sqrt(cross @ cross))
    magnus = np.zeros(3) if norm == 0.0 else \
        lift_coefficient(speed, float(np.sqrt(w @ w)), ball) * pressure * cross / norm
    return gravity + drag + magnus


@dataclass
class Flight:
    """A solved flight: ``at(t)`` positions (K, 3), ``velocity(t)``; ``spin`` the constant spin vector."""
    solution: object
    spin: np.ndarray
    duration: float

    def at(self, times) -> np.ndarray:
        return self.solution.sol(np.atleast_1d(np.asarray(times, np.float64)))[:3].T

    def velocity(self, times) -> np.ndarray:
        return self.solution.sol(np.atleast_1d(np.asarray(times, np.float64)))[3:].T

    def samples(self, step: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
        times = np.linspace(0.0, self.duration, max(2, int(np.ceil(self.duration / step)) + 1))
        return times, self.at(times)


def fly(position, velocity, spin, duration: float, ball: Ball = BASEBALL, air: Air = SEA_LEVEL,
        tolerance: float = 1e-9) -> Flight:
    """Integrate Eq. 6.12 from ``position`` (m) and ``velocity`` (m/s) with ``spin`` (rad/s) for ``duration``
    seconds: Dormand-Prince 5(4) with dense output (``Flight.at``)."""
    state = np.concatenate([np.asarray(position, np.float64), np.asarray(velocity, np.float64)])
    w = np.asarray(spin, np.float64)
    if state.shape != (6,) or w.shape != (3,) or not np.all(np.isfinite(state)) or not np.all(np.isfinite(w)):
        raise UserError("a flight needs a finite initial position, velocity and spin vector (3 numbers each)")
    if not (duration > 0 and np.isfinite(duration)):
        raise UserError("a flight needs a positive duration in seconds")

    def rhs(_t, y):
        return np.concatenate([y[3:], acceleration(y[3:], w, ball, air)])

    solution = solve_ivp(rhs, (0.0, float(duration)), state, method="RK45", rtol=tolerance,
                         atol=tolerance * 1e-3, dense_output=True)
    if not solution.success:
        raise UserError(f"the flight could not be integrated ({solution.message})")
    return Flight(solution, w.copy(), float(duration))


def curve_distances(points: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """Euclidean distance of each point (N, 3) to the polyline ``curve`` (M, 3) (Table 6.6: "Euclidean
    distance between trajectory and center of ball"): the closest point on any of its segments."""
    p = np.asarray(points, np.float64)[:, None, :]
    a, b = curve[:-1][None], curve[1:][None]
    ab = b - a
    t = np.clip(np.einsum("nmk,nmk->nm", p - a, ab) / np.maximum(np.einsum("nmk,nmk->nm", ab, ab), 1e-30), 0, 1)
    closest = a + t[..., None] * ab
    return np.sqrt(np.min(np.einsum("nmk,nmk->nm", p - closest, p - closest), axis=1))
