# SPDX-License-Identifier: GPL-3.0-or-later
"""Fit any orientation, refuse nonsense (thesis 3.1.2; issue 10 items 3-4): each head turned into several
axis orientations and scales, searched among the 24 orientations and fitted; per case the chosen
orientation, the score margin (runner-up / winner), the landmark residual of the quality gate, the
surface RMS, the disagreement with the head's own first fit (turned with it), and the time.

Heads: the procedural face mask and full head of ``fitting.testdata`` (known truth), the three heads of real
topology in tests/data/heads (MakeHuman neutral and african-female-old, SOMA-X; Y up, face +Z), and
Blender's Suzanne and a cube when ``--suzanne FILE.npz`` gives them (``vertices``, ``faces``). Runs the
extension installed by ``make install`` (``_harness.py``). Times are wall clock, one run each, on whatever
the machine is doing (noisy on a shared machine). Ends with ``RESULT fitted=N refused=M
max_same_median_pct=...``.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)

import numpy as np  # noqa: E402

from faces_hands_addon.core.errors import UserError  # noqa: E402
from faces_hands_addon.fitting import locate_landmarks, testdata  # noqa: E402
from faces_hands_addon.fitting.template import face_template  # noqa: E402

HEADS = Path(__file__).resolve().parents[1] / "tests" / "data" / "heads"


def _turn(axis: int, degrees: float) -> np.ndarray:
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


CASES = (("as given", np.eye(3), 1.0), ("X+90", _turn(0, 90), 1.0), ("Y+90 x0.01", _turn(1, 90), 0.01),
         ("Z+90 x37", _turn(2, 90), 37.0), ("Z+180", _turn(2, 180), 1.0), ("mirrored", None, 1.0))


def _heads(suzanne: Path | None):
    mask = testdata.remeshed_face(0, spacing=0.006)
    head = testdata.full_head(0, spacing=0.008, body_spacing=0.03)
    yield "procedural mask", mask.vertices, mask.faces, np.array([0.0, -1.0, 0.0])
    yield "procedural full head", head.vertices, head.faces, np.array([0.0, -1.0, 0.0])
    for name in ("makehuman_neutral", "makehuman_african_female_old", "soma"):
        data = np.load(HEADS / f"{name}.npz")
        yield name, data["vertices"].astype(float), data["faces"].astype(np.int64), np.array([0.0, 0.0, 1.0])
    if suzanne is not None:
        data = np.load(suzanne)
        yield "Suzanne", data["vertices"].astype(float), data["faces"].astype(np.int64), np.array([0.0, -1.0, 0.0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suzanne", type=Path, help="an .npz with Blender's Suzanne (vertices, faces)")
    parser.add_argument("--quick", action="store_true", help="only 'as given' and 'X+90'")
    args = parser.parse_args()
    mirror = face_template().mirror
    fitted = refused = 0
    worst = 0.0
    print(f"{'head':30s} {'case':11s} {'result':8s} {'orientation':22s} {'margin':>6s} {'resid%':>6s} "
          f"{'rms%':>5s} {'same med/max %':>15s} {'time s':>6s}")
    for name, vertices, faces, forward in _heads(args.suzanne):
        centre = vertices.mean(axis=0)
        first = None
        for label, matrix, scale in CASES[:2] if args.quick else CASES:
            if matrix is None:      # mirrored front to back: along the head's own forward axis
                matrix = np.eye(3) - 2 * np.outer(forward, forward)
            moved = (vertices - centre) @ matrix.T * scale
            tris = faces if np.linalg.det(matrix) > 0 else faces[:, ::-1]
            started = time.perf_counter()
            try:
                fit = locate_landmarks(moved, tris, seed=0)
            except UserError as error:
                refused += 1
                print(f"{name:30s} {label:11s} refused  {str(error)[:110]} ({time.perf_counter() - started:.1f} s)")
                continue
            took = time.perf_counter() - started
            fitted += 1
            residual = next(c["value"] for c in fit.checks if c["name"] == "landmark_residual")
            same = "-"
            if first is None:
                first = (fit.positions, fit.face_width)        # the "as given" case: centred, unscaled
            else:
                expected = first[0] @ matrix.T * scale
                if np.linalg.det(matrix) < 0:
                    expected = expected[mirror]
                gap = np.linalg.norm(fit.positions - expected, axis=1) / (first[1] * scale)
                worst = max(worst, float(np.median(gap)))
                same = f"{100 * np.median(gap):.2f}/{100 * gap.max():.2f}"
            o = fit.orientation
            print(f"{name:30s} {label:11s} fitted   {o['orientation']:22s} {o['margin']:6.2f} {100 * residual:6.1f} "
                  f"{100 * fit.rms_fraction:5.2f} {same:>15s} {took:6.1f}")
    print(f"RESULT fitted={fitted} refused={refused} max_same_median_pct={100 * worst:.2f}")


if __name__ == "__main__":
    main()
