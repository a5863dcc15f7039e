# SPDX-License-Identifier: GPL-3.0-or-later
"""What the replay shows, as plain keyframes (thesis 6.3.4, Figs. 6.32-6.34): the ball flying the reference
trajectory and spinning with the measured spin, its measured positions, the hand's reconstructed poses in
slow motion, all on one time line: ``slowdown`` stretches real seconds (a 0.6 s pitch becomes 12 s at 20x).

Quaternions are (w, x, y, z), kept on one hemisphere from key to key so that interpolation turns the short way.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .camera import rotation_from_vector

__all__ = ["ReplayPlan", "plan_replay", "quaternion"]


def quaternion(m: np.ndarray) -> np.ndarray:
    """The unit quaternion (w, x, y, z) of a rotation matrix."""
    w = np.sqrt(max(0.0, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2
    x = np.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2
    y = np.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2
    z = np.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2
    x = np.copysign(x, m[2, 1] - m[1, 2])
    y = np.copysign(y, m[0, 2] - m[2, 0])
    z = np.copysign(z, m[1, 0] - m[0, 1])
    q = np.array([w, x, y, z])
    return q / np.linalg.norm(q)


def _continuous(quats: np.ndarray) -> np.ndarray:
    out = quats.copy()
    for i in range(1, len(out)):
        if out[i] @ out[i - 1] < 0:
            out[i] = -out[i]
    return out


@dataclass
class ReplayPlan:
    frames: np.ndarray            # ball key frames
    ball_locations: np.ndarray    # (K, 3)
    ball_rotations: np.ndarray    # (K, 4)
    reference_curve: np.ndarray   # (M, 3)
    measured: np.ndarray          # (N, 3)
    hand_frames: np.ndarray       # (H,)
    hand_locations: np.ndarray    # (H, 3)
    hand_rotations: np.ndarray    # (H, 4)
    hand_angles: np.ndarray       # (H, DOFs)
    last_frame: int


def plan_replay(result, fps: float = 30.0, slowdown: float = 20.0, start_frame: int = 1) -> ReplayPlan:
    """Keyframes for a :class:`.pipeline.PitchResult` (module docstring). Hand poses come first (they end at
    release), then the ball's flight from its first measured position."""
    hand_span = float(result.hand_times[-1]) if len(result.hand_times) else 0.0
    hand_frames = start_frame + np.round(np.asarray(result.hand_times) * slowdown * fps).astype(int)
    hand_loc, hand_rot, hand_ang = [], [], []
    for _, pose, *_ in result.hands:
        hand_loc.append(pose.root[:3, 3])
        hand_rot.append(quaternion(pose.root[:3, :3]))
        hand_ang.append(pose.angles)
    ball_start = start_frame + int(round(hand_span * slowdown * fps))
    reference = result.reference
    measured = np.vstack([result.front, result.back]) if len(result.back) else np.asarray(result.front)
    if reference is None:
        empty = np.zeros((0, 3))
        return ReplayPlan(np.zeros(0, int), empty, np.zeros((0, 4)), empty, measured, hand_frames,
                          np.array(hand_loc).reshape(-1, 3), _continuous(np.array(hand_rot).reshape(-1, 4)),
                          np.array(hand_ang), int(hand_frames[-1]) if len(hand_frames) else start_frame)
    count = int(np.ceil(reference.duration * slowdown * fps)) + 1
    times = np.arange(count) / (slowdown * fps)
    times = times[times <= reference.duration]
    locations = np.interp(times, reference.curve_times, reference.curve[:, 0]), \
        np.interp(times, reference.curve_times, reference.curve[:, 1]), \
        np.interp(times, reference.curve_times, reference.curve[:, 2])
    start = result.orientations[0] if len(result.orientations) else np.eye(3)
    rotations = _continuous(np.array([quaternion(rotation_from_vector(reference.spin * t) @ start) for t in times]))
    return ReplayPlan(ball_start + np.arange(len(times)), np.column_stack(locations), rotations, reference.curve,
                      measured, hand_frames, np.array(hand_loc).reshape(-1, 3),
                      _continuous(np.array(hand_rot).reshape(-1, 4)), np.array(hand_ang),
                      int(ball_start + len(times) - 1))
