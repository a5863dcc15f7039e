# SPDX-License-Identifier: GPL-3.0-or-later
"""Rig controls as animatable custom properties, one per control and layer, and the mixing rule written
into Blender as drivers.

Every control exists once per layer of :data:`LAYERS` on the rig object: ``fh.ctrl.<name>`` is what the
artist keys, ``fh.speech.<name>`` what lip sync writes, ``fh.behavior.<name>`` non-verbal behaviour,
``fh.emotion.<name>`` emotions. What the rig shows is the engine's :func:`mix` of them (thesis 4.3.5):
the live preview and bakes read the layers here and mix in the engine; drivers use the expressions of
``anim.layers``, so all of them agree. Re-running lip sync replaces the speech layer only; the artist's keys
on ``fh.ctrl.*`` are never touched.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from ...faces_hands_addon.anim.layers import BASE_LAYER, LAYERS, DriverExpression, LayerTable
from ...faces_hands_addon.core.controls import ControlSpec
from ...faces_hands_addon.core.errors import UserError
from . import fcurves
from ...names import CONTROL_PREFIX, control_property
from ...names import layer_prefix as names_layer_prefix

__all__ = ["LAYERS", "prop_name", "data_path", "layer_prefix", "ensure_property", "ensure_controls",
           "reset_controls", "layer_values", "available_layers", "sample_layers", "add_mixed_driver",
           "curves_evaluate_exactly"]


def prop_name(control: str, layer: str = BASE_LAYER) -> str:
    if layer not in LAYERS:
        raise ValueError(f"unknown control layer {layer!r}")
    return control_property(control, layer)


def data_path(control: str, layer: str = BASE_LAYER) -> str:
    return f'["{prop_name(control, layer)}"]'


def layer_prefix(layer: str) -> str:
    """Data-path prefix shared by every control of ``layer`` (for replacing a whole take)."""
    return f'["{names_layer_prefix(layer)}'


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def ensure_property(obj, control: str, layer: str, low: float, high: float, default: float = 0.0,
                    description: str = "") -> str:
    """Create (or update the UI range of) one control property; returns its name."""
    name = prop_name(control, layer)
    if name not in obj.keys():
        obj[name] = float(default)
    ui = obj.id_properties_ui(name)
    ui.update(min=float(low), max=float(high), soft_min=float(low), soft_max=float(high),
              default=float(default), description=_one_line(description or control.replace("_", " ")),
              subtype="FACTOR" if (low, high) == (0.0, 1.0) else "NONE")
    return name


def ensure_controls(obj, specs: Mapping[str, ControlSpec]) -> None:
    """Every control in every layer (``ctrl`` at its default, the other layers at 0), so drivers and
    F-curves can always refer to them."""
    for layer in LAYERS:
        for name, spec in specs.items():
            base = layer == BASE_LAYER
            ensure_property(obj, name, layer, spec.minimum, spec.maximum, spec.default if base else 0.0,
                            spec.description if base else f"{layer} layer of {name} (added to the control)")


def reset_controls(obj, specs: Mapping[str, ControlSpec]) -> None:
    """The artist's layer back to the defaults (the other layers belong to takes)."""
    for name, spec in specs.items():
        key = prop_name(name, BASE_LAYER)
        if key in obj.keys():
            obj[key] = float(spec.default)


def control_number(obj, name: str) -> float:
    """The number a control property holds; a UserError when a script or the UI gave it text or a list."""
    value = obj[name]
    try:
        return float(value)
    except (TypeError, ValueError):
        raise UserError(f"'{obj.name}' property {name!r} is {value!r}, not a number; set it to a number "
                        "(Object Properties > Custom Properties)") from None


def layer_values(obj, controls) -> dict[str, dict[str, float]]:
    """The layer properties of ``controls`` as they are now (animated at the current frame)."""
    keys = set(obj.keys())
    out = {}
    for layer in LAYERS:
        values = {}
        for control in controls:
            name = prop_name(control, layer)
            if name in keys:
                values[control] = control_number(obj, name)
        out[layer] = values
    return out


