# SPDX-License-Identifier: GPL-3.0-or-later
"""The live preview's whole tick inside Blender: ``live_tick_ms`` = the add-on's ``live_step`` (controls read
from the rig object, mix, simulate one frame, write the skin into its simulation shape key, move the parts,
update the muscle display) + Blender's depsgraph evaluation of the result (``view_layer.update()``, then
the evaluated skin's vertex normals, which drawing needs). Measured on the default head, the 10k variant
and a fitted ~50k-vertex synthetic artist head (``fitting.testdata.full_head`` through Fit Face Rig).

Every control changes every tick (as ``bench/face_sim.py``). Per-tick wall and CPU times (``process_time``: every thread of
Blender's process, what the tick costs when no other job competes for the cores); medians (the machine
may be shared); the split step / write / depsgraph is measured in a second pass of the same ticks with
the same calls made one by one. Backend: the fused numba kernel when importable, else numpy (printed);
``FH_PHYSICS_KERNEL=numpy`` for the reference path.

Run: ``make install`` then ``.venv/bin/python bench/live_tick.py [--skip-fitted]``. Ends with
``RESULT live_tick_ms_3k=... live_tick_ms_11k=... live_tick_ms_50k=...``.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402
from _workloads import animated_controls, record_split  # noqa: E402

from faces_hands_addon.physics import kernel  # noqa: E402

FRAME_DT = 1.0 / 24.0


def default_rig(resolution: str):
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    assert bpy.ops.faces_hands.build_face_rig(resolution=resolution) == {"FINISHED"}
    return bpy.context.active_object


def fitted_rig():
    from faces_hands_addon.fitting import testdata
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    head = testdata.full_head(0, spacing=0.0022, body_spacing=0.005)
    mesh = bpy.data.meshes.new("Artist Head")
    mesh.from_pydata(head.vertices.tolist(), [], head.faces.tolist())
    obj = bpy.data.objects.new("Artist Head", mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    started = time.perf_counter()
    assert bpy.ops.faces_hands.fit_face_rig() == {"FINISHED"}
    print(f"  fitted rig built in {time.perf_counter() - started:.1f} s")
    return obj


def evaluate(obj) -> None:
    """Blender's share: depsgraph evaluation (shape keys mixed, modifiers) and the normals drawing needs."""
    bpy.context.view_layer.update()
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    evaluated.vertex_normals[0].vector


def _set_animated_controls(obj, frame: int) -> None:
    for name, value in animated_controls(frame).items():
        obj[f"fh.ctrl.{name}"] = float(value)


def measure(obj, frames: int, set_controls=_set_animated_controls, hook=None, dt: float = FRAME_DT) -> dict:
    """Median wall and CPU ms of ``frames`` live ticks (``set_controls(obj, frame)`` first, outside the
    timing), then the split rig lookup / step / write (pose + ``hook``, default: the face's muscle display)
    / depsgraph from a second pass of the same ticks."""
    ext = _harness.EXTENSION.operators
    live = ext.bases.live
    hook = ext.face.objects.update_muscle_display if hook is None else hook
    rig_store, controls, poses = ext.adapters.rig_store, ext.adapters.controls, ext.adapters.poses
    context = bpy.context
    for frame in range(3):
        live.live_step(context, obj, hook, dt)
        evaluate(obj)
    total, cpu = [], []
    for frame in range(frames):
        set_controls(obj, frame)
        started, started_cpu = time.perf_counter(), time.process_time()
        live.live_step(context, obj, hook, dt)
        evaluate(obj)
        total.append(1e3 * (time.perf_counter() - started))
        cpu.append(1e3 * (time.process_time() - started_cpu))
    split = {"rig": [], "step": [], "write": [], "depsgraph": []}
    for frame in range(frames):
        set_controls(obj, frame)
        t0 = time.perf_counter()
        rig = rig_store.get_rig(obj)
        t1 = time.perf_counter()
        pose = rig.step(controls.layer_values(obj, rig.control_specs()), dt)
        t2 = time.perf_counter()
        poses.push_pose(obj, pose)
        hook(obj, rig)
        t3 = time.perf_counter()
        evaluate(obj)
        record_split(split, [t0, t1, t2, t3, time.perf_counter()])
    return {"ms": statistics.median(total), "cpu_ms": statistics.median(cpu),
            **{k: statistics.median(v) for k, v in split.items()}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=48)
    parser.add_argument("--skip-fitted", action="store_true")
    args = parser.parse_args()
    compiled = kernel.substep_kernel()
    backend = "numba" if compiled is not None else "numpy"
    print(f"settings: Blender {bpy.app.version_string}, backend {backend} (first-call compile "
          f"{kernel.compile_seconds() or 0:.2f} s, cache {kernel.cache_folder()}), frame dt 1/24 s, "
          f"{args.frames} ticks, every control animated, one thread, {os.cpu_count()} cores; medians, shared "
          f"machine (the load average is printed per head)")
    cases = [("3k", lambda: default_rig("default")), ("11k", lambda: default_rig("10k"))]
    if not args.skip_fitted:
        cases.append(("50k", fitted_rig))
    result = []
    for label, make in cases:
        obj = make()
        load = os.getloadavg()[0]
        f = measure(obj, args.frames if label != "50k" else max(12, args.frames // 2))
        rig = _harness.EXTENSION.operators.adapters.rig_store.get_rig(obj)
        f.update(nodes=rig.face.network.node_count, vertices=len(obj.data.vertices),
                 substeps=rig.substeps_per_frame(FRAME_DT))
        print(f"{label:>4} (load average {load:.1f}): {f['vertices']} vertices, {f['nodes']} simulated nodes, "
              f"{f['substeps']} substeps: "
              f"live tick {f['ms']:.2f} ms wall ({1e3 / f['ms']:.0f} fps), {f['cpu_ms']:.2f} ms CPU "
              f"({1e3 / f['cpu_ms']:.0f} fps); wall split: get_rig {f['rig']:.3f} + step "
              f"{f['step']:.2f} + write {f['write']:.2f} + depsgraph {f['depsgraph']:.2f} ms")
        result.append(f"live_tick_ms_{label}={f['ms']:.2f} live_tick_cpu_ms_{label}={f['cpu_ms']:.2f}")
        result.append(f"write_ms_{label}={f['write']:.2f} depsgraph_ms_{label}={f['depsgraph']:.2f}")
    print(f"RESULT backend={backend} " + " ".join(result))


if __name__ == "__main__":
    main()
