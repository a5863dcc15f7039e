# SPDX-License-Identifier: GPL-3.0-or-later
"""Skin quality of the hand in every preset pose and motion, both hands (issue 36 item 2; thesis 6.2's
mass-spring skin): the least and greatest skin edge length over its rest length (goal 0.6-1.6), skin triangle
pairs passing through each other (goal 0), and the pinch's fingertip gap (goal <= 2 mm: the least distance
between the thumb's and the index finger's pads, the skin within ``PAD_RADIUS`` of their tip points at rest).

Poses are settled from rest stage by stage as the contact sheets show them (``HandRig.settled_stages``);
motions are stepped at 30 fps and measured every ``--every`` frames. Measures: ``faces_hands_addon.hand.
skin_quality``. Run: ``make install`` then ``.venv/bin/python bench/hand_skin.py``. Ends with one ``RESULT``
line (the worst over every pose, motion frame and hand).
"""
from __future__ import annotations

import argparse
import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401

import numpy as np  # noqa: E402

from faces_hands_addon.anim.layers import BASE_LAYER  # noqa: E402
from faces_hands_addon.hand import motion, skin_quality  # noqa: E402
from faces_hands_addon.hand.rig import build_hand_rig  # noqa: E402

PAD_RADIUS = 0.008      # m of skin around a tip point that counts as its pad


def measure(rig, skin, pads) -> dict:
    ratios = skin_quality.edge_ratios(rig.rest_positions.astype(np.float64), skin.astype(np.float64), rig.faces)
    return {"min_stretch": float(ratios.min()), "max_stretch": float(ratios.max()),
            "outside": int(((ratios < 0.6) | (ratios > 1.6)).sum()), "edges": int(len(ratios)),
            "self_intersections": skin_quality.self_intersections(skin, rig.faces),
            "pinch_gap_mm": 1000.0 * skin_quality.surface_gap(skin.astype(np.float64), *pads)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sides", default="right,left")
    parser.add_argument("--every", type=int, default=3, help="measure every Nth motion frame (default 3)")
    parser.add_argument("--no-motions", action="store_true")
    args = parser.parse_args()
    rows = []
    for side in args.sides.split(","):
        rig = build_hand_rig(side)
        rest, tips = rig.rest_positions.astype(np.float64), rig.feature_points()
        pads = [skin_quality.patch_near(rest, tips[name].astype(np.float64), PAD_RADIUS)
                for name in ("thumb_tip", "index_tip")]
        for name in motion.pose_names():
            pose = rig.settled_stages(motion.pose_stages(name, rig.muscle_names))
            row = {"side": side, "case": name, **measure(rig, pose.positions["skin"], pads)}
            rows.append(row)
            print(f"{side:5s} pose   {name:28s} stretch {row['min_stretch']:.2f}-{row['max_stretch']:.2f} "
                  f"({row['outside']} of {row['edges']} edges outside 0.6-1.6)  self-intersections "
                  f"{row['self_intersections']:4d}  pinch gap {row['pinch_gap_mm']:.1f} mm", flush=True)
        if args.no_motions:
            continue
        for name in motion.motion_names():
            _, table = motion.motion_table(name, rig.muscle_names, 30.0)
            rig.reset()
            worst = None
            for frame, values in enumerate(table):
                pose = rig.step({BASE_LAYER: dict(zip(rig.muscle_names, values))}, 1 / 30)
                if frame % args.every:
                    continue
                got = measure(rig, pose.positions["skin"], pads)
                worst = got if worst is None else {
                    "min_stretch": min(worst["min_stretch"], got["min_stretch"]),
                    "max_stretch": max(worst["max_stretch"], got["max_stretch"]),
                    "outside": max(worst["outside"], got["outside"]), "edges": got["edges"],
                    "self_intersections": max(worst["self_intersections"], got["self_intersections"]),
                    "pinch_gap_mm": min(worst["pinch_gap_mm"], got["pinch_gap_mm"])}
            rows.append({"side": side, "case": f"motion:{name}", **worst})
            print(f"{side:5s} motion {name:28s} stretch {worst['min_stretch']:.2f}-{worst['max_stretch']:.2f} "
                  f"(worst frame: {worst['outside']} edges outside)  self-intersections (worst frame) "
                  f"{worst['self_intersections']:4d}  closest thumb-index {worst['pinch_gap_mm']:.1f} mm",
                  flush=True)
    pinch = [r["pinch_gap_mm"] for r in rows if r["case"] == "pinch"]
    clean = sum(1 for r in rows if r["self_intersections"] == 0 and r["outside"] == 0)
    print(f"RESULT cases={len(rows)} clean_cases={clean} min_stretch={min(r['min_stretch'] for r in rows):.2f} "
          f"max_stretch={max(r['max_stretch'] for r in rows):.2f} "
          f"self_intersections_max={max(r['self_intersections'] for r in rows)} "
          f"pinch_gap_mm={max(pinch) if pinch else float('nan'):.1f}")


if __name__ == "__main__":
    main()
