"""New hands from photographs (thesis 6.2.3): exact feature points, proportions of a scaled hand, bad input."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.hand.features import FEATURE_NAMES
from faces_hands_addon.hand.photo import check_photo, photo_targets, photo_warp
from faces_hands_addon.hand.template import reference_template, warped_template

PIXELS_PER_M = 4000.0
STRETCH = np.diag([1.0, 0.93, 1.12])      # narrower, longer hand (X is the palm normal)


def camera_axes(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Image right and up of a camera looking at the flat hand ``points`` along their plane's normal."""
    x = points - points.mean(axis=0)
    vectors = np.linalg.eigh(x.T @ x)[1]
    normal = vectors[:, 0] * np.sign(vectors[0, 0])        # the camera sits on the back of the hand (-X)
    up = np.array([0.0, 0.0, 1.0]) - normal[2] * normal
    up /= np.linalg.norm(up)
    return np.cross(up, normal), up


def synthetic_photo(features: dict, transform=STRETCH, names=FEATURE_NAMES) -> dict:
    """What an artist would click on a photo of the flat hand ``transform`` @ reference taken from the back
    of the hand along its plane's normal: orthographic, 1 px = 0.25 mm, rows downwards; a 200 mm ruler."""
    moved = {name: transform @ features[name] for name in features}
    right, up = camera_axes(np.array(list(moved.values())))
    points = {name: [float(1000 + moved[name] @ right * PIXELS_PER_M), float(1000 - moved[name] @ up * PIXELS_PER_M)]
              for name in names}
    return {"points": points, "ruler": [[100.0, 1900.0], [900.0, 1900.0]], "ruler_mm": 200.0}


@pytest.fixture(scope="module")
def template():
    return reference_template()


def test_there_are_26_source_feature_points(template):
    assert tuple(template.features) == FEATURE_NAMES and len(FEATURE_NAMES) == 26


def test_the_warp_maps_every_source_feature_point_exactly_onto_its_target(template):
    photo = synthetic_photo(template.features)
    names, source, target = photo_targets(template.features, photo)
    warp = photo_warp(template.features, photo)
    assert len(names) == 26
    np.testing.assert_allclose(warp(source), target, atol=1e-9)
    warped = warped_template(template, warp)
    for name, point in zip(names, target):
        np.testing.assert_allclose(warped.features[name], point, atol=1e-9)


def _segment_lengths(skeleton):
    return {n: skeleton.bone_length(b) for b, n in enumerate(skeleton.names) if "phalanx" in n}


def test_the_warped_hand_has_the_proportions_of_the_photographed_hand(template):
    warped = warped_template(template, photo_warp(template.features, synthetic_photo(template.features)))
    ref, new = _segment_lengths(template.skeleton), _segment_lengths(warped.skeleton)
    sk = template.skeleton
    for name, length in ref.items():
        b = sk.index[name]
        expected = np.linalg.norm(STRETCH @ (sk.tail[b] - sk.position[b]))
        assert new[name] == pytest.approx(expected, rel=0.03), name
    for a, b in (("index_mcp", "pinky_mcp"), ("ulna_head", "middle_tip"), ("wrist_radial", "wrist_ulnar"),
                 ("thumb_tip", "pinky_tip")):             # width, length, wrist, span
        expected = np.linalg.norm(STRETCH @ (template.features[a] - template.features[b]))
        assert np.linalg.norm(warped.features[a] - warped.features[b]) == pytest.approx(expected, rel=0.03), (a, b)
    assert np.all(np.isfinite(warped.skin.vertices)) and warped.masses.sum() > 0
    frames = warped.skeleton.frame
    assert np.allclose(frames.transpose(0, 2, 1) @ frames, np.eye(3), atol=1e-9)   # still orthonormal


def test_a_photo_of_the_palm_side_is_mirrored_back(template):
    mirror = STRETCH @ np.diag([1.0, -1.0, 1.0])
    names, _, target = photo_targets(template.features, synthetic_photo(template.features, mirror))
    _, _, straight = photo_targets(template.features, synthetic_photo(template.features))
    np.testing.assert_allclose(target, straight, atol=2e-3)


@pytest.mark.parametrize("mutate, message", [
    (lambda p: p["points"].pop("thumb_tip") and [p["points"].pop(n) for n in list(p["points"])[:10]], "at least 16"),
    (lambda p: p.update(ruler=[[500.0, 500.0], [500.0, 500.0]]), "ruler marks are 0 pixels apart"),
    (lambda p: p["points"].update(index_pip=p["points"]["index_tip"], index_tip=p["points"]["index_pip"]),
     "impossible order"),
    (lambda p: p["points"].update(ring_mcp=p["points"]["index_mcp"], index_mcp=p["points"]["ring_mcp"]),
     "impossible order"),
    (lambda p: p["points"].update(elbow=[1.0, 2.0]), "unknown feature point"),
    (lambda p: p["points"].pop("ulna_head"), "ulna head is needed"),
    (lambda p: p.update(ruler_mm=0.0), "ruler_mm"),
])
def test_bad_photo_input_is_refused_clearly(template, mutate, message):
    photo = synthetic_photo(template.features)
    mutate(photo)
    with pytest.raises(UserError, match=message):
        check_photo(photo)


def test_sixteen_points_are_enough(template):
    names = ["thumb_tip", "index_tip", "middle_tip", "ring_tip", "pinky_tip", "thumb_ip", "index_pip", "middle_pip",
             "ring_pip", "pinky_pip", "thumb_mcp", "index_mcp", "middle_mcp", "pinky_mcp", "wrist_ulnar", "ulna_head"]
    photo = synthetic_photo(template.features, names=names)
    assert len(check_photo(photo)["points"]) == 16
    warped = warped_template(template, photo_warp(template.features, photo))
    assert np.all(np.isfinite(warped.skin.vertices))
