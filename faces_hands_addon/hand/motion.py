# SPDX-License-Identifier: GPL-3.0-or-later
"""Poses and motions of the hand (thesis 6.2.1 "Animation": "contraction values are specified as key frames
with an arbitrary temporal distribution. During simulation, the contraction values are interpolated using a
smooth spline function (Hermite), which is evaluated at discrete points in time").

Poses (``presets/hand/poses.json``) are contraction values; a motion is a list of ``[time, pose]`` keys. Between
keys every contraction follows a cubic Hermite segment with Catmull-Rom tangents (zero at the ends),
clamped to [0, 1]; the same keys become Bezier F-curves in Blender (auto-clamped handles, also cubic).

A pose may carry a second stage, beyond the thesis: ``"squeeze"`` sets the contractions it names once the
first stage has settled (a fist closes, then squeezes isometrically: the thenar muscles contract while the
thumb rests on the curled fingers, :mod:`.thumb_contact`, so the thenar eminence swells, Fig. 6.18, without
the thumb crossing the palm before the fingers have closed). :func:`pose_stages` gives both stages,
``HandRig.settled_stages`` settles them in turn, and a motion holds a staged pose's key for
:data:`SQUEEZE_AFTER` seconds, keys its squeeze :data:`SQUEEZE_RISE` after that (close, then squeeze) and
lets go of it :data:`SQUEEZE_RISE` before the next key (a hand opening while the thenar still pulled swung the
released thumb across the palm). The thumb must have come to rest on the fingers first: with the squeeze keyed 0.3 s after the fist's key, or with
Catmull-Rom tangents that let the held contractions sag before the squeeze (hence the clamped tangents of
:func:`hermite`), the rising thenar contraction swung the still-moving thumb across the palm to its CMC limits
(its tip 89 mm from the staged pose's).
"""
from __future__ import annotations

import warnings

import numpy as np

from ..core.errors import InputWarning, UserError
from ..core.presets import resolve
from .presets import poses_preset

__all__ = ["pose_names", "motion_names", "check_preset_name", "check_pose_names", "pose_contractions", "pose_squeeze", "pose_stages", "motion_keys",
           "hermite", "motion_table", "checked_contractions", "SQUEEZE_AFTER", "SQUEEZE_RISE"]

SQUEEZE_AFTER = 1.0     # s a staged pose's key is held in a motion before its squeeze rises (the thumb settles)
SQUEEZE_RISE = 0.3      # s the squeeze takes to rise


