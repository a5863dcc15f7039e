# SPDX-License-Identifier: GPL-3.0-or-later
"""Landmark location (thesis 3.1.2 "Creating New Animatable Head Models from the Template"): time to
register the canonical face onto synthetic full heads (face + cranium cap, ears, neck, shoulders) of about
5k, 50k and 200k vertices, and the landmark error against the known ground truth.

Runs the extension installed by ``make install`` (see ``_harness.py``). Prints one line per target and ends with
``RESULT fit_s_5k=... fit_s_50k=... fit_s_200k=... median_err_pct=...`` (median landmark error in % of the
face width, median over the three targets). Timings are wall-clock, best of ``--repeat`` runs, one
process; set OMP_NUM_THREADS=1 for single-core figures.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)

import numpy as np  # noqa: E402

from faces_hands_addon.fitting import locate_landmarks, testdata  # noqa: E402

# (label, face edge length, body edge length) in canonical metres -> about 5k / 50k / 200k vertices
TARGETS = (("5k", 0.0042, 0.018), ("50k", 0.0022, 0.005), ("200k", 0.0013, 0.0025))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2, help="runs per target (best time is reported)")
    args = parser.parse_args()
    results, errors = {}, []
    for label, spacing, body in TARGETS:
        head = testdata.full_head(0, spacing=spacing, body_spacing=body)
        times = []
        for _ in range(max(args.repeat, 1)):
            start = time.perf_counter()
            fit = locate_landmarks(head.vertices, head.faces, seed=0)
            times.append(time.perf_counter() - start)
        error = np.linalg.norm(fit.positions - head.truth, axis=1) / head.face_width * 100
        results[label] = min(times)
        errors.append(float(np.median(error)))
        print(f"{label:>5}: {len(head.vertices):7d} vertices {len(head.faces):7d} triangles  "
              f"fit {min(times):6.2f} s  error median {np.median(error):.2f} %  "
              f"p95 {np.quantile(error, 0.95):.2f} %  max {error.max():.2f} % of face width  "
              f"rms-to-surface {100 * fit.rms_fraction:.2f} %  matched {100 * fit.matched_fraction:.0f} %")
    print(f"RESULT fit_s_5k={results['5k']:.2f} fit_s_50k={results['50k']:.2f} "
          f"fit_s_200k={results['200k']:.2f} median_err_pct={float(np.median(errors)):.2f}")


if __name__ == "__main__":
    main()
