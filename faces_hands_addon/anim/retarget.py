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
from ..core.foreign_files import read_text

__all__ = ["ARKIT_NAMES", "LIVE_LINK_EXTRA", "aliases", "match_targets", "write_live_link_csv",
           "read_live_link_csv", "timecode_rate", "take_rate", "MAX_CSV_BYTES", "TIMECODE_RATE"]

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
#: the rate Live Link Face's timecodes count frames in unless set otherwise, and the one this writer uses
TIMECODE_RATE = 60
#: frame rates timecodes run at (a take that passes a whole second shows which)
STANDARD_RATES = (24, 25, 30, 48, 50, 60, 72, 90, 100, 120, 144, 240)


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


def _timecode(seconds: float, fps: float = TIMECODE_RATE) -> str:
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


def write_live_link_csv(path: str | Path, times, weights: dict[str, np.ndarray], fps: float | None = None) -> Path:
    """Write the ARKit weights (name -> per-time values; missing names are 0) at ``times`` (s) as a Live Link
    Face CSV (52 blendshapes + 9 rotations per row). The timecodes count frames at Live Link Face's 60 per
    second whatever the take's rate (``fps``, kept for callers): a 30-fps take's rows step two frames, a
    24-fps take's 2.5; so every reader that takes Live Link Face's default reads the times exactly, and
    :func:`read_live_link_csv` finds the take's own rate in the steps."""
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
            writer.writerow([_timecode(float(time)), count, *(f"{c[row]:.6f}" for c in columns),
                             *(["0.000000"] * len(LIVE_LINK_EXTRA))])
    return path


_TIMECODE = re.compile(r"^(\d+):(\d\d):(\d\d):(\d+)(?:\.(\d+))?$")


def timecode_rate(frames: np.ndarray, seconds: np.ndarray, given: float | None = None) -> float:
    """The rate a Live Link Face CSV's timecodes count frames in: the frame number runs from 0 to the rate
    minus one and starts again at each whole second, so a take that passes a second shows it (the next
    standard rate at or above the largest frame number + 1); a shorter take takes ``given`` or Live Link
    Face's default, 60. A ``given`` rate that frame numbers exceed is refused."""
    largest = int(frames.max()) if len(frames) else 0
    if given is not None:
        if largest >= given:
            raise UserError(f"the timecodes count frames up to {largest}, so they are not at {given:g} fps; "
                            "leave out --csv-fps (the timecodes give the rate)")
        return float(given)
    if len(seconds) > 1 and np.any(np.diff(seconds) > 0):
        return float(next((rate for rate in STANDARD_RATES if rate > largest), largest + 1))
    return float(max(TIMECODE_RATE, largest + 1))


def take_rate(times: np.ndarray) -> float:
    """Frames per second of a take sampled at ``times`` (s): the median step gives the count of frames the
    take spans, the span then the rate (timecodes hold a sixty-thousandth of a second, too coarse for one
    step to tell 29.97 from 30), snapped to a standard or NTSC rate within 0.01 %."""
    steps = np.diff(times)
    if not len(steps) or np.median(steps) <= 0:
        return float(TIMECODE_RATE)
    span = float(times[-1] - times[0])
    rate = round(span / float(np.median(steps))) / span
    for known in tuple(r * 1000 / 1001 for r in (24, 30, 60)) + STANDARD_RATES:
        if abs(rate - known) <= 1e-4 * known:
            return float(known)
    return rate


def _read_rows(path: Path) -> list[list[str]]:
    text = read_text(path, "the Live Link CSV", MAX_CSV_BYTES)
    try:
        return list(csv.reader(text.splitlines()))
    except csv.Error as error:
        raise UserError(f"{path}: not a readable CSV ({error})") from None


def read_live_link_csv(path: str | Path, fps: float | None = None) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Times (s, from the first row) and ARKit weights (camelCase name -> values) of a Live Link Face CSV;
    ``fps``: the rate its timecodes count frames in, when known (default: found from the timecodes, see
    :func:`timecode_rate`)."""
    path = Path(path)
    rows = _read_rows(path)
    if len(rows) < 2 or not rows[0] or rows[0][0] != "Timecode":
        raise UserError(f"{path}: not a Live Link Face CSV (the first column must be 'Timecode')")
    header = {name.lower(): index for index, name in enumerate(rows[0])}
    stamps, values = [], {name: [] for name in ARKIT_NAMES}
    for number, row in enumerate(rows[1:], start=2):
        match = _TIMECODE.match(row[0].strip()) if row else None
        if match is None:
            raise UserError(f"{path} line {number}: timecode {row[0] if row else ''!r} is not HH:MM:SS:FF.mmm")
        h, m, s, f, sub = match.groups()
        stamps.append((int(h) * 3600 + int(m) * 60 + int(s), int(f) + float(f"0.{sub or 0}")))
        for name in ARKIT_NAMES:
            index = header.get(name.lower())
            try:
                value = float(row[index]) if index is not None and index < len(row) else 0.0
            except ValueError:
                raise UserError(f"{path} line {number}: {name} is not a number ({row[index]!r})") from None
            if not math.isfinite(value):
                raise UserError(f"{path} line {number}: {name} is not a finite number")
            values[name].append(value)
    seconds, frames = (np.array(column, dtype=np.float64) for column in zip(*stamps))
    rate = timecode_rate(np.floor(frames), seconds, fps)
    times = seconds + frames / rate
    if np.any(np.diff(times) <= 0):
        bad = int(np.flatnonzero(np.diff(times) <= 0)[0]) + 3
        raise UserError(f"{path} line {bad}: the timecode does not come after the one before it")
    return times - times[0], {name: np.asarray(v) for name, v in values.items()}
