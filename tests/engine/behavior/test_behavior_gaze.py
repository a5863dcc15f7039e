"""Gaze, brows and head at questions, accents, thinking pauses and turn-taking (thesis 4.3.5), gaze jitter
with the lids following (4.2.1 "Random Eye Movement", 4.3.5 "Gaze")."""
from __future__ import annotations

import math

import numpy as np
import pytest

from behavior_utterances import neutral_runs  # noqa: F401  (fixtures)

JITTER = 0.07 + 1e-6         # the neutral style's jitter range (eye_yaw / eye_pitch units)


def _at(result, name, time):
    return float(result.tracks[name].sample(time))


def test_question_eyes_on_listener_brows_and_head_raised_on_last_word(neutral_runs):
    checked = 0
    for u, r in neutral_runs[:20]:
        for s in u.sentences:
            if s.kind != "question":
                continue
            last = u.words[s.last_word]
            nxt = u.words[s.last_word + 1].start if s.last_word + 1 < len(u.words) else u.duration
            for t in np.linspace(last.start + 0.6 * (last.end - last.start), nxt - 0.03, 6):
                assert abs(_at(r, "eye_yaw", t)) <= JITTER and abs(_at(r, "eye_pitch", t)) <= JITTER
                assert _at(r, "frontalis_inner_L", t) >= 0.45 - 1e-9 and _at(r, "frontalis_outer_R", t) >= 0.45 - 1e-9
                assert _at(r, "head.pitch", t) >= math.radians(3.0) - 1e-9
            before = last.start - 0.05
            assert _at(r, "head.pitch", before) < math.radians(3.0) or _at(r, "frontalis_outer_R", before) < 0.45
            checked += 1
    assert checked >= 60


def test_accent_glances_look_at_the_listener(neutral_runs):
    for u, r in neutral_runs[:10]:
        for e in r.of_kind("accent_glance"):
            mid = 0.5 * (e.start + e.params["syllable_end"])
            assert abs(_at(r, "eye_yaw", mid)) <= JITTER


def test_gaze_never_moves_away_during_an_accent(neutral_runs):
    for u, r in neutral_runs[:20]:
        yaw, pitch = r.tracks["eye_yaw"], r.tracks["eye_pitch"]
        for s in u.accented_syllables:
            # after a saccade (0.05 s) begun before it, up to one sample (10 ms) before its end
            times = np.linspace(s.start + 0.05, s.end - 0.01, 12)
            distance = np.hypot(yaw.sample(times), pitch.sample(times))
            assert np.all(np.diff(distance) <= 1e-9), f"gaze moved away during the accent at {s.start:.2f} s"


def test_thinking_looks_up_with_brows_or_down_with_a_frown_and_to_the_right(neutral_runs):
    for u, r in neutral_runs[:20]:
        for e in r.of_kind("thinking"):
            mid = 0.5 * (e.start + e.end)
            assert _at(r, "eye_yaw", mid) < -0.1, "gaze shifted to the character's right"
            if e.params["mode"] == "up":
                assert _at(r, "eye_pitch", mid) > 0.3 and _at(r, "frontalis_inner_L", mid) >= 0.4 - 1e-9
                assert _at(r, "corrugator_supercilii_L", mid) == 0.0
            else:
                assert _at(r, "eye_pitch", mid) < -0.3 and _at(r, "corrugator_supercilii_R", mid) > 0.2
                assert _at(r, "eyelid_close_L", mid) > 0.05, "the lids follow the downward gaze"


def test_within_turn_glances_look_at_the_listener_during_the_pause(neutral_runs):
    for u, r in neutral_runs[:10]:
        for e in r.of_kind("within_turn_glance"):
            mid = e.start + 0.5 * min(e.end - e.start, 0.3)
            assert abs(_at(r, "eye_yaw", mid)) <= JITTER and abs(_at(r, "eye_pitch", mid)) <= JITTER


def test_speaker_state_at_the_start_and_speaker_turn_at_the_end(neutral_runs):
    for u, r in neutral_runs[:20]:
        (state,) = r.of_kind("speaker_state")
        first = u.words[0].start
        assert abs(_at(r, "eye_yaw", 0.5 * first)) >= 0.22 - JITTER, "gaze averted before speaking"
        assert abs(_at(r, "head.yaw", first)) == pytest.approx(math.radians(5.0)), "head turned away"
        assert np.sign(_at(r, "head.yaw", first)) == np.sign(_at(r, "eye_yaw", 0.5 * first))
        assert _at(r, "head.yaw", state.end + 0.5) == 0.0
        (turn,) = r.of_kind("speaker_turn")
        assert turn.end == pytest.approx(u.duration)
        for t in np.linspace(u.words[-1].start + 0.1, u.duration, 5):
            assert abs(_at(r, "eye_yaw", t)) <= JITTER and abs(_at(r, "eye_pitch", t)) <= JITTER


def test_statements_do_not_look_at_the_listener_all_the_time(neutral_runs):
    u, r = neutral_runs[0]
    yaw = r.tracks["eye_yaw"].values
    assert np.mean(np.abs(yaw) > 0.1) > 0.1


def test_gaze_jitter_is_small_and_never_erratic(neutral_runs):
    for u, r in neutral_runs[:20]:
        jitter = r.of_kind("gaze_jitter")
        assert len(jitter) > u.duration / 0.9 - 2
        offsets = np.array([(e.params["yaw"], e.params["pitch"]) for e in jitter])
        assert np.abs(offsets).max() <= 0.07 + 1e-12
        steps = np.abs(np.diff(np.vstack([[0.0, 0.0], offsets]), axis=0))
        assert steps.max() <= 0.045 + 1e-12
        assert 0.35 - 1e-9 <= np.diff([e.start for e in jitter]).min()
        for e in jitter:
            assert not any(s.start < e.start < s.end for s in u.accented_syllables)
        # the eyes are never still for long: some movement in every 2 s window of an utterance
        yaw = r.tracks["eye_yaw"]
        for t0 in np.arange(0, u.duration - 2.0, 2.0):
            window = yaw.sample(np.linspace(t0, t0 + 2.0, 200))
            assert np.ptp(window) > 1e-3


def test_lids_follow_downward_gaze_outside_blinks(neutral_runs):
    u, r = neutral_runs[0]
    grid = r.tracks["eye_pitch"].times
    blinking = np.zeros(grid.shape, bool)
    for e in r.of_kind("blink"):
        blinking |= (grid >= e.start) & (grid <= e.end)
    pitch = r.tracks["eye_pitch"].values
    lids = r.tracks["eyelid_close_L"].values
    down = (pitch < -0.2) & ~blinking
    level = (np.abs(pitch) < 0.02) & ~blinking & (r.tracks["head.pitch"].values == 0.0)
    assert down.sum() > 20 and level.sum() > 20
    assert lids[down].min() > lids[level].max()
