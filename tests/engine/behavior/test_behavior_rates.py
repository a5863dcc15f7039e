"""Thesis 4.3.5 / 4.2.1 rates, measured over many seeds and utterances: brow raises at 0.71 of the pitch
maxima, sideways tilts in ~75 % of head raises, glances at 70 % of accents and of phrase-boundary pauses,
frowns in 25 % of thinking pauses, head raises of at most ~3 degrees in proportion to the pitch."""
from __future__ import annotations

import math

import numpy as np
import pytest

from faces_hands_addon.behavior import pitch_extrema

from behavior_utterances import monologues, neutral_runs  # noqa: F401  (fixtures)


def _rate(runs, kind, candidates):
    hits = sum(r.count(kind) for _, r in runs)
    total = sum(candidates(u, r) for u, r in runs)
    assert total > 300, f"too few candidates ({total}) for a rate"
    return hits / total


def test_every_accent_peak_is_found_as_a_pitch_maximum(monologues):
    for u, peaks in monologues[:10]:
        maxima = [e for e in pitch_extrema(u.pitch.times, u.pitch.f0_hz, 1.0) if e.kind == "max"]
        assert len(maxima) == len(peaks)
        assert np.allclose([m.time for m in maxima], [t for t, _ in peaks], atol=0.04)


def test_pitch_extrema_ignore_small_wiggles():
    times = np.arange(0, 3, 0.01)
    f0 = 120 * 2 ** (0.3 * np.sin(2 * np.pi * 2 * times) / 12)    # +-0.3 semitone melody: not prominent
    assert [e for e in pitch_extrema(times, f0, 1.0) if e.kind == "max"] == []
    f0 = 120 * 2 ** (3.0 * np.sin(2 * np.pi * 1 * times) / 12)    # +-3 semitones: 3 maxima in 3 s
    assert len([e for e in pitch_extrema(times, f0, 1.0) if e.kind == "max"]) == 3


def test_brow_raise_at_071_of_pitch_maxima(neutral_runs):
    rate = _rate(neutral_runs, "brow_raise", lambda u, r: r.count("pitch_max"))
    assert rate == pytest.approx(0.71, abs=0.03)


def test_head_raises_at_every_maximum_and_tilts_in_75_percent(neutral_runs):
    assert all(r.count("head_raise") == r.count("pitch_max") for _, r in neutral_runs)
    raises = [e for _, r in neutral_runs for e in r.of_kind("head_raise")]
    tilted = np.mean([e.params["tilt_rad"] != 0.0 for e in raises])
    assert tilted == pytest.approx(0.75, abs=0.03)
    tilts = np.array([e.params["tilt_rad"] for e in raises if e.params["tilt_rad"] != 0.0])
    assert 0.35 < np.mean(tilts > 0) < 0.65, "tilts go to both sides"
    assert np.abs(tilts).max() <= math.radians(2.0) + 1e-12, "the tilt is slight"


def test_head_raise_is_at_most_3_degrees_and_proportional_to_pitch(neutral_runs):
    raises = [e for _, r in neutral_runs for e in r.of_kind("head_raise")]
    amounts = np.array([e.params["pitch_rad"] for e in raises])
    hz = np.array([e.params["hz"] for e in raises])
    assert amounts.max() <= math.radians(3.0) + 1e-12
    assert amounts.max() > math.radians(2.0)
    assert np.corrcoef(amounts, hz)[0, 1] > 0.95
    for _, r in neutral_runs[:10]:      # the curve too: pitch raises and question raises stay within ~3 deg
        assert r.tracks["head.pitch"].values.max() <= math.radians(3.0) + 1e-9


def test_head_returns_to_rest_between_maxima(neutral_runs):
    u, r = neutral_runs[0]
    track = r.tracks["head.pitch"]
    questions = [(e.start, e.end + 0.2) for e in r.of_kind("question_raise")]
    thinking = [(e.start, e.end) for e in r.of_kind("thinking")]
    for e in r.of_kind("head_raise"):
        if any(a <= e.end <= b for a, b in questions + thinking):
            continue
        assert track.sample(e.end) == pytest.approx(0.0, abs=1e-9)
        assert track.sample(e.params["peak"]) == pytest.approx(e.params["pitch_rad"], abs=1e-9) or \
            any(a <= e.params["peak"] <= b for a, b in questions + thinking)


def test_left_brow_follows_pitch_right_brow_constant(neutral_runs):
    brows = [e for _, r in neutral_runs for e in r.of_kind("brow_raise")]
    left = np.array([e.params["left"] for e in brows])
    right = np.array([e.params["right"] for e in brows])
    hz = np.array([e.params["hz"] for e in brows])
    assert np.ptp(right) == 0.0 and right[0] > 0
    assert np.corrcoef(left, hz)[0, 1] > 0.95


def test_glance_at_70_percent_of_accented_syllables(neutral_runs):
    rate = _rate(neutral_runs, "accent_glance", lambda u, r: len(u.accented_syllables))
    assert rate == pytest.approx(0.70, abs=0.03)
    for u, r in neutral_runs:
        assert r.count("accent_glance") + r.count("accent_hold") == len(u.accented_syllables)


def test_within_turn_glance_at_70_percent_of_phrase_boundary_pauses(neutral_runs):
    def candidates(u, r):
        thinking = [(e.start, e.end) for e in r.of_kind("thinking")]
        return sum(1 for p in u.pauses if p.kind in ("phrase", "sentence")
                   and not any(a < p.end and p.start < b for a, b in thinking))
    rate = _rate(neutral_runs, "within_turn_glance", candidates)
    assert rate == pytest.approx(0.70, abs=0.04)


def test_frown_in_25_percent_of_thinking_pauses(neutral_runs):
    thinking = [e for _, r in neutral_runs for e in r.of_kind("thinking")]
    assert len(thinking) > 500
    assert np.mean([e.params["mode"] == "down" for e in thinking]) == pytest.approx(0.25, abs=0.03)
    assert any(e.params["filled"] for e in thinking) and not all(e.params["filled"] for e in thinking)


def test_thinking_happens_in_every_long_and_filled_pause(neutral_runs):
    for u, r in neutral_runs[:10]:
        spans = [(e.start, e.end) for e in r.of_kind("thinking")]
        for p in u.pauses:
            if p.kind in ("word", "phrase", "sentence") and p.duration >= 0.6:
                assert any(a <= p.start and p.end <= b for a, b in spans)
            elif p.kind in ("word", "phrase", "sentence") and p.duration < 0.6:
                assert not any(a <= p.start and p.end <= b for a, b in spans) or \
                    any(w.text == "errr" and abs(w.end - p.start) < 1e-9 for w in u.words)
        for w in u.words:
            if w.text == "errr":
                assert any(a <= w.start and w.end <= b for a, b in spans)
