"""The thesis' identities, numerically (3.2.1-3.2.3): PCA reproduces the examples, adding N/||w||^2 ds_A
raises f by exactly 1, Eq. 3.7 equals the explicit C^-1 product, constraints hold to 1e-9 while other
attributes change, segment-restricted edits stay in their blend zone, feature import copies exactly."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.morph import build, editing, segments


def _grid(nx=8, nz=6):
    xs, zs = np.meshgrid(np.linspace(-0.07, 0.07, nx), np.linspace(-0.09, 0.09, nz))
    vertices = np.stack([xs.ravel(), np.zeros(xs.size), zs.ravel()], axis=1)
    faces = []
    for j in range(nz - 1):
        for i in range(nx - 1):
            a = j * nx + i
            faces += [[a, a + 1, a + nx + 1], [a, a + nx + 1, a + nx]]
    return vertices, np.array(faces)


def _examples(count, vertices, seed=0):
    rng = np.random.default_rng(seed)
    return vertices[None] + 0.004 * rng.standard_normal((count, *vertices.shape))


def _model(count=15, seed=0, with_colour=True, segments_from=None):
    vertices, faces = _grid()
    shapes = _examples(count, vertices, seed)
    colours = 0.5 + 0.1 * np.random.default_rng(seed + 1).standard_normal(shapes.shape) if with_colour else None
    labels = {"a": shapes[:, 0, 0] + shapes[:, 5, 2], "b": shapes[:, 10, 1] - shapes[:, 3, 0],
              "c": np.random.default_rng(seed + 2).standard_normal(count)}
    extra = {}
    if segments_from is not None:
        extra["segments"] = segments_from(vertices)
    return build.build_model("test", shapes, faces, colours, labels=labels, **extra), shapes, colours


def test_pca_reproduces_the_examples_and_is_orthonormal():
    model, shapes, colours = _model()
    assert model.shape.components == len(shapes) - 1                      # 0 < i < N (3.2.1)
    basis = model.shape.basis
    assert np.abs(basis.T @ basis - np.eye(basis.shape[1])).max() < 1e-12
    for k in (0, 7):
        rebuilt = model.shape.vector(model.examples["shape"][k]).reshape(-1, 3)
        assert np.abs(rebuilt - shapes[k]).max() < 1e-12
    centred = shapes.reshape(len(shapes), -1) - shapes.reshape(len(shapes), -1).mean(0)
    covariance = centred.T @ centred / len(shapes)                         # Eq. 3.1
    assert np.allclose(covariance @ basis, basis * model.shape.sd ** 2, atol=1e-15)   # Eq. 3.2


def test_adding_n_over_w_squared_raises_f_by_exactly_one():
    model, shapes, _ = _model()
    count = len(shapes)
    weights = model.attributes["a"]
    raw = shapes[:, 0, 0] + shapes[:, 5, 2]
    w = (raw - raw.mean()) / raw.std()                                     # the centred, scaled ratings
    ds_a = (shapes.reshape(count, -1) - shapes.reshape(count, -1).mean(0)).T @ w / count   # Eq. 3.4
    assert np.abs(model.shape.project(ds_a) - weights.shape).max() < 1e-15
    face = editing.EditFace(model)
    face.create("random", seed=3)
    before = face.value("a")
    step = count / (w @ w) * model.shape.project(ds_a)
    after = float(model.shape.mahalanobis(face.alpha + step, weights.shape))
    assert abs(after - before - 1.0) < 1e-9
    assert np.abs(face.unit_direction("a", "shape") - step).max() < 1e-9 * np.abs(step).max()
    face.set_attribute("a", 0.7)
    assert abs(face.value("a") - before - 0.7) < 1e-9


def test_mahalanobis_through_eq_3_7_equals_the_explicit_inverse():
    vertices, faces = _grid(2, 2)                                          # 12 dimensions, 40 examples
    shapes = _examples(40, vertices, seed=5)
    model = build.build_model("small", shapes, faces)
    assert model.shape.components == 12
    centred = shapes.reshape(40, -1) - shapes.reshape(40, -1).mean(0)
    inverse = np.linalg.inv(centred.T @ centred / 40)                      # C^-1, formed explicitly
    rng = np.random.default_rng(1)
    a, b = 0.003 * rng.standard_normal((2, 12))
    explicit = a @ inverse @ b
    factored = model.shape.mahalanobis(model.shape.project(a), model.shape.project(b))
    assert abs(factored - explicit) < 1e-9 * abs(explicit)


def test_constraints_keep_their_values_while_others_change():
    model, _, _ = _model()
    face = editing.EditFace(model)
    face.create("random", seed=1)
    face.set_attribute("a", 1.2)
    face.constrain("a", part="both")
    kept = face.value("a"), face.value("a", "colour")
    before_c = face.value("c")
    face.set_attribute("b", -1.5, part="both")
    face.set_attribute("c", 2.0)
    face.caricature(1.4)
    assert abs(face.value("a") - kept[0]) < 1e-9 and abs(face.value("a", "colour") - kept[1]) < 1e-9
    assert abs(face.value("c") - before_c) > 0.5
    released = editing.EditFace(model)
    released.create("random", seed=1)
    released.set_attribute("a", 1.2)
    released.set_attribute("b", -1.5)
    assert abs(released.value("a") - kept[0]) > 1e-3, "the attributes must be correlated for this test"


def test_coefficients_and_vertices_stay_in_sync_and_state_replays():
    model, _, _ = _model()
    face = editing.EditFace(model)
    face.create("example", index=2)
    face.set_attribute("a", 0.5)
    face.set_attribute("a", -0.25)                     # one slider drag: one history entry
    face.constrain("b")
    face.set_attribute("c", 1.0, part="colour")
    assert len(face.history) == 4
    assert np.abs(model.shape.vector(face.alpha).reshape(-1, 3) - face.shape).max() < 1e-12
    assert np.abs(model.colour.vector(face.beta).reshape(-1, 3) - face.colour).max() < 1e-12
    again = editing.face_from_state(model, face.state())
    assert np.abs(again.shape - face.shape).max() < 1e-12 and np.abs(again.colour - face.colour).max() < 1e-12
    twice = editing.face_from_state(model, face.state())
    assert twice.shape.tobytes() == again.shape.tobytes()                  # same state, same bytes
    face.undo()
    assert len(face.history) == 3
    with pytest.raises(UserError, match="saved with model"):
        other, _, _ = _model(seed=9)
        editing.face_from_state(other, again.state())


def _halves(vertices):
    left = vertices[:, 0] < -0.03
    return {"face": np.ones(len(vertices), bool), "left": left, "right": ~left}


def test_segment_edits_stay_inside_the_blend_zone_and_import_copies_exactly():
    model, shapes, _ = _model(segments_from=_halves)
    face = editing.EditFace(model)
    face.create("random", seed=4)
    start = face.shape.copy()
    face.set_attribute("a", 2.0, segments=["left"])
    zone = face.blender.zone(model.segments["left"])
    assert not zone.all() and zone[model.segments["left"]].all()
    assert np.array_equal(face.shape[~zone], start[~zone])                 # bit for bit outside
    assert np.abs(face.shape[model.segments["left"]] - start[model.segments["left"]]).max() > 1e-4
    face.import_feature(6, ["left"], part="both")
    inside = model.segments["left"]
    example = model.shape.vector(model.examples["shape"][6]).reshape(-1, 3)
    assert np.abs(face.shape[inside] - example[inside]).max() < 1e-15
    colour = model.colour.vector(model.examples["colour"][6]).reshape(-1, 3)
    assert np.abs(face.colour[inside] - colour[inside]).max() < 1e-15
    assert np.array_equal(face.shape[~zone], start[~zone])


def test_blend_is_smooth_and_affine_moves_a_segment():
    vertices, faces = _grid(12, 10)
    blender = segments.SegmentBlender(vertices, faces, levels=2)
    mask = vertices[:, 0] > 0.0
    blended = blender.blend(np.ones((len(vertices), 3)), mask)[:, 0]
    assert blended[mask].min() == 1.0 and blender.rings == 3
    assert 0.0 < blended[~mask].max() < 1.0
    model, _, _ = _model(segments_from=_halves)
    face = editing.EditFace(model)
    matrix = np.eye(4)
    matrix[:3, 3] = (0.0, 0.0, 0.01)
    face.transform(matrix, ["left"])
    inside = model.segments["left"]
    assert np.allclose(face.shape[inside] - model.mean_vertices()[inside], (0.0, 0.0, 0.01), atol=1e-15)


def test_bad_operations_are_refused():
    model, _, _ = _model()
    face = editing.EditFace(model)
    for call, message in ((lambda: face.set_attribute("a", float("nan")), "out of range"),
                          (lambda: face.set_attribute("zz", 1.0), "no attribute"),
                          (lambda: face.set_attribute("a", 1e6), "out of range"),
                          (lambda: face.caricature(0.0), "at least"),
                          (lambda: face.import_feature(99, ["face"]), "does not exist"),
                          (lambda: face.transform(np.zeros((4, 4))), "collapses"),
                          (lambda: face.set_attribute("a", 1.0, segments=["nose"]), "unknown segment")):
        before = face.shape.copy()
        with pytest.raises(UserError, match=message):
            call()
        assert np.array_equal(face.shape, before)


def test_build_refuses_mixed_topology_and_nan():
    vertices, faces = _grid()
    with pytest.raises(UserError, match="same number of vertices"):
        build.build_model("x", [vertices, vertices, vertices[:-1]], faces)
    bad = _examples(5, vertices)
    bad[2, 3, 1] = np.nan
    with pytest.raises(UserError, match="example meshes 2 has NaN"):
        build.build_model("x", bad, faces)


def test_labels_csv_rules():
    names = ["a", "b", "c"]
    labels, rows = build.read_labels_csv("name,sex,age,pop\na,male,30,x\nb,female,41,y\nc,male,25,z\n", names)
    assert labels["female-male"].tolist() == [1.0, -1.0, 1.0] and labels["age"].tolist() == [30, 41, 25]
    assert labels["y"].tolist() == [0.0, 1.0, 0.0] and rows[1]["sex"] == "female"
    with pytest.raises(UserError, match="no row for 1 example"):
        build.read_labels_csv("name,age\na,3\nb,4\n", names)
    with pytest.raises(UserError, match="is empty for b"):
        build.read_labels_csv("name,age\na,3\nb,\nc,4\n", names)
    with pytest.raises(UserError, match="NaN"):
        build.read_labels_csv("name,age\na,3\nb,nan\nc,4\n", names)


def test_constraints_applied_to_the_database_adapt_every_example():
    model, _, _ = _model()
    face = editing.EditFace(model)
    face.set_attribute("a", 1.5, part="both")
    face.constrain("a", part="both", database=True)
    target = face.value("a"), face.value("a", "colour")
    for part, value in zip(("shape", "colour"), target):
        values = model.part(part).mahalanobis(face.database[part], model.attributes["a"].vector(part))
        assert np.abs(values - value).max() < 1e-9                       # Fig. 5.8: every example adapted
    assert not np.array_equal(face.database["shape"], model.examples["shape"])
    face.import_feature(3, ["face"], part="shape")
    assert abs(face.value("a") - target[0]) < 1e-9
