# SPDX-License-Identifier: GPL-3.0-or-later
"""Face simulation speed : engine figures for the default head (~2.9k skin nodes)
and the 10k variant (~11k nodes), on one core.

Prints, per resolution: nodes and springs, the substeps per frame the stability guard picks, raw spring
steps per second, and simulated frames per second while the controls change every frame (the live preview
case: muscles, jaw and lids all animated). Ends with one ``RESULT key=value ...`` line.

Run: ``make bench`` (installed extension, inside the bpy module), or ``FH_TEST_FROM_SOURCE=1 python
bench/face_sim.py`` from the repository root (working tree, engine figures only). With bpy it also measures,
in the same run: Blender's Cloth modifier (default quality) on the same 10k-node mesh for the same number
of frames (``cloth_ratio`` = Cloth ms per frame / our ms per frame), the cost of pushing 10k positions into
a shape key (``push_ms``), and the whole live-preview step of the default head inside Blender (controls
read from the rig object, simulate, push skin + eyes/jaw/teeth/tongue + muscle display).

These figures leave Blender's share out: ``push_ms`` is a bare ``foreach_set`` + ``mesh.update()`` (the
depsgraph evaluation it triggers is not in it), ``live_fps`` has no depsgraph evaluation and only the
default head, and ``cloth_ratio`` compares against an unpinned Cloth under gravity. The honest figures are
``bench/live_tick.py`` (step + shape-key write + depsgraph, default/10k/fitted 50k heads) and
``bench/kernel.py`` (frame and substep cost, numpy vs the numba kernel, 3k/11k/45k nodes).
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
sys.path.insert(0, str(Path(__file__).resolve().parent))  # bench/_workloads.py
from _workloads import animated_controls as _animated_controls  # noqa: E402

from faces_hands_addon.face.rig import build_default_rig  # noqa: E402

FRAME_DT = 1.0 / 24.0          # Blender's default scene rate


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


def cloth_ms_per_frame(rig, frames: int = 24) -> float:
    """Blender's own mass-spring solver on the same skin mesh: a Cloth modifier at default settings
    (quality 5), timed over ``frames`` frames of its simulation."""
    import bpy
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    mesh = bpy.data.meshes.new("ClothBench")
    mesh.from_pydata(rig.rest_positions.tolist(), [], rig.faces.tolist())
    obj = bpy.data.objects.new("ClothBench", mesh)
    bpy.context.scene.collection.objects.link(obj)
    cloth = obj.modifiers.new("Cloth", "CLOTH")
    cloth.point_cache.frame_start, cloth.point_cache.frame_end = 1, frames + 1
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, frames + 1
    scene.frame_set(1)
    started = time.perf_counter()
    for frame in range(2, frames + 2):
        scene.frame_set(frame)
        obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    return 1e3 * (time.perf_counter() - started) / frames


def push_ms(rig, repeats: int = 200) -> float:
    """Positions (N, 3) float32 -> a shape key of an N-vertex mesh, the live preview's write path."""
    import bpy
    mesh = bpy.data.meshes.new("PushBench")
    mesh.from_pydata(rig.rest_positions.tolist(), [], rig.faces.tolist())
    obj = bpy.data.objects.new("PushBench", mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.shape_key_add(name="Basis")
    key = obj.shape_key_add(name="FH Simulation")
    positions = np.ascontiguousarray(rig.positions, dtype=np.float32).ravel()
    started = time.perf_counter()
    for _ in range(repeats):
        key.points.foreach_set("co", positions)
        mesh.update()
    return 1e3 * (time.perf_counter() - started) / repeats


def live_preview_fps(frames: int = 96) -> tuple[float, int]:
    """The add-on's live step on the default head in Blender (read controls, simulate, push everything)."""
    import bpy
    live = _harness.EXTENSION.operators.bases.live
    muscles = _harness.EXTENSION.operators.face.objects.update_muscle_display
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    bpy.ops.faces_hands.build_face_rig()
    obj = bpy.context.active_object
    for frame in range(3):
        live.live_step(bpy.context, obj, muscles, FRAME_DT)
    started = time.perf_counter()
    for frame in range(frames):
        for name, value in _animated_controls(frame).items():
            obj[f"fh.ctrl.{name}"] = float(value)
        live.live_step(bpy.context, obj, muscles, FRAME_DT)
    return frames / (time.perf_counter() - started), len(obj.data.vertices)


def main() -> None:
    figures = {}
    for resolution in ("default", "10k"):
        f = engine_figures(resolution)
        figures[resolution] = f
        print(f"{resolution:>7}: {f['nodes']} nodes, {f['springs']} springs, build {f['build_s']:.2f} s; "
              f"guard substeps/frame at {1 / FRAME_DT:.0f} fps: {f['substeps']}; "
              f"{f['step_ms']:.3f} ms/step ({f['steps_per_s']:.0f} steps/s); "
              f"animated frame {f['frame_ms']:.2f} ms ({f['sim_fps']:.0f} simulated frames/s)")
    if os.environ.get("FH_TEST_FROM_SOURCE") == "1":
        print(result_line(figures["default"], figures["10k"]))
        return
    dense_rig = build_default_rig("10k")
    cloth = cloth_ms_per_frame(dense_rig)
    print(f"Blender Cloth modifier (default quality) on the same {len(dense_rig.rest_positions)}-vertex mesh: "
          f"{cloth:.1f} ms/frame; ours {figures['10k']['frame_ms']:.2f} ms/frame -> "
          f"{cloth / figures['10k']['frame_ms']:.1f}x faster")
    push = push_ms(dense_rig)
    print(f"push {len(dense_rig.rest_positions)} positions into a shape key: {push:.3f} ms/frame")
    live_fps, vertices = live_preview_fps()
    print(f"live preview in Blender, default head ({vertices} vertices, everything pushed): "
          f"{live_fps:.0f} frames/s (goal >= 30)")
    line = result_line(figures["default"], figures["10k"], cloth_ms=cloth, push_ms=push)
    print(line.replace("RESULT live_fps=", f"RESULT live_fps={live_fps:.1f} engine_fps=", 1))


if __name__ == "__main__":
    main()
