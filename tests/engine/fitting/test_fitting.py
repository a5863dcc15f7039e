# SPDX-License-Identifier: GPL-3.0-or-later
"""Automatic landmark location (thesis 3.1.2 "Creating New Animatable Head Models from the Template"):
the canonical face registered onto heads of another topology, proportions, scale and position must put
the 468 landmarks where the generator's known map sends them."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.fitting import LandmarkFit, locate_landmarks, project_to_surface, testdata
from faces_hands_addon.fitting.template import face_template


@pytest.fixture(scope="module")
def mask():
    """Face mask: re-triangulated, eye/mouth openings, x*1.15 y*1.05 z*0.9, longer nose, fuller cheeks."""
    return testdata.remeshed_face(3, spacing=0.005)


@pytest.fixture(scope="module")
def mask_fit(mask):
    return locate_landmarks(mask.vertices, mask.faces, seed=0)


@pytest.fixture(scope="module")
def head_fit(head):
    return locate_landmarks(head.vertices, head.faces, seed=0)


def relative_errors(fit: LandmarkFit, target) -> np.ndarray:
    return np.linalg.norm(fit.positions - target.truth, axis=1) / target.face_width


def test_test_meshes_differ_from_the_template(mask, head):
    template = face_template()
    for target in (mask, head):
        assert len(target.vertices) != len(template.vertices)
        assert target.truth.shape == (468, 3)
    # non-uniform: width / height ratio of the truth differs from the template's
    ratio = np.ptp(mask.truth[:, 0]) / np.ptp(mask.truth[:, 2])
    template_ratio = np.ptp(template.vertices[:, 0]) / np.ptp(template.vertices[:, 2])
    assert ratio / template_ratio == pytest.approx(1.15 / 0.9, rel=0.01)
    # the full head is mostly not face, and its chest reaches further forward than the nose tip
    assert len(head.vertices) > 3 * len(mask.vertices)
    assert head.vertices[:, 1].min() < head.truth[:, 1].min() - 0.1 * head.face_width


@pytest.mark.parametrize("name", ["mask", "head"])
def test_landmarks_match_ground_truth(name, request):
    target = request.getfixturevalue(name)
    fit = request.getfixturevalue(f"{name}_fit")
    error = relative_errors(fit, target)
    assert np.median(error) < 0.012, f"median {100 * np.median(error):.2f} % of face width"
    assert np.quantile(error, 0.95) < 0.03, f"95th percentile {100 * np.quantile(error, 0.95):.2f} %"
    assert error.max() < 0.06
    assert fit.face_width == pytest.approx(target.face_width, rel=0.03)


def _border_edges(vertices, faces):
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    edges, counts = np.unique(e, axis=0, return_counts=True)
    return edges[counts == 1]


def _distance_to_segments(points, a, b):
    ab = b - a
    t = np.clip(((points[:, None] - a[None]) * ab[None]).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-30), 0, 1)
    return np.linalg.norm(points[:, None] - (a[None] + t[..., None] * ab[None]), axis=-1).min(axis=1)


@pytest.mark.parametrize("name", ["mask", "head"])
def test_eye_and_lip_contours_land_on_the_right_features(name, request):
    target = request.getfixturevalue(name)
    fit = request.getfixturevalue(f"{name}_fit")
    contours = face_template().contours
    edges = _border_edges(target.vertices, target.faces)
    middles = target.vertices[edges].mean(axis=1)
    mouth = np.concatenate([contours["lips_inner_upper"], contours["lips_inner_lower"]])
    openings = {"eye_L": contours["eye_L"], "eye_R": contours["eye_R"], "mouth": mouth}
    rims = {}
    for key, index in openings.items():     # the target's opening: border edges next to the true contour
        near = np.linalg.norm(middles[:, None] - target.truth[index][None], axis=2).min(axis=1)
        rims[key] = edges[near < 0.03 * target.face_width]
    def rim_gap(points, rim):
        return _distance_to_segments(points, target.vertices[rim[:, 0]], target.vertices[rim[:, 1]]) / target.face_width

    for key, index in openings.items():
        gaps = {other: rim_gap(fit.positions[index], rim) for other, rim in rims.items()}
        # as close to the opening's rim as the true landmarks are (the rim is a coarse polyline), +1.5 %
        excess = gaps[key] - rim_gap(target.truth[index], rims[key])
        assert excess.max() < 0.015, f"{key} landmarks up to {100 * excess.max():.1f} % further off their rim"
        for other, gap in gaps.items():
            if other != key:
                assert gap.min() > 0.05, f"{key} landmarks touch the {other} opening"
    error = relative_errors(fit, target)
    for key in ("lips_outer_upper", "lips_outer_lower", "eye_L", "eye_R", "eyebrow_L_upper", "eyebrow_R_upper"):
        assert error[contours[key]].max() < 0.03, key
    # order along the contours is kept: upper inner lip above the lower, left eye (+X) left of the right one
    assert (fit.positions[contours["lips_inner_upper"][3:8], 2]
            > fit.positions[contours["lips_inner_lower"][3:8], 2]).all()
    assert fit.positions[contours["eye_L"], 0].min() > fit.positions[contours["eye_R"], 0].max()


@pytest.mark.parametrize("name", ["mask", "head"])
def test_mirror_symmetry_is_preserved(name, request):
    target = request.getfixturevalue(name)
    fit = request.getfixturevalue(f"{name}_fit")
    mirrored = fit.positions[face_template().mirror] * (-1.0, 1.0, 1.0) + (2 * target.symmetry_x, 0.0, 0.0)
    asymmetry = np.linalg.norm(mirrored - fit.positions, axis=1) / target.face_width
    assert np.median(asymmetry) < 0.006
    assert np.quantile(asymmetry, 0.95) < 0.02


@pytest.mark.parametrize("name", ["mask", "head"])
def test_landmarks_are_stored_as_triangle_and_barycentric(name, request):
    target = request.getfixturevalue(name)
    fit = request.getfixturevalue(f"{name}_fit")
    assert fit.positions.shape == (468, 3) and fit.triangles.shape == (468,) and fit.barycentric.shape == (468, 3)
    assert fit.triangles.min() >= 0 and fit.triangles.max() < len(target.faces)
    assert (fit.barycentric >= 0).all() and np.allclose(fit.barycentric.sum(axis=1), 1.0)
    corners = target.vertices[target.faces[fit.triangles]]
    assert np.allclose((fit.barycentric[:, :, None] * corners).sum(axis=1), fit.positions, atol=1e-9)


@pytest.mark.parametrize("name", ["mask", "head"])
def test_quality_report(name, request):
    fit = request.getfixturevalue(f"{name}_fit")
    assert fit.rms_fraction < 0.01 and fit.max_distance < 0.05 * fit.face_width
    assert 0.8 < fit.matched_fraction <= 1.0
    assert not fit.matched[face_template().contours["lips_inner_upper"][4:7]].all()   # over the mouth opening
    report = fit.quality()
    assert set(report) >= {"rms_distance", "max_distance", "matched_fraction", "rms_percent_of_face_width"}
    assert fit.warnings == ()


def test_same_seed_same_result_and_progress(mask, mask_fit):
    calls = []
    again = locate_landmarks(mask.vertices, mask.faces, seed=0, progress=lambda f, m: calls.append((f, m)))
    assert np.array_equal(again.positions, mask_fit.positions)
    assert np.array_equal(again.triangles, mask_fit.triangles)
    assert np.array_equal(again.barycentric, mask_fit.barycentric)
    fractions = [f for f, _ in calls]
    assert fractions[0] == 0.0 and fractions[-1] == 1.0 and fractions == sorted(fractions)
    assert all(isinstance(m, str) and m for _, m in calls)


def test_project_to_surface_snaps_dragged_markers(mask, mask_fit):
    rng = np.random.default_rng(0)
    dragged = mask_fit.positions + rng.normal(0.0, 0.01 * mask.face_width, mask_fit.positions.shape)
    points, triangles, bary = project_to_surface(dragged, mask.vertices, mask.faces)
    corners = mask.vertices[mask.faces[triangles]]
    assert np.allclose((bary[:, :, None] * corners).sum(axis=1), points, atol=1e-9)
    assert (np.linalg.norm(points - dragged, axis=1) <= np.linalg.norm(mask_fit.positions - dragged, axis=1)
            + 1e-12).all()
    # points already on the surface stay put
    same, _, _ = project_to_surface(mask_fit.positions, mask.vertices, mask.faces)
    assert np.allclose(same, mask_fit.positions, atol=1e-9 * mask.face_width)


def test_closest_points_are_exact_on_triangles():
    from faces_hands_addon.core.geometry import closest_points_on_triangles
    from faces_hands_addon.fitting.surface import TargetSurface
    head = testdata.full_head(1, spacing=0.008, body_spacing=0.03)
    rng = np.random.default_rng(1)
    queries = head.truth[::9] + rng.normal(0.0, 0.05 * head.face_width, head.truth[::9].shape)
    hit = TargetSurface(head.vertices, head.faces).closest(queries, exact=True)
    tri = head.vertices[head.faces]
    for query, found in zip(queries, hit.distances):
        point, _ = closest_points_on_triangles(np.repeat(query[None], len(tri), 0), tri[:, 0], tri[:, 1], tri[:, 2])
        assert found == pytest.approx(np.linalg.norm(point - query, axis=1).min(), abs=1e-12)
