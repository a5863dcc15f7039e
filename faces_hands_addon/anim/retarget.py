# SPDX-License-Identifier: GPL-3.0-or-later
"""Named-target animation between characters and pipelines: the 52 ARKit blendshapes (in the column order
Live Link Face records), the 15 visemes, the spellings other tools use for them, and the Live Link Face CSV
layout that Unreal imports (``Timecode,BlendShapeCount,EyeBlinkLeft,...,TongueOut,HeadYaw,...``).

A weights animation (``anim.weights``) is a set of target names with one weight curve each; any character
with shape keys of those names (or their aliases: ``EyeBlinkLeft``, ``eyeBlink_L``, ``viseme_I``) plays it.
"""
from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np

from ..core.errors import UserError

__all__ = ["ARKIT_NAMES", "LIVE_LINK_EXTRA", "aliases", "match_targets", "write_live_link_csv",
           "read_live_link_csv", "MAX_CSV_BYTES"]

#: the 52 ARKit blendshapes in Live Link Face's CSV column order (presets/SOURCES.md, ARKit)
ARKIT_NAMES = (
    "eyeBlinkLeft", "eyeLookDownLeft", "eyeLookInLeft", "eyeLookOutLeft", "eyeLookUpLeft", "eyeSquintLeft",
    "eyeWideLeft", "eyeBlinkRight", "eyeLookDownRight", "eyeLookInRight", "eyeLookOutRight", "eyeLookUpRight",
    "eyeSquintRight", "eyeWideRight", "jawForward", "jawRight", "jawLeft", "jawOpen", "mouthClose",
    "mouthFunnel", "mouthPucker", "mouthRight", "mouthLeft", "mouthSmileLeft", "mouthSmileRight",
    "mouthFrownLeft", "mouthFrownRight", "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft",
    "mouthStretchRight", "mouthRollLower", "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper",
    "mouthPressLeft", "mouthPressRight", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft",
    "mouthUpperUpRight", "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight",
    "cheekPuff", "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft", "noseSneerRight", "tongueOut")
#: head and eye rotations Live Link Face records after the blendshapes (radians; 0 where the rig has none)
LIVE_LINK_EXTRA = ("HeadYaw", "HeadPitch", "HeadRoll", "LeftEyeYaw", "LeftEyePitch", "LeftEyeRoll",
                   "RightEyeYaw", "RightEyePitch", "RightEyeRoll")
VISEME_SPELLINGS = {"viseme_ih": ("viseme_I",), "viseme_oh": ("viseme_O",), "viseme_ou": ("viseme_U",)}
MAX_CSV_BYTES = 200_000_000


def aliases(name: str) -> tuple[str, ...]:
    """Spellings of a target other tools use: PascalCase (Live Link Face), Apple's raw ``_L``/``_R`` form,
    Ready Player Me's viseme names."""
    out = [name, name[:1].upper() + name[1:]]
    for side, short in (("Left", "_L"), ("Right", "_R")):
        if name.endswith(side):
            out.append(name[:-len(side)] + short)
    out += VISEME_SPELLINGS.get(name, ())
    return tuple(dict.fromkeys(out))


def match_targets(wanted, available) -> dict[str, str]:
    """Wanted target name -> the available shape key that plays it (exact name first, then an alias, then a
    case-insensitive match); targets the character lacks are left out."""
    available = list(available)
    lower = {name.lower(): name for name in available}
    present = set(available)
    out = {}
    for name in wanted:
        for candidate in aliases(name):
            if candidate in present:
                out[name] = candidate
                break
        else:
            for candidate in aliases(name):
                if candidate.lower() in lower:
                    out[name] = lower[candidate.lower()]
                    break
    return out


def _timecode(seconds: float, fps: float) -> str:
    """``HH:MM:SS:FF.mmm``: whole frames at ``fps`` and the thousandths of a frame (counted in integer
    thousandths of a frame, so a time on a frame never reads as the end of the frame before)."""
    ticks = int(round(seconds * fps * 1000.0))
    frames, thousandths = divmod(ticks, 1000)
    whole_seconds = int(frames // fps)
    frame = int(round(frames - whole_seconds * fps))
    if frame >= fps:                       # non-integer rates: the last partial frame of a second
        whole_seconds, frame = whole_seconds + 1, 0
    hours, rest = divmod(whole_seconds, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours:02d}:{minutes:02d}:{secs:02d}:{frame:02d}.{thousandths:03d}"


def write_live_link_csv(path: str | Path, times, weights: dict[str, np.ndarray], fps: float) -> Path:
    """Write the ARKit weights (name -> per-time values; missing names are 0) at ``times`` (s) as a Live Link
    Face CSV (52 blendshapes + 9 rotations per row)."""
    times = np.asarray(times, np.float64)
    for name, values in weights.items():
        if np.asarray(values).shape != times.shape or not np.all(np.isfinite(values)):
            raise UserError(f"the weights of {name!r} do not match the frame times")
    path = Path(path)
    columns = [np.clip(np.asarray(weights.get(name, np.zeros_like(times)), np.float64), 0.0, 1.0)
               for name in ARKIT_NAMES]
    with open(path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(["Timecode", "BlendShapeCount", *(n[:1].upper() + n[1:] for n in ARKIT_NAMES),
                         *LIVE_LINK_EXTRA])
        count = len(ARKIT_NAMES) + len(LIVE_LINK_EXTRA)
        for row, time in enumerate(times):
            writer.writerow([_timecode(float(time), fps), count, *(f"{c[row]:.6f}" for c in columns),
                             *(["0.000000"] * len(LIVE_LINK_EXTRA))])
    return path


_TIMECODE = re.compile(r"^(\d+):(\d\d):(\d\d):(\d+)(?:\.(\d+))?$")


def read_live_link_csv(path: str | Path, fps: float = 60.0) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Times (s, from the first row) and ARKit weights (camelCase name -> values) of a Live Link Face CSV;
    ``fps`` is the rate its timecodes count frames in (Live Link Face records at 60 unless set to 30)."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path} does not exist")
    if path.stat().st_size > MAX_CSV_BYTES:
        raise UserError(f"{path} is larger than {MAX_CSV_BYTES // 1_000_000} MB")
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            rows = list(csv.reader(handle))
    except (UnicodeDecodeError, csv.Error) as error:
        raise UserError(f"{path}: not a readable UTF-8 CSV ({error})") from None
    if len(rows) < 2 or not rows[0] or rows[0][0] != "Timecode":
        raise UserError(f"{path}: not a Live Link Face CSV (the first column must be 'Timecode')")
    header = {name.lower(): index for index, name in enumerate(rows[0])}
    times, values = [], {name: [] for name in ARKIT_NAMES}
    for number, row in enumerate(rows[1:], start=2):
        match = _TIMECODE.match(row[0].strip()) if row else None
        if match is None:
            raise UserError(f"{path} line {number}: timecode {row[0] if row else ''!r} is not HH:MM:SS:FF.mmm")
        h, m, s, f, sub = match.groups()
        times.append(int(h) * 3600 + int(m) * 60 + int(s) + (int(f) + float(f"0.{sub or 0}")) / fps)
        for name in ARKIT_NAMES:
            index = header.get(name.lower())
            try:
                value = float(row[index]) if index is not None and index < len(row) else 0.0
            except ValueError:
                raise UserError(f"{path} line {number}: {name} is not a number ({row[index]!r})") from None
            if not math.isfinite(value):
                raise UserError(f"{path} line {number}: {name} is not a finite number")
            values[name].append(value)
    times = np.asarray(times) - times[0]
    return times, {name: np.asarray(v) for name, v in values.items()}
