# SPDX-License-Identifier: GPL-3.0-or-later
"""Named expressions as control combinations (``presets/expressions/*.json``): the 52 ARKit blendshapes,
the 15 Oculus/Meta visemes and a few named emotions. An expression is a partial control dict (muscle
contractions and direct parameters, CONTRIBUTING.md); controls it does not name stay at their defaults.

An entry is either ``{control: value, ...}`` or a reference to a mouth shape defined once, in the speech
articulation preset (thesis 3.1.3 targets): ``{"from_speech": "<class>", "controls": {departures}}``, so
the viseme shapes and the lip-sync targets cannot drift apart.
"""
from __future__ import annotations

from pathlib import Path

from ..core.controls import ControlSpec, clamp_controls
from ..core.errors import UserError
from ..core.presets import NUMBER, PresetFormat, preset_names, read_preset, read_preset_file, register_format

__all__ = ["FORMAT", "expression_sets", "load_expressions", "expression_controls"]

FORMAT = register_format(PresetFormat(
    "faces_hands.expressions", 1, required=("expressions",),
    shape={"about": str, "expressions": {str: {str: (NUMBER, str, {str: NUMBER})}}}))
REFERENCE_KEYS = {"from_speech", "controls"}


def expression_sets() -> list[str]:
    """Names of the expression sets (shipped and the user's), e.g. ``["arkit", "named", "visemes"]``."""
    return preset_names("expressions")


def _resolved(source: str, name: str, entry: dict) -> dict[str, float]:
    if "from_speech" not in entry:
        bad = [key for key, value in entry.items() if isinstance(value, (str, dict))]
        if bad:
            raise UserError(f"{source}: expression {name!r}: {bad[0]!r} must be a number (or write "
                            "{\"from_speech\": class, \"controls\": {...}} to start from a speech mouth shape)")
        return {str(control): float(value) for control, value in entry.items()}
    unknown = set(entry) - REFERENCE_KEYS
    if unknown:
        raise UserError(f"{source}: expression {name!r} starts from a speech class and may only add "
                        f"\"controls\"; remove {sorted(unknown)}")
    from ..speech.articulation import class_controls
    controls = class_controls(str(entry["from_speech"]))
    controls.update({str(c): float(v) for c, v in (entry.get("controls") or {}).items()})
    return controls


def load_expressions(name_or_path: str | Path) -> dict[str, dict[str, float]]:
    """Expressions of a set (``"arkit"``, ``"visemes"``, ``"named"``; the user's override if there is one)
    or of a JSON file, in file order."""
    if Path(name_or_path).suffix:
        doc, source = read_preset_file(name_or_path, FORMAT.name)
    elif str(name_or_path) in expression_sets():
        doc, source = read_preset(f"expressions/{name_or_path}.json", FORMAT.name)
    else:
        raise UserError(f"expression set {name_or_path!r} not found; choose one of {expression_sets()}")
    return {str(name): _resolved(source, str(name), entry) for name, entry in doc["expressions"].items()}


def expression_controls(expression: dict[str, float], specs: dict[str, ControlSpec]) -> dict[str, float]:
    """Every control of a rig for ``expression``: defaults, overridden by the (clamped) expression values."""
    values = {name: spec.default for name, spec in specs.items()}
    values.update(clamp_controls(expression, specs, strict=True))
    return values
