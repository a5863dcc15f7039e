# SPDX-License-Identifier: GPL-3.0-or-later
"""Named expressions as control combinations (``presets/expressions/*.json``): the 52 ARKit blendshapes,
the 15 Oculus/Meta visemes and a few named emotions. An expression is a partial control dict (muscle
contractions and direct parameters, CONTRIBUTING.md); controls it does not name stay at their defaults."""
from __future__ import annotations

import json
from pathlib import Path

from ..errors import UserError
from .controls import ControlSpec, clamp_controls

__all__ = ["EXPRESSIONS_DIR", "expression_sets", "load_expressions", "expression_controls"]

EXPRESSIONS_DIR = Path(__file__).resolve().parents[2] / "presets" / "expressions"


def expression_sets() -> list[str]:
    """Names of the shipped expression sets (file stems), e.g. ``["arkit", "named", "visemes"]``."""
    return sorted(p.stem for p in EXPRESSIONS_DIR.glob("*.json"))


def load_expressions(name_or_path: str | Path) -> dict[str, dict[str, float]]:
    """Expressions of a set (``"arkit"``, ``"visemes"``, ``"named"``) or of a JSON file, in file order."""
    path = Path(name_or_path)
    if not path.suffix:
        path = EXPRESSIONS_DIR / f"{name_or_path}.json"
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        table = doc["expressions"]
        return {str(k): {str(c): float(v) for c, v in d.items()} for k, d in table.items()}
    except OSError:
        raise UserError(f"expression set {name_or_path!r} not found; choose one of {expression_sets()}") from None
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise UserError(f"{path}: malformed expression set ({exc}); each entry maps control names to numbers") from None


def expression_controls(expression: dict[str, float], specs: dict[str, ControlSpec]) -> dict[str, float]:
    """Every control of a rig for ``expression``: defaults, overridden by the (clamped) expression values."""
    values = {name: spec.default for name, spec in specs.items()}
    values.update(clamp_controls(expression, specs, strict=True))
    return values
