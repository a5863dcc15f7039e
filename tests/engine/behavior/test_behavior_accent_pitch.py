"""From text, the head and brows rise on the accented words (thesis 4.3.5 "Expressions linked to
intonation": the pitch extrema come from "the intonation information provided by the TTS system", whose
accents sit on content words, 4.3.2). espeak-ng's tracked contour alone put the one maximum of the thesis
example (Figure 4.7) on "show" at 1.11 s and none on "conference"."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.behavior import generate_behavior, pitch_extrema
from faces_hands_addon.behavior.prosody import accent_extrema
from faces_hands_addon.speech import espeak_available, synthesize

EXAMPLE = "Hi! ;-) Can you show me the way to the conference hall? :-)"


def _declining_contour():
    """A phrase-initial rise then declination, with sub-semitone accent bumps at 1.0 s and 2.0 s."""
    times = np.arange(0.0, 3.0, 0.01)
    hz = 120.0 - 8.0 * times + 14.0 * np.exp(-((times - 0.4) / 0.12) ** 2)
    for centre in (1.0, 2.0):
        hz += 3.0 * np.exp(-((times - centre) / 0.06) ** 2)
    return times, hz


def test_accent_bumps_on_a_declination_line_are_maxima():
    times, hz = _declining_contour()
    accents = np.array([[0.3, 0.5], [0.9, 1.1], [1.9, 2.1]])
    spline_maxima = [e.time for e in pitch_extrema(times, hz, 1.0) if e.kind == "max"]
    assert not any(1.9 <= t <= 2.1 for t in spline_maxima), "the B-spline path should miss the small bump"
    extrema = accent_extrema(times, hz, accents)
    maxima = [e for e in extrema if e.kind == "max"]
    assert [round(e.time, 2) for e in maxima] == [0.4, 1.0, 2.0]
    assert [e.kind for e in extrema] == ["min", "max", "min", "max", "min", "max", "min"]
    # proportional to the excursion above the declination line: the late bump rises as the early one
    assert maxima[0].level > maxima[1].level > 0.2 and abs(maxima[2].level - maxima[1].level) < 0.15
    # an unvoiced accent gives no maximum
    hz[(times >= 1.9) & (times <= 2.1)] = np.nan
    assert len([e for e in accent_extrema(times, hz, accents) if e.kind == "max"]) == 2


@pytest.mark.skipif(not espeak_available(), reason="espeak-ng is not available")
def test_head_and_brows_rise_on_conference_in_the_thesis_example():
    u = synthesize(EXAMPLE)
    conference = next(w for w in u.words if w.text.lower() == "conference")
    head_on, brow_on = 0, 0
    seeds = range(20)
    for seed in seeds:
        r = generate_behavior(u, seed=seed)
        peaks = [e.params["peak"] for e in r.of_kind("head_raise")]
        head_on += any(conference.start <= p <= conference.end for p in peaks)
        brows = [e.params["peak"] for e in r.of_kind("brow_raise")]
        brow_on += any(conference.start <= p <= conference.end for p in brows)
    assert head_on == len(seeds), "the head rises at every pitch maximum (head_raise_probability 1)"
    assert 0.45 <= brow_on / len(seeds) <= 0.95, f"brows on 'conference' in {brow_on} of 20 seeds (p = 0.71)"
    r = generate_behavior(u, seed=0)
    mid = 0.5 * (conference.start + conference.end)
    peak = next(e for e in r.of_kind("head_raise") if conference.start <= e.params["peak"] <= conference.end)
    assert r.tracks["head.pitch"].sample(peak.params["peak"]) > 0.4 * np.radians(3.0)
    assert r.tracks["head.pitch"].sample(mid) > 0.0
