# SPDX-License-Identifier: GPL-3.0-or-later
"""The 26 feature points of thesis 6.2.3 found automatically on a synthetic photo of a known hand.

The reference hand (its skin only, a skin-coloured material, Workbench studio light, a plain background) is
rendered from the back by an orthographic camera; MediaPipe's hand models (the extension's numpy runtime)
find it and ``tracking.photo_points`` maps the 21 landmarks to the 26 points (19 direct, 7 derived). Each point is
compared with the reference's own feature point projected by the same camera: errors in pixels and in % of
the hand's projected length (wrist centre -> middle finger tip), direct and derived apart. The photo input is
then warped as 6.2.3 does (the hand's length given as the ruler): the warped hand's feature points against
the reference's (it is the same hand, so the warp should move them little), in mm. Bad input, each refused
with its message: a blank photo, two hands (the render beside its mirror image), a left hand (the mirror
image), a partial hand (the fingers cut off).

``.venv/bin/python bench/hand_photo_detect.py [--size 640]``; needs ``make install``. Writes the render and
the detected points to out/bench/hand_photo/. The last line is ``RESULT key=value ...``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402  (the installed extension)
import bpy  # noqa: E402
import numpy as np  # noqa: E402
from bpy_extras.object_utils import world_to_camera_view  # noqa: E402
from mathutils import Vector  # noqa: E402

from faces_hands_addon.core.errors import UserError  # noqa: E402
from faces_hands_addon.hand.features import FEATURE_NAMES  # noqa: E402
from faces_hands_addon.tracking.photo_points import DERIVED, detect_photo_points  # noqa: E402
from faces_hands_addon.hand.rig import build_hand_rig  # noqa: E402
from faces_hands_addon.tracking.mediapipe_hands import HandDetector  # noqa: E402

OUT = _harness.ROOT / "out" / "bench" / "hand_photo"
AZIMUTH = -90.0                      # the camera at -X looks at the back of the right hand (palm faces +X)


def render_hand(size: int) -> tuple[np.ndarray, dict, float]:
    """(image (H, W, 3) RGB top row first, projected feature points (pixels), hand length in mm)."""
    services = _harness.addon_module("operators.hand.services")
    render = _harness.addon_module("operators.adapters.render")
    rig_store = _harness.addon_module("operators.adapters.rig_store")
    obj = services.build_hand_object()
    scene = bpy.context.scene
    for other in scene.objects:
        other.hide_render = other is not obj
    render.setup_workbench(scene, (size, size))
    scene.display.shading.color_type = "MATERIAL"
    scene.world = bpy.data.worlds.new("FH Plain Background")
    scene.world.color = (0.25, 0.32, 0.4)
    camera = render.frame_camera(scene, [obj], azimuth_deg=AZIMUTH, elevation_deg=0.0, margin=1.3)
    OUT.mkdir(parents=True, exist_ok=True)
    path = OUT / "render.png"
    scene.render.filepath = str(path)
    with render.quiet_stdout():
        bpy.ops.render.render(write_still=True)
    image = render.read_png(path)[::-1, :, :3].copy()
    points = rig_store.get_rig(obj, "hand").feature_points()
    projected = {}
    for name, point in points.items():
        c = world_to_camera_view(scene, camera, Vector(point))
        projected[name] = np.array([c.x * size, (1.0 - c.y) * size])
    wrist = 0.5 * (points["wrist_radial"] + points["wrist_ulnar"])
    return image, projected, float(np.linalg.norm(points["middle_tip"] - wrist) * 1000.0)


def refusal(image: np.ndarray, source_points: dict, detector, side: str = "right") -> str:
    try:
        detect_photo_points(image, source_points, side, 185.0, "bench", detector)
    except UserError as error:
        return str(error)
    return ""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=640, help="render size in pixels (default 640)")
    args = parser.parse_args()
    image, projected, length_mm = render_hand(args.size)
    rig = build_hand_rig()
    source_points = rig.feature_points()
    detector = HandDetector()
    doc = detect_photo_points(image, source_points, "right", length_mm, str(OUT / "render.png"), detector)
    wrist = 0.5 * (projected["wrist_radial"] + projected["wrist_ulnar"])
    length_px = float(np.linalg.norm(projected["middle_tip"] - wrist))
    errors = {n: float(np.linalg.norm(np.array(doc["points"][n]) - projected[n])) for n in FEATURE_NAMES}
    direct = np.array([e for n, e in errors.items() if n not in DERIVED])
    derived = np.array([errors[n] for n in DERIVED])
    print(f"hand {length_mm:.1f} mm long, {length_px:.0f} px in the {args.size} px render")
    for name in FEATURE_NAMES:
        kind = "derived" if name in DERIVED else "direct"
        print(f"  {name:18s} {kind:8s} {errors[name]:6.1f} px  {100 * errors[name] / length_px:5.1f} %")
    warped = build_hand_rig(photo=doc).feature_points()
    moved = np.array([np.linalg.norm(warped[n] - source_points[n]) * 1000.0 for n in FEATURE_NAMES])
    print(f"warped hand's feature points from the reference's: median {np.median(moved):.1f} mm, max {moved.max():.1f} mm")
    blank = np.full_like(image, 0.5)
    cases = {"no_hand": refusal(blank, source_points, detector),
             "two_hands": refusal(np.concatenate([image, image[:, ::-1]], axis=1), source_points, detector),
             "mirrored": refusal(image[:, ::-1].copy(), source_points, detector),
             "partial": refusal(image[: int(0.84 * len(image))].copy(), source_points, detector)}
    for case, message in cases.items():
        print(f"  {case:10s} {'refused: ' + message if message else 'NOT refused'}")
    print(f"RESULT direct_median_px={np.median(direct):.1f} direct_max_px={direct.max():.1f} "
          f"direct_median_pct={100 * np.median(direct) / length_px:.1f} direct_max_pct={100 * direct.max() / length_px:.1f} "
          f"derived_median_px={np.median(derived):.1f} derived_max_px={derived.max():.1f} "
          f"derived_max_pct={100 * derived.max() / length_px:.1f} hand_px={length_px:.0f} "
          f"warp_median_mm={np.median(moved):.1f} warp_max_mm={moved.max():.1f} "
          f"refused={sum(bool(m) for m in cases.values())}/{len(cases)}")


if __name__ == "__main__":
    main()
