# SPDX-License-Identifier: GPL-3.0-or-later
"""Controls every rig exposes (CONTRIBUTING.md "Controls"): what an artist animates, each with its range,
default, UI group, units and a description, and the one clamping rule."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from .errors import UserError

__all__ = ["ControlSpec", "clamp_controls", "control_ranges"]


@dataclass(frozen=True)
class ControlSpec:
    """One animatable control: ``name`` (snake_case, ``_L``/``_R`` for the character's sides), range
    ``minimum..maximum``, ``default``, ``group`` (UI region, e.g. brow, jaw, thumb), ``kind`` (e.g. "muscle"
    for a contraction, "direct" for a direct parameter), a one-line ``description`` for tooltips and the
    ``units`` of a value (empty for a factor)."""
    name: str
    minimum: float
    maximum: float
    default: float
    group: str
    kind: str
    description: str
    units: str = ""

    @property
    def full_value(self) -> float:
        """The value a basis shape is baked at: the range end farthest from 0."""
        return self.maximum if abs(self.maximum) >= abs(self.minimum) else self.minimum


def control_ranges(specs: Mapping[str, ControlSpec]) -> dict[str, tuple[float, float]]:
    return {name: (spec.minimum, spec.maximum) for name, spec in specs.items()}


def clamp_controls(values: Mapping[str, float], specs: Mapping[str, ControlSpec], strict: bool = True,
                   what: str = "control") -> dict[str, float]:
    """Clamp ``values`` to their ranges. Unknown names raise a :class:`UserError` when ``strict``; values
    that are not finite numbers always do."""
    out = {}
    for name, value in values.items():
        spec = specs.get(name)
        if spec is None:
            if strict:
                raise UserError(f"unknown {what} {name!r}; the rig's controls are listed in its panel "
                                "(or by rig.control_specs())")
            continue
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise UserError(f"{what} {name!r} needs a number, got {value!r}") from None
        if not math.isfinite(value):
            raise UserError(f"{what} {name!r} needs a finite number, got {value!r}")
        value = value if value > spec.minimum else float(spec.minimum)    # np.clip's rule (signed zeros too),
        out[name] = value if value < spec.maximum else float(spec.maximum)   # without its per-call cost
    return out
