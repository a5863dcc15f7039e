# SPDX-License-Identifier: GPL-3.0-or-later
"""Face simulation speed (issue 3, "Performance"): engine figures for the default head (~2.9k skin nodes)
and the 10k variant (~11k nodes), on one core.

Prints, per resolution: nodes and springs, the substeps per frame the stability guard picks, raw spring
steps per second, and simulated frames per second while the controls change every frame (the live preview
case: muscles, jaw and lids all animated). Ends with one ``RESULT key=value ...`` line.

Run: ``make bench`` (installed extension), or ``FH_TEST_FROM_SOURCE=1 python bench/face_sim.py`` from the
repository root (working tree, no bpy needed). Structured for the Blender half: :func:`engine_figures` returns the numbers; a Cloth comparison and the
cost of pushing positions into a mesh (both need ``bpy``) can be measured elsewhere and passed to
:func:`result_line` as ``cloth_ms`` (per frame, 10k-node mesh) and ``push_ms``.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")          # one core, as the issue asks

import sys
import time
from pathlib import Path

if os.environ.get("FH_TEST_FROM_SOURCE") == "1":      # engine from the working tree (quick iteration)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
else:                                                # the installed extension, like `make bench`
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import _harness  # noqa: E402,F401

import numpy as np  # noqa: E402

from faces_hands_addon.face.rig import build_default_rig  # noqa: E402

FRAME_DT = 1.0 / 24.0          # Blender's default scene rate


def _animated_controls(frame: int) -> dict[str, float]:
    """A busy performance: smile and jaw in anti-phase, a blink, brows, lips, every frame different."""
    phase = 2 * np.pi * frame / 24.0
    wave = 0.5 - 0.5 * np.cos(phase)
    return {"zygomaticus_major_L": wave, "zygomaticus_major_R": wave, "jaw_open": 0.6 * (1 - wave),
            "frontalis_inner_L": 0.5 * wave, "frontalis_inner_R": 0.5 * wave,
            "orbicularis_oris_upper": 0.3 * (1 - wave), "orbicularis_oris_lower": 0.3 * (1 - wave),
            "eyelid_close_L": float(frame % 48 < 4), "eyelid_close_R": float(frame % 48 < 4),
            "eye_yaw": 0.3 * np.sin(phase / 2)}


def engine_figures(resolution: str = "default", frames: int = 96, steps: int = 300) -> dict[str, float]:
    """Engine speed for one resolution (median-free, plain wall time on one core)."""
    started = time.perf_counter()
    rig = build_default_rig(resolution)
    build_s = time.perf_counter() - started
    net, integ = rig.face.network, rig.face.integrator
    dt = integ.max_substep
    for _ in range(10):
        integ.step(dt)
    started = time.perf_counter()
    for _ in range(steps):
        integ.step(dt)
    step_s = (time.perf_counter() - started) / steps
    rig.reset_state()
    rig.set_controls(_animated_controls(0))
    rig.step_frame(FRAME_DT)
    started = time.perf_counter()
    for frame in range(1, frames + 1):
        rig.set_controls(_animated_controls(frame))
        rig.step_frame(FRAME_DT)
    frame_s = (time.perf_counter() - started) / frames
    return {"nodes": net.node_count, "springs": net.springs.count, "build_s": build_s,
            "substeps": rig.substeps_per_frame(FRAME_DT), "step_ms": 1e3 * step_s, "steps_per_s": 1.0 / step_s,
            "frame_ms": 1e3 * frame_s, "sim_fps": 1.0 / frame_s}


def result_line(default: dict, dense: dict, cloth_ms: float | None = None, push_ms: float | None = None) -> str:
    """``RESULT ...``: live_fps (default head), engine figures, and cloth_ratio/push_ms when measured."""
    parts = [f"live_fps={default['sim_fps']:.1f}", f"frame_ms_10k={dense['frame_ms']:.2f}",
             f"steps_per_s_2k={default['steps_per_s']:.0f}", f"steps_per_s_10k={dense['steps_per_s']:.0f}",
             f"substeps_2k={default['substeps']}", f"substeps_10k={dense['substeps']}"]
    if cloth_ms is not None:
        parts.append(f"cloth_ratio={cloth_ms / dense['frame_ms']:.1f}")
    if push_ms is not None:
        parts.append(f"push_ms={push_ms:.3f}")
    return "RESULT " + " ".join(parts)


def main() -> None:
    figures = {}
    for resolution in ("default", "10k"):
        f = engine_figures(resolution)
        figures[resolution] = f
        print(f"{resolution:>7}: {f['nodes']} nodes, {f['springs']} springs, build {f['build_s']:.2f} s; "
              f"guard substeps/frame at {1 / FRAME_DT:.0f} fps: {f['substeps']}; "
              f"{f['step_ms']:.3f} ms/step ({f['steps_per_s']:.0f} steps/s); "
              f"animated frame {f['frame_ms']:.2f} ms ({f['sim_fps']:.0f} simulated frames/s)")
    print(result_line(figures["default"], figures["10k"]))


if __name__ == "__main__":
    main()
