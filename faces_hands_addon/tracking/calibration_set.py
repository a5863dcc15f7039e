# SPDX-License-Identifier: GPL-3.0-or-later
"""Calibrating a whole recording set-up (thesis 6.3.1): every camera's intrinsics from its checkerboard photos,
then its pose from its photo of the 3D calibration object (coloured spheres at known world positions, each
colour once, so every sphere is identified by its colour).

The description of the photos (``calibration/setup.json``, format ``faces_hands.pitch_calibration_photos``)
names the board (inner corners, square size), the objects (sphere centres in world metres, their colours, the
cameras that photographed each), the stereo pairs, the strobes and the pitcher's hand photo.
"""
from __future__ import annotations

import numpy as np

from ..core.errors import UserError
from ..core.presets import ANY, NUMBER, PresetFormat, register_format
from .calibrate import calibrate_intrinsics, solve_pose
from .checkerboard import find_corners
from .images import colour_masks, hsv, regions, undistort_image
from .setup import Calibration

__all__ = ["PHOTOS_FORMAT", "object_centres", "calibrate_setup", "check_photo_sizes"]

PHOTOS_FORMAT = register_format(PresetFormat(
    "faces_hands.pitch_calibration_photos", 1, required=("board", "objects", "pairs", "strobes"),
    shape={"board": {"inner": [NUMBER], "square": NUMBER}, "objects": {str: ANY}, "pairs": {str: [str]},
           "strobes": {str: ANY}, "plate_direction": [NUMBER], "hand": ANY}))


def object_centres(image: np.ndarray, colours: list[str]) -> dict[str, np.ndarray]:
    """The centre of the largest region of each colour (``white``: bright and unsaturated) in a photo of the
    calibration object."""
    masks = colour_masks(image, [c for c in colours if c != "white"])
    if "white" in colours:
        _, sat, val = hsv(image)
        masks["white"] = (sat < 0.2) & (val > 0.6)
    out = {}
    for colour, mask in masks.items():
        found = regions(mask, 6)
        if found:
            out[colour] = max(found, key=lambda r: r.area).centroid
    return out


def check_photo_sizes(images: dict[str, np.ndarray], expected: dict[str, tuple[int, int]] | None = None) -> None:
    """Photos of one camera must all have its size (a resized photo breaks the calibration)."""
    for name, image in images.items():
        size = (image.shape[1], image.shape[0])
        if expected and name in expected and tuple(expected[name]) != size:
            raise UserError(f"photo {name} is {size[0]}x{size[1]} pixels but camera {name} was calibrated at "
                            f"{expected[name][0]}x{expected[name][1]}; use the photos as the camera took them")


def calibrate_setup(doc: dict, photos: dict[str, dict], progress=None) -> tuple[Calibration, str]:
    """Calibrate every camera of ``photos`` (name -> {"boards": [images], "object": image}) with the set-up
    description ``doc``; returns the calibration and a report (reprojection errors in pixels)."""
    progress = progress or (lambda fraction, message="": None)
    inner = tuple(int(v) for v in doc["board"]["inner"])
    square = float(doc["board"]["square"])
    cameras, errors, lines = {}, {}, []
    for k, (name, shots) in enumerate(sorted(photos.items())):
        progress(k / max(len(photos), 1), f"calibrating {name}")
        sizes = {(img.shape[1], img.shape[0]) for img in shots["boards"] + [shots["object"]]}
        if len(sizes) != 1:
            raise UserError(f"camera {name}: its calibration photos have different sizes {sorted(sizes)}; one camera, "
                            "one size")
        size = sizes.pop()
        corners = [find_corners(img, inner) for img in shots["boards"]]
        intrinsics = calibrate_intrinsics(corners, inner, square, size, name)
        placement = [p for p in doc["objects"].values() if name in p["cameras"]]
        if not placement:
            raise UserError(f"camera {name}: no calibration object is listed for it in setup.json")
        placement = placement[0]
        flat = undistort_image(shots["object"], intrinsics.camera)
        found = object_centres(flat, placement["colours"])
        known = [c for c in placement["colours"] if c in found]
        points = np.array([placement["points"][placement["colours"].index(c)] for c in known])
        undistorted = intrinsics.camera.undistorted()
        posed, error = solve_pose(undistorted, points, np.array([found[c] for c in known]))
        camera = intrinsics.camera.with_pose(posed.R, posed.t)
        cameras[name] = camera
        errors[name] = error
        lines.append(f"{name}: f = {camera.fx:.1f} px, board error {intrinsics.error_px:.2f} px, object error "
                     f"{error:.2f} px ({len(known)} spheres)")
    strobes = {k: float(v["hz"] if isinstance(v, dict) else v) for k, v in doc["strobes"].items()}
    pairs = {k: v for k, v in doc["pairs"].items() if all(n in cameras for n in v)}
    calibration = Calibration(cameras, pairs, strobes, np.asarray(doc.get("plate_direction", [0, 1, 0]), float),
                              errors, doc.get("hand"))
    return calibration, "\n".join(lines)
