"""The default head's painted brows and lips (face/appearance.py)."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.face import appearance
from faces_hands_addon.face.rig import build_default_rig


@pytest.fixture(scope="module")
def skin():
    return build_default_rig().template.skin


def test_brows_lie_between_the_eyes_and_the_brow_contour_on_both_sides(skin):
    v = np.asarray(skin.vertices)
    surface = skin.group("surface").astype(float)
    for side, sign in (("L", 1), ("R", -1)):
        contour = np.asarray(skin.contours[f"eyebrow_{side}_upper"])
        weight = appearance.brow_weights(v, contour, surface)
        hair = weight > 0.5
        assert 8 <= hair.sum() <= 80, hair.sum()
        assert np.all(np.sign(v[hair, 0]) == sign)                         # on its own side
        lid_top = v[np.asarray(skin.contours[f"eye_{side}_upper"]), 2].max()
        assert v[hair, 2].min() > lid_top + 0.005                          # well above the eye
        assert v[hair, 2].max() <= v[contour, 2].max() + appearance.BROW_SOFT_EDGE
        assert not (weight[skin.group("mouth_bag")] > 0).any()


def test_lips_are_the_front_surface_inside_the_outer_lip_contours(skin):
    v = np.asarray(skin.vertices)
    outer_up, outer_low = (np.asarray(skin.contours[k]) for k in ("lips_outer_upper", "lips_outer_lower"))
    weight = appearance.lip_weights(v, outer_up, outer_low, skin.group("surface").astype(float))
    lips = weight > 0.5
    assert 40 <= lips.sum() <= 600
    ring = np.concatenate([v[outer_up], v[outer_low]])
    assert v[lips, 0].min() >= ring[:, 0].min() - 0.002 and v[lips, 0].max() <= ring[:, 0].max() + 0.002
    assert v[lips, 2].min() >= ring[:, 2].min() - 0.002 and v[lips, 2].max() <= ring[:, 2].max() + 0.002
    assert weight[~skin.group("surface")].max() == 0.0
    nose_tip = np.argmin(v[:, 1])                                          # the front-most node
    assert weight[nose_tip] == 0.0


def test_skin_colours_are_skin_brows_and_lips_and_the_same_every_time(skin):
    colours = appearance.skin_colours(skin)
    assert colours.shape == (len(skin.vertices), 3) and colours.min() >= 0.0 and colours.max() <= 1.0
    darkest = colours.sum(axis=1)
    assert np.isclose(np.median(colours, axis=0), appearance.SKIN_RGB).all()
    assert darkest.min() == pytest.approx(sum(appearance.BROW_RGB), abs=1e-9)
    assert np.array_equal(colours, appearance.skin_colours(skin))
