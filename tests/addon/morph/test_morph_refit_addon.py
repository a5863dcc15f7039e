"""Refit Face Rig through the installed add-on: after the morph head reshaped the character strongly
(masculine-feminine slid to +2), the character's face rig is fitted again to the morphed head and its baked
targets are baked again. Measured on the morphed head as Blender mixes it (basis + morph key + target):
eyeBlinkLeft closes the lids (<= 0.5 mm) and viseme_PP shuts the lips; the artist's key, its value and its
animation are kept; Esc and bad input leave the scene unchanged."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from conftest import addon_module

MASC = "masculine-feminine"
TARGETS = ("jawOpen", "eyeBlinkLeft", "viseme_PP")


@pytest.fixture(scope="module")
def scene(installed):
    """The character (no hand rigs) with three baked targets and an artist's animated key, reshaped by a morph
    head whose masculine-feminine slider is at +2."""
    import bpy
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    assert bpy.ops.faces_hands.add_character(skeleton="game_engine", hands=False) == {"FINISHED"}
    body = bpy.data.objects["FH Character"]
    bake, jobs = addon_module("operators.bases.bake"), addon_module("operators.bases.jobs")
    expressions = addon_module("operators.face.services").expressions("all")
    inputs = bake.bake_inputs(bpy.context, body, animated=False)
    jobs.run_job(bake.BakeJob(inputs, "EXPRESSIONS", {n: expressions[n] for n in TARGETS}), bpy.context)
    artist = body.shape_key_add(name="Artist Key", from_mix=False)
    co = _co(artist)
    co[:200, 0] += 0.01
    artist.points.foreach_set("co", co.ravel())
    for frame, value in ((1, 0.0), (10, 0.3)):
        artist.value = value
        artist.keyframe_insert("value", frame=frame)
    bpy.context.scene.faces_hands_morph.model_path = ""
    assert bpy.ops.faces_hands.morph_new_face(kind="average") == {"FINISHED"}
    head = bpy.context.active_object
    body.select_set(True)
    assert bpy.ops.faces_hands.morph_link_character() == {"FINISHED"}
    assert bpy.ops.faces_hands.morph_set_attribute(name=MASC, part="shape", value=2.0) == {"FINISHED"}
    yield bpy, body, head
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)


def _co(block) -> np.ndarray:
    out = np.empty(len(block.data) * 3, np.float32)
    block.points.foreach_get("co", out)
    return out.reshape(-1, 3).astype(np.float64)


def _mixed(body, name: str) -> np.ndarray:
    """What Blender shows with the morph key and ``name`` at 1 (relative keys over the basis)."""
    keys = body.data.shape_keys.key_blocks
    basis = _co(keys["Basis"])
    return basis + (_co(keys["FH Morph Head"]) - basis) + (_co(keys[name]) - basis)


def _snapshot(body):
    keys = body.data.shape_keys.key_blocks
    return body.get("fh_rig_id"), {block.name: _co(block) for block in keys}


def _fake_modal(bpy, operator_name: str):
    """The operator class, a stand-in operator and context (the bpy module has no window)."""
    cls = getattr(addon_module("operators.morph.operators"), operator_name)
    progress = []
    wm = SimpleNamespace(event_timer_add=lambda step, window=None: object(), event_timer_remove=lambda t: None,
                         modal_handler_add=lambda op: None, progress_begin=lambda a, b: None,
                         progress_update=progress.append, progress_end=lambda: progress.append("end"))
    real = bpy.context
    context = SimpleNamespace(window=object(), window_manager=wm, scene=real.scene,
                              active_object=real.active_object, view_layer=real.view_layer,
                              workspace=SimpleNamespace(status_text_set=lambda text: None))
    fake = SimpleNamespace(report=lambda *a: None, _timer=None, _job=None, time_slice=0.0, targets=True)
    fake.make_job = lambda ctx: cls.make_job(fake, ctx)
    fake._finish_modal = lambda ctx: cls._finish_modal(fake, ctx)
    return cls, fake, context, progress


def test_escape_and_bad_input_leave_the_scene_unchanged(scene):
    bpy, body, head = scene
    before_id, before = _snapshot(body)
    cls, fake, context, progress = _fake_modal(bpy, "FH_OT_morph_refit_character")
    assert cls.invoke(fake, context, SimpleNamespace(type="NONE")) == {"RUNNING_MODAL"}
    for _ in range(2):
        assert cls.modal(fake, context, SimpleNamespace(type="TIMER")) == {"RUNNING_MODAL"}
    assert any(isinstance(p, int) and p > 0 for p in progress), progress
    assert cls.modal(fake, context, SimpleNamespace(type="ESC")) == {"CANCELLED"}
    after_id, after = _snapshot(body)
    assert after_id == before_id and after.keys() == before.keys()
    assert all(np.array_equal(after[name], before[name]) for name in before)
    lonely = head.copy()                          # a morph head that reshapes no character
    del lonely["fh_morph_character"]
    bpy.context.scene.collection.objects.link(lonely)
    bpy.context.view_layer.objects.active = lonely
    with pytest.raises(RuntimeError, match="reshapes no character"):
        bpy.ops.faces_hands.morph_refit_character()
    bpy.data.objects.remove(lonely)
    bpy.context.view_layer.objects.active = head
    assert _snapshot(body)[0] == before_id


def test_refit_blinks_closed_and_presses_the_lips_on_the_morphed_head_and_keeps_the_artists_key(scene):
    bpy, body, head = scene
    rig_store = addon_module("operators.adapters.rig_store")
    audit = addon_module("faces_hands_addon.face.audit_targets")
    keys = body.data.shape_keys.key_blocks
    artist, artist_value = _co(keys["Artist Key"]), keys["Artist Key"].value
    stale = {name: _mixed(body, name) for name in ("eyeBlinkLeft", "viseme_PP")}
    bpy.context.view_layer.objects.active = head
    assert bpy.ops.faces_hands.morph_refit_character() == {"FINISHED"}
    rig = rig_store.get_rig(body, "character")
    assert rig.basis is not None
    np.testing.assert_allclose(_co(keys["FH Morph Head"]), rig.morphed_rest, atol=1e-6)
    expressions = addon_module("operators.face.services").expressions("all")
    report = audit.audit_shapes(rig.face, expressions, ("eyeBlinkLeft", "viseme_PP"))["rows"]
    assert report["eyeBlinkLeft"][0]["gap_L"] <= 0.5
    assert report["viseme_PP"][0]["lip_gap"] <= 0.3 and report["viseme_PP"][1] == []
    for name in ("eyeBlinkLeft", "viseme_PP"):
        # what Blender mixes is the refitted rig's pose on the morphed head (to 0.01 mm), not the old one's
        pose = rig.settled({"ctrl": expressions[name]}).positions["skin"].astype(np.float64)
        on_morph = rig.morphed_rest + (pose - rig.rest_positions)
        assert np.abs(_mixed(body, name) - on_morph).max() < 1e-5, name
        assert np.linalg.norm(stale[name] - on_morph, axis=1).max() > 1e-3, name
    assert np.array_equal(_co(keys["Artist Key"]), artist)
    assert keys["Artist Key"].value == pytest.approx(artist_value)
    curves = body.data.shape_keys.animation_data.action.fcurves if bpy.app.version < (4, 4) else [
        c for layer in body.data.shape_keys.animation_data.action.layers for strip in layer.strips
        for bag in strip.channelbags for c in bag.fcurves]
    artist_curves = [c for c in curves if c.data_path == 'key_blocks["Artist Key"].value']
    assert len(artist_curves) == 1 and len(artist_curves[0].keyframe_points) == 2
    assert body["fh_morph_refit"] == head["fh_morph_state"]          # the panel knows the rig is fitted to it
    assert bpy.ops.faces_hands.morph_set_attribute(name=MASC, part="shape", value=1.0) == {"FINISHED"}
    assert body["fh_morph_refit"] != head["fh_morph_state"]          # another edit: a refit is due again
