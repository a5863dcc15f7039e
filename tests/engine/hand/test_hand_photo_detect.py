"""The 26 feature points of 6.2.3 from MediaPipe's 21 hand landmarks (tracking/photo_points.py): the derived points
land where the reference hand has them, on a photo from the back or from the palm, and bad photos are refused
with a clear message (the detection itself on a rendered hand: tests/addon/hand/test_hand_photo_addon.py)."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.hand.features import FEATURE_NAMES
from faces_hands_addon.tracking.photo_points import DERIVED, DIRECT, detect_photo_points, feature_pixels
from faces_hands_addon.hand.template import reference_template
from test_hand_photo import STRETCH, synthetic_photo


@pytest.fixture(scope="module")
def template():
    return reference_template()


def _landmarks(points: dict) -> dict:
    """MediaPipe's named landmarks as a detector would give them for a photo whose feature points are ``points``
    (its wrist at the middle of the two wrist points)."""
    out = {mp: np.array(points[name]) for name, mp in DIRECT.items()}
    out["wrist"] = 0.5 * (np.array(points["wrist_radial"]) + np.array(points["wrist_ulnar"]))
    return out


@pytest.mark.parametrize("mirror", [False, True])
def test_the_derived_points_land_where_the_reference_has_them(template, mirror):
    """19 points are MediaPipe's landmarks, 7 derived; for a photo of the reference hand itself (from the back
    or, mirrored, from the palm), every derived point comes out where the reference's projects (< 0.01 px)."""
    photo = synthetic_photo(template.features, np.eye(3))["points"]
    if mirror:
        photo = {n: [2000.0 - x, y] for n, (x, y) in photo.items()}
    points = feature_pixels(_landmarks(photo), template.features)
    assert list(points) == list(FEATURE_NAMES) and len(DIRECT) == 19 and len(DERIVED) == 7
    for name in FEATURE_NAMES:
        assert np.allclose(points[name], photo[name], atol=1e-2), name


def test_the_derived_points_follow_a_differently_shaped_hand(template):
    """On a narrower, longer hand the derived webs stay between their knuckles and the wrist points keep
    the wrist's side: each derived point within 8% of the hand's length of the stretched hand's own."""
    photo = synthetic_photo(template.features, STRETCH)["points"]
    points = feature_pixels(_landmarks(photo), template.features)
    wrist = 0.5 * (np.array(photo["wrist_radial"]) + np.array(photo["wrist_ulnar"]))
    length = np.linalg.norm(np.array(photo["middle_tip"]) - wrist)
    for name in DERIVED:
        assert np.linalg.norm(np.array(points[name]) - photo[name]) < 0.08 * length, name


@pytest.mark.parametrize("image, length, message", [
    (np.full((256, 256, 3), 0.5, np.float32), 185.0, "no hand found"),
    (np.full((32, 32, 3), 0.5, np.float32), 185.0, "at least 64 x 64"),
    (np.full((256, 256, 3), 0.5, np.float32), 20.0, "must be 80-300 mm"),
    (np.full((256, 256, 3), 0.5, np.float32), float("nan"), "must be 80-300 mm"),
])
def test_a_photo_without_a_hand_or_a_bad_length_is_refused(template, image, length, message):
    with pytest.raises(UserError, match=message):
        detect_photo_points(image, template.features, "right", length, "photo.png")
