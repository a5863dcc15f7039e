"""Emotions in the voice (thesis 4.4.2, Table 4.5): every prosodic parameter changes from neutral by
coefficient x dimension percent ("0.5% linking activation to rate means that for an activation level of +50,
rate increases by +25%, while for an activation level of -30, rate decreases by -15%"), in espeak-ng units."""
from __future__ import annotations

import inspect

import pytest

from faces_hands_addon.emotion import voice_for
from faces_hands_addon.speech import synthesize


def test_rate_follows_the_worked_example_of_the_thesis():
    assert voice_for((50, 0, 0)).changes["rate"] == pytest.approx(25.0)
    assert voice_for((50, 0, 0)).rate == pytest.approx(175 * 1.25)
    assert voice_for((-30, 0, 0)).changes["rate"] == pytest.approx(-15.0)
    assert voice_for((-30, 0, 0)).rate == pytest.approx(175 * 0.85)
    assert voice_for((0, 50, 0)).rate == pytest.approx(175 * 1.10)        # evaluation 0.2 %


def test_every_row_of_table_4_5():
    changes = voice_for((10, 20, 30)).changes
    expected = {  # coefficients (activation, evaluation, power) of Table 4.5 applied to (10, 20, 30)
        "pitch": 0.3 * 10 + 0.1 * 20 - 0.1 * 30, "pitch-dynamics": 0.3 * 10 - 0.3 * 30, "range": 0.4 * 10,
        "range-dynamics": 1.2 * 10 + 0.4 * 30, "accent-prominence": 0.5 * 10 - 0.5 * 20,
        "accent-slope": 1.0 * 10 - 0.5 * 20, "rate": 0.5 * 10 + 0.2 * 20, "number-of-pauses": 0.7 * 10,
        "pause-duration": -0.2 * 10, "vowel-duration": 0.3 * 20 + 0.3 * 30, "nasal-duration": 0.3 * 20 + 0.3 * 30,
        "liquid-duration": 0.3 * 20 + 0.3 * 30, "plosive-duration": 0.5 * 10 - 0.3 * 20,
        "fricative-duration": 0.5 * 10 - 0.3 * 20, "volume": 0.33 * 10,
    }
    assert set(changes) == set(expected)
    for name, value in expected.items():
        assert changes[name] == pytest.approx(value), name


def test_espeak_units():
    voice = voice_for((50, 0, 0))
    assert voice.pitch == pytest.approx(50 + 15)           # +15 % base pitch, ~1 espeak unit per percent
    assert voice.range == pytest.approx(50 * 1.20)         # +20 % range on espeak's 0..100 (50 neutral)
    assert voice.volume == pytest.approx(100 * 1.165)      # +16.5 % volume, espeak percent
    assert voice.pause_count == pytest.approx(1.35) and voice.pause_duration == pytest.approx(0.90)
    assert voice_for((0, 0, 0)).synthesize_kwargs() == {"rate": 175.0, "pitch": 50.0, "volume": 100.0}
    durations = voice_for((50, 50, -20)).durations
    assert durations["vowel"] == pytest.approx(1.09) and durations["plosive"] == pytest.approx(1.10)


def test_settings_fit_what_synthesize_takes():
    accepted = set(inspect.signature(synthesize).parameters)
    for emotion in ("hate", "fear", "surprise", (100, 100, -100), (-100, -100, 100)):
        voice = voice_for(emotion)
        assert set(voice.synthesize_kwargs()) <= accepted
        assert 80 <= voice.rate <= 450 and 0 <= voice.pitch <= 100 and 0 <= voice.volume <= 200
        assert 0 <= voice.range <= 100


def test_words_use_their_table_coordinates():
    anger = voice_for("anger")                              # Table 4.4: 34.0, -35.6, 20.0
    assert anger == voice_for((34.0, -35.6, 20.0))
    assert anger.rate == pytest.approx(175 * (1 + (0.5 * 34.0 + 0.2 * -35.6) / 100))
    assert anger.pitch == pytest.approx(50 + 0.3 * 34.0 + 0.1 * -35.6 - 0.1 * 20.0)


@pytest.mark.parametrize("evaluation, shape", [(-20.0, "falling"), (-19.9, "rising"), (40.0, "rising"),
                                               (40.1, "alternating")])
def test_preferred_accent_shape(evaluation, shape):
    assert voice_for((0, evaluation, 0)).accent_shape == shape


def test_preferred_boundary_type():
    assert voice_for((0, 0, 0)).boundary_type == "high"
    assert voice_for((0, 0, 0.5)).boundary_type == "low"
