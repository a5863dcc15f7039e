"""The ball-flight model of Eq. 6.12 (thesis 6.3.3) against published curve and drop figures.

(a) Integration, geometry, units: the flight of ``fly`` (scipy's Dormand-Prince 5(4)) against a fixed-step
fourth-order Runge-Kutta of the same forces written here (``rk4_in``: the deflections agree to that many
inches), and a level 90 mph fastball's drop, which is gravity over the flight time (drag only sets the time).

(b) The lift. Figures (each with what it is):

* R. K. Adair, The Physics of Baseball (3rd ed., 2002; the thesis' [Ada02]), chapter 2: a curveball thrown at
  70 mph with 1600 rpm of sidespin "has curved 14.4 inches" over 60 ft, 3.4 in largest gap from the straight
  line from release to plate; a 90 mph fastball falls almost 3 ft and reaches the plate at about 82 mph.
  These are OUTPUTS OF ADAIR'S MODEL, whose lift he took from wind-tunnel measurements, not trajectories.
* L. J. Briggs, "Effect of spin and speed on the lateral deflection (curve) of a baseball; and the Magnus
  effect for smooth spheres", Am. J. Phys. 27 (1959) 589, and the National Bureau of Standards' release of
  29 March 1959: wind-tunnel forces on spinning baseballs put as the curve over 60 ft: 17.5 in at
  1800 rpm and 100 ft/s, "speed by itself has little effect". MEASURED (wind tunnel), not a trajectory.
* The lift models of :data:`flight.LIFT_MODELS`: the thesis' C_L = 1.5 S (Eq. 6.12 as printed, [AMH01]) and
  G. S. Sawicki, M. Hubbard, W. J. Stronge, "How to hit home runs", Am. J. Phys. 71 (2003) 1152: the bilinear
  C_L(S) FITTED to measured lift of pitched balls (L. W. Alaways' trajectories, the data behind the thesis'
  [AMH01]) and of wind-tunnel balls (Watts and Ferrer 1987). Neither model is fitted to the figures above.
  A. M. Nathan, "The effect of spin on the flight of a baseball", Am. J. Phys. 76 (2008) 119 (trajectories
  of machine-pitched balls by high-speed video, S = 0.09-0.6) reports C_L depending on S alone.

For each figure, also the lift slope ``k`` (C_L = k S) that reproduces it, so a gap is a number. The drag is
the thesis' C_D(Re) quartic throughout (the fastball's plate speed shows what it does).
Usage: ``python bench/pitch_physics.py`` (no Blender needed beyond the installed engine).
"""
from __future__ import annotations

import numpy as np

import _harness  # noqa: F401  (the installed engine)
from faces_hands_addon.tracking import flight as fl  # noqa: E402

FEET, INCH = 0.3048, 0.0254
PLATE = 60.5 * FEET - 1.7        # release about 1.7 m in front of the rubber


def path_to(distance: float, speed_mph: float, spin_rpm: float, axis, lift: str = "thesis"):
    """The flight along +y at ``speed_mph`` with ``spin_rpm`` about ``axis`` until ``distance`` metres."""
    ball = fl.Ball(lift=lift)
    f = fl.fly([0.0, 0.0, 0.0], [0.0, speed_mph * fl.MPH, 0.0], np.asarray(axis, float) * spin_rpm * fl.RPM,
               1.5, ball)
    times, points = f.samples(1e-4)
    k = int(np.searchsorted(points[:, 1], distance))
    return times[:k + 1], points[:k + 1], f.velocity(times[k])[0]


def curve(speed_mph: float, spin_rpm: float, lift: str, distance: float = 60.0 * FEET) -> tuple[float, float]:
    """Sidespin curve: deflection from the initial line and largest gap from the chord (inches)."""
    _, path, _ = path_to(distance, speed_mph, spin_rpm, [0.0, 0.0, 1.0], lift)
    chord = path[-1] - path[0]
    gap = np.abs(path[:, 0] - (path[0, 0] + (path[:, 1] - path[0, 1]) / chord[1] * chord[0]))
    return abs(path[-1, 0] - path[0, 0]) / INCH, gap.max() / INCH


def rk4_deflection(speed_mph: float, spin_rpm: float, lift: str, distance: float = 60.0 * FEET,
                   step: float = 1e-4) -> float:
    """The same sidespin curve by a fixed-step classical Runge-Kutta (an independent integrator)."""
    ball = fl.Ball(lift=lift)
    w = np.array([0.0, 0.0, spin_rpm * fl.RPM])
    y = np.array([0.0, 0.0, 0.0, 0.0, speed_mph * fl.MPH, 0.0])

    def f(s):
        return np.concatenate([s[3:], fl.acceleration(s[3:], w, ball)])
    while True:
        k1 = f(y)
        k2 = f(y + 0.5 * step * k1)
        k3 = f(y + 0.5 * step * k2)
        k4 = f(y + step * k3)
        nxt = y + step / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        if nxt[1] >= distance:
            t = (distance - y[1]) / (nxt[1] - y[1])
            return abs(y[0] + t * (nxt[0] - y[0])) / INCH
        y = nxt


