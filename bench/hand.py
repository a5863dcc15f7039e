# SPDX-License-Identifier: GPL-3.0-or-later
"""Hand simulation speed (thesis 6.2.4: "over 60 fps ... approximately 1500 nodes and 4500 springs" on a
2.4 GHz Opteron in 2003): simulated frames per second of the default hand on one core.

A *frame* is everything the rig does per animation frame: mix the control layers, the pseudo muscles'
substeps (Eqs. 6.1-6.9), forward kinematics, the geometric muscles' bulge, the skin's attachment targets,
the mass-spring substeps and the output pose (skin positions, muscle surfaces, 21 bone transforms), while
the contractions change every frame (a motion preset, Hermite-interpolated). Frames are 1/30 s (and 1/60 s
for comparison with the thesis' real-time rate). Ends with one ``RESULT fps=...`` line (1/30 s frames).

Two paths, measured in the same run: the one the live preview in Blender takes (an interactive session loads
the compiled physics kernel, so the skin substeps, the finger contact's sweeps and the pseudo muscles' joint
substeps run compiled; ``fps``) and
the numpy reference path that a short batch command takes when loading numba would not pay (``fps_numpy``).

Then the skin quality of the hand's mesh (``--mesh``, default the MPFB2 hand) in every preset pose and motion,
both hands (``hand_skin.py``'s measures: least and greatest skin edge length over its rest length, goal
0.6-1.6; triangle pairs passing through each other, goal 0; the *pinch* fingertip gap, goal <= 2 mm; motions
measured every ``--every`` frames at 30 fps) and the thenar bulge at full opponens contraction (goal >= 2 mm,
:func:`faces_hands_addon.hand.skin_quality.thenar_bulge`). The ``RESULT`` line carries both.

Run: ``make bench`` (installed extension), or ``FH_TEST_FROM_SOURCE=1 python bench/hand.py`` (working tree).
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")          # one core

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

if os.environ.get("FH_TEST_FROM_SOURCE") == "1":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
else:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import _harness  # noqa: E402,F401

import numpy as np  # noqa: E402

import faces_hands_addon.character  # noqa: E402,F401  (registers the MPFB2 hand mesh)
from faces_hands_addon.anim.layers import BASE_LAYER  # noqa: E402
from faces_hands_addon.hand import motion, skin_quality  # noqa: E402
from faces_hands_addon.hand.rig import build_hand_rig  # noqa: E402
from faces_hands_addon.physics import kernel  # noqa: E402

THESIS_FPS = 60.0


def simulated_fps(rig, dt: float, repeats: int = 3, compiled: bool = True) -> tuple[float, float]:
    """Best-of-``repeats`` frames per second over the 'showcase' motion at frame length ``dt`` (after one untimed
    pass); ms per frame.
    ``compiled``: the live path (compiled kernel when numba is loaded), else the numpy reference path."""
    rig.hand.integrator.backend = rig.contact.backend = rig.pseudo.backend = "auto" if compiled else "numpy"
    times, table = motion.motion_table("showcase", rig.muscle_names, 1.0 / dt)
    layers = [{"ctrl": dict(zip(rig.muscle_names, row))} for row in table]
    best = np.inf
    for repeat in range(repeats + 1):        # the first pass is not timed: it loads the compiled loops
        rig.reset()
        started = time.perf_counter()
        for values in layers:
            rig.step(values, dt)
        if repeat:
            best = min(best, (time.perf_counter() - started) / len(layers))
    return 1.0 / best, best * 1000.0


def quality(mesh: str, sides: list[str], every: int) -> dict:
    """The worst skin figures over every preset pose and motion of both hands, and the thenar bulge."""
    from hand_skin import PAD_RADIUS, measure
    worst = {"min_stretch": np.inf, "max_stretch": 0.0, "self_intersections": 0, "pinch_gap_mm": 0.0,
             "thenar_bulge_mm": np.inf}

    def keep(case: str, side: str, got: dict) -> None:
        print(f"{side:5s} {case:36s} stretch {got['min_stretch']:.2f}-{got['max_stretch']:.2f} "
              f"({got['outside']} of {got['edges']} edges outside 0.6-1.6)  self-intersections "
              f"{got['self_intersections']:4d}  thumb-index gap {got['pinch_gap_mm']:.1f} mm", flush=True)
        worst["min_stretch"] = min(worst["min_stretch"], got["min_stretch"])
        worst["max_stretch"] = max(worst["max_stretch"], got["max_stretch"])
        worst["self_intersections"] = max(worst["self_intersections"], got["self_intersections"])
        if case == "pose pinch":
            worst["pinch_gap_mm"] = max(worst["pinch_gap_mm"], got["pinch_gap_mm"])

    for side in sides:
        rig = build_hand_rig(side, mesh=mesh)
        rest, tips = rig.rest_positions.astype(np.float64), rig.feature_points()
        pads = [skin_quality.patch_near(rest, tips[n].astype(np.float64), PAD_RADIUS) for n in ("thumb_tip", "index_tip")]
        for name in motion.pose_names():
            pose = rig.settled_stages(motion.pose_stages(name, rig.muscle_names))
            keep(f"pose {name}", side, measure(rig, pose.positions["skin"], pads))
        for name in motion.motion_names():
            _, table = motion.motion_table(name, rig.muscle_names, 30.0)
            rig.reset()
            frames = []
            for frame, values in enumerate(table):
                pose = rig.step({BASE_LAYER: dict(zip(rig.muscle_names, values))}, 1 / 30)
                if frame % every == 0:
                    frames.append(measure(rig, pose.positions["skin"], pads))
            keep(f"motion {name} (worst of {len(frames)} frames)", side, {
                "min_stretch": min(f["min_stretch"] for f in frames), "max_stretch": max(f["max_stretch"] for f in frames),
                "outside": max(f["outside"] for f in frames), "edges": frames[0]["edges"],
                "self_intersections": max(f["self_intersections"] for f in frames),
                "pinch_gap_mm": min(f["pinch_gap_mm"] for f in frames)})
        bulge = 1000.0 * skin_quality.thenar_bulge(rig)
        print(f"{side:5s} thenar bulge at full opponens pollicis: {bulge:.1f} mm", flush=True)
        worst["thenar_bulge_mm"] = min(worst["thenar_bulge_mm"], bulge)
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh", default="mpfb2", help="the hand's skin: mpfb2 (default) or tube")
    parser.add_argument("--sides", default="right,left")
    parser.add_argument("--every", type=int, default=3, help="measure every Nth motion frame (default 3)")
    parser.add_argument("--no-quality", action="store_true", help="only the speed")
    args = parser.parse_args()
    compiled = kernel.substep_kernel() is not None
    started = time.perf_counter()
    rig = build_hand_rig(mesh=args.mesh)
    build_s = time.perf_counter() - started
    net = rig.hand.network
    print(f"hand: {net.node_count} nodes, {net.springs.count} springs, {len(rig.muscle_names)} pseudo muscles, "
          f"{len(rig.geometric.names)} geometric muscles; built in {build_s:.1f} s")
    fps30, ms30 = simulated_fps(rig, 1 / 30)
    print(f"1/30 s frames: {rig.hand.integrator.substeps_for(1 / 30)} skin substeps, {ms30:.2f} ms per frame, "
          f"{fps30:.0f} simulated frames/s")
    fps60, ms60 = simulated_fps(rig, 1 / 60)
    print(f"1/60 s frames: {rig.hand.integrator.substeps_for(1 / 60)} skin substeps, {ms60:.2f} ms per frame, "
          f"{fps60:.0f} simulated frames/s ({fps60 / THESIS_FPS:.1f}x the thesis' 60 fps)")
    fps_numpy, ms_numpy = simulated_fps(rig, 1 / 30, compiled=False)
    print(f"path: {'compiled kernel (numba), as live in Blender' if compiled else 'numpy (numba not importable)'}; "
          f"numpy reference path, 1/30 s frames: {ms_numpy:.2f} ms per frame, {fps_numpy:.0f} frames/s")
    figures = ""
    if not args.no_quality:
        q = quality(args.mesh, args.sides.split(","), args.every)
        figures = (f" max_stretch={q['max_stretch']:.2f} min_stretch={q['min_stretch']:.2f} "
                   f"self_intersections={q['self_intersections']} pinch_gap_mm={q['pinch_gap_mm']:.1f} "
                   f"thenar_bulge_mm={q['thenar_bulge_mm']:.1f}")
    print(f"RESULT mesh={args.mesh} fps={fps30:.0f} fps_60hz={fps60:.0f} fps_numpy={fps_numpy:.0f} "
          f"ms_per_frame={ms30:.3f} compiled={int(compiled)} nodes={net.node_count} springs={net.springs.count} "
          f"thesis_ratio={fps60 / THESIS_FPS:.1f}{figures}")


if __name__ == "__main__":
    main()
