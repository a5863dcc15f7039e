# SPDX-License-Identifier: GPL-3.0-or-later
"""What mass scaling (face/network.py ``_masses``: node masses raised so no node's own stability limit
forces more substeps) does to the surface (issue 11, item 2): the default head with the shipped
``mass_cap_factor`` vs natural masses (no inflation, ``mass_cap_factor`` huge, no substep cap), for every
6th ARKit expression, from rest: node distance p99/max after 0.125 s (3 frames, the transient) and after
1.5 s (settled). Prints the mass ratios and substeps per frame of both. Measurement only; nothing changes.

Run: ``FH_TEST_FROM_SOURCE=1 python bench/mass_scaling.py`` (working tree) or with the installed extension.
Ends with ``RESULT mass_scaling_p99_mm_transient_max=... mass_scaling_p99_mm_settled_max=...``.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

if os.environ.get("FH_TEST_FROM_SOURCE") == "1":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
else:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import _harness  # noqa: E402,F401

import numpy as np  # noqa: E402

import faces_hands_addon.face.rig as face_rig  # noqa: E402
from faces_hands_addon.face.expressions import expression_controls, load_expressions  # noqa: E402

FRAME_DT = 1.0 / 24.0


def main() -> None:
    build = face_rig.build_network
    scaled = face_rig.build_default_rig("default")
    face_rig.build_network = lambda t, m=None: build(t, m, mass_cap_factor=1e12, max_substeps=100000)
    try:
        natural = face_rig.build_default_rig("default")
    finally:
        face_rig.build_network = build
    ratio = scaled.face.network.masses / natural.face.network.masses
    print(f"settings: default head, dt 1/24 s; mass ratio scaled/natural max {ratio.max():.1f}, median "
          f"{np.median(ratio):.2f}, {100 * np.mean(ratio > 1.01):.0f} % of nodes inflated; substeps/frame "
          f"scaled {scaled.substeps_per_frame(FRAME_DT)}, natural {natural.substeps_per_frame(FRAME_DT)}")
    expressions = load_expressions("arkit")
    names = list(expressions)[::max(1, len(expressions) // 12)]
    transient, settled = [], []
    for name in names:
        out = []
        for rig in (scaled, natural):
            rig.reset_state()
            rig.reset_controls()
            rig.set_controls(expression_controls(expressions[name], rig.specs))
            for _ in range(3):
                rig.step_frame(FRAME_DT)
            early = rig.face.network.positions.copy()
            for _ in range(33):
                rig.step_frame(FRAME_DT)
            out.append((early, rig.face.network.positions.copy()))
        early = np.linalg.norm(out[0][0] - out[1][0], axis=0) * 1e3
        late = np.linalg.norm(out[0][1] - out[1][1], axis=0) * 1e3
        transient.append(float(np.quantile(early, 0.99)))
        settled.append(float(np.quantile(late, 0.99)))
        print(f"{name:>22}: |scaled - natural| after 0.125 s p99 {transient[-1]:.3f} mm (max {early.max():.3f}), "
              f"after 1.5 s p99 {settled[-1]:.3f} mm (max {late.max():.3f})")
    print(f"RESULT mass_scaling_p99_mm_transient_max={max(transient):.3f} "
          f"mass_scaling_p99_mm_settled_max={max(settled):.3f} expressions={len(names)}")


if __name__ == "__main__":
    main()
