# SPDX-License-Identifier: GPL-3.0-or-later
"""The scene's frame rate and the seconds <-> frames mapping (one place; fractional rates such as 29.97 =
30000/1001 included)."""
from __future__ import annotations

import numpy as np

from ...faces_hands_addon.anim.timing import fps_fraction, frame_rate

__all__ = ["scene_fps", "set_scene_fps", "frame_duration", "seconds_to_frames"]


def scene_fps(scene) -> float:
    """Frames per second of ``scene``."""
    return frame_rate(scene.render.fps, scene.render.fps_base)


def set_scene_fps(scene, fps: float) -> None:
    """Give ``scene`` the rate ``fps`` (29.97 becomes 30 / 1.001)."""
    scene.render.fps, scene.render.fps_base = fps_fraction(fps)


def frame_duration(scene) -> float:
    """Seconds per frame of ``scene``."""
    return 1.0 / scene_fps(scene)


def seconds_to_frames(times_s, scene, start_frame: float | None = None) -> np.ndarray:
    """Seconds from the start of a take -> scene frames, from ``start_frame`` (default the scene start)."""
    start = scene.frame_start if start_frame is None else start_frame
    return start + np.asarray(times_s, dtype=np.float64) * scene_fps(scene)
