"""The emotion picker's disk picture (emotion/disk.py): where the words, the basic emotions and the chosen
point land on Cowie's activation-evaluation disk (thesis 4.4.1)."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.emotion import EmotionPoint, load_model
from faces_hands_addon.emotion.disk import BASIC, CHOSEN, DISK, disk_image, strongest_controls


def _pixel(image, activation, evaluation):
    size = image.shape[0]
    scale = 0.47 * size / 100
    return image[int(size / 2 - activation * scale), int(size / 2 + evaluation * scale)]


def test_chosen_point_is_red_where_activation_is_up_and_evaluation_right():
    model = load_model()
    basics = tuple(b.word for b in model.basics)
    image = disk_image(model.words, basics, EmotionPoint(60.0, -40.0), size=200)
    assert image.shape == (200, 200, 4) and image.dtype == np.float32
    assert np.allclose(_pixel(image, 60.0, -40.0), CHOSEN)
    assert np.allclose(_pixel(image, -60.0, 40.0), DISK), "the mirrored point stays empty"
    for word in basics:
        p = model.words[word]
        assert np.allclose(_pixel(image, p.activation, p.evaluation), BASIC), word


def test_a_point_beyond_the_rim_is_drawn_on_the_rim_and_none_draws_no_point():
    model = load_model()
    outside = disk_image(model.words, (), EmotionPoint(0.0, 300.0), size=200)
    assert np.allclose(_pixel(outside, 0.0, 100.0), CHOSEN)
    empty = disk_image(model.words, (), None, size=200)
    assert not np.isclose(empty, CHOSEN).all(axis=2).any()
    with pytest.raises(ValueError):
        disk_image(model.words, (), None, size=8)


def test_strongest_controls_by_magnitude():
    values = {"a": 0.1, "b": -0.9, "c": 0.5, "d": 0.0, "e": 0.5}
    assert strongest_controls(values, 3) == [("b", -0.9), ("c", 0.5), ("e", 0.5)]
    assert strongest_controls({"z": 0.0}) == []
