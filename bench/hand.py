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

Run: ``make bench`` (installed extension), or ``FH_TEST_FROM_SOURCE=1 python bench/hand.py`` (working tree).
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")          # one core

import sys
import time
from pathlib import Path

if os.environ.get("FH_TEST_FROM_SOURCE") == "1":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
else:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import _harness  # noqa: E402,F401

import numpy as np  # noqa: E402

from faces_hands_addon.hand import motion  # noqa: E402
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


def main() -> None:
    kernel.set_interactive(True)          # as the live preview in Blender: the compiled kernel pays there
    compiled = kernel.substep_kernel() is not None
    started = time.perf_counter()
    rig = build_hand_rig()
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
    print(f"RESULT fps={fps30:.0f} fps_60hz={fps60:.0f} fps_numpy={fps_numpy:.0f} ms_per_frame={ms30:.3f} "
          f"compiled={int(compiled)} nodes={net.node_count} springs={net.springs.count} "
          f"thesis_ratio={fps60 / THESIS_FPS:.1f}")


if __name__ == "__main__":
    main()
