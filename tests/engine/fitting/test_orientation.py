# SPDX-License-Identifier: GPL-3.0-or-later
"""Fit any orientation, refuse nonsense (issue 10 item 3; thesis 3.1.2 "Creating New Animatable Head Models
from the Template"): a head turned 90 degrees about X, Y or Z, or mirrored front to back, is found in its own
axes and gets the same landmarks as the upright head (turned with it); what is not a face is refused with
the check that failed, its figure and its limit."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from faces_hands_addon import UserError
from faces_hands_addon.fitting import locate_landmarks, testdata
from faces_hands_addon.fitting.orientation import ORIENTATIONS, axis_facing, orientation_name
from faces_hands_addon.fitting.preview import png_bytes, preview_image
from faces_hands_addon.fitting.quality import FitRefused, check_fit
from faces_hands_addon.fitting.template import face_template

# The same landmarks as the upright fit, turned with the head: per landmark, in face widths.
SAME_MEDIAN, SAME_MAX = 0.005, 0.03
# ... and as close to the generator's truth as the upright fit is (test_fitting.py's tolerances).
TRUTH_MEDIAN, TRUTH_MAX = 0.012, 0.06


def _turn(axis: int, degrees: float) -> np.ndarray:
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


TRANSFORMS = {"X+90": _turn(0, 90), "Y+90": _turn(1, 90), "Z+90": _turn(2, 90),
              "mirrored front to back": np.diag([1.0, -1.0, 1.0])}


@pytest.fixture(scope="module")
def mask():
    return testdata.remeshed_face(0, spacing=0.008)


@pytest.fixture(scope="module")
def upright(mask):
    return locate_landmarks(mask.vertices, mask.faces, seed=0)


def _moved(mask, matrix):
    centre = mask.truth.mean(axis=0)
    vertices = (mask.vertices - centre) @ matrix.T + centre
    faces = mask.faces if np.linalg.det(matrix) > 0 else mask.faces[:, ::-1]
    return vertices, faces, lambda points: (points - centre) @ matrix.T + centre


def test_24_orientations_are_the_rotations_of_the_cube():
    assert len(ORIENTATIONS) == 24
    rotations = np.array([f.rotation() for f in ORIENTATIONS])
    assert np.allclose(np.linalg.det(rotations), 1.0)
    assert len({tuple(np.round(r, 6).ravel()) for r in rotations}) == 24
    assert np.allclose(axis_facing("-Y", "+Z").rotation(), np.eye(3))


def test_upright_fit_passes_the_gate(upright):
    assert upright.orientation["orientation"] == "forward -Y, up +Z"
    assert upright.orientation["margin"] > 1.3
    assert upright.checks and all(c["ok"] for c in upright.checks)


@pytest.mark.parametrize("name", list(TRANSFORMS))
def test_turned_or_mirrored_head_gets_the_same_landmarks(name, mask, upright):
    matrix = TRANSFORMS[name]
    vertices, faces, move = _moved(mask, matrix)
    fit = locate_landmarks(vertices, faces, seed=0)
    expected = move(upright.positions)
    truth = move(mask.truth)
    if np.linalg.det(matrix) < 0:    # a mirror image: the character's left is the original's right
        expected, truth = expected[face_template().mirror], truth[face_template().mirror]
    same = np.linalg.norm(fit.positions - expected, axis=1) / mask.face_width
    error = np.linalg.norm(fit.positions - truth, axis=1) / mask.face_width
    assert np.median(same) < SAME_MEDIAN and same.max() < SAME_MAX, \
        f"{name}: median {100 * np.median(same):.2f} %, max {100 * same.max():.2f} % off the upright fit"
    assert np.median(error) < TRUTH_MEDIAN and error.max() < TRUTH_MAX
    assert fit.orientation["orientation"] == orientation_name(matrix @ (0.0, -1.0, 0.0), matrix @ (0.0, 0.0, 1.0))
    assert fit.orientation["margin"] > 1.3
    print(f"{name}: {fit.orientation['orientation']}, margin {fit.orientation['margin']:.2f}, same as upright: "
          f"median {100 * np.median(same):.2f} % max {100 * same.max():.2f} %")


@pytest.mark.parametrize("name, matrix", [("pitch 25", _turn(0, 25)), ("roll 35", _turn(1, 35))])
def test_head_tilted_off_the_axes_is_fitted(name, matrix, mask):
    vertices, faces, move = _moved(mask, matrix)
    fit = locate_landmarks(vertices, faces, seed=0)
    error = np.linalg.norm(fit.positions - move(mask.truth), axis=1) / mask.face_width
    assert np.median(error) < TRUTH_MEDIAN and error.max() < TRUTH_MAX, (name, np.median(error), error.max())


@pytest.mark.parametrize("name, matrix", [("pitch 30 yaw 50", _turn(0, 30) @ _turn(2, 50)),
                                          ("yaw 30 roll 20", _turn(2, 30) @ _turn(1, 20))])
def test_head_tilted_about_two_axes_is_refused_or_fitted(name, matrix, mask):
    """Tilted about two axes (pitch 30 + yaw 50 is ~45 degrees from every axis orientation): the search's
    tilts are about one axis at a time, the fit lands off the face and the gate says so instead of
    exiting 0 with a broken rig (measured: both refused, landmark residual ~18 %)."""
    vertices, faces, move = _moved(mask, matrix)
    try:
        fit = locate_landmarks(vertices, faces, seed=0)
    except FitRefused as error:
        assert "limit" in str(error) and error.checks
        return
    error = np.linalg.norm(fit.positions - move(mask.truth), axis=1) / mask.face_width
    assert np.median(error) < TRUTH_MEDIAN and error.max() < TRUTH_MAX


def test_given_axes_are_used(mask, upright):
    vertices, faces, move = _moved(mask, TRANSFORMS["X+90"])
    fit = locate_landmarks(vertices, faces, seed=0, forward="-Z", up="-Y")
    assert fit.orientation["forced"] and fit.orientation["orientation"] == "forward -Z, up -Y"
    same = np.linalg.norm(fit.positions - move(upright.positions), axis=1) / mask.face_width
    assert np.median(same) < SAME_MEDIAN


def test_wrong_given_axes_are_refused(mask):
    with pytest.raises(UserError, match=r"forward \+Y, up \+Z"):
        locate_landmarks(mask.vertices, mask.faces, seed=0, forward="+Y", up="+Z")


@pytest.mark.parametrize("forward, up, message", [("-Y", None, "both"), ("-Y", "+Y", "perpendicular"),
                                                  ("front", "+Z", "one of")])
def test_bad_axes(forward, up, message):
    with pytest.raises(UserError, match=message):
        locate_landmarks(face_template().vertices, face_template().faces, forward=forward, up=up)


def test_cube_and_sphere_are_refused():
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    points = np.random.default_rng(0).normal(size=(400, 3))
    points /= np.linalg.norm(points, axis=1, keepdims=True)
    for vertices in (corners, points):
        with pytest.raises(UserError, match="could not find a face|does not look like a human face"):
            locate_landmarks(vertices, ConvexHull(vertices).simplices)


def test_gate_names_the_failed_check_with_figure_and_limit(mask, upright):
    template = face_template()
    checks = {c.name: c for c in check_fit(upright.positions, mask.vertices, mask.faces)}
    assert all(c.ok for c in checks.values())
    # landmarks slid down the face by a third of its height: the mouth is no longer between nose and chin
    wrong = upright.positions.copy()
    wrong[[13, 14]] = upright.positions[[1, 1]] + (upright.positions[[13, 14]] - upright.positions[[1, 1]]) * -0.5
    failed = [c for c in check_fit(wrong, mask.vertices, mask.faces) if not c.ok]
    assert [c.name for c in failed] == ["mouth_between_nose_and_chin"]
    assert "mouth at" in failed[0].text and "need 15-55 %" in failed[0].text
    # the template landmarks on a flat sheet: no nose, no eye sockets
    flat = template.vertices * (1.0, 0.0, 1.0)
    names = {c.name for c in check_fit(flat, flat, template.faces) if not c.ok}
    assert {"nose_protrusion", "eye_depth_L", "eye_depth_R"} <= names


def test_refusal_preview_is_a_picture_of_the_face_found(mask, upright):
    image = preview_image(mask.vertices, mask.faces, upright.positions, upright.rigid_rotation.T, samples=50_000)
    assert image.dtype == np.uint8 and image.shape == (400, 720, 3)
    assert (image != 245).any(axis=2).mean() > 0.1          # the mesh is in the picture
    data = png_bytes(image)
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 1000
    error = FitRefused("no", mask.vertices, mask.faces, upright.positions, upright.rigid_rotation.T)
    assert error.preview().shape == image.shape


def _upside_down_first(monkeypatch, keep_runner_up: bool):
    """The face search answers with the head upside down (a near tie it can lose on a long-necked head, as
    the held-out SOMA head did: crown and face scored 0.293 and 0.397) and, when ``keep_runner_up``, the true
    orientation as its runner-up."""
    from dataclasses import replace

    from faces_hands_addon.fitting import landmarks
    from faces_hands_addon.fitting.align import DepthMatch, Similarity

    real = landmarks.choose_orientation

    def upside_down(*args, **kwargs):
        choice = real(*args, **kwargs)
        right = choice.match
        flip = np.diag([-1.0, 1.0, -1.0])                     # 180 degrees about the face's forward axis
        wrong = DepthMatch(axis_facing("-Y", "-Z"), 0.9 * right.score,
                           Similarity(right.similarity.scale, right.similarity.rotation @ flip,
                                      right.similarity.translation), right.coverage)
        return replace(choice, match=wrong, runners_up=(right,) if keep_runner_up else ())
    monkeypatch.setattr(landmarks, "choose_orientation", upside_down)


def test_a_refused_best_match_falls_back_to_the_runner_up(mask, upright, monkeypatch):
    """When the best depth match's fit does not look like a face, the next orientation that does is fitted
    (and the user is told), instead of refusing a head that is one."""
    _upside_down_first(monkeypatch, keep_runner_up=True)
    fit = locate_landmarks(mask.vertices, mask.faces, seed=0)
    assert fit.orientation["orientation"] == "forward -Y, up +Z"
    assert any("did not fit a face" in w and "forward -Y, up -Z" in w for w in fit.warnings), fit.warnings
    same = np.linalg.norm(fit.positions - upright.positions, axis=1) / mask.face_width
    assert np.median(same) < SAME_MEDIAN


def test_without_a_runner_up_the_best_match_is_refused(mask, monkeypatch):
    """No runner-up that looks like a face: the refusal names the best match's orientation."""
    _upside_down_first(monkeypatch, keep_runner_up=False)
    with pytest.raises(FitRefused, match=r"forward -Y, up -Z"):
        locate_landmarks(mask.vertices, mask.faces, seed=0)
