# SPDX-License-Identifier: GPL-3.0-or-later
"""Photographs into the engine: the file checked from its bytes (``photo.images.check_photo_file``), decoded
by Blender's own image loader, scaled by Blender when it is larger than the photo work's size (so a
40-megapixel photo is never held as floats at full size), read as raw values (``Non-Color``: a 16-bit PNG is
not linearised) and handed over as rows from the top with the EXIF orientation applied; and pictures back out
as PNG files."""
from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.photo.images import WORK_SIDE, PhotoFile, check_photo_file, working_pixels
from ...faces_hands_addon.photo.pipeline import Photo

__all__ = ["load_photo", "write_picture", "image_from_pixels"]


def load_photo(path, what: str = "the photo", face: int = 1, role: str = "front") -> tuple[Photo, PhotoFile]:
    """The engine's :class:`Photo` of ``path`` and what its header said (module docstring)."""
    header = check_photo_file(path, what)
    try:
        image = bpy.data.images.load(str(header.path.resolve()), check_existing=False)
    except RuntimeError as error:
        raise UserError(f"{what} {header.path.name} cannot be decoded ({str(error).strip().splitlines()[-1]})") from None
    try:
        image.colorspace_settings.name = "Non-Color"
        width, height = image.size
        if width == 0 or height == 0 or not image.has_data and not _load_data(image):
            raise UserError(f"{what} {header.path.name} cannot be decoded: Blender read no pixels from it "
                            "(a damaged or unsupported file)")
        width, height = image.size
        if max(width, height) > WORK_SIDE:
            scale = WORK_SIDE / max(width, height)
            image.scale(max(int(round(width * scale)), 1), max(int(round(height * scale)), 1))
            width, height = image.size
        pixels = np.empty(width * height * 4, np.float32)
        image.pixels.foreach_get(pixels)
    finally:
        bpy.data.images.remove(image)
    rgba = pixels.reshape(height, width, 4)[::-1]
    if not header.alpha:
        rgba = rgba[..., :3]
    photo = Photo(working_pixels(rgba, header.orientation), header.path.name, header.focal_35mm, face=face,
                  role=role)
    return photo, header


def _load_data(image) -> bool:
    """Make Blender decode ``image`` now (it loads lazily); False when it could not."""
    try:
        image.pixels[0]
    except (IndexError, RuntimeError):
        return False
    return bool(image.has_data)


def image_from_pixels(name: str, pixels: np.ndarray, colorspace: str = "sRGB", alpha: np.ndarray | None = None):
    """A new Blender image of (H, W, 3) float pixels (rows from the top), packed into the .blend."""
    height, width = pixels.shape[:2]
    image = bpy.data.images.new(name, width=width, height=height, alpha=alpha is not None)
    rgba = np.ones((height, width, 4), np.float32)
    rgba[..., :3] = np.clip(pixels, 0.0, 1.0)
    if alpha is not None:
        rgba[..., 3] = np.clip(alpha, 0.0, 1.0)
    image.colorspace_settings.name = colorspace
    image.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())
    image.pack()
    return image


def write_picture(path: Path, pixels: np.ndarray) -> Path:
    """Write (H, W, 3) sRGB pixels (rows from the top) as an 8-bit PNG at ``path`` (its parent must exist)."""
    height, width = pixels.shape[:2]
    image = bpy.data.images.new("FH Picture", width=width, height=height, alpha=False)
    try:
        rgba = np.ones((height, width, 4), np.float32)
        rgba[..., :3] = np.clip(pixels, 0.0, 1.0)
        image.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())
        image.filepath_raw = str(path)
        image.file_format = "PNG"
        image.save()
    finally:
        bpy.data.images.remove(image)
    return Path(path)
