"""The mixing rule in Blender (thesis 4.3.5): on random values of every layer property, the live preview's
mix (engine), the baked basis keys' drivers and the wrinkle strength drivers, all evaluated by Blender,
agree; the drivers are simple expressions (no Python needed); bakes sample the layers the same way whether
they read F-curves directly or play the frames."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import addon_module

LAYERS = ("ctrl", "speech", "behavior", "emotion")


@pytest.fixture
def baked_rig(bpy_clean):
    bpy = bpy_clean
    assert bpy.ops.faces_hands.build_face_rig(resolution="default") == {"FINISHED"}
    rig = bpy.context.active_object
    assert bpy.ops.faces_hands.bake_face(mode="BASIS") == {"FINISHED"}
    return bpy, rig


def test_blender_drivers_agree_with_the_engine_mix(baked_rig):
    bpy, rig = baked_rig
    engine = addon_module("operators.adapters.rig_store").get_rig(rig)
    specs = engine.control_specs()
    from faces_hands_addon.anim.layers import mix, weighted_sum
    from faces_hands_addon.face.rig import WRINKLE_DRIVERS
    blocks = rig.data.shape_keys.key_blocks
    material = rig.data.materials[0]
    for block in ("FH.jaw_open", "FH.zygomaticus_major_L"):
        fcurve = rig.data.shape_keys.animation_data.drivers.find(f'key_blocks["{block}"].value')
        assert fcurve is not None and fcurve.driver.is_simple_expression, block
    rng = np.random.default_rng(11)
    worst, clamped = 0.0, 0
    for _ in range(4):
        layers = {layer: {} for layer in LAYERS}
        for name, spec in specs.items():
            for layer in LAYERS:
                value = float(rng.uniform(spec.minimum - 0.6, spec.maximum + 0.6)) / (2 if layer != "ctrl" else 1)
                value = min(max(value, spec.minimum), spec.maximum)      # each property within its own range
                rig[f"fh.{layer}.{name}"] = value
                layers[layer][name] = value
        rig.update_tag()
        depsgraph = bpy.context.evaluated_depsgraph_get()
        depsgraph.update()
        live = mix(layers, specs)
        evaluated = rig.data.shape_keys.evaluated_get(depsgraph).key_blocks
        for name, spec in specs.items():
            value = evaluated[f"FH.{name}"].value * spec.full_value
            worst = max(worst, abs(value - live[name]))
            clamped += live[name] in (spec.minimum, spec.maximum)
        nodes = material.evaluated_get(depsgraph).node_tree.nodes
        for region, terms in WRINKLE_DRIVERS.items():
            strength = nodes[f"FH wrinkle {region}"].outputs[0].default_value
            worst = max(worst, abs(strength - weighted_sum(terms, live)))
    assert worst < 2e-6, f"Blender's drivers differ from the engine's mix by {worst}"   # float32 in Blender
    assert clamped > 20
    assert len(blocks) > 40


def test_wrinkle_drivers_are_simple_expressions(baked_rig):
    _, rig = baked_rig
    drivers = rig.data.materials[0].node_tree.animation_data.drivers
    assert len(drivers) == 3 and all(d.driver.is_simple_expression for d in drivers)


def test_sampled_layers_match_playing_the_frames(bpy_clean):
    bpy = bpy_clean
    bpy.ops.faces_hands.build_face_rig()
    rig = bpy.context.active_object
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 30
    for frame, value in ((1, 0.0), (9, 0.8), (20, 0.1), (30, 0.6)):
        rig["fh.ctrl.jaw_open"] = value
        rig.keyframe_insert('["fh.ctrl.jaw_open"]', frame=frame)
        rig["fh.speech.risorius_L"] = value / 2
        rig.keyframe_insert('["fh.speech.risorius_L"]', frame=frame)
    rig["fh.ctrl.procerus"] = 0.4                                   # set, not animated
    controls = addon_module("operators.adapters.controls")
    specs = addon_module("operators.adapters.rig_store").get_rig(rig).control_specs()
    frames = list(range(1, 31))
    direct = controls.sample_layers(rig, scene, specs, frames)
    scene.frame_set(7)
    played = controls.sample_layers(rig, scene, specs, frames, method="frames")
    assert scene.frame_current == 7, "sampling by playing the frames moved the current frame"
    column = direct.controls.index("jaw_open")
    assert np.ptp(direct.values["ctrl"][:, column]) > 0.5
    assert np.all(direct.values["ctrl"][:, direct.controls.index("procerus")] == pytest.approx(0.4))
    for layer in LAYERS:
        np.testing.assert_array_equal(direct.values[layer], played.values[layer])
