# SPDX-License-Identifier: GPL-3.0-or-later
"""Folds on the way to rest: settle every audited expression from rest frame by frame for the whole settle
time (1.5 s = 36 frames at 1/24 s) and count, at every frame, the outer-skin triangles turned over (the
shape audit's ``inverted``, ``face.audit``), and the nodes still moving more than the settle's rest
tolerance. The audit measures one frame only, the one where ``FaceRig.settle`` stops (at rest, or at the
36-frame cap); a shape that folds on its way there, or that is clean only at the frame it happens to stop
at, passes it. Such a fold is what a per-frame bake or the live preview shows while the face moves.

Per expression: the frame the settle stops at, the inverted count there, the largest count from frame 12
on (after the first rush) and the frames from 12 on that have one. Ends with one ``RESULT`` line per head:
``stop_clean`` (expressions clean where the settle stops), ``transient`` (of those, how many fold at some
frame from 12 on).

Run: ``make install`` then ``.venv/bin/python bench/settle_folds.py [--fit tests/data/heads/X.npz]
[--names a,b]``.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401

import numpy as np  # noqa: E402

from faces_hands_addon.anim.baking import SETTLE_DT  # noqa: E402
from faces_hands_addon.face import audit  # noqa: E402
from faces_hands_addon.face.audit_targets import TARGETS  # noqa: E402
from faces_hands_addon.face.expressions import expression_controls, load_expressions  # noqa: E402

DT, FRAMES, TOLERANCE, AFTER = SETTLE_DT, 36, 2e-4, 12   # as a bake's settles (1.5 s), FaceRig.settle's tolerance


def trajectory(rig, probe, controls: dict) -> tuple[int, list[int]]:
    """(the frame ``FaceRig.settle`` would stop at, inverted outer triangles after every frame 1..36)."""
    rig.reset()
    rig.set_controls(controls)
    x = rig.face.network.positions
    previous, stop, inverted = x.copy(), None, []
    for frame in range(FRAMES):
        rig._advance(DT)
        if stop is None and frame >= 2 and float(np.abs(x - previous).max()) < TOLERANCE * DT:
            stop = frame + 1
        previous[...] = x
        normals = audit._face_normals(np.asarray(x.T, np.float64), probe.faces)
        flipped = np.einsum("ij,ij->i", normals, probe.rest_normals) < 0
        inverted.append(int(np.sum(flipped & probe.outside)))
    return stop or FRAMES, inverted


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fit", help="a head mesh (.npz with vertices, faces) fitted here (seed 0)")
    parser.add_argument("--names", help="comma-separated expressions (default: every audited one)")
    args = parser.parse_args()
    if args.fit:
        from faces_hands_addon.face.fitted import build_fitted_rig
        data = np.load(args.fit)
        rig = build_fitted_rig(data["vertices"].astype(np.float64), data["faces"].astype(np.int64), seed=0)
        head = Path(args.fit).stem
    else:
        from faces_hands_addon.face.rig import build_default_rig
        rig, head = build_default_rig("default"), "default_head"
    expressions = {}
    for name in ("arkit", "visemes", "named"):
        expressions.update(load_expressions(name))
    names = args.names.split(",") if args.names else [n for n in TARGETS if n in expressions]
    probe = audit.Probe(rig)
    clean = transient = 0
    print(f"== {head}: {len(names)} expressions, {FRAMES} frames each; folds counted from frame {AFTER}")
    for name in names:
        stop, inverted = trajectory(rig, probe, expression_controls(expressions[name], rig.control_specs()))
        later = inverted[AFTER - 1:]
        folded = [AFTER + i for i, count in enumerate(later) if count]
        at_stop = inverted[stop - 1]
        clean += at_stop == 0
        transient += at_stop == 0 and bool(folded)
        if folded or at_stop:
            span = f"{folded[0]}-{folded[-1]} ({len(folded)} frames)" if folded else "none"
            print(f"{name:22s} stops at {stop:2d}: inverted {at_stop}; from frame {AFTER}: max {max(later)}, "
                  f"folded at frames {span}")
    print(f"RESULT head={head} expressions={len(names)} stop_clean={clean} transient={transient}")


if __name__ == "__main__":
    main()
