# SPDX-License-Identifier: GPL-3.0-or-later
"""``bake_s``: settle every shipped expression (all sets: ARKit, visemes, named) from rest on a head, as
Bake does (``anim.baking.expression_shapes``, settle time 1.5 s, no shape cache), with the numpy
reference path and the fused numba kernel (physics/kernel.py), and with the settles on one thread and on
``anim.baking.SETTLE_THREADS`` threads (each on its own copy of the rig; the shapes are byte-identical,
checked here), and the frames the settles simulated (a settle stops when the skin is at rest, at the
latest after 1.5 s = 36 frames: the count says how many settles ran to that cap). Wall and CPU
(``process_time``: all threads) seconds and the load average before each run: on a shared machine the
second core may be busy, and then only the one-thread figure means anything.
BLAS: one thread. The 45k case is the 10k skin subdivided once and fitted as an artist's mesh (as
``bench/kernel.py``), optional (``--resolutions default 10k 45k``).

Run: ``FH_TEST_FROM_SOURCE=1 python bench/bake.py [--resolutions default 10k]`` or with the installed
extension. Ends with ``RESULT bake_s_numba_3k=... bake_s_numba_t2_3k=... ...``.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

if os.environ.get("FH_TEST_FROM_SOURCE") == "1":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
else:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import _harness  # noqa: E402,F401

from faces_hands_addon.anim import baking  # noqa: E402
from faces_hands_addon.anim.baking import expression_shapes  # noqa: E402
from faces_hands_addon.face.expressions import expression_sets, load_expressions  # noqa: E402
from faces_hands_addon.face.rig import FaceRig, build_default_rig  # noqa: E402
from faces_hands_addon.physics import kernel  # noqa: E402

LABELS = {"default": "3k", "10k": "11k", "45k": "45k"}
SETTLE_FRAMES: list[int] = []        # frames of every settle since the last clear (any thread)


def _counting_settle(settle):
    """``FaceRig.settle`` that also appends the frames it simulated to :data:`SETTLE_FRAMES`."""
    def counted(self, *args, **kwargs):
        started = self.time
        positions = settle(self, *args, **kwargs)
        SETTLE_FRAMES.append(round((self.time - started) / kwargs.get("dt", baking.SETTLE_DT)))   # as settled() passes it
        return positions
    return counted


FaceRig.settle = _counting_settle(FaceRig.settle)


def make_rig(resolution: str):
    if resolution != "45k":
        return build_default_rig(resolution)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from kernel import subdivided_head_rig                       # bench/kernel.py (not physics.kernel)
    return subdivided_head_rig()[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolutions", nargs="+", default=["default", "10k"], choices=sorted(LABELS))
    parser.add_argument("--threads", type=int, default=getattr(baking, "SETTLE_THREADS", 1),
                        help="threads of the threaded run (a build without threaded settles: 1)")
    parser.add_argument("--backends", nargs="+", default=["numpy", "numba"], choices=["numpy", "numba"])
    args = parser.parse_args()
    baking.SETTLE_THREADS = args.threads
    expressions = {}
    for name in expression_sets():
        expressions.update({f"{name}:{key}": value for key, value in load_expressions(name).items()})
    ready = kernel.substep_kernel() is not None
    print(f"settings: {len(expressions)} expressions ({', '.join(expression_sets())}), settle 1.5 s at 1/24 s "
          f"(stops early at rest), no shape cache, BLAS 1 thread, settles on 1 and {args.threads} threads "
          f"({os.cpu_count()} cores); numba kernel "
          f"{'ready, compile %.2f s not counted' % kernel.compile_seconds() if ready else 'unavailable'}; "
          f"shared machine")
    result = []
    for resolution in args.resolutions:
        rig = make_rig(resolution)
        label = LABELS[resolution]
        for backend in args.backends:
            if backend == "numba" and not ready:
                continue
            rig.face.set_backend(backend)
            shapes = {}
            for threads in sorted({1, baking.SETTLE_THREADS}):
                baking.SETTLE_THREADS = threads
                load = os.getloadavg()[0]
                SETTLE_FRAMES.clear()
                started, started_cpu = time.perf_counter(), time.process_time()
                shapes[threads] = [s.pose.positions["skin"].tobytes() for s in expression_shapes(rig, expressions)]
                wall, cpu = time.perf_counter() - started, time.process_time() - started_cpu
                print(f"{label:>4} ({rig.face.network.node_count} nodes, {rig.substeps_per_frame(1 / 24)} substeps), "
                      f"{backend}, {threads} thread{'s' if threads > 1 else ''}: {len(shapes[threads])} expressions "
                      f"in {wall:.1f} s wall, {cpu:.1f} s CPU (load average before: {load:.1f}); "
                      f"{sum(SETTLE_FRAMES)} frames simulated, {sum(f >= 36 for f in SETTLE_FRAMES)} of "
                      f"{len(SETTLE_FRAMES)} settles at the 36-frame cap")
                suffix = "" if threads == 1 else f"_t{threads}"
                result += [f"bake_s_{backend}{suffix}_{label}={wall:.1f}", f"bake_cpu_s_{backend}{suffix}_{label}={cpu:.1f}"]
                if threads == 1:
                    result.append(f"frames_{backend}_{label}={sum(SETTLE_FRAMES)}")
            if len(shapes) > 1 and len(set(map(tuple, shapes.values()))) != 1:
                sys.exit("the threaded bake gave other shapes than the one-thread bake")
    print("RESULT " + " ".join(result))


if __name__ == "__main__":
    main()
