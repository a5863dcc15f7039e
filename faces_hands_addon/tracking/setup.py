# SPDX-License-Identifier: GPL-3.0-or-later
"""The recording set-up (thesis 6.3.1) and the pitch types, read from ``presets/tracking/setup.json`` and
``presets/tracking/pitches.json``; the calibration document that ``track-pitch`` reads."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..core.errors import UserError
from ..core.presets import ANY, NUMBER, PresetFormat, parse_preset, read_preset, read_preset_text, register_format
from .camera import Camera

__all__ = ["setup_preset", "pitch_preset", "SETUP_FORMAT", "PITCHES_FORMAT", "CALIBRATION_FORMAT",
           "read_calibration", "calibration_document", "Calibration", "PITCH_TYPES"]

SETUP_FORMAT = register_format(PresetFormat(
    "faces_hands.pitch_setup", 1, required=("strobes", "pairs", "cameras", "plate_direction"),
    shape={"description": str, "plate_direction": [NUMBER], "strobes": {str: ANY}, "pairs": {str: [str]},
           "cameras": {str: ANY}, "views": ANY, "calibration": ANY, "jitter_m": NUMBER, "distortion": ANY,
           "principal_jitter_px": NUMBER, "noise_sigma": NUMBER, "video": ANY}))
PITCHES_FORMAT = register_format(PresetFormat(
    "faces_hands.pitch_types", 1, required=("pitches",),
    shape={"description": str, "release_point": [NUMBER], "target": [NUMBER], "jitter": {str: NUMBER},
           "pitches": {str: ANY}}))
CALIBRATION_FORMAT = register_format(PresetFormat(
    "faces_hands.pitch_calibration", 1, required=("cameras", "pairs", "strobes"),
    shape={"cameras": [ANY], "pairs": {str: [str]}, "strobes": {str: ANY}, "plate_direction": [NUMBER],
           "errors_px": {str: NUMBER}, "ball": ANY, "hand": ANY, "description": str}))
PITCH_TYPES = ("fastball", "curveball", "slider", "changeup", "knuckleball")
MAX_CALIBRATION_BYTES = 2_000_000


def setup_preset() -> dict:
    return read_preset("tracking/setup.json", SETUP_FORMAT.name)[0]


def pitch_preset() -> dict:
    doc = read_preset("tracking/pitches.json", PITCHES_FORMAT.name)[0]
    missing = [p for p in PITCH_TYPES if p not in doc["pitches"]]
    if missing:
        raise UserError(f"pitch preset: missing pitch type(s) {', '.join(missing)}")
    return doc


class Calibration:
    """Calibrated cameras by name, the stereo pairs (``front``, ``back``, ``hand_left``, ``hand_right``),
    strobe frequencies (Hz) by pair role and the plate direction (the flight's rough direction)."""

    def __init__(self, cameras: dict[str, Camera], pairs: dict[str, list[str]], strobes: dict[str, float],
                 plate_direction: np.ndarray, errors_px: dict[str, float] | None = None, hand: dict | None = None):
        self.cameras, self.pairs, self.strobes = cameras, pairs, strobes
        self.plate_direction = np.asarray(plate_direction, np.float64)
        self.errors_px = errors_px or {}
        self.hand = hand

    def pair(self, role: str) -> tuple[Camera, Camera] | None:
        names = self.pairs.get(role)
        if not names or any(n not in self.cameras for n in names):
            return None
        return self.cameras[names[0]], self.cameras[names[1]]


def calibration_document(calibration: Calibration) -> dict:
    return {"format": CALIBRATION_FORMAT.name, "version": CALIBRATION_FORMAT.version,
            "description": "Calibrated cameras of a multi-exposure pitch recording (thesis 6.3.1)",
            "cameras": [c.to_dict() for c in calibration.cameras.values()],
            "pairs": calibration.pairs, "strobes": {k: {"hz": float(v)} for k, v in calibration.strobes.items()},
            "plate_direction": [float(v) for v in calibration.plate_direction],
            "errors_px": {k: float(v) for k, v in calibration.errors_px.items()},
            "hand": calibration.hand or {}}


def read_calibration(path: str | Path) -> Calibration:
    """A calibration file (``faces_hands.pitch_calibration``), checked: cameras, pairs naming them, strobes."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"calibration file {path} does not exist; make one with `calibrate-pitch`")
    if path.stat().st_size > MAX_CALIBRATION_BYTES:
        raise UserError(f"{path}: larger than a calibration file can be")
    doc = parse_preset(read_preset_text(path), str(path), CALIBRATION_FORMAT.name)
    cameras = {}
    for k, entry in enumerate(doc["cameras"]):
        camera = Camera.from_dict(entry, f"{path} camera {k + 1}")
        cameras[camera.name] = camera
    for role, names in doc["pairs"].items():
        missing = [n for n in names if n not in cameras]
        if len(names) != 2 or missing:
            raise UserError(f"{path}: pair {role!r} must name two calibrated cameras"
                            + (f"; {', '.join(missing)} not in the file" if missing else ""))
    strobes = {}
    for role, entry in doc["strobes"].items():
        hz = entry.get("hz") if isinstance(entry, dict) else entry
        if not isinstance(hz, (int, float)) or not 1.0 <= hz <= 10000.0:
            raise UserError(f"{path}: strobe {role!r} needs a frequency 'hz' between 1 and 10000")
        strobes[role] = float(hz)
    direction = np.asarray(doc.get("plate_direction", [0.0, 1.0, 0.0]), np.float64)
    if direction.shape != (3,) or np.linalg.norm(direction) == 0:
        raise UserError(f"{path}: plate_direction must be a non-zero 3-vector")
    return Calibration(cameras, doc["pairs"], strobes, direction / np.linalg.norm(direction),
                       doc.get("errors_px", {}), doc.get("hand") or None)


def dump_calibration(calibration: Calibration) -> str:
    return json.dumps(calibration_document(calibration), indent=1, sort_keys=True)
