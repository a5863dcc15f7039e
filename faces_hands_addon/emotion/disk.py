# SPDX-License-Identifier: GPL-3.0-or-later
"""The activation-evaluation disk as a picture (thesis 4.4.1, Fig. 4.9; Table 4.4), for the emotion picker.

Cowie's disk: evaluation runs left (negative) to right (positive), activation bottom (passive) to top
(active); the neutral centre is no emotion and the rim (radius 100) the most intense ones. Drawn as an RGBA
float image (rows from the top): the disk and its axes, every word of Table 4.4 as a small grey dot, the
basic expressions of 4.4.3 as coloured dots, and the chosen point in red with a line from the centre (its
angle is the similarity to the basic emotions, its length the intensity).
"""
from __future__ import annotations

import numpy as np

from .words import DISK_RADIUS, EmotionPoint

__all__ = ["disk_image", "strongest_controls", "picked_point", "CUSTOM"]

#: the picker's menu entry for "no word: the sliders' own point"
CUSTOM = "CUSTOM"

BACKGROUND = (0.16, 0.16, 0.16, 1.0)
DISK = (0.24, 0.24, 0.26, 1.0)
LINES = (0.42, 0.42, 0.45, 1.0)
WORD = (0.62, 0.62, 0.62, 1.0)
BASIC = (0.35, 0.75, 1.0, 1.0)
CHOSEN = (1.0, 0.25, 0.2, 1.0)


def _to_pixels(activation: float, evaluation: float, size: int) -> tuple[float, float]:
    """(row, column) of a disk point; the disk fills the image with a 6 % margin."""
    scale = 0.47 * size / DISK_RADIUS
    return size / 2 - activation * scale, size / 2 + evaluation * scale


def _dot(image: np.ndarray, rows: np.ndarray, cols: np.ndarray, centre, radius: float, colour) -> None:
    inside = (rows - centre[0]) ** 2 + (cols - centre[1]) ** 2 <= radius ** 2
    image[inside] = colour


def _segment(image: np.ndarray, rows, cols, start, end, width: float, colour) -> None:
    a, b = np.asarray(start, float), np.asarray(end, float)
    ab = b - a
    length2 = max(float(ab @ ab), 1e-12)
    t = np.clip(((rows - a[0]) * ab[0] + (cols - a[1]) * ab[1]) / length2, 0.0, 1.0)
    distance2 = (rows - a[0] - t * ab[0]) ** 2 + (cols - a[1] - t * ab[1]) ** 2
    image[distance2 <= (width / 2) ** 2] = colour


def disk_image(words: dict[str, EmotionPoint], basics: tuple[str, ...], chosen: EmotionPoint | None,
               size: int = 128) -> np.ndarray:
    """The disk with ``words`` (grey), ``basics`` (the basic emotions' words, blue) and ``chosen`` (red), as
    a ``(size, size, 4)`` float32 RGBA image, rows from the top."""
    size = int(size)
    if size < 16:
        raise ValueError("the disk image needs at least 16 x 16 pixels")
    image = np.empty((size, size, 4), np.float32)
    image[:] = BACKGROUND
    rows, cols = np.mgrid[0:size, 0:size].astype(np.float64) + 0.5
    centre = _to_pixels(0.0, 0.0, size)
    rim = 0.47 * size
    distance = np.hypot(rows - centre[0], cols - centre[1])
    image[distance <= rim] = DISK
    image[np.abs(distance - rim) <= 0.75] = LINES
    for end in ((DISK_RADIUS, 0.0), (-DISK_RADIUS, 0.0), (0.0, DISK_RADIUS), (0.0, -DISK_RADIUS)):
        _segment(image, rows, cols, centre, _to_pixels(*end, size), 1.0, LINES)
    dot = max(1.0, size / 96)
    for name, point in words.items():
        if name not in basics:
            _dot(image, rows, cols, _to_pixels(point.activation, point.evaluation, size), dot, WORD)
    for name in basics:
        point = words.get(name)
        if point is not None:
            _dot(image, rows, cols, _to_pixels(point.activation, point.evaluation, size), 2 * dot, BASIC)
    if chosen is not None:
        scale = min(1.0, DISK_RADIUS / max(chosen.radius, 1e-12))        # outside the rim: on the rim
        target = _to_pixels(chosen.activation * scale, chosen.evaluation * scale, size)
        _segment(image, rows, cols, centre, target, max(1.0, size / 128), CHOSEN)
        _dot(image, rows, cols, target, 2.5 * dot, CHOSEN)
    return image


def strongest_controls(values: dict[str, float], count: int = 6) -> list[tuple[str, float]]:
    """The ``count`` controls of an expression with the largest magnitude, largest first (ties by name)."""
    ranked = sorted(values.items(), key=lambda item: (-abs(item[1]), item[0]))
    return [(name, float(value)) for name, value in ranked[:count] if value != 0.0]


def picked_point(word: str, activation: float, evaluation: float,
                 words: dict[str, EmotionPoint] | None = None) -> EmotionPoint:
    """The picker's point: the table's own point of ``word`` (exact, unlike the sliders' single precision)
    when ``words`` has it, else the sliders' activation and evaluation (``word`` :data:`CUSTOM`: the
    sliders were moved off the word's point)."""
    if words is not None and word in words:
        return words[word]
    return EmotionPoint(float(activation), float(evaluation), word="" if word == CUSTOM else str(word))