def available_layers(obj, controls) -> set[tuple[str, str]]:
    """The (control, layer) pairs that exist as properties on ``obj`` (what a driver can read)."""
    keys = set(obj.keys())
    return {(c, layer) for c in controls for layer in LAYERS if prop_name(c, layer) in keys}


def curves_evaluate_exactly(obj, scene) -> bool:
    """Can the layer F-curves be evaluated directly (the same numbers a frame change would give)? Only with
    one plain action: no NLA, full influence, replace mode, no time remapping, no drivers on the layers."""
    anim = obj.animation_data
    if anim is None:
        return True
    if len(anim.nla_tracks) or getattr(anim, "action_influence", 1.0) != 1.0:
        return False
    if getattr(anim, "action_blend_type", "REPLACE") != "REPLACE":
        return False
    if scene.render.frame_map_old != scene.render.frame_map_new:
        return False
    if any(d.data_path.startswith(f'["{CONTROL_PREFIX}.') for d in anim.drivers):
        return False
    action = anim.action
    if action is not None:
        layers = list(action.layers)
        if len(layers) > 1 or any(getattr(layer, "influence", 1.0) != 1.0 or
                                  getattr(layer, "mix_mode", "REPLACE") != "REPLACE" for layer in layers):
            return False
    return True


def sample_layers(obj, scene, specs: Mapping[str, ControlSpec], frames, method: str = "auto",
                  lead: float = 0.0, layers=LAYERS) -> LayerTable:
    """``layers`` of every control at ``frames`` as the scene plays them: what the artist's F-curves show,
    for a take filled from them (``takes.take_for_bake``). F-curves are evaluated directly where that gives
    the same values as playing the scene (``method="auto"``); otherwise (NLA, drivers, blending) or with
    ``method="frames"`` each frame is set once and the properties read. ``lead`` (frames, may be
    fractional) gives each row the values that much later."""
    controls = tuple(specs)
    frames = np.asarray(list(frames), dtype=np.int64)
    keys = set(obj.keys())
    values = {}
    for layer in layers:
        table = np.zeros((len(frames), len(controls)))
        for column, control in enumerate(controls):
            name = prop_name(control, layer)
            table[:, column] = control_number(obj, name) if name in keys else (
                specs[control].default if layer == BASE_LAYER else 0.0)
        values[layer] = table
    if method not in ("auto", "frames"):
        raise ValueError(f"unknown sampling method {method!r}")
    if method == "auto" and curves_evaluate_exactly(obj, scene):
        bag = fcurves.existing_channelbag(obj)
        curves = {fc.data_path: fc for fc in (bag.fcurves if bag else []) if fc.array_index == 0 and not fc.mute}
        for layer in layers:
            for column, control in enumerate(controls):
                curve = curves.get(data_path(control, layer))
                if curve is not None:
                    values[layer][:, column] = [curve.evaluate(float(f) + lead) for f in frames]
        return LayerTable(frames, controls, values)
    original = scene.frame_current
    try:
        for row, frame in enumerate(frames):
            at = float(frame) + lead
            scene.frame_set(int(np.floor(at)), subframe=float(at - np.floor(at)))
            current = layer_values(obj, controls)
            for layer in layers:
                for column, control in enumerate(controls):
                    if control in current[layer]:
                        values[layer][row, column] = current[layer][control]
    finally:
        scene.frame_set(original)
    return LayerTable(frames, controls, values)


def add_mixed_driver(owner, path: str, obj, expression: DriverExpression, index: int = -1):
    """Drive ``owner.<path>`` (its element ``index`` of an array property) by ``expression`` over ``obj``'s
    layer properties (replacing a driver there); the expression is a simple one, which Blender evaluates
    without Python."""
    owner.driver_remove(path, index)
    driver = owner.driver_add(path, index).driver
    driver.type = "SCRIPTED"
    for name, control, layer in expression.variables:
        var = driver.variables.new()
        var.name = name
        var.type = "SINGLE_PROP"
        var.targets[0].id_type = "OBJECT"
        var.targets[0].id = obj
        var.targets[0].data_path = data_path(control, layer)
    driver.expression = expression.expression
    return driver
