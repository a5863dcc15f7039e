"""Blinks (thesis 4.2.1 "Punctuators and Manipulators", 4.3.5 "Eye blinks"): at pauses, and an extra blink
whenever 4.8 s would pass without one; closing 1/8 s, apex 1/24 s, opening 1/12 s."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.behavior import generate_behavior
from faces_hands_addon.behavior.prosody import phone_boundaries

from behavior_utterances import build, neutral_runs  # noqa: F401  (neutral_runs: a fixture)

THESIS_INTERVAL = 4.8
CLOSE, APEX, OPEN = 1 / 8, 1 / 24, 1 / 12


def _onsets(result):
    return np.array([e.start for e in result.of_kind("blink")])


def test_no_gap_between_blinks_exceeds_4_8_s(neutral_runs):
    for u, r in neutral_runs:
        onsets = _onsets(r)
        gaps = np.diff(np.concatenate([[0.0], onsets, [u.duration - (CLOSE + APEX + OPEN)]]))
        assert gaps.max() <= THESIS_INTERVAL + 1e-9
        assert np.diff(onsets).min() >= CLOSE + APEX + OPEN - 1e-9, "blinks do not overlap"


def test_speech_without_pauses_still_blinks_every_4_8_s():
    u, _ = build([(".", [["2"] * 80])])          # one 20 s phrase, no pause inside
    r = generate_behavior(u, seed=3)
    onsets = _onsets(r)
    assert len(onsets) >= int(np.ceil(u.duration / THESIS_INTERVAL)) - 1
    assert np.diff(np.concatenate([[0.0], onsets])).max() <= THESIS_INTERVAL + 1e-9
    assert {e.params["cause"] for e in r.of_kind("blink")} >= {"interval"}
    boundaries = phone_boundaries(u)
    on_boundary = [np.min(np.abs(boundaries - t)) < 1e-9 for t in onsets]
    assert np.mean(on_boundary) > 0.8, "extra blinks start at phoneme boundaries (4.2.1)"


def test_a_blink_starts_every_pause(neutral_runs):
    for u, r in neutral_runs[:20]:
        onsets = _onsets(r)
        for p in u.pauses:
            if p.kind != "leading" and p.duration >= 0.1 and p.start + CLOSE + APEX + OPEN <= u.duration:
                assert np.min(np.abs(onsets - p.start)) < 1e-9


def test_blink_phases_are_exactly_the_thesis_durations(neutral_runs):
    for u, r in neutral_runs[:5]:
        lid = r.tracks["eyelid_close_L"]
        for e in r.of_kind("blink"):
            assert e.params["closed"] - e.start == pytest.approx(CLOSE, abs=1e-9)
            assert e.params["opening"] - e.params["closed"] == pytest.approx(APEX, abs=1e-9)
            assert e.end - e.params["opening"] == pytest.approx(OPEN, abs=1e-9)
            # the curve: fully closed from 1/8 s after the onset for 1/24 s, not before, open again after
            assert lid.sample(e.params["closed"]) == pytest.approx(1.0)
            assert lid.sample(e.params["opening"]) == pytest.approx(1.0)
            assert lid.sample(e.start + 0.5 * CLOSE) < 0.9
            assert lid.sample(e.params["opening"] + 0.5 * OPEN) < 0.9
            assert lid.sample(e.end) < 0.5
        assert np.array_equal(lid.values, r.tracks["eyelid_close_R"].values), "both eyes blink"


def test_blinks_are_punctuators_at_pauses_mostly(neutral_runs):
    causes = [e.params["cause"] for _, r in neutral_runs for e in r.of_kind("blink")]
    assert causes.count("pause") > 10 * causes.count("interval")


def test_pauses_4_9_s_apart_get_one_extra_blink_between_them():
    """Pause blinks 4.9 s apart: just over the thesis' 4.8 s, so exactly one extra blink between each pair."""
    phrases = [["1"] * 19 for _ in range(6)]         # 19 syllables of 0.25 s, then a 0.15 s pause: 4.9 s
    u, _ = build([(".", phrases)], phrase_pause=0.15)
    r = generate_behavior(u, seed=0)
    pause_onsets = [e.start for e in r.of_kind("blink") if e.params["cause"] == "pause"]
    assert len(pause_onsets) == 6 and np.allclose(np.diff(pause_onsets), 4.9)
    extra = np.array([e.start for e in r.of_kind("blink") if e.params["cause"] == "interval"])
    for a, b in zip(pause_onsets, pause_onsets[1:]):
        assert np.sum((extra > a) & (extra < b)) == 1
    onsets = _onsets(r)
    assert np.diff(np.concatenate([[0.0], onsets])).max() <= THESIS_INTERVAL + 1e-9
