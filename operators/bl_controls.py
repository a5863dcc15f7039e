# SPDX-License-Identifier: GPL-3.0-or-later
"""Rig controls as animatable custom properties, in layers that add up.

Every control (a muscle contraction or a direct parameter, names in CONTRIBUTING.md) exists once per
layer on the rig object: ``fh.ctrl.<name>`` is what the artist keys, ``fh.speech.<name>`` what lip sync
writes, ``fh.behavior.<name>`` non-verbal behaviour, ``fh.emotion.<name>`` emotions. The value the face
shows is the sum of the layers, clamped to the control's range, as the thesis combines speech and
emotion "by summing up the respective muscle contraction values" (4.3.5). Re-running lip sync replaces
the speech layer only; the artist's keys on ``fh.ctrl.*`` are never touched.
"""
from __future__ import annotations

LAYERS = ("ctrl", "speech", "behavior", "emotion")


def prop_name(control: str, layer: str = "ctrl") -> str:
    if layer not in LAYERS:
        raise ValueError(f"unknown control layer {layer!r}")
    return f"fh.{layer}.{control}"


def data_path(control: str, layer: str = "ctrl") -> str:
    return f'["{prop_name(control, layer)}"]'


def layer_prefix(layer: str) -> str:
    """Data-path prefix shared by every control of ``layer`` (for replacing a whole take)."""
    return f'["fh.{layer}.'


def ensure_property(obj, control: str, layer: str, low: float, high: float, default: float = 0.0,
                    description: str = "") -> str:
    """Create (or update the UI range of) one control property; returns its name."""
    name = prop_name(control, layer)
    if name not in obj.keys():
        obj[name] = float(default)
    ui = obj.id_properties_ui(name)
    ui.update(min=float(low), max=float(high), soft_min=float(low), soft_max=float(high),
              default=float(default), description=description or control.replace("_", " "),
              subtype="FACTOR" if (low, high) == (0.0, 1.0) else "NONE")
    return name


def effective_values(obj, ranges: dict[str, tuple[float, float]]) -> dict[str, float]:
    """The value each control shows: the sum of its layers, clamped to its range."""
    values = {}
    keys = set(obj.keys())
    for control, (low, high) in ranges.items():
        total = 0.0
        for layer in LAYERS:
            name = prop_name(control, layer)
            if name in keys:
                total += float(obj[name])
        values[control] = min(max(total, low), high)
    return values