def checked_contractions(values: dict, muscles: list[str], where: str) -> dict[str, float]:
    """Contractions by muscle name: an unknown name or a value that is not a finite number is refused (a clear
    UserError); a number outside [0, 1] is clamped into it with an :class:`InputWarning` that names the muscle,
    the value given, the value used and ``where`` (the preset file and pose)."""
    out = {}
    for name, value in values.items():
        if name not in muscles:
            raise UserError(f"{where}: unknown hand muscle {name!r}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
            raise UserError(f"{where}: contraction {name} must be a number in [0, 1], not {value!r}")
        if not 0.0 <= value <= 1.0:
            used = min(max(float(value), 0.0), 1.0)
            warnings.warn(f"{where}: contraction {name} = {value} is outside [0, 1]; {used:g} is used",
                          InputWarning, stacklevel=2)
            value = used
        out[name] = float(value)
    return out


def _where(name: str) -> str:
    """The preset file a pose is read from (the artist's copy when there is one) and the pose, for messages."""
    return f"{resolve('hand/poses.json')}: hand pose {name!r}"


def pose_names() -> list[str]:
    return sorted(poses_preset()["poses"])


def motion_names() -> list[str]:
    return sorted(poses_preset().get("motions", {}))


def check_preset_name(name: str) -> None:
    """Refuse ``name`` unless it is a motion or a pose of the hand presets (a UserError naming both lists)."""
    doc = poses_preset()
    motions = doc.get("motions", {})
    if name not in doc["poses"] and name not in motions:
        raise UserError(f"unknown hand motion or pose {name!r}; motions: {', '.join(sorted(motions))}; poses: "
                        f"{', '.join(sorted(doc['poses']))}")


def check_pose_names(names: list[str]) -> None:
    """Refuse the names of ``names`` that are no pose of the hand presets (one UserError naming them all)."""
    known = pose_names()
    unknown = [name for name in names if name not in known]
    if unknown:
        raise UserError(f"unknown hand pose(s) {', '.join(map(repr, unknown))}; the poses are {', '.join(known)}")


def pose_contractions(name: str, muscles: list[str]) -> dict[str, float]:
    poses = poses_preset()["poses"]
    if name not in poses:
        raise UserError(f"unknown hand pose {name!r}; the poses are {', '.join(sorted(poses))}")
    return checked_contractions(poses[name].get("contractions", {}), muscles, _where(name))


def pose_squeeze(name: str, muscles: list[str]) -> dict[str, float]:
    """The second stage of pose ``name``: the contractions its ``"squeeze"`` sets once the pose has settled
    (empty for a pose without one; checked like the contractions)."""
    poses = poses_preset()["poses"]
    if name not in poses:
        raise UserError(f"unknown hand pose {name!r}; the poses are {', '.join(sorted(poses))}")
    squeeze = poses[name].get("squeeze", {})
    if not isinstance(squeeze, dict):
        raise UserError(f"hand pose {name!r}: \"squeeze\" must map muscle names to contractions in [0, 1]")
    return checked_contractions(squeeze, muscles, f"{_where(name)} squeeze")


def pose_stages(name: str, muscles: list[str]) -> list[dict[str, float]]:
    """The contractions of pose ``name`` stage by stage: the pose, then (if it has a squeeze) the pose with the
    squeeze's contractions set."""
    pose, squeeze = pose_contractions(name, muscles), pose_squeeze(name, muscles)
    return [pose, {**pose, **squeeze}] if squeeze else [pose]


def motion_keys(name: str, muscles: list[str]) -> tuple[np.ndarray, list[dict[str, float]]]:
    """Key times (s) and the contractions at each key of a motion (or of a single pose held for 1 s); a staged
    pose's key is held :data:`SQUEEZE_AFTER`, its squeeze keyed :data:`SQUEEZE_RISE` later and let go again
    :data:`SQUEEZE_RISE` before the next key, when the motion leaves room for that (module docstring)."""
    doc = poses_preset()
    motions = doc.get("motions", {})
    if name in doc["poses"] and name not in motions:
        stages = pose_stages(name, muscles)
        if len(stages) == 1:
            return np.array([0.0, 0.5, 1.5]), [{}, stages[0], stages[0]]
        times = [0.0, 0.5, 0.5 + SQUEEZE_AFTER, 0.5 + SQUEEZE_AFTER + SQUEEZE_RISE, 1.5 + SQUEEZE_AFTER + SQUEEZE_RISE]
        return np.array(times), [{}, stages[0], stages[0], stages[1], stages[1]]
    check_preset_name(name)
    keys = motions[name].get("keys", [])
    times, poses = [], []
    for key in keys:
        if not (isinstance(key, list) and len(key) == 2 and isinstance(key[0], (int, float)) and isinstance(key[1], str)):
            raise UserError(f"hand motion {name!r}: every key must be [seconds, pose name], got {key!r}")
        times.append(float(key[0]))
        poses.append(pose_stages(key[1], muscles))
    if len(times) < 2 or np.any(np.diff(times) <= 0):
        raise UserError(f"hand motion {name!r}: needs at least two keys with increasing times")
    out_times, out_poses = [], []
    for k, (time, stages) in enumerate(zip(times, poses)):
        out_times.append(time)
        out_poses.append(stages[0])
        last = k + 1 == len(times)
        room = np.inf if last else times[k + 1] - time
        if len(stages) > 1 and room >= SQUEEZE_AFTER + 3 * SQUEEZE_RISE:
            out_times += [time + SQUEEZE_AFTER, time + SQUEEZE_AFTER + SQUEEZE_RISE]
            out_poses += [stages[0], stages[1]]
            if not last:                # let go of the squeeze before the hand leaves the pose
                out_times.append(times[k + 1] - SQUEEZE_RISE)
                out_poses.append(stages[0])
    return np.array(out_times), out_poses


def hermite(times: np.ndarray, values: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Cubic Hermite interpolation of ``values`` (K, C) keyed at ``times`` (K,), Catmull-Rom tangents with zero
    tangents at the first and last key and at every peak, dip or held value, evaluated at ``at`` and clamped to
    [0, 1]."""
    times, values, at = np.asarray(times, float), np.asarray(values, float), np.asarray(at, float)
    tangents = np.zeros_like(values)
    if len(times) > 2:
        tangents[1:-1] = (values[2:] - values[:-2]) / (times[2:] - times[:-2])[:, None]
        # clamped, as Blender's auto-clamped handles: flat at a key that is a peak, a dip or a held value, so
        # a held contraction does not sag before it rises (a squeeze after its pose, :func:`motion_keys`)
        before, after = values[1:-1] - values[:-2], values[2:] - values[1:-1]
        tangents[1:-1][before * after <= 0] = 0.0
    k = np.clip(np.searchsorted(times, at, side="right") - 1, 0, len(times) - 2)
    span = times[k + 1] - times[k]
    u = np.clip((at - times[k]) / span, 0.0, 1.0)[:, None]
    h00, h10 = 2 * u ** 3 - 3 * u ** 2 + 1, u ** 3 - 2 * u ** 2 + u
    h01, h11 = -2 * u ** 3 + 3 * u ** 2, u ** 3 - u ** 2
    out = (h00 * values[k] + h10 * span[:, None] * tangents[k] + h01 * values[k + 1]
           + h11 * span[:, None] * tangents[k + 1])
    return np.clip(out, 0.0, 1.0)


def motion_table(name: str, muscles: list[str], fps: float) -> tuple[np.ndarray, np.ndarray]:
    """Frame times and the (frames, muscles) contractions of a motion sampled at ``fps``."""
    times, poses = motion_keys(name, muscles)
    values = np.array([[pose.get(m, 0.0) for m in muscles] for pose in poses])
    at = np.arange(0.0, times[-1] + 1e-9, 1.0 / fps)
    return at, hermite(times, values, at)
