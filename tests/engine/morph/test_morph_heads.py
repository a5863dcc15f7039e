"""The morphable model of whole heads on the character's topology (morph/heads.py, the shipped
assets/morph/mpfb2_heads.npz): what the file holds, absolute attribute values, a constraint kept through
other edits (Eqs. 3.5-3.6), caricature inside the Mahalanobis radius without folds (3.2.2), measures that
the sliders move, a model of another topology refused, the head written into the character."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.core.errors import UserError
from faces_hands_addon.morph import heads, population
from faces_hands_addon.morph.editing import EditFace
from faces_hands_addon.morph.model import save_model

MASC = "masculine-feminine"


@pytest.fixture(scope="module")
def model():
    return heads.head_model()


def test_the_shipped_model_is_the_character_head_and_small(model):
    info = model.info
    assert info["topology"] == heads.TOPOLOGY and model.vertex_count == len(set(info["base_ids"])) > 4000
    assert len(model.example_names) == info["examples_total"] - info["held_out"] >= 200     # held out: never in
    assert model.shape.components >= info["components_95"] and info["variance_kept"] >= 0.95
    assert heads.HEAD_MODEL_FILE.stat().st_size < 4_000_000
    categories = {a.category for a in model.attributes.values()}
    assert categories <= {"overall", "face shape", "eyes", "nose", "mouth", "ears"} and len(categories) == 6
    for part in ("eye_L", "eye_R", "teeth_upper", "tongue"):
        assert len(info["parts"][part]) > 10
    measured = heads.measures(model.mean_vertices(), model)
    assert 100 < measured["face_width"] < 160 and 50 < measured["eye_distance"] < 70
    assert measured["face_height"] < measured["head_height"] and abs(measured["fullness"]) < 1e-9


def test_set_is_absolute_on_the_head_model(model):
    face = EditFace(model)
    face.create("random", seed=11)
    assert abs(face.value(MASC)) > 0.05                     # the random face does not start there
    face.set_attribute_value(MASC, 0.0, "shape")
    assert abs(face.value(MASC)) < 1e-9
    face.set_attribute_value("thin-full lips", 0.7, "shape")        # a segment-restricted attribute
    assert abs(face.value("thin-full lips") - 0.7) < 1e-9
    face.set_attribute_value("thin-full lips", 0.7, "shape")        # again: stays (absolute, not added)
    assert abs(face.value("thin-full lips") - 0.7) < 1e-9


def test_a_locked_attribute_is_kept_through_five_other_edits(model):
    face = EditFace(model)
    face.create("random", seed=4)
    face.set_attribute_value(MASC, 1.2, "shape")
    face.constrain(MASC, "shape")
    free = EditFace(model)
    free.create("random", seed=4)
    free.set_attribute_value(MASC, 1.2, "shape")
    edits = [("set_attribute", ("short-long nose", 1.5)), ("set_attribute", ("narrow-wide jaw", -1.5)),
             ("set_attribute", ("younger-older", 2.0)), ("set_attribute", ("receding-protruding chin", 1.0)),
             ("caricature", (1.3,))]
    for method, args in edits:
        getattr(face, method)(*args)
        getattr(free, method)(*args)
        assert abs(face.value(MASC) - 1.2) < 1e-9
    assert abs(free.value(MASC) - 1.2) > 0.05               # the edits do move it without the lock


def test_the_neck_cut_never_moves(model):
    """The examples are blended into the unchanged body at the neck, so no face moves the cut ring."""
    mean = model.mean_vertices()
    skin = np.setdiff1d(np.arange(model.vertex_count), np.concatenate(list(model.info["parts"].values())))
    ring = skin[mean[skin, 2] < mean[skin, 2].min() + 0.002]
    assert len(ring) >= 12
    face = EditFace(model)
    face.create("random", seed=9, scale=2.0)
    face.set_attribute("slender-obese", 2.0)
    assert np.abs(face.shape[ring] - mean[ring]).max() < 1e-6
    assert np.abs(face.shape - mean).max() > 0.005


def test_caricature_stays_in_the_radius_without_folds(model):
    radius = heads.mahalanobis_radius(model)
    for seed in (1, 3, 7):
        face = EditFace(model)
        face.create("random", seed=seed)
        start = face.shape.copy()
        face.caricature(5.0)
        assert np.linalg.norm(face.alpha / model.shape.sd) <= radius * (1 + 1e-9)
        assert heads.folded_triangles(face.shape, start, model.triangles) == 0
        assert face.caricature_level() > 1.0
    unbounded = heads.head_model.__wrapped__(None)          # the same model without its range: folds
    del unbounded.info["mahalanobis_radius"]
    face = EditFace(unbounded)
    face.create("random", seed=3)
    start = face.shape.copy()
    face.caricature(5.0)
    assert heads.folded_triangles(face.shape, start, model.triangles) > 0


@pytest.mark.parametrize("name", ["narrow-wide jaw", "short-long nose", "thin-full lips", "small-large ears",
                                  "slender-obese", "masculine-feminine"])
def test_a_slider_moves_its_measure(model, name):
    entry = model.info["attributes"][name]
    face = EditFace(model)
    offset, _ = face.direction(name, "shape")
    head = model.shape.vector(model.examples["shape"][5]).reshape(-1, 3)
    values = [heads.measures(head + t * offset, model)[entry["measure"]] for t in (-2, -1, 0, 1, 2)]
    assert np.all(entry["sign"] * np.diff(values) > 0), values


def test_a_model_of_another_topology_is_refused(tmp_path, model):
    mask = tmp_path / "mask.npz"
    save_model(population.default_model(), mask)
    with pytest.raises(UserError, match="topology"):
        heads.head_model(str(mask))
    broken = heads.head_model.__wrapped__(None)
    broken.info["base_ids"] = broken.info["base_ids"][:-1]
    path = tmp_path / "short.npz"
    save_model(broken, path)
    with pytest.raises(UserError, match="vertex ids"):
        heads.head_model(str(path))
    with pytest.raises(UserError, match="missing"):
        heads.head_model(str(tmp_path / "none.npz"))


def test_the_head_is_written_into_the_character(model):
    from faces_hands_addon.character.body import character_mesh
    mesh = character_mesh()
    face = EditFace(model)
    face.create("random", seed=2)
    out = heads.character_vertices(model, mesh.base_index, mesh.vertices, face.shape)
    ids = np.asarray(model.info["base_ids"])
    kept, local = mesh.local_ids(ids)
    assert kept.all() and np.allclose(out[local], face.shape)
    rest = np.setdiff1d(np.arange(len(mesh.vertices)), local)
    assert np.array_equal(out[rest], mesh.vertices[rest])
    with pytest.raises(UserError, match="lacks"):
        heads.character_vertices(model, mesh.base_index[:100], mesh.vertices[:100], face.shape)
