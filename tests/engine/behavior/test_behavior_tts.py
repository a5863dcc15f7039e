"""The rules on real synthesised speech (espeak-ng, as the speech tests use it): the thesis' own examples,
Figure 4.7 ("Hi! ;-) Can you show me the way to the conference hall? :-)") and Figure 4.4 ("I'd like to
tell you ...errr ... something!")."""
from __future__ import annotations

import math

import numpy as np
import pytest

from faces_hands_addon.behavior import channel_specs, generate_behavior
from faces_hands_addon.speech import espeak_available, synthesize

pytestmark = pytest.mark.skipif(not espeak_available(), reason="espeak-ng is not available")


@pytest.fixture(scope="module")
def figure_4_7():
    u = synthesize("Hi! ;-) Can you show me the way to the conference hall? :-)")
    return u, generate_behavior(u, seed=0)


def test_question_on_the_last_word_and_eye_contact_at_the_end(figure_4_7):
    u, r = figure_4_7
    (raise_,) = r.of_kind("question_raise")
    assert raise_.params["word"] == "hall"
    hall = u.words[-1]
    t = 0.5 * (hall.end + u.duration)              # in the pause after the question
    assert r.tracks["head.pitch"].sample(t) == pytest.approx(math.radians(3.0))
    assert r.tracks["frontalis_outer_L"].sample(t) >= 0.45 - 1e-9
    assert abs(r.tracks["eye_yaw"].sample(hall.end)) <= 0.036
    assert r.count("speaker_turn") == 1 and r.count("speaker_state") == 1


def test_blinks_punctuate_the_sentence_pause(figure_4_7):
    u, r = figure_4_7
    onsets = [e.start for e in r.of_kind("blink")]
    for p in u.pauses:
        if p.kind == "sentence":
            assert min(abs(t - p.start) for t in onsets) < 1e-9
    specs = channel_specs()
    for track in r.tracks:
        assert np.all(np.isfinite(track.values))
        assert specs[track.name].minimum <= track.values.min() and track.values.max() <= specs[track.name].maximum


def test_filled_pause_is_a_thinking_pause():
    u = synthesize("I'd like to tell you ... errr ... something!")
    r = generate_behavior(u, seed=2)
    errr = next(w for w in u.words if w.text == "errr")
    (thinking,) = r.of_kind("thinking")
    assert thinking.start <= errr.start and errr.end <= thinking.end and thinking.params["filled"]
    mid = 0.5 * (errr.start + errr.end)
    assert r.tracks["eye_yaw"].sample(mid) < -0.1
    assert abs(r.tracks["eye_pitch"].sample(mid)) > 0.3
