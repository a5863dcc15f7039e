# SPDX-License-Identifier: GPL-3.0-or-later
"""Lip closures of a take and the closed-sample guarantee of the bakes (speech.closures, anim.semantic)."""
from __future__ import annotations

import numpy as np

from faces_hands_addon.anim.semantic import closure_frames, with_closures
from faces_hands_addon.speech.closures import lip_closures
from faces_hands_addon.speech.utterance import Phone


def _phones(*rows):
    return [Phone(symbol=p, phone=p, start=s, duration=d) for p, s, d in rows]


def test_p_closes_for_its_closure_share_m_throughout_and_runs_merge():
    from faces_hands_addon.speech.articulation import load_articulation
    share = load_articulation().closure_fraction
    spans = lip_closures(_phones(("p", 0.0, 0.1), ("aa", 0.1, 0.1), ("m", 0.2, 0.05), ("p", 0.25, 0.1),
                                 ("ah", 0.35, 0.1), ("t", 0.45, 0.05)))
    assert [(round(c.start, 6), round(c.end, 6)) for c in spans] == [(0.0, round(0.1 * share, 6)),
                                                                    (0.2, round(0.25 + 0.1 * share, 6))]
    assert {c.viseme for c in spans} == {"viseme_PP"}


def test_every_closure_gets_a_closed_frame_even_between_frames():
    frames = np.arange(0.0, 20.0)
    rows = closure_frames(frames, [(2.2, 4.9, "viseme_PP"), (7.3, 7.6, "viseme_PP"), (40.0, 41.0, "viseme_PP")])
    assert sorted(rows) == [3, 4, 7]            # inside; nearest the middle of a sub-frame closure; outside: none


def test_closure_rows_show_their_viseme_alone_and_keep_other_targets():
    names = ["viseme_PP", "viseme_aa", "viseme_kk", "mouthSmileLeft"]
    weights = np.array([[0.7, 0.3, 0.2, 0.5], [0.1, 0.9, 0.0, 0.5]])
    out = with_closures(weights, names, {0: "viseme_PP"})
    assert out[0].tolist() == [1.0, 0.0, 0.0, 0.5]
    assert out[1].tolist() == weights[1].tolist() and weights[0, 0] == 0.7     # other rows, input untouched
