# SPDX-License-Identifier: GPL-3.0-or-later
"""Calibrating a whole recording set-up (thesis 6.3.1): every camera's intrinsics from its checkerboard photos,
then its pose from its photo of the 3D calibration object (coloured spheres at known world positions, each
colour once, so every sphere is identified by its colour).

The description of the photos (``calibration/setup.json``, format ``faces_hands.pitch_calibration_photos``)
names the board (inner corners, square size), the objects (sphere centres in world metres, their colours, the
cameras that photographed each), the stereo pairs, the strobes and the pitcher's hand photo.
"""
from __future__ import annotations

import itertools

import numpy as np

from ..core.errors import UserError
from ..core.presets import ANY, NUMBER, PresetFormat, register_format
from .calibrate import calibrate_intrinsics, solve_pose
from .checkerboard import find_corners
from .images import colour_masks, hsv, regions, undistort_image
from .setup import Calibration

__all__ = ["PHOTOS_FORMAT", "object_centres", "identify_spheres", "calibrate_setup", "check_photo_sizes"]

PHOTOS_FORMAT = register_format(PresetFormat(
    "faces_hands.pitch_calibration_photos", 1, required=("board", "objects", "pairs", "strobes"),
    shape={"board": {"inner": [NUMBER], "square": NUMBER}, "objects": {str: ANY}, "pairs": {str: [str]},
           "strobes": {str: ANY}, "plate_direction": [NUMBER], "hand": ANY, "single": [str],
           "sphere_radius": NUMBER}))


def object_centres(image: np.ndarray, colours: list[str]) -> dict[str, list[tuple[np.ndarray, int]]]:
    """Colour -> (centre, area in pixels) of the regions of that colour (``white``: bright and unsaturated),
    largest first, as many as the object has spheres of the colour, in a photo of the calibration object."""
    wanted = {c: colours.count(c) for c in colours}
    masks = colour_masks(image, [c for c in wanted if c != "white"])
    if "white" in wanted:
        _, sat, val = hsv(image)
        masks["white"] = (sat < 0.2) & (val > 0.6)
    out = {}
    for colour, mask in masks.items():
        found = sorted(regions(mask, 6), key=lambda r: -r.area)[:wanted[colour]]
        if found:
            out[colour] = [(r.centroid, r.area) for r in found]
    return out


def identify_spheres(camera, points: np.ndarray, colours: list[str], found: dict,
                     sphere_radius: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Which sphere each found region is: spheres of one colour are told apart by trying every assignment and
    keeping the one whose camera pose reprojects best (each colour appears at most twice, so at most 2^8
    tries). A sphere half hidden behind another, or two of one colour run together, shows a region far from the
    disc the pose predicts (``sphere_radius`` known: below 60 % or above 160 %): dropped; then, one by one,
    the sphere whose reprojection is off by more than three times the median (a partly hidden one: its centre
    of gravity moved), the pose solved again each time. Returns (world points, pixels)."""
    options = []
    for colour in dict.fromkeys(colours):
        indices = [i for i, c in enumerate(colours) if c == colour]
        seen = [c for c, _ in found.get(colour, [])]
        choices = [list(zip(perm, seen)) for perm in itertools.permutations(indices, len(seen))] if seen else [[]]
        options.append(choices)
    best = None
    for combination in itertools.product(*options):
        pairs = [pair for part in combination for pair in part]
        if len(pairs) < 6:
            continue
        world = points[[i for i, _ in pairs]]
        pixels = np.array([p for _, p in pairs])
        try:
            posed, error = solve_pose(camera, world, pixels, refine=False)
        except UserError:
            continue
        if best is None or error < best[0]:
            best = (error, world, pixels, posed)
    if best is None:
        raise UserError(f"{camera.name}: fewer than 6 spheres of the calibration object were found")
    _, world, pixels, posed = best
    keep = np.ones(len(world), bool)
    if sphere_radius is not None:
        areas = {tuple(np.round(c, 6)): a for entries in found.values() for c, a in entries}
        disc = np.pi * (camera.fx * sphere_radius / posed.depth(world)) ** 2
        shown = np.array([areas[tuple(np.round(p, 6))] for p in pixels]) / disc
        keep &= (shown > 0.6) & (shown < 1.6)            # half hidden, or two discs run together
    while keep.sum() > 6:
        posed, _ = solve_pose(camera, world[keep], pixels[keep])
        residual = np.linalg.norm(posed.project(world) - pixels, axis=1)
        worst = int(np.argmax(np.where(keep, residual, -1.0)))
        if residual[worst] <= max(3.0 * float(np.median(residual[keep])), 0.3):
            break
        keep[worst] = False                              # partly hidden: its centre of gravity moved
    return world[keep], pixels[keep]


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
        undistorted = intrinsics.camera.undistorted()
        world, pixels = identify_spheres(undistorted, np.asarray(placement["points"], float), placement["colours"],
                                         found, doc.get("sphere_radius"))
        posed, error = solve_pose(undistorted, world, pixels)
        camera = intrinsics.camera.with_pose(posed.R, posed.t)
        cameras[name] = camera
        errors[name] = error
        lines.append(f"{name}: f = {camera.fx:.1f} px, board error {intrinsics.error_px:.2f} px, object error "
                     f"{error:.2f} px ({len(world)} spheres)")
    strobes = {k: float(v["hz"] if isinstance(v, dict) else v) for k, v in doc["strobes"].items()}
    pairs = {k: v for k, v in doc["pairs"].items() if all(n in cameras for n in v)}
    calibration = Calibration(cameras, pairs, strobes, np.asarray(doc.get("plate_direction", [0, 1, 0]), float),
                              errors, doc.get("hand"))
    return calibration, "\n".join(lines)
