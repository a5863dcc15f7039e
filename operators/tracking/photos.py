# SPDX-License-Identifier: GPL-3.0-or-later
"""Photos from disk for the pitch tracker: PNG/JPEG files read through Blender's image loader as float
arrays (top row first), never modified."""
from __future__ import annotations

import json
from pathlib import Path

import bpy
import numpy as np

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.core.presets import parse_preset, read_preset_text
from ...faces_hands_addon.tracking.calibration_set import PHOTOS_FORMAT, calibrate_setup

__all__ = ["load_photo", "calibrate_folder", "photo_files", "load_photos"]

SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff")
MAX_PIXELS = 40_000_000


def load_photo(path: Path) -> np.ndarray:
    """(H, W, 3) float32 in [0, 1], top row first."""
    if not path.is_file():
        raise UserError(f"photo {path} does not exist")
    try:
        image = bpy.data.images.load(str(path), check_existing=False)
    except RuntimeError as error:
        raise UserError(f"{path}: not an image Blender can read ({error})") from None
    try:
        width, height = image.size
        if width * height == 0 or width * height > MAX_PIXELS:
            raise UserError(f"{path}: {width}x{height} pixels; a photo must have 1 to {MAX_PIXELS:,} pixels")
        pixels = np.empty(width * height * 4, np.float32)
        image.pixels.foreach_get(pixels)
    finally:
        bpy.data.images.remove(image)
    return np.ascontiguousarray(pixels.reshape(height, width, 4)[::-1, :, :3])


def photo_files(folder: Path) -> dict[str, Path]:
    """Camera name (the file's stem) -> photo file, for the images in ``folder``."""
    if not folder.is_dir():
        raise UserError(f"photo folder {folder} does not exist")
    return {p.stem: p for p in sorted(folder.iterdir()) if p.suffix.lower() in SUFFIXES}


def load_photos(folder: Path, names) -> dict[str, np.ndarray]:
    files = photo_files(folder)
    return {name: load_photo(files[name]) for name in names if name in files}


def calibrate_folder(folder: Path, progress):
    """Calibrate from ``folder`` (``setup.json`` + ``<camera>_board_<k>.png`` + ``<camera>_object.png``)."""
    description = folder / "setup.json"
    if not description.is_file():
        raise UserError(f"{folder} has no setup.json describing the calibration board and object")
    doc = parse_preset(read_preset_text(description), str(description), PHOTOS_FORMAT.name)
    files = photo_files(folder)
    names = sorted({n for pair in doc["pairs"].values() for n in pair} | set(doc.get("single", [])))
    photos = {}
    for name in names:
        boards = sorted(k for k in files if k.startswith(f"{name}_board_"))
        if f"{name}_object" not in files or len(boards) < 3:
            raise UserError(f"camera {name}: needs at least 3 photos {name}_board_<k>.png and one {name}_object.png "
                            f"in {folder}")
        photos[name] = {"boards": [load_photo(files[b]) for b in boards], "object": load_photo(files[f"{name}_object"])}
    return calibrate_setup(doc, photos, progress)


def dump(doc: dict) -> str:
    return json.dumps(doc, indent=1, sort_keys=True)
