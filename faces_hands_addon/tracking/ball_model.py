# SPDX-License-Identifier: GPL-3.0-or-later
"""The marked ball of thesis 6.3.3 ("Preparation of the Ball", Fig. 6.28), read from
``presets/tracking/ball.json``: its radius and mass and the 12 markers' unit directions in the ball's own
frame with their types (red square, blue ring, green triangle, black circle; three of each)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import UserError
from ..core.presets import NUMBER, PresetFormat, read_preset, register_format
from .flight import LIFT_MODELS, Ball

__all__ = ["BallModel", "ball_model", "BALL_FORMAT"]

BALL_FORMAT = register_format(PresetFormat(
    "faces_hands.pitch_ball", 1, required=("radius", "mass", "marker_size", "types", "markers"),
    shape={"description": str, "radius": NUMBER, "mass": NUMBER, "marker_size": NUMBER, "lift": str,
           "types": {str: {"colour": str, "shape": str, "rgb": [NUMBER]}},
           "markers": [{"type": str, "azimuth": NUMBER, "polar": NUMBER}]}))
SHAPES = ("square", "ring", "triangle", "circle")


@dataclass(frozen=True)
class BallModel:
    """``directions`` (12, 3) unit vectors in the ball frame, ``types`` (12,) type index, ``type_names``,
    ``colours`` (colour class per type), ``shapes``, ``rgb`` (paint colours), ``radius``, ``mass``,
    ``marker_size`` (metres across)."""
    directions: np.ndarray
    types: np.ndarray
    type_names: tuple[str, ...]
    colours: tuple[str, ...]
    shapes: tuple[str, ...]
    rgb: tuple[tuple[float, float, float], ...]
    radius: float
    mass: float
    marker_size: float
    lift: str = "thesis"

    @property
    def physics(self) -> Ball:
        return Ball(self.mass, self.radius, self.lift)

    def type_of_colour(self, colour: str) -> int:
        return self.colours.index(colour)


def ball_model(document: dict | None = None) -> BallModel:
    """The ball of ``presets/tracking/ball.json`` (or of ``document``), checked."""
    doc = document or read_preset("tracking/ball.json", BALL_FORMAT.name)[0]
    names = tuple(sorted(doc["types"]))
    for name in names:
        if doc["types"][name]["shape"] not in SHAPES or len(doc["types"][name]["rgb"]) != 3:
            raise UserError(f"ball preset: marker type {name!r} needs a shape of {SHAPES} and an rgb triple")
    directions, types = [], []
    for m in doc["markers"]:
        if m["type"] not in doc["types"]:
            raise UserError(f"ball preset: unknown marker type {m['type']!r}")
        a, p = np.radians(m["azimuth"]), np.radians(m["polar"])
        directions.append([np.sin(p) * np.cos(a), np.sin(p) * np.sin(a), np.cos(p)])
        types.append(names.index(m["type"]))
    if not 0.02 < doc["radius"] < 0.2 or not doc["mass"] > 0 or not 0 < doc["marker_size"] < doc["radius"]:
        raise UserError("ball preset: radius 0.02-0.2 m, a positive mass and a marker smaller than the ball")
    lift = doc.get("lift", "thesis")
    if lift not in LIFT_MODELS:
        raise UserError(f"ball preset: lift {lift!r} is not one of {', '.join(LIFT_MODELS)}")
    return BallModel(np.array(directions), np.array(types), names,
                     tuple(doc["types"][n]["colour"] for n in names), tuple(doc["types"][n]["shape"] for n in names),
                     tuple(tuple(float(v) for v in doc["types"][n]["rgb"]) for n in names),
                     float(doc["radius"]), float(doc["mass"]), float(doc["marker_size"]), lift)
