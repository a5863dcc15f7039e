# SPDX-License-Identifier: GPL-3.0-or-later
"""The photo step of 6.2.3 in Blender: the photo of a flat hand becomes a reference image (an image empty
standing in the front view, one millimetre per pixel), with one movable marker (an empty) per feature point
of Table 6.5 and two for the ruler marks. The artist drags the markers onto the photo and deletes the ones
that are not visible; :func:`photo_input` turns what is left into the engine's photo input (pixels)."""
from __future__ import annotations

import math

import bpy
import numpy as np

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.core.foreign_files import check_path
from ...faces_hands_addon.hand.features import FEATURE_NAMES
from ...faces_hands_addon.hand.photo import check_photo
from ...names import HAND_PHOTO, PHOTO_IMAGE, PHOTO_IMAGE_SIZE, PHOTO_POINT, PHOTO_RULER_MM

__all__ = ["PHOTO_MARKER", "POINT_MARKER", "load_photo", "photo_input", "find_photo"]

PHOTO_MARKER, POINT_MARKER = HAND_PHOTO, PHOTO_POINT
RULER = ("ruler_start", "ruler_end")


def _layout(width: int, height: int) -> dict[str, tuple[float, float]]:
    """Starting marker positions (pixels): a rough hand outline in the middle of the picture."""
    out = {}
    for i, name in enumerate(FEATURE_NAMES):
        angle = 2 * math.pi * i / len(FEATURE_NAMES)
        out[name] = (width * (0.5 + 0.3 * math.cos(angle)), height * (0.5 + 0.3 * math.sin(angle)))
    out["ruler_start"], out["ruler_end"] = (width * 0.1, height * 0.95), (width * 0.6, height * 0.95)
    return out


def load_photo(context, filepath: str, ruler_mm: float):
    """Add the photo as an image empty with its markers; returns the image empty."""
    path = check_path(bpy.path.abspath(filepath) if filepath else filepath, "the photo of the hand")
    known = set(bpy.data.images)
    try:
        image = bpy.data.images.load(str(path), check_existing=True)
    except RuntimeError as error:
        raise UserError(f"cannot read {path.name} as an image ({error})") from None
    width, height = image.size
    if width < 16 or height < 16:
        if image not in known:
            bpy.data.images.remove(image)          # the scene stays as it was
        raise UserError(f"{path.name} is {width}x{height} pixels (not a picture Blender reads); use a PNG or "
                        "JPEG photo of the hand")
    photo = bpy.data.objects.new(f"FH Hand Photo {path.stem}", None)
    photo.empty_display_type = "IMAGE"
    photo.data = image
    photo.empty_display_size = max(width, height) / 1000.0
    photo.rotation_euler = (math.pi / 2, 0.0, 0.0)
    photo[PHOTO_MARKER] = 1
    photo[PHOTO_IMAGE_SIZE] = [int(width), int(height)]
    photo[PHOTO_RULER_MM] = float(ruler_mm)
    photo[PHOTO_IMAGE] = str(path)
    context.scene.collection.objects.link(photo)
    for name, (u, v) in _layout(width, height).items():
        marker = bpy.data.objects.new(f"FH Point {name}", None)
        marker.empty_display_type = "SPHERE"
        marker.empty_display_size = 0.003
        marker.parent = photo
        marker.location = ((u - width / 2) / 1000.0, (height / 2 - v) / 1000.0, 0.001)
        marker[POINT_MARKER] = name
        context.scene.collection.objects.link(marker)
    return photo


def find_photo(context):
    photos = [o for o in context.scene.objects if o.get(PHOTO_MARKER)]
    active = context.active_object
    if active is not None and active.get(PHOTO_MARKER):
        return active
    if active is not None and active.parent is not None and active.parent.get(PHOTO_MARKER):
        return active.parent
    if not photos:
        raise UserError("load a hand photo first (Load Hand Photo) and place its markers")
    return photos[0]


def photo_input(context) -> dict:
    """The checked photo input (pixels) from the markers on the loaded photo."""
    photo = find_photo(context)
    width, height = (int(v) for v in photo[PHOTO_IMAGE_SIZE])
    points, ruler = {}, {}
    for marker in photo.children:
        name = marker.get(POINT_MARKER)
        if not name:
            continue
        x, y = float(marker.location[0]), float(marker.location[1])
        pixel = [x * 1000.0 + width / 2, height / 2 - y * 1000.0]
        (ruler if name in RULER else points)[name] = pixel
    if set(ruler) != set(RULER):
        raise UserError("both ruler markers (ruler_start, ruler_end) are needed; undo their deletion")
    doc = {"points": points, "ruler": [ruler["ruler_start"], ruler["ruler_end"]],
           "ruler_mm": float(photo.get(PHOTO_RULER_MM, 200.0)), "image": str(photo.get(PHOTO_IMAGE, ""))}
    return check_photo(doc, f"the markers on '{photo.name}'")


def marker_pixels(photo) -> dict[str, np.ndarray]:
    """Name -> pixel position of every marker (for tests and the panel)."""
    width, height = (int(v) for v in photo[PHOTO_IMAGE_SIZE])
    return {m[POINT_MARKER]: np.array([m.location[0] * 1000.0 + width / 2, height / 2 - m.location[1] * 1000.0])
            for m in photo.children if m.get(POINT_MARKER)}
