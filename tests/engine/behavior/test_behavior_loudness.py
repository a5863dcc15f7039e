"""Volume-controlled intensity (thesis 4.2.1): windowed power -> B-spline -> maxima -> a [0, 1] curve that
scales every parameter by its own weight, the jaw more than the brows."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.anim.tracks import Track, TrackSet
from faces_hands_addon.behavior.loudness import (LoudnessSettings, load_loudness_settings, loudness_curve,
                                                 scale_tracks, windowed_power)

RATE = 16000


def _syllables(seconds: float, amplitude_first: float, amplitude_second: float, seed: int = 0) -> np.ndarray:
    """Voiced 'syllables' (4 Hz amplitude modulation of a 140 Hz buzz + a little noise); the first half at
    one amplitude, the second at another."""
    t = np.arange(int(seconds * RATE)) / RATE
    buzz = np.sign(np.sin(2 * np.pi * 140 * t)) * 0.5 + np.random.default_rng(seed).normal(0, 0.05, t.size)
    syllable = np.clip(np.sin(2 * np.pi * 4 * t), 0, None) ** 2
    gain = np.where(t < seconds / 2, amplitude_first, amplitude_second)
    return (buzz * syllable * gain).astype(np.float32)


def test_the_louder_half_gives_the_larger_curve():
    curve = loudness_curve(_syllables(6.0, 0.05, 0.5), RATE)
    assert curve.values.min() >= 0.0 and curve.values.max() == pytest.approx(1.0)
    first = curve.sample(np.arange(0.5, 2.5, 0.05))
    second = curve.sample(np.arange(3.5, 5.5, 0.05))
    assert second.mean() > first.mean() + 0.4, (first.mean(), second.mean())   # 20 dB apart, 30 dB range
    assert np.all(second > 0.9)
    # the curve follows the maxima, not the gaps between syllables: flat within a half
    assert np.ptp(second) < 0.15
    assert len(curve.maxima) >= 16                   # ~ one maximum per syllable (4 per second)
    # the other way round
    flipped = loudness_curve(_syllables(6.0, 0.5, 0.05), RATE)
    assert flipped.sample(1.5) > flipped.sample(4.5) + 0.4


def test_weights_are_applied_per_parameter():
    settings = load_loudness_settings()
    assert settings.weight("jaw_open") > settings.weight("frontalis_inner_L") > 0.0
    assert settings.weight("eyelid_close_L") == 0.0
    curve = loudness_curve(_syllables(6.0, 0.05, 0.5), RATE, settings)
    times = np.linspace(0.0, 6.0, 61)
    tracks = TrackSet()
    for name in ("jaw_open", "frontalis_inner_L", "eyelid_close_L"):
        tracks.add(Track(name, times, np.full(times.size, 0.5)))
    scaled = scale_tracks(tracks, curve, settings, {"jaw_open": (0.0, 1.0)})
    quiet = 1.5
    jaw, brow, lid = (float(scaled[n].sample(quiet)) for n in ("jaw_open", "frontalis_inner_L", "eyelid_close_L"))
    expected = lambda w: 0.5 * (1 - w + w * curve.sample(quiet))      # noqa: E731
    assert jaw == pytest.approx(expected(settings.weight("jaw_open")))
    assert brow == pytest.approx(expected(settings.weight("frontalis_inner_L")))
    assert jaw < brow < lid == 0.5, "the jaw is scaled down more than the brows; the lids not at all"
    assert float(scaled["jaw_open"].sample(4.5)) == pytest.approx(0.5, abs=0.03)     # loud: almost unchanged


def test_first_matching_pattern_wins_and_bad_input_is_flat():
    settings = LoudnessSettings(weights=(("jaw_open", 0.9), ("jaw_*", 0.1)))
    assert settings.weight("jaw_open") == 0.9 and settings.weight("jaw_drop") == 0.1
    assert settings.weight("procerus") == 0.0
    flat = loudness_curve(np.zeros(50, dtype=np.float32), RATE)
    assert np.all(flat.values == 1.0)
    times, db = windowed_power(np.ones(RATE, dtype=np.float32) * 0.1, RATE)
    assert db == pytest.approx(np.full(times.size, -20.0), abs=1e-3)
