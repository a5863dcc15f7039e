"""The one mixing rule of thesis 4.3.5 (control layers add up, then clamp) and the driver expressions written
from it: on random layer values the live-preview mix, the baked basis driver and the wrinkle strength agree."""
from __future__ import annotations

import ast
import operator

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.anim.layers import (LAYERS, LayerTable, control_driver, mix, weighted_driver,
                                           weighted_sum)
from faces_hands_addon.core.controls import ControlSpec
from faces_hands_addon.face.controls import control_specs
from faces_hands_addon.face.rig import WRINKLE_DRIVERS

MUSCLES = sorted({m for terms in WRINKLE_DRIVERS.values() for m, _ in terms} | {"zygomaticus_major_L"})
SPECS = control_specs(MUSCLES)
_OPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv}


def evaluate(expression: str, variables: dict[str, float]) -> float:
    """Evaluate a driver expression the way Blender's simple-expression evaluator does: numbers, variables,
    + - * /, min and max; anything else is an error (so the expression stays Python-free in Blender)."""
    def walk(node):
        if isinstance(node, ast.Expression):
            return walk(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return float(node.value)
        if isinstance(node, ast.Name):
            return variables[node.id]
        if isinstance(node, ast.BinOp) and type(node.op) in _OPS:
            return _OPS[type(node.op)](walk(node.left), walk(node.right))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            return -walk(node.operand)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("min", "max"):
            return (min if node.func.id == "min" else max)(*(walk(a) for a in node.args))
        raise AssertionError(f"not a simple driver expression: {ast.dump(node)}")
    return walk(ast.parse(expression, mode="eval"))


def _random_layers(rng, specs):
    return {layer: {name: float(rng.uniform(spec.minimum - 0.7, spec.maximum + 0.7)) for name, spec in specs.items()}
            for layer in LAYERS}


def _variables(expression, layers):
    return {name: layers[layer][control] for name, control, layer in expression.variables}


def test_live_mix_basis_driver_and_wrinkle_driver_agree_on_random_layers():
    rng = np.random.default_rng(7)
    specs = dict(SPECS)
    clamped = 0
    for _ in range(300):
        layers = _random_layers(rng, specs)
        live = mix(layers, specs)                                    # what the live preview and bakes use
        for name, spec in specs.items():
            driver = control_driver(name, spec, spec.full_value)     # what a baked basis key is driven by
            value = evaluate(driver.expression, _variables(driver, layers)) * spec.full_value
            assert value == pytest.approx(live[name], abs=1e-9)
            clamped += live[name] in (spec.minimum, spec.maximum)
        for region, terms in WRINKLE_DRIVERS.items():
            driver = weighted_driver(terms, specs)
            assert evaluate(driver.expression, _variables(driver, layers)) == pytest.approx(
                weighted_sum(terms, live), abs=1e-9)
    assert clamped > 100, "the random values never exercised the clamp"


def test_mix_is_the_clamped_sum_in_layer_order_with_the_ctrl_default():
    spec = ControlSpec("jaw_yaw", -1.0, 1.0, 0.25, "jaw", "direct", "")
    assert mix({}, {"jaw_yaw": spec}) == {"jaw_yaw": 0.25}                        # ctrl missing: its default
    assert mix({"speech": {"jaw_yaw": 0.5}}, {"jaw_yaw": spec}) == {"jaw_yaw": 0.75}
    assert mix({"ctrl": {"jaw_yaw": 0.9}, "emotion": {"jaw_yaw": 0.9}}, {"jaw_yaw": spec}) == {"jaw_yaw": 1.0}
    assert mix({"ctrl": {"jaw_yaw": -0.9}, "behavior": {"jaw_yaw": -0.9}}, {"jaw_yaw": spec}) == {"jaw_yaw": -1.0}


@pytest.mark.parametrize("layers, message", [
    ({"speach": {"jaw_open": 1.0}}, "unknown control layer 'speach'"),
    ({"ctrl": {"jaw_opne": 1.0}}, "unknown control 'jaw_opne'"),
    ({"ctrl": {"zygomaticus_major_L": float("nan")}}, "finite number"),
])
def test_mix_refuses_typos_and_non_finite_values(layers, message):
    with pytest.raises(UserError, match=message):
        mix(layers, SPECS)


def test_driver_leaves_out_layers_without_a_property():
    spec = SPECS["procerus"]
    driver = control_driver("procerus", spec, 1.0, available={("procerus", "ctrl"), ("procerus", "speech")})
    assert [layer for _, _, layer in driver.variables] == ["ctrl", "speech"]
    assert evaluate(driver.expression, {"c0": 0.7, "s0": 0.6}) == 1.0


def test_layer_table_walks_frames():
    table = LayerTable(np.array([3, 4]), ("a", "b"), {"ctrl": np.array([[0.1, 0.2], [0.3, 0.4]])})
    assert len(table) == 2 and table.at(1) == {"ctrl": {"a": 0.3, "b": 0.4}}
    with pytest.raises(ValueError):
        LayerTable(np.array([3]), ("a",), {"ctrl": np.zeros((2, 1))})
