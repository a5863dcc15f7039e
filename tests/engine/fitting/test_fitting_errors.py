# SPDX-License-Identifier: GPL-3.0-or-later
"""Landmark location refuses unusable meshes with a UserError that says what to do (CONTRIBUTING.md)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from faces_hands_addon import UserError
from faces_hands_addon.core import geometry
from faces_hands_addon.fitting import locate_landmarks, project_to_surface, testdata

TRIANGLE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


@pytest.fixture(scope="module")
def mask():
    return testdata.remeshed_face(0, spacing=0.006)


@pytest.mark.parametrize("vertices, faces, message", [
    (TRIANGLE, np.zeros((0, 3), np.int64), "no faces"),
    (TRIANGLE, np.array([[0, 1, 2, 0]]), "must be triangles"),
    (TRIANGLE, np.array([[0, 1, 3]]), "outside 0..2"),
    (np.array([[0.0, np.nan, 0.0], [1, 0, 0], [0, 0, 1]]), np.array([[0, 1, 2]]), "NaN"),
    (np.ones((3, 3)), np.array([[0, 1, 2]]), "degenerate"),
    (np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.array([[0, 1, 2]]), "zero area"),
    (np.zeros((3, 2)), np.array([[0, 1, 2]]), "(N, 3)"),
])
def test_bad_meshes(vertices, faces, message):
    with pytest.raises(UserError, match=message.replace("(", r"\(").replace(")", r"\)")):
        locate_landmarks(vertices, faces)
    with pytest.raises(UserError):
        project_to_surface(np.zeros((1, 3)), vertices, faces)


def test_too_large_mesh_names_the_limit(monkeypatch, mask):
    monkeypatch.setattr(geometry, "MAX_VERTICES", 100)
    with pytest.raises(UserError, match="at most 100 vertices"):
        locate_landmarks(mask.vertices, mask.faces)


def test_full_head_facing_plus_y_is_found_and_fitted():
    """Used to be refused with advice to rotate it; now found in its own axes (test_orientation.py)."""
    head = testdata.rotated_head(testdata.full_head(0, spacing=0.008, body_spacing=0.03), "+Y")
    fit = locate_landmarks(head.vertices, head.faces)
    assert fit.orientation["orientation"] == "forward +Y, up +Z"
    error = np.linalg.norm(fit.positions - head.truth, axis=1) / head.face_width
    assert np.median(error) < 0.012 and error.max() < 0.06


def test_not_a_face():
    points = np.random.default_rng(0).normal(size=(400, 3))
    points /= np.linalg.norm(points, axis=1, keepdims=True)
    with pytest.raises(UserError, match="could not find a face"):
        locate_landmarks(points, ConvexHull(points).simplices)


def test_failed_fit_reports_the_limit(mask):
    rng = np.random.default_rng(0)
    crumpled = mask.vertices + rng.normal(0.0, 0.08 * mask.face_width, mask.vertices.shape)
    with pytest.raises(UserError, match=r"could not fit the face template .*limit 4 %"):
        locate_landmarks(crumpled, mask.faces)


@pytest.mark.parametrize("case", ["collapsed", "flat", "one_triangle_skin"])
def test_landmarks_placed_by_hand_on_no_face_are_refused(mask, case):
    """Landmarks dragged onto one point or flattened onto a plane, or a skin that is a single triangle under
    good landmarks: a clear error, not 'Singular matrix' from deep inside the fit (issue 33)."""
    from faces_hands_addon.face.fitted import build_fitted_rig
    landmarks = mask.truth.copy()
    vertices, faces = mask.vertices, mask.faces
    if case == "collapsed":
        landmarks[:] = landmarks[0]
    elif case == "flat":
        landmarks[:, 1] = 0.0
    else:
        vertices, faces = TRIANGLE * 0.2, np.array([[0, 1, 2]])
    with pytest.raises(UserError, match="point, a line or a plane"):
        build_fitted_rig(vertices, faces, landmarks)


def test_a_singular_registration_is_the_meshs_problem_said_as_such():
    """SuperLU's 'Factor is exactly singular' (the review's one-triangle mesh) reaches the artist as what to
    do about the mesh."""
    from scipy import sparse
    from faces_hands_addon.fitting import nicp
    with pytest.raises(UserError, match="cannot be registered onto this mesh"):
        nicp._lu_solve(sparse.csr_matrix((3, 3)), np.ones(3))
    assert np.allclose(nicp._lu_solve(sparse.identity(3, format="csr") * 2.0, np.ones(3)), 0.5)
