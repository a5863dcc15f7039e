"""A take flows one way: the command line bakes the engine take it built, the UI bakes the take the rig object
holds (the same object, stored when the take was put on the rig), and both give the same table and the same
GLB bytes; once the artist edits a layer's keys, the UI's take holds what those F-curves play and nothing else
changes."""
from __future__ import annotations

import numpy as np

from conftest import addon_module

TEXT = "Bob is happy :-)"
FPS = 30


def _performed(bpy):
    from faces_hands_addon.performance import perform
    from faces_hands_addon.speech.takes import take_from_text
    take = take_from_text(TEXT, fps=FPS, target="muscles")
    return perform(take, style="expressive", seed=3, emotion="joy")


def _rig_with_take(bpy, performed):
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = FPS, 1.0
    scene.frame_start, scene.frame_end = 0, int(np.ceil(performed.duration * FPS))
    assert bpy.ops.faces_hands.build_face_rig() == {"FINISHED"}
    rig = bpy.context.active_object
    addon_module("operators.speech.apply").apply_take(scene, rig, performed, start_frame=0, add_sound=False)
    return rig


def _tables(rig, scene, engine_take):
    takes = addon_module("operators.adapters.takes")
    specs = addon_module("operators.adapters.rig_store").get_rig(rig).control_specs()
    frames = range(scene.frame_start, scene.frame_end + 1)
    stored, start = takes.take_for_bake(rig, scene, specs)
    return engine_take.table(specs, frames, FPS, 0), stored.table(specs, frames, FPS, start), specs


def test_cli_and_ui_routes_bake_the_same_table_and_the_same_bytes(bpy_clean, tmp_path):
    bpy = bpy_clean
    from faces_hands_addon.performance import take_of
    performed = _performed(bpy)
    rig = _rig_with_take(bpy, performed)
    scene = bpy.context.scene
    engine = take_of(performed)
    cli, ui, _ = _tables(rig, scene, engine)
    assert set(cli.values) == set(ui.values)
    for layer in cli.values:
        assert cli.values[layer].tobytes() == ui.values[layer].tobytes(), f"{layer} differs between the routes"
    assert any(np.ptp(cli.values[layer], axis=0).max() > 0 for layer in ("speech", "behavior", "emotion"))
    face = addon_module("operators.face.services")
    outputs = []
    for route in ("cli", "ui"):
        face.bake(bpy.context, rig, "animation", preset="visemes", take=(engine, 0) if route == "cli" else None)
        path = tmp_path / f"{route}.glb"
        face.export(bpy.context, rig, str(path))
        outputs.append(path.read_bytes())
    assert outputs[0] == outputs[1], "the UI route baked other bytes than the command line"


def test_an_edited_layer_is_read_from_its_curves_and_the_others_stay_the_engine_take(bpy_clean):
    bpy = bpy_clean
    from faces_hands_addon.performance import take_of
    performed = _performed(bpy)
    rig = _rig_with_take(bpy, performed)
    scene = bpy.context.scene
    fcurves = addon_module("operators.adapters.fcurves")
    curve = next(c for c in fcurves.existing_channelbag(rig).fcurves
                 if c.data_path == '["fh.emotion.zygomaticus_major_L"]')
    key = curve.keyframe_points[len(curve.keyframe_points) // 2]
    key.co[1] += 0.25
    curve.update()
    cli, ui, specs = _tables(rig, scene, take_of(performed))
    for layer in ("speech", "behavior", "ctrl"):
        assert cli.values[layer].tobytes() == ui.values[layer].tobytes(), f"{layer} should still be the engine's"
    column = cli.controls.index("zygomaticus_major_L")
    played = np.array([curve.evaluate(float(f)) for f in cli.frames])
    np.testing.assert_allclose(ui.values["emotion"][:, column], played, atol=1e-6)
    assert np.abs(ui.values["emotion"][:, column] - cli.values["emotion"][:, column]).max() > 0.05
