"""Lip moistening (thesis 4.2.1 "Punctuators and Manipulators"): a lick of the lips in the pause that best
matches the moistening interval during extended speech, slower in thinking pauses; seeded."""
from __future__ import annotations

import numpy as np

from faces_hands_addon.behavior import generate_behavior
from faces_hands_addon.behavior.styles import load_style

from behavior_utterances import build, long_monologue, monologues, neutral_runs  # noqa: F401


def _long_speech(seed=0, minutes=1.0):
    """Sentences of short phrases for about ``minutes`` minutes, some with a long (thinking) pause."""
    u, _ = long_monologue(seed, sentences=int(14 * minutes))
    return u


def test_licks_in_inner_pauses_of_long_speech_about_every_interval(neutral_runs):  # noqa: F811
    style = load_style("neutral")
    licks, spans = [], []
    for u, r in neutral_runs:
        events = r.of_kind("lick")
        for e in events:
            pause = next(p for p in u.pauses if p.start <= e.start and e.end <= p.end + 1e-9)
            assert pause.kind in ("word", "phrase", "sentence"), "a lick outside an inner pause"
            # during the lick no word is spoken, and the tongue comes out
            assert r.tracks["tongue_out"].sample(0.5 * (e.start + e.end)) > 0.3
            assert r.tracks["jaw_open"].sample(0.5 * (e.start + e.end)) > 0.05
        starts = [0.0] + [e.start for e in events]
        spans += list(np.diff(starts))
        licks.append(len(events))
    assert sum(licks) > 0.5 * len(neutral_runs)
    gaps = np.array(spans)
    assert np.all(gaps >= 0.5 * style.lick_interval_s * (1 - style.lick_jitter) - 1e-9)
    assert abs(np.median(gaps) - style.lick_interval_s) < 0.35 * style.lick_interval_s, np.median(gaps)
    # no lick in a short utterance
    short, _ = build([(".", [["2", "1"], ["3"]])])
    assert generate_behavior(short, seed=0).count("lick") == 0


def test_licks_are_slower_in_thinking_pauses():
    style = load_style("neutral")
    # one sentence after 14 s of speech ends in a long pause that is a thinking pause, the other does not
    fast_sentences = [(".", [["2", "2", "3", "1"], ["3", "2", "2"]]) for _ in range(6)]
    fast, _ = build(fast_sentences, sentence_pause=0.5)
    thinking, _ = build(fast_sentences, sentence_pause=1.3)
    fast_licks = [e for s in range(20) for e in generate_behavior(fast, seed=s).of_kind("lick")]
    slow_licks = [e for s in range(20) for e in generate_behavior(thinking, seed=s).of_kind("lick")]
    assert fast_licks and slow_licks
    assert all(not e.params["thinking"] and abs((e.end - e.start) - style.lick_s) < 1e-9 for e in fast_licks)
    assert all(e.params["thinking"] for e in slow_licks)
    assert min(e.end - e.start for e in slow_licks) > 1.5 * style.lick_s


def test_same_seed_same_licks_other_seed_other_licks():
    u = _long_speech(3, minutes=1.5)
    a = [(e.start, e.end) for e in generate_behavior(u, seed=7).of_kind("lick")]
    b = [(e.start, e.end) for e in generate_behavior(u, seed=7).of_kind("lick")]
    assert a == b and a
    others = {tuple((e.start, e.end) for e in generate_behavior(u, seed=s).of_kind("lick")) for s in range(8)}
    assert len(others) > 1
