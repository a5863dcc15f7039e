# SPDX-License-Identifier: GPL-3.0-or-later
"""Simulation frame cost, numpy reference path vs the fused numba kernel (physics/kernel.py), on the
default head (~2.9k nodes), the 10k variant (~11k), the 10k skin subdivided once and fitted (~45k
nodes, all simulated) and a fitted ~50k-vertex synthetic artist head (``fitting.testdata.full_head``,
only its face is simulated; node counts are printed).

A frame is what the live preview and the bakes do per frame: ``rig.step_frame`` with every control
changing (muscles, jaw, lids, gaze), i.e. attachment targets, all guard substeps, the bone/teeth/eye
guards (numpy in both cases) and the output positions. Per-frame wall and CPU (``process_time``) times;
medians are reported (the machine may be shared: medians, not means; CPU time is what a frame costs
when nothing else competes for the core). One core (numba runs serially; BLAS threads = 1).
The numba figure excludes the one-off compile, reported separately as ``compile_s`` (numba import +
compile, or load from the cache folder when one is set).

Run: ``FH_TEST_FROM_SOURCE=1 python bench/kernel.py`` (working tree; needs numba importable) or inside
the bpy module with the installed extension (``make install``; numba from the extension's wheels).
Ends with ``RESULT frame_ms_numpy_3k=... frame_ms_numba_3k=... ...``.
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

if os.environ.get("FH_TEST_FROM_SOURCE") == "1":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
else:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import _harness  # noqa: E402,F401

import numpy as np  # noqa: E402
sys.path.insert(0, str(Path(__file__).resolve().parent))  # bench/_workloads.py
from _workloads import animated_controls  # noqa: E402

from faces_hands_addon.face.rig import GUARD_EVERY, build_default_rig  # noqa: E402
from faces_hands_addon.physics import kernel  # noqa: E402

FRAME_DT = 1.0 / 24.0


def fitted_head_rig():
    from faces_hands_addon.face.fitted import build_fitted_rig
    from faces_hands_addon.fitting import testdata
    head = testdata.full_head(0, spacing=0.0022, body_spacing=0.005)      # ~50k vertices (bench/fitting.py)
    return build_fitted_rig(head.vertices, head.faces, seed=0), len(head.vertices)


def subdivided_head_rig():
    """The 10k head's skin split once at its edge midpoints (every triangle into four, ~45k vertices),
    fitted as an artist's mesh: a dense head whose whole surface is simulated."""
    from faces_hands_addon.face.fitted import build_fitted_rig
    base = build_default_rig("10k")
    vertices, faces = base.rest_positions.astype(np.float64), base.faces.astype(np.int64)
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    mid = len(vertices) + inverse.reshape(3, -1).T                      # midpoints of edges 01, 12, 20
    vertices = np.concatenate([vertices, 0.5 * (vertices[unique[:, 0]] + vertices[unique[:, 1]])])
    a, b, c = faces.T
    ab, bc, ca = mid.T
    faces = np.concatenate([np.stack(t, 1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
    return build_fitted_rig(vertices, faces, seed=0), len(vertices)


def substep_ms(rig, backend: str, frames: int = 6) -> float:
    """Pure substeps (no guard, fixed attachment targets): ``advance`` of whole frames / substeps."""
    rig.reset_state()
    integrator = rig.face.integrator
    integrator.backend = backend
    integrator.advance(FRAME_DT)
    times = []
    for _ in range(frames):
        started = time.perf_counter()
        used = integrator.advance(FRAME_DT)
        times.append(1e3 * (time.perf_counter() - started) / used)
    rig.reset_state()
    return statistics.median(times)


def frame_times(rig, backend: str, frames: int) -> tuple[list[float], np.ndarray]:
    rig.reset_state()
    rig.reset_controls()
    rig.face.set_backend(backend)
    for frame in range(3):                                   # warm-up (and the kernel's compile)
        rig.set_controls(animated_controls(frame))
        rig.step_frame(FRAME_DT)
    times, cpu, advance = [], [], []
    integrator = rig.face.integrator
    plain = integrator.advance

    def timed(*a, **k):                      # the integrator's share (substeps + the guards it calls)
        started = time.perf_counter()
        out = plain(*a, **k)
        advance.append(1e3 * (time.perf_counter() - started))
        return out
    integrator.advance = timed
    for frame in range(3, frames + 3):
        rig.set_controls(animated_controls(frame))
        started, started_cpu = time.perf_counter(), time.process_time()
        rig.step_frame(FRAME_DT)
        times.append(1e3 * (time.perf_counter() - started))
        cpu.append(1e3 * (time.process_time() - started_cpu))
    del integrator.advance
    return times, cpu, advance, rig.face.network.positions.copy()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=48)
    parser.add_argument("--skip-fitted", action="store_true", help="only the default and 10k heads")
    parser.add_argument("--cache-folder", type=Path, default=None,
                        help="numba cache folder (a second run then shows the cached load time)")
    args = parser.parse_args()
    if args.cache_folder is not None:
        kernel.set_cache_folder(args.cache_folder)
    started = time.perf_counter()
    compiled = kernel.substep_kernel()
    if compiled is None:
        sys.exit(f"numba kernel unavailable here: {kernel._STATE['error'] or kernel.ENV_VARIABLE + '=numpy'}")
    import numba
    print(f"settings: frame dt 1/24 s, guard every {GUARD_EVERY} substeps, every control animated, one core; "
          f"numpy {np.__version__}, numba {numba.__version__}; kernel ready in "
          f"{time.perf_counter() - started:.2f} s (compile_s={kernel.compile_seconds():.2f}, cache folder: "
          f"{kernel.cache_folder() or 'none (in memory)'}); medians of per-frame wall times, shared machine")
    cases = [("3k", lambda: (build_default_rig("default"), None)), ("11k", lambda: (build_default_rig("10k"), None))]
    if not args.skip_fitted:
        cases.append(("45k", subdivided_head_rig))
        cases.append(("50k-fitted", fitted_head_rig))
    result = [f"compile_s={kernel.compile_seconds():.2f}"]
    for label, build in cases:
        rig, vertices = build()
        frames = args.frames if label in ("3k", "11k") else max(8, args.frames // 2)
        numpy_times, numpy_cpu, numpy_adv, numpy_x = frame_times(rig, "numpy", frames)
        numba_times, numba_cpu, numba_adv, numba_x = frame_times(rig, "numba", frames)
        aa, ab = statistics.median(numpy_adv), statistics.median(numba_adv)
        sa, sb = substep_ms(rig, "numpy"), substep_ms(rig, "numba")
        a, b = statistics.median(numpy_times), statistics.median(numba_times)
        ca, cb = statistics.median(numpy_cpu), statistics.median(numba_cpu)
        net = rig.face.network
        print(f"{label:>4}: {net.node_count} nodes, {net.springs.count} springs"
              + (f" (mesh of {vertices} vertices)" if vertices else "")
              + f", {rig.substeps_per_frame(FRAME_DT)} substeps/frame, {frames} frames: numpy {a:.2f} ms, "
              f"numba {b:.2f} ms per frame ({a / b:.2f}x) wall; CPU {ca:.2f} vs {cb:.2f} ms ({ca / cb:.2f}x); of which integrator.advance (substeps + guard calls) {aa:.2f} vs {ab:.2f} ms; one bare substep {sa:.3f} vs {sb:.3f} ms ({sa / sb:.1f}x); max |dx| numpy vs numba after the run "
              f"{np.abs(numpy_x - numba_x).max():.1e} m")
        result += [f"frame_ms_numpy_{label}={a:.2f}", f"frame_ms_numba_{label}={b:.2f}",
                   f"frame_cpu_ms_numpy_{label}={ca:.2f}", f"frame_cpu_ms_numba_{label}={cb:.2f}",
                   f"advance_ms_numpy_{label}={aa:.2f}", f"advance_ms_numba_{label}={ab:.2f}",
                   f"substep_ms_numpy_{label}={sa:.3f}", f"substep_ms_numba_{label}={sb:.3f}",
                   f"nodes_{label}={net.node_count}"]
    print("RESULT " + " ".join(result))


if __name__ == "__main__":
    main()