def slope_for(target_in: float, speed_mph: float, spin_rpm: float) -> float:
    """The k of C_L = k S whose curve is ``target_in`` (bisection)."""
    low, high = 0.05, 3.0
    try:
        for _ in range(40):
            mid = 0.5 * (low + high)
            fl.LIFT_MODELS["_slope"] = lambda s, k=mid: k * s
            low, high = (mid, high) if curve(speed_mph, spin_rpm, "_slope")[0] < target_in else (low, mid)
    finally:
        fl.LIFT_MODELS.pop("_slope", None)
    return 0.5 * (low + high)


def main() -> None:
    adair = (70.0, 1600.0, 14.4)
    briggs = (100.0 * FEET / fl.MPH, 1800.0, 17.5)
    rows = {}
    for lift in fl.LIFT_MODELS:
        a, gap = curve(adair[0], adair[1], lift)
        b, _ = curve(briggs[0], briggs[1], lift)
        rows[lift] = (a, gap, b)
        s_a = float(fl.spin_factor(adair[0] * fl.MPH, adair[1] * fl.RPM))
        s_b = float(fl.spin_factor(briggs[0] * fl.MPH, briggs[1] * fl.RPM))
        print(f"{lift:12s} Adair's curve (70 mph, 1600 rpm, S {s_a:.3f}, C_L {float(fl.LIFT_MODELS[lift](s_a)):.3f}): "
              f"{a:.1f} in (Adair 14.4), gap from the chord {gap:.1f} in (Adair 3.4); Briggs' (100 ft/s, 1800 rpm, "
              f"S {s_b:.3f}, C_L {float(fl.LIFT_MODELS[lift](s_b)):.3f}): {b:.1f} in (Briggs 17.5)")
    rk4 = rk4_deflection(adair[0], adair[1], "thesis")
    k_adair, k_briggs = slope_for(adair[2], adair[0], adair[1]), slope_for(briggs[2], briggs[0], briggs[1])
    print(f"(a) fixed-step RK4 of the same forces: {rk4:.3f} in against {rows['thesis'][0]:.3f} in (Dormand-Prince)")
    print(f"(b) lift slope k (C_L = k S) reproducing Adair's 14.4 in: {k_adair:.3f}; Briggs' 17.5 in: {k_briggs:.3f} "
          f"(the thesis 1.5; Sawicki et al. at S 0.2: {float(fl.LIFT_MODELS['sawicki2003'](0.2)) / 0.2:.2f})")
    times, path, v = path_to(PLATE, 90.0, 0.0, [1.0, 0.0, 0.0])
    drop = -path[-1, 2] / FEET
    gravity_only = 0.5 * 9.81 * times[-1] ** 2 / FEET
    print(f"fastball 90 mph, level, no spin: drop {drop:.2f} ft in {times[-1]:.3f} s (gravity over that time "
          f"{gravity_only:.2f} ft; Adair: almost 3 ft), plate speed {np.linalg.norm(v) / fl.MPH:.1f} mph (Adair: "
          f"about 82)")
    re = fl.reynolds(np.array([60, 70, 80, 90]) * fl.MPH)
    print("C_D(Re) at 60/70/80/90 mph:", np.round(fl.drag_coefficient(re), 3).tolist(),
          f"(Re {np.round(re / 1e5, 2).tolist()} e5)")
    t, s = rows["thesis"], rows["sawicki2003"]
    print(f"RESULT adair_in=14.4 briggs_in=17.5 thesis_adair_in={t[0]:.2f} thesis_briggs_in={t[2]:.2f} "
          f"sawicki_adair_in={s[0]:.2f} sawicki_briggs_in={s[2]:.2f} thesis_vs_briggs={t[2] / 17.5:.3f} "
          f"sawicki_vs_briggs={s[2] / 17.5:.3f} sawicki_vs_adair={s[0] / 14.4:.3f} slope_adair={k_adair:.3f} "
          f"slope_briggs={k_briggs:.3f} rk4_diff_in={abs(rk4 - t[0]):.4f} fastball_drop_ft={drop:.3f} "
          f"drop_vs_3ft={drop / 3.0:.3f} plate_speed_mph={np.linalg.norm(v) / fl.MPH:.2f}")


if __name__ == "__main__":
    main()
