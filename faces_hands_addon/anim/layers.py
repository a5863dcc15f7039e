# SPDX-License-Identifier: GPL-3.0-or-later
"""Control layers and the one rule that mixes them (thesis 4.3.5: speech-related and emotional contractions
are combined "by summing up the respective muscle contraction values"; 4.4: emotions are mixed before they
reach their layer, Eqs. 4.8-4.10).

Every control of a rig exists once per layer: ``ctrl`` (what the artist keys; it carries the control's
default), ``speech`` (lip sync), ``behavior`` (non-verbal behaviour), ``emotion``. The value a rig shows is

    value(control) = clamp(ctrl + speech + behavior + emotion, minimum, maximum)          (:func:`mix`)

The same rule is written out as Blender driver expressions (:class:`DriverExpression`) for shape keys that a
control drives (a baked muscle basis) and for quantities several controls drive (wrinkle strength), so the
live preview, the baked drivers and the wrinkle shading cannot disagree. The expressions use only ``+``,
``*``, ``min`` and ``max``: Blender evaluates them without Python ("simple expressions"), so they also run
when a file is opened with auto-run scripts off.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ..core.controls import ControlSpec
from ..core.errors import UserError

__all__ = ["LAYERS", "BASE_LAYER", "mix", "LayerTable", "DriverExpression", "control_driver",
           "weighted_driver", "weighted_sum"]

LAYERS = ("ctrl", "speech", "behavior", "emotion")
BASE_LAYER = "ctrl"
_SHORT = {"ctrl": "c", "speech": "s", "behavior": "b", "emotion": "e"}


def _sum(layer_values: Mapping[str, Mapping[str, float]], control: str, default: float) -> float:
    total = 0.0
    for layer in LAYERS:
        values = layer_values.get(layer)
        if values is None:
            if layer == BASE_LAYER:
                total += default
            continue
        value = values.get(control)
        if value is None:
            value = default if layer == BASE_LAYER else 0.0
        total += float(value)
    return total


def mix(layer_values: Mapping[str, Mapping[str, float]], specs: Mapping[str, ControlSpec]) -> dict[str, float]:
    """The value of every control of ``specs``: the sum over the layers in :data:`LAYERS` order, clamped to
    the control's range. A control missing from the ``ctrl`` layer counts with its default, missing from
    another layer with 0. Unknown layers or control names, and values that are not finite numbers, are
    refused (a typo must not silently do nothing)."""
    for layer, values in layer_values.items():
        if layer not in LAYERS:
            raise UserError(f"unknown control layer {layer!r}; use one of {', '.join(LAYERS)}")
        unknown = [name for name in values if name not in specs]
        if unknown:
            raise UserError(f"unknown control {unknown[0]!r} in the {layer} layer")
        bad = [name for name, value in values.items() if not _finite(value)]
        if bad:
            raise UserError(f"control {bad[0]!r} in the {layer} layer needs a finite number, got {values[bad[0]]!r}")
    return {name: min(max(_sum(layer_values, name, spec.default), spec.minimum), spec.maximum)
            for name, spec in specs.items()}


def _finite(value) -> bool:
    try:
        return math.isfinite(float(value))
    except (TypeError, ValueError):
        return False


def weighted_sum(terms: Sequence[tuple[str, float]], values: Mapping[str, float], low: float = 0.0,
                 high: float = 1.0) -> float:
    """``clamp(sum of weight * value(control), low, high)`` over already mixed control ``values``."""
    total = 0.0
    for control, weight in terms:
        total += float(weight) * float(values.get(control, 0.0))
    return min(max(total, low), high)


@dataclass
class LayerTable:
    """Layer values sampled at a run of frames: ``values[layer]`` is (F, C) over ``controls``; a bake walks
    it frame by frame (:meth:`at`) without asking Blender anything."""
    frames: np.ndarray
    controls: tuple[str, ...]
    values: dict[str, np.ndarray]

    def __post_init__(self) -> None:
        for layer, table in self.values.items():
            if layer not in LAYERS:
                raise ValueError(f"unknown control layer {layer!r}")
            if table.shape != (len(self.frames), len(self.controls)):
                raise ValueError(f"layer {layer}: shape {table.shape} does not match the frames and controls")

    def __len__(self) -> int:
        return len(self.frames)

    def at(self, index: int) -> dict[str, dict[str, float]]:
        """The layer values of frame ``index`` (a position in :attr:`frames`)."""
        return {layer: dict(zip(self.controls, table[index].tolist())) for layer, table in self.values.items()}


@dataclass(frozen=True)
class DriverExpression:
    """A Blender driver for a value mixed from control layers: ``expression`` refers to ``variables``
    (name, control, layer); each variable reads the layer property of that control."""
    expression: str
    variables: tuple[tuple[str, str, str], ...]


def _number(value: float) -> str:
    return repr(float(value))


def _clamped_sum(control: str, spec: ControlSpec, index: int, available: set[str] | None):
    """The expression of one control's mixed value and its variables (layers without a property are left
    out; a missing ``ctrl`` property contributes the default)."""
    names, variables = [], []
    for layer in LAYERS:
        if available is not None and (control, layer) not in available:
            if layer == BASE_LAYER and spec.default:
                names.append(_number(spec.default))
            continue
        name = f"{_SHORT[layer]}{index}"
        names.append(name)
        variables.append((name, control, layer))
    total = " + ".join(names) or "0.0"
    return f"min(max({total}, {_number(spec.minimum)}), {_number(spec.maximum)})", variables


def control_driver(control: str, spec: ControlSpec, scale: float = 1.0,
                   available: set[tuple[str, str]] | None = None) -> DriverExpression:
    """The driver of a shape key baked at ``scale`` times one unit of ``control`` (a muscle-basis key baked
    at the control's full value): ``mix(control) / scale``. ``available`` = the (control, layer) pairs that
    exist as properties (None: all)."""
    expression, variables = _clamped_sum(control, spec, 0, available)
    if scale != 1.0:
        expression = f"{expression} / {_number(scale)}"
    return DriverExpression(expression, tuple(variables))


def weighted_driver(terms: Sequence[tuple[str, float]], specs: Mapping[str, ControlSpec], low: float = 0.0,
                    high: float = 1.0, available: set[tuple[str, str]] | None = None) -> DriverExpression:
    """The driver of :func:`weighted_sum` over mixed controls (e.g. a wrinkle's strength, 3.1.2)."""
    parts, variables = [], []
    for index, (control, weight) in enumerate(terms):
        expression, found = _clamped_sum(control, specs[control], index, available)
        parts.append(f"{_number(weight)} * {expression}")
        variables += found
    return DriverExpression(f"min(max({' + '.join(parts) or '0.0'}, {_number(low)}), {_number(high)})",
                            tuple(variables))
