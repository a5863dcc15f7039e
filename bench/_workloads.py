# SPDX-License-Identifier: GPL-3.0-or-later
"""Workloads the simulation benches share (no bpy, numpy only)."""
from __future__ import annotations

import numpy as np

__all__ = ["animated_controls", "record_split"]


def animated_controls(frame: int) -> dict[str, float]:
    """A busy performance: smile and jaw in anti-phase, a blink, brows, lips, every frame different."""
    phase = 2 * np.pi * frame / 24.0
    wave = 0.5 - 0.5 * np.cos(phase)
    return {"zygomaticus_major_L": wave, "zygomaticus_major_R": wave, "jaw_open": 0.6 * (1 - wave),
            "frontalis_inner_L": 0.5 * wave, "frontalis_inner_R": 0.5 * wave,
            "orbicularis_oris_upper": 0.3 * (1 - wave), "orbicularis_oris_lower": 0.3 * (1 - wave),
            "eyelid_close_L": float(frame % 48 < 4), "eyelid_close_R": float(frame % 48 < 4),
            "eye_yaw": 0.3 * np.sin(phase / 2)}


def record_split(split: dict, stamps: list) -> None:
    """Append each stage's milliseconds to ``split`` (stage -> list, in stage order) from the
    ``time.perf_counter()`` ``stamps`` taken before the first stage and after each one."""
    for key, start, end in zip(split, stamps, stamps[1:]):
        split[key].append(1e3 * (end - start))
