"""The ball-flight model of Eq. 6.12 (thesis 6.3.3) against figures published in the thesis' own reference
[Ada02] (R. K. Adair, The Physics of Baseball): a wide curveball thrown at 70 mph with 1600 rpm of sidespin
"has curved 14.4 inches" over the distance to the plate, the largest gap between its path and the straight
line from release to plate is 3.4 inches; a 90 mph fastball falls almost 3 feet on its way to the plate; it
loses about 8 mph on the way (1 mph every seven feet).

The model is the thesis' as printed: C_D(Re) its quartic, C_L = 1.5 r w / v [AMH01]. Also shown: the lift
coefficient that reproduces Adair's curve (bisection on a constant factor), so the gap is a number.
Usage: ``python bench/pitch_physics.py`` (no Blender needed beyond the installed engine).
"""
from __future__ import annotations

import numpy as np

import _harness  # noqa: F401  (the installed engine)
from faces_hands_addon.tracking import flight as fl  # noqa: E402

FEET, INCH = 0.3048, 0.0254
DISTANCE = 60.5 * FEET - 1.7        # release about 1.7 m in front of the rubber


def at_plate(speed_mph: float, spin_rpm: float, axis, distance: float = DISTANCE):
    f = fl.fly([0.0, 0.0, 0.0], [0.0, speed_mph * fl.MPH, 0.0], np.asarray(axis, float) * spin_rpm * fl.RPM, 1.0)
    times, points = f.samples(1e-4)
    k = int(np.searchsorted(points[:, 1], distance))
    return times[k], points[:k + 1], f.velocity(times[k])[0]


def curve_break(slope: float) -> tuple[float, float]:
    saved = fl.LIFT_SLOPE
    fl.LIFT_SLOPE = slope
    try:
        _, path, _ = at_plate(70.0, 1600.0, [0.0, 0.0, 1.0], 60.0 * FEET)
    finally:
        fl.LIFT_SLOPE = saved
    chord = path[-1] - path[0]
    sideways = path[:, 0] - path[0, 0]
    gap = np.abs(path[:, 0] - (path[0, 0] + (path[:, 1] - path[0, 1]) / chord[1] * chord[0]))
    return abs(sideways[-1]) / INCH, gap.max() / INCH


def main() -> None:
    deflection, gap = curve_break(fl.LIFT_SLOPE)
    print(f"curveball 70 mph, 1600 rpm sidespin, 60 ft: deflection {deflection:.1f} in (Adair 14.4), largest gap from "
          f"the chord {gap:.1f} in (Adair 3.4)")
    low, high = 0.1, fl.LIFT_SLOPE
    for _ in range(40):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if curve_break(mid)[0] < 14.4 else (low, mid)
    print(f"  lift slope that gives Adair's 14.4 in: C_L = {mid:.3f} r w / v (the thesis: {fl.LIFT_SLOPE})")
    t, path, v = at_plate(90.0, 0.0, [1.0, 0.0, 0.0])
    print(f"fastball 90 mph, thrown level, no spin: drop {-path[-1, 2] / FEET:.2f} ft at the plate in {t:.3f} s "
          f"(Adair: almost 3 ft); speed at the plate {np.linalg.norm(v) / fl.MPH:.1f} mph (Adair: about 82)")
    re = fl.reynolds(np.array([60, 70, 80, 90]) * fl.MPH)
    print("C_D(Re) at 60/70/80/90 mph:", np.round(fl.drag_coefficient(re), 3).tolist(), f"(Re {np.round(re / 1e5, 2).tolist()} e5)")
    drop_ratio = -path[-1, 2] / FEET / 3.0
    print(f"RESULT curve_deflection_in={deflection:.2f} adair_in=14.4 ratio={deflection / 14.4:.3f} "
          f"fastball_drop_ft={-path[-1, 2] / FEET:.3f} drop_vs_3ft={drop_ratio:.3f} "
          f"plate_speed_mph={np.linalg.norm(v) / fl.MPH:.2f} lift_slope_for_adair={mid:.3f}")


if __name__ == "__main__":
    main()
