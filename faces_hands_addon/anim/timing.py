# SPDX-License-Identifier: GPL-3.0-or-later
"""Frame rates: Blender stores a rate as ``fps / fps_base`` (29.97 = 30 / 1.001). One place converts."""
from __future__ import annotations

import math

from ..core.errors import UserError

__all__ = ["MIN_FPS", "MAX_FPS", "frame_rate", "fps_fraction", "check_fps"]

MIN_FPS, MAX_FPS = 1.0, 240.0


def frame_rate(fps: float, fps_base: float = 1.0) -> float:
    """Frames per second of a Blender rate pair."""
    return float(fps) / float(fps_base)


def check_fps(fps: float) -> float:
    """``fps`` as a float, or a UserError when it is not a number in 1..240."""
    try:
        fps = float(fps)
    except (TypeError, ValueError):
        raise UserError(f"the frame rate must be a number, not {fps!r}") from None
    if not (MIN_FPS <= fps <= MAX_FPS):
        raise UserError(f"the frame rate {fps} is outside {MIN_FPS:g}..{MAX_FPS:g} frames per second")
    return fps


def fps_fraction(fps: float) -> tuple[int, float]:
    """The rate pair Blender understands for ``fps``: 29.97 -> (30, 1.001...), whole rates stay whole."""
    fps = check_fps(fps)
    if abs(fps - round(fps)) < 1e-6:
        return int(round(fps)), 1.0
    rounded = math.ceil(fps)
    return rounded, rounded / fps
