"""Emotion words (thesis Table 4.4, the NECA working model) and the activation-evaluation disk in polar form
(4.4.3): the preset holds the table's numbers, surprise sits at activation 100 / evaluation 0, angles and
radii follow omega = atan2(activation, evaluation), r = distance from the centre."""
from __future__ import annotations

import math

import pytest

from faces_hands_addon import UserError
from faces_hands_addon.emotion import DISK_RADIUS, emotion_point, from_polar, load_model, load_words, polar

# thesis Table 4.4, row by row: (activation, evaluation, power)
TABLE_4_4 = {
    "joy": (17.3, 42.2, 12.5), "distress": (-17.2, -40.1, -52.4), "happy-for": (17.3, 42.2, 12.5),
    "gloating": (40.0, 30.0, 30.0), "resentment": (0.0, -40.0, -20.0), "sorry-for": (-17.2, -40.1, -52.4),
    "hope": (20.0, 20.0, -10.0), "fear": (14.8, -44.4, -79.4), "satisfaction": (-14.9, 33.1, 12.2),
    "relief": (3.0, 33.0, -3.0), "fears-confirmed": (-30.0, -50.0, -70.0),
    "disappointment": (2.4, -24.9, -37.2), "pride": (30.0, 40.0, 30.0), "admiration": (27.0, 53.0, 17.0),
    "shame": (4.6, -26.3, -62.3), "reproach": (-3.0, -30.0, 43.0), "liking": (-14.9, 33.1, 12.2),
    "disliking": (15.0, -35.0, -10.0), "gratitude": (20.0, 40.0, -30.0), "anger": (34.0, -35.6, 20.0),
    "gratification": (-14.9, 33.1, 12.2), "remorse": (4.6, -26.3, -62.3), "love": (1.2, 33.3, 14.9),
    "hate": (60.0, -60.0, 30.0),
}


def test_the_preset_holds_table_4_4_and_surprise():
    words = load_words()
    for name, (a, e, p) in TABLE_4_4.items():
        point = words[name]
        assert (point.activation, point.evaluation, point.power) == (a, e, p), name
    surprise = words["surprise"]  # 4.4.3: "100% activation, and 0% on evaluation and power"
    assert (surprise.activation, surprise.evaluation, surprise.power) == (100.0, 0.0, 0.0)
    assert set(words) == set(TABLE_4_4) | {"surprise", "anxiety", "panic"}


def test_polar_form_of_the_disk():
    # evaluation is the horizontal axis, activation the vertical one (Fig. 4.9)
    assert polar(0.0, 50.0) == (0.0, 50.0)
    assert polar(100.0, 0.0) == (90.0, 100.0)
    angle, radius = polar(-17.2, -40.1)   # sorry-for: third quadrant
    assert angle == pytest.approx(180.0 + math.degrees(math.atan(17.2 / 40.1)))
    assert radius == pytest.approx(math.sqrt(17.2 ** 2 + 40.1 ** 2))
    angle, radius = polar(-14.9, 33.1)    # satisfaction: fourth quadrant
    assert angle == pytest.approx(360.0 - math.degrees(math.atan(14.9 / 33.1)))
    assert polar(0.0, 0.0) == (0.0, 0.0)
    assert polar(100.0, 100.0) == (pytest.approx(45.0), DISK_RADIUS)   # projected onto the disk
    a, e = from_polar(*polar(14.8, -44.4))
    assert (a, e) == (pytest.approx(14.8), pytest.approx(-44.4))


def test_the_basic_emotions_are_the_thesis_words_at_their_places():
    model = load_model()
    by_word = {b.word: b for b in model.basics}
    assert set(by_word) == {"joy", "anger", "fear", "hate", "sorry-for", "surprise"}
    assert {b.label for b in model.basics} == {"joy", "anger", "fear", "disgust", "sadness", "surprise"}
    for word in ("joy", "anger", "fear", "hate", "sorry-for"):
        a, e, _ = TABLE_4_4[word]
        assert by_word[word].angle == pytest.approx(math.degrees(math.atan2(a, e)) % 360.0)
        assert by_word[word].radius == pytest.approx(math.hypot(a, e))
    assert (by_word["surprise"].angle, by_word["surprise"].radius) == (90.0, 100.0)
    assert [b.word for b in model.basics] == ["joy", "surprise", "hate", "anger", "fear", "sorry-for"]


def test_anxiety_and_panic_lie_on_the_ray_of_fear():
    words = load_words()
    fear_angle = math.degrees(math.atan2(14.8, -44.4))
    for name in ("anxiety", "panic"):
        assert words[name].angle == pytest.approx(fear_angle)
    assert words["anxiety"].radius < math.hypot(14.8, 44.4) < words["panic"].radius


def test_emotion_points_from_words_and_numbers():
    assert emotion_point("Fear").activation == 14.8
    assert emotion_point((10, -20)).evaluation == -20.0
    assert emotion_point((10, -20, 30)).power == 30.0
    with pytest.raises(UserError, match="unknown emotion word 'glee'"):
        emotion_point("glee")
    with pytest.raises(UserError, match="2 or 3 finite numbers"):
        emotion_point((1.0, float("nan")))
