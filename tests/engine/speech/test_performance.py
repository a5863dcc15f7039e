"""Animate Speech: speech + behaviour + emotion layers of one take (thesis 4.3.5, 4.4)."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.emotion import expression_for
from faces_hands_addon.speech import synthesize
from faces_hands_addon.emotion import parse_emotion
from faces_hands_addon.performance import voice_settings, with_nonverbal
from faces_hands_addon.speech.takes import take_from_utterance

THESIS_EXAMPLE = "Hi! ;-) Can you show me the way to the conference hall? :-)"  # Figure 4.7


@pytest.fixture(scope="module")
def take():
    return take_from_utterance(synthesize(THESIS_EXAMPLE), fps=30.0, target="muscles")


def test_layers_of_the_thesis_example(take):
    performed = with_nonverbal(take, style="neutral", seed=1)
    assert set(performed.layers) == {"behavior", "emotion"}
    assert performed.tracks is take.tracks                          # the speech layer is untouched
    behavior, emotion = performed.layers["behavior"], performed.layers["emotion"]
    assert not any(t.name.startswith("head.") for t in behavior)   # no face control: the head turns whole
    pitch = performed.head["head.pitch"]
    assert 0.01 < pitch.values.max() <= np.radians(3.0) + 1e-9      # raised at pitch maxima, at most ~3 deg
    assert set(performed.head.names) == {"head.pitch", "head.yaw", "head.roll"}
    lids = behavior["eyelid_close_L"]
    assert lids.values.max() == pytest.approx(1.0)                  # blinks close the lids
    # the two emoticons: a smile at each, and the wink of ";-)" on one eye only
    tags = take.utterance.emotions
    assert [t.emotion for t in tags] == ["kidding", "happy"]
    smile = emotion["zygomaticus_major_L"]
    for tag in tags:
        assert smile.sample(tag.time) > 0.3, tag
    assert emotion["eyelid_close_R"].values.max() > 0.8
    assert "eyelid_close_L" not in emotion or emotion["eyelid_close_L"].values.max() < 0.2
    # no blink of both eyes drowns the wink: the mixed lids differ at the wink's apex
    wink = tags[0].time
    right = emotion["eyelid_close_R"].sample(wink) + behavior["eyelid_close_R"].sample(wink)
    assert min(1.0, right) - behavior["eyelid_close_L"].sample(wink) > 0.6
    for layer in (behavior, emotion):
        for track in layer:
            low, high = performed.ranges[track.name]
            assert np.all(np.isfinite(track.values))
            assert track.values.min() >= low - 1e-12 and track.values.max() <= high + 1e-12, track.name


def test_same_seed_same_layers_other_seed_other(take):
    def arrays(t):
        return {n: (tr.times.tobytes(), tr.values.tobytes()) for n, tr in t.layers["behavior"].tracks.items()}
    a, b = with_nonverbal(take, seed=7), with_nonverbal(take, seed=7)
    assert arrays(a) == arrays(b)
    assert arrays(a) != arrays(with_nonverbal(take, seed=8))


def test_an_emotion_for_the_whole_take_adds_and_clamps(take):
    sad = with_nonverbal(take, style=None, emotion="sorry-for")
    assert "behavior" not in sad.layers
    brows = sad.layers["emotion"]["frontalis_inner_L"]
    assert brows.sample(0.05) > 0.3 and brows.sample(take.duration - 0.05) > 0.3   # all through the take
    # the whole-take emotion adds to the emoticons' (summed, then clamped to the control's range)
    plain = with_nonverbal(take, style=None).layers["emotion"]["zygomaticus_major_L"]
    joyful = with_nonverbal(take, style=None, emotion="joy").layers["emotion"]["zygomaticus_major_L"]
    apex = take.utterance.emotions[0].time
    high = sad.ranges["zygomaticus_major_L"][1]
    constant = expression_for("joy")["zygomaticus_major_L"]
    assert joyful.sample(apex) == pytest.approx(min(high, plain.sample(apex) + constant), abs=1e-6)
    assert joyful.values.max() <= high


def test_parse_emotion_and_voice():
    assert parse_emotion(None) is None and parse_emotion("  ") is None
    assert parse_emotion("Joy") == "joy"
    assert parse_emotion("50,-20") == (50.0, -20.0)
    with pytest.raises(UserError, match="unknown emotion word"):
        parse_emotion("hungry")
    with pytest.raises(UserError):
        parse_emotion("50,x")
    # Table 4.5: rate +0.5 % per unit of activation, +0.2 % per unit of evaluation
    assert voice_settings((50.0, 0.0), 175)["rate"] == pytest.approx(175 * 1.25)
    assert voice_settings((0.0, 50.0), 175)["rate"] == pytest.approx(175 * 1.10)
    assert voice_settings(None, 175, 40, 90) == {"rate": 175, "pitch": 40, "volume": 90}


def test_viseme_targets_are_refused(take):
    visemes = take_from_utterance(take.utterance, fps=30.0, target="visemes")
    with pytest.raises(UserError, match="face rig"):
        with_nonverbal(visemes)
