# SPDX-License-Identifier: GPL-3.0-or-later
"""Free phone recognition beside the forced alignment (speech.phone_loop): the child process gives the same
paths as decoding here, and a child that cannot start or dies leaves the parent to decode itself."""
from __future__ import annotations

from pathlib import Path

import pytest
import soundfile

from faces_hands_addon.speech import phone_loop
from faces_hands_addon.speech.audio import to_int16

WAV = Path(__file__).resolve().parents[2] / "data" / "transcript_check" / "slt_bring_the_blue_basket.wav"


@pytest.fixture(scope="module")
def pcm():
    samples, rate = soundfile.read(WAV, dtype="float64")
    assert rate == 16000
    return to_int16(samples).tobytes()


@pytest.fixture(scope="module")
def ps():
    return pytest.importorskip("pocketsphinx")


def test_the_child_decodes_exactly_as_this_process(ps, pcm):
    runs = [{}, {"lw": 1.0}]
    with phone_loop.PhoneLoops(ps, pcm, runs) as loops:
        assert loops._child is not None                          # it really ran beside us
        paths = [loops.result(1), loops.result(0)]               # in any order
    assert paths == [phone_loop.decode(ps, pcm, lw=1.0), phone_loop.decode(ps, pcm)]
    assert len(paths[0]) > 10 and all(isinstance(seg, tuple) and len(seg) == 4 for seg in paths[0])


def test_no_child_or_a_dead_one_leaves_the_decodes_to_the_parent(ps, pcm, monkeypatch):
    expected = phone_loop.decode(ps, pcm)
    monkeypatch.setattr(phone_loop.sys, "executable", "/nonexistent/python")
    with phone_loop.PhoneLoops(ps, pcm, [{}]) as loops:
        assert loops._child is None and loops.result(0) == expected
    monkeypatch.undo()
    loops = phone_loop.PhoneLoops(ps, pcm, [{}, {"lw": 1.0}])
    loops._child.kill()                                          # dies before it writes anything
    assert loops.result(0) == expected and loops._child is None
    loops.close()
