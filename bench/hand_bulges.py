# SPDX-License-Identifier: GPL-3.0-or-later
"""Geometric-muscle bulges in the grip poses of the hand's contact sheet (thesis 6.2.2, Figs. 6.15 and 6.18;
issue 13: "fist, point, thumbs up, spread, pinch, each with plausible finger curls and visible muscle bulges").

For each pose the hand is simulated from rest with the pose's contractions (as the contact sheet does). At
the joint angles it reached, the skin is settled twice: with the geometric muscles bulging ("on") and with
their pseudo-muscle twins at 0 ("off"; the joints are held, so only the bulge differs). Printed per pose:

* the skin lift: the largest outward motion of a skin node (mm), the nodes lifted by more than 1 mm, and the
  largest lift over the thenar eminence (adductor and opponens pollicis), the first web (first dorsal
  interosseus) and the hypothenar eminence (opponens, flexor and abductor digiti minimi): each node counts for
  the geometric muscle whose footprint weighs most on it;
* per view, the same camera for "on" and "off" (framed on the pose, the demo's shape matcap): the pixels of the
  hand whose colour changes by more than 20 of 255 levels, and their share of the hand's pixels. The view
  "grip" is the one the demo's ``hand_grip_bulges.png`` shows each pose from (the side its swelling faces).

``--out-dir`` also writes the renders and a difference image per pose and view (changed pixels in red).
Ends with one ``RESULT`` line (palm view). Runs the installed extension inside the bpy module (``make install``).

Run: ``.venv/bin/python bench/hand_bulges.py [--size 600x750] [--views grip,palm,back] [--out-dir DIR]``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

POSES = ("fist", "point", "thumbs_up", "pinch", "spread")
REGIONS = {"thenar": ("adductor_pollicis", "opponens_pollicis"), "web": ("first_dorsal_interosseus",),
           "hypothenar": ("opponens_digiti_minimi", "flexor_digiti_minimi_brevis", "abductor_digiti_minimi")}
LEVELS = 20


def node_regions(rig) -> dict[str, np.ndarray]:
    """Region -> (N,) bool: the skin nodes whose heaviest geometric-muscle footprint is one of its muscles."""
    owner = rig.geometric.footprint_owner()
    return {region: np.isin(owner, [rig.geometric.names.index(n) for n in names]) for region, names in REGIONS.items()}


def changed_pixels(on: np.ndarray, off: np.ndarray) -> tuple[int, int, np.ndarray]:
    """(changed hand pixels, hand pixels, mask) of two renders (H, W, 4) in 0..1."""
    hand = (on[..., 3] > 0.5) | (off[..., 3] > 0.5)
    mask = hand & (np.abs(on[..., :3] - off[..., :3]).max(axis=-1) * 255.0 > LEVELS)
    return int(mask.sum()), int(hand.sum()), mask


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="600x750", help="cell size WIDTHxHEIGHT (default 600x750)")
    parser.add_argument("--views", default="grip,palm",
                        help="comma-separated views: grip (the view of the demo's grip sheet for each pose), palm, "
                             "back, side, ulnar, three-quarter; the first gives the RESULT")
    parser.add_argument("--poses", default=",".join(POSES))
    parser.add_argument("--out-dir", help="write the renders and difference images here")
    args = parser.parse_args()
    size = tuple(int(v) for v in args.size.split("x"))
    views = args.views.split(",")
    services, render, sheet = (_harness.addon_module(f"operators.{m}")
                               for m in ("hand.services", "adapters.render", "hand.sheet"))
    obj = services.build_hand_object()
    rig = _harness.addon_module("operators.adapters.rig_store").get_rig(obj, "hand")
    folder = Path(args.out_dir) if args.out_dir else None
    if folder:
        folder.mkdir(parents=True, exist_ok=True)
    regions = node_regions(rig)
    result = {}
    with sheet.sheet_scene(bpy.context, obj, [obj]) as (_, tmp):
        for name in args.poses.split(","):
            own = [sheet.GRIP_VIEWS.get(name, "palm") if v == "grip" else v for v in views]
            for index, view in enumerate(dict.fromkeys(own)):
                lift, image_on, image_off = sheet.bulge_pair(bpy.context, obj, name, view, size, folder or tmp)
                if index == 0:
                    lift_mm = lift * 1000.0
                    by_region = " ".join(f"{r}={lift_mm[m].max():.1f}" for r, m in regions.items())
                    print(f"{name}: skin lift {lift_mm.max():.1f} mm, {(lift_mm > 1.0).sum()} nodes > 1 mm; largest "
                          f"lift (mm) {by_region}")
                    result[f"{name}_lift_mm"] = f"{lift_mm.max():.1f}"
                    result[f"{name}_nodes_1mm"] = str(int((lift_mm > 1.0).sum()))
                    result[f"{name}_thenar_mm"] = f"{lift_mm[regions['thenar']].max():.1f}"
                changed, hand, mask = changed_pixels(image_on, image_off)
                print(f"  {view}: {changed} of {hand} hand pixels change by more than {LEVELS} levels "
                      f"({100.0 * changed / max(hand, 1):.1f} %)")
                if index == 0:
                    result[f"{name}_px"] = str(changed)
                if folder:
                    diff = image_on.copy()
                    diff[mask, :3] = (0.9, 0.1, 0.1)
                    render.write_png(diff, folder / f"{name}_{view}_diff.png")
    rig.reset()
    lifts = [float(result[f"{n}_lift_mm"]) for n in args.poses.split(",")]
    pixels = [int(result[f"{n}_px"]) for n in args.poses.split(",")]
    print(f"RESULT view={views[0]} size={args.size} min_lift_mm={min(lifts):.1f} min_px={min(pixels)} "
          + " ".join(f"{k}={v}" for k, v in result.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
