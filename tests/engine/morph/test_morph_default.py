"""The default model (synthetic population, presets/morph): deterministic, Table 5.2 attributes present, the
Fig. 3.8 experiment (masculine, then higher eyebrows: less masculine without the constraint, unchanged with
it), a Fig. 5.3 correlation (a wider mouth widens the nose), segments of Table 5.1."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.core.errors import UserError
from faces_hands_addon.morph import editing, population

MASC, BROWS = "masculine-feminine", "eyebrows-eyes distance"


def test_default_model_is_deterministic_and_complete():
    model = population.default_model()
    again = population.sample_population(count=None)[1]
    assert np.array_equal(again.reshape(len(again), -1).mean(0), model.shape.mean)
    for name in (MASC, BROWS, "slender-obese", "dark-light skin", "younger-older", "narrow-wide", "Asian"):
        assert name in model.attributes
    assert model.landmarks is not None and len(model.landmarks) == 468
    for segment in ("nose", "nose tip", "mouth", "upper lip", "eyebrows", "chin", "forehead"):
        assert model.segments[segment].any()
    assert not model.segments["ears"].any()


def test_fig_3_8_masculinity_with_and_without_constraint():
    model = population.default_model()
    free, kept = editing.EditFace(model), editing.EditFace(model)
    for face in (free, kept):
        face.set_attribute(MASC, -1.5, "shape")
    masculine = free.value(MASC)
    kept.constrain(MASC, "shape")
    for face in (free, kept):
        face.set_attribute(BROWS, 1.5, "shape")
    assert free.value(MASC) - masculine > 0.2                 # measurably less masculine
    assert abs(kept.value(MASC) - masculine) < 1e-9           # unchanged
    assert kept.value(BROWS) > 0.3                            # and the eyebrows did go up


def test_fig_5_3_wider_mouth_brings_a_wider_nose():
    model = population.default_model()
    face = editing.EditFace(model)
    width = lambda f: float(np.linalg.norm(f.shape[129] - f.shape[358]))     # al-al
    base = width(face)
    face.set_attribute("narrow-wide", 2.0, "shape")
    assert width(face) > base + 1e-4


def test_a_broken_user_preset_is_refused_by_name(tmp_path):
    from faces_hands_addon import UserError
    from faces_hands_addon.core import presets
    import pytest
    shipped = (presets.SHIPPED_FOLDER / "morph" / "segments.json").read_text(encoding="utf-8")
    (tmp_path / "morph").mkdir()
    (tmp_path / "morph" / "segments.json").write_text(shipped.replace('"nose tip": [4, 1, 19]', '"nose tip": [4, 1, 9999]'))
    before = presets.user_folder()
    presets.set_user_folder(tmp_path)
    try:
        with pytest.raises(UserError, match="segments.json: seeds of 'nose tip' index vertices outside"):
            population.sample_population(count=10)
    finally:
        presets.set_user_folder(before)


def test_setting_an_attribute_value_is_absolute():
    """``--set A=v`` leaves the face with ``f_A = v`` whatever it started from (a random face, a segment,
    another attribute held by a constraint): on main it added v to the random face's own value."""
    model = population.default_model()
    face = editing.EditFace(model)
    face.create("random", seed=11)
    assert abs(face.value(MASC)) > 0.1                       # the random face has a value of its own
    face.set_attribute_value(MASC, 0.0)
    assert abs(face.value(MASC)) < 1e-9 and abs(face.value(MASC, "colour")) < 1e-9
    face.set_attribute_value(MASC, 0.7, "shape", ["mouth"])
    assert abs(face.value(MASC) - 0.7) < 1e-9
    face.constrain(BROWS, "shape")
    brows = face.value(BROWS)
    face.set_attribute_value(MASC, -0.4, "shape")
    assert abs(face.value(MASC) + 0.4) < 1e-9 and abs(face.value(BROWS) - brows) < 1e-9
    replayed = editing.face_from_state(model, face.state())
    assert np.allclose(replayed.alpha, face.alpha)
    face.constrain(MASC, "shape")
    with pytest.raises(UserError, match="constraints hold"):
        face.set_attribute_value(MASC, 1.0, "shape")
