# SPDX-License-Identifier: GPL-3.0-or-later
"""``bake_s``: settle every shipped expression (all sets: ARKit, visemes, named) from rest on a head, as
Bake does (``anim.baking.expression_shapes``, settle time 1.5 s, no shape cache), with the numpy
reference path and the fused numba kernel (physics/kernel.py). Wall and CPU (``process_time``) seconds;
the machine may be shared. One core.

Run: ``FH_TEST_FROM_SOURCE=1 python bench/bake.py [--resolutions default 10k]`` or with the installed
extension. Ends with ``RESULT bake_s_numpy_3k=... bake_s_numba_3k=... ...``.
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

from faces_hands_addon.anim.baking import expression_shapes  # noqa: E402
from faces_hands_addon.face.expressions import expression_sets, load_expressions  # noqa: E402
from faces_hands_addon.face.rig import build_default_rig  # noqa: E402
from faces_hands_addon.physics import kernel  # noqa: E402

LABELS = {"default": "3k", "10k": "11k"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolutions", nargs="+", default=["default", "10k"], choices=sorted(LABELS))
    parser.add_argument("--backends", nargs="+", default=["numpy", "numba"], choices=["numpy", "numba"])
    args = parser.parse_args()
    expressions = {}
    for name in expression_sets():
        expressions.update({f"{name}:{key}": value for key, value in load_expressions(name).items()})
    ready = kernel.substep_kernel() is not None
    print(f"settings: {len(expressions)} expressions ({', '.join(expression_sets())}), settle 1.5 s at 1/24 s "
          f"(stops early at rest), no shape cache, one core; numba kernel "
          f"{'ready, compile %.2f s not counted' % kernel.compile_seconds() if ready else 'unavailable'}; "
          f"shared machine")
    result = []
    for resolution in args.resolutions:
        rig = build_default_rig(resolution)
        for backend in args.backends:
            if backend == "numba" and not ready:
                continue
            rig.face.set_backend(backend)
            started, started_cpu = time.perf_counter(), time.process_time()
            count = sum(1 for _ in expression_shapes(rig, expressions))
            wall, cpu = time.perf_counter() - started, time.process_time() - started_cpu
            label = LABELS[resolution]
            print(f"{label:>4} ({rig.face.network.node_count} nodes), {backend}: {count} expressions in {wall:.1f} s "
                  f"wall, {cpu:.1f} s CPU")
            result += [f"bake_s_{backend}_{label}={wall:.1f}", f"bake_cpu_s_{backend}_{label}={cpu:.1f}"]
    print("RESULT " + " ".join(result))


if __name__ == "__main__":
    main()
