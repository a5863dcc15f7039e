"""Cohen-Massaro coarticulation with the MEDUSA extensions (thesis 3.1.3) and the track API."""
from __future__ import annotations

import json

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.anim import Track, TrackSet
from faces_hands_addon.speech import (coarticulate, load_articulation, load_target_set,
                                      load_viseme_targets, synthesize)
from faces_hands_addon.core.presets import SHIPPED_FOLDER
from faces_hands_addon.speech.articulation import compile_target_set

MUSCLES = load_articulation()
VISEMES = load_viseme_targets()


def _value(result, parameter, time_):
    p = result.parameters.index(parameter)
    return float(np.interp(time_, result.times, result.values[p]))


def _target(parameter, phone, targets=MUSCLES):
    return float(targets.targets[targets.row_of[phone], targets.parameters.index(parameter)])


def _random_segments(rng, count):
    phones = ["sil", "aa", "b", "iy", "m", "uw", "f", "t", "s", "k", "ow", "p", "v", "eh", "l", "ay", "sh"]
    durations = rng.uniform(0.03, 0.2, count)
    starts = np.concatenate([[0.0], np.cumsum(durations)[:-1]])
    return [(str(rng.choice(phones)), float(s), float(d)) for s, d in zip(starts, durations)]


def test_windowed_sum_equals_full_sum():
    """3.1.3 'Speed-up': 11 neighbours + Hermite fade in the 12th changes F_p by less than 1e-3."""
    rng = np.random.default_rng(4)
    for targets in (MUSCLES, VISEMES):
        segments = _random_segments(rng, 120)
        dense = np.linspace(0, segments[-1][1] + segments[-1][2], 3000)
        windowed = coarticulate(segments, targets, times=dense)
        full = coarticulate(segments, targets, times=dense, window=None)
        assert np.abs(windowed.values - full.values).max() < 1e-3
    u = synthesize("Can you show me the way to the conference hall? Peter Piper picked a peck of pickled peppers.")
    windowed = coarticulate(u, MUSCLES, fps=60)
    full = coarticulate(u, MUSCLES, times=windowed.times, window=None)
    assert np.abs(windowed.values - full.values).max() < 1e-3


def test_windowed_curve_is_continuous():
    segments = _random_segments(np.random.default_rng(7), 60)
    dense = np.linspace(0, segments[-1][1] + segments[-1][2], 40000)
    values = coarticulate(segments, MUSCLES, times=dense).values
    assert np.abs(np.diff(values, axis=1)).max() < 0.05  # no jumps at segment boundaries


@pytest.mark.parametrize("stop", ["b", "p"])
def test_bilabial_closure_reaches_target_at_its_key_frame(stop):
    segments = [("sil", 0.0, 0.2), ("aa", 0.2, 0.14), (stop, 0.34, 0.09), ("aa", 0.43, 0.15),
                ("sil", 0.58, 0.3)]
    result = coarticulate(segments, MUSCLES, fps=30)
    closure_start = 0.34
    release_start = 0.34 + 0.09 * MUSCLES.closure_fraction
    assert np.isclose(result.key_times, closure_start).any()
    assert np.isclose(result.key_times, release_start).any()
    assert np.isclose(result.key_times, 0.43).any()  # next phoneme
    k = int(np.argmin(np.abs(result.times - closure_start)))
    assert result.times[k] == pytest.approx(closure_start)
    for parameter in ("orbicularis_oris_upper", "orbicularis_oris_lower"):  # lips closed: within 2 %
        target = _target(parameter, stop)
        assert result.values[result.parameters.index(parameter), k] == pytest.approx(target, rel=0.02)
    jaw = result.values[result.parameters.index("jaw_open"), k]  # jaw nearly closed: 2 % of its range
    assert jaw == pytest.approx(_target("jaw_open", stop), abs=0.02)
    # viseme target set: viseme_PP dominates the closure key frame
    visemes = coarticulate(segments, VISEMES, fps=30)
    k = int(np.argmin(np.abs(visemes.times - closure_start)))
    assert visemes.values[visemes.parameters.index("viseme_PP"), k] >= 0.98


def test_closure_like_phones_m_f_v_reach_their_targets():
    for phone, parameter in (("m", "orbicularis_oris_upper"), ("f", "orbicularis_oris_lower"),
                             ("v", "mentalis_L")):
        segments = [("sil", 0.0, 0.2), ("eh", 0.2, 0.12), (phone, 0.32, 0.08), ("ih", 0.40, 0.12),
                    ("sil", 0.52, 0.3)]
        result = coarticulate(segments, MUSCLES, fps=25)
        assert np.isclose(result.key_times, 0.32).any() and np.isclose(result.key_times, 0.40).any()
        assert _value(result, parameter, 0.32) == pytest.approx(_target(parameter, phone), abs=0.02)
        # no equidistant frame inside the closure: the next key is the next phoneme
        assert not ((result.times > 0.32 + 1e-9) & (result.times < 0.40 - 1e-9)).any()


@pytest.mark.parametrize("duration", [0.04, 0.08, 0.15, 0.3])
def test_closures_hold_from_key_to_key_and_release_their_neighbours(duration):
    """A closure of any length is closed at its first and last key frame ("alpha_at": "edges"), and
    an ordinary vowel next to it is not swallowed."""
    segments = [("sil", 0.0, 0.2), ("aa", 0.2, 0.09), ("m", 0.29, duration), ("iy", 0.29 + duration, 0.09),
                ("sil", 0.38 + duration, 0.3)]
    result = coarticulate(segments, MUSCLES, times=[0.29, 0.29 + duration, 0.245, 0.335 + duration])
    lips = dict(zip(result.times, result.values[result.parameters.index("orbicularis_oris_upper")]))
    closed = _target("orbicularis_oris_upper", "m")
    assert lips[0.29] == pytest.approx(closed, rel=0.03)
    assert lips[0.29 + duration] == pytest.approx(closed, rel=0.03)
    assert lips[0.245] < 0.35 * closed and lips[0.335 + duration] < 0.35 * closed  # vowel centres


def test_long_vowel_reaches_target_short_vowel_is_undershot():
    def peak_jaw(duration):
        segments = [("sil", 0.0, 0.3), ("t", 0.3, 0.06), ("aa", 0.36, duration), ("t", 0.36 + duration, 0.06),
                    ("sil", 0.42 + duration, 0.3)]
        result = coarticulate(segments, MUSCLES, times=np.linspace(0, 0.72 + duration, 2000))
        return result.values[result.parameters.index("jaw_open")].max()
    target = _target("jaw_open", "aa")
    assert peak_jaw(0.30) == pytest.approx(target, rel=0.05)
    assert peak_jaw(0.05) < 0.8 * target
    assert peak_jaw(0.05) < peak_jaw(0.10) < peak_jaw(0.30)


def test_rounding_anticipated_through_a_neutral_consonant():
    """/k/ gives no lip target, so it takes the protrusion of the following /u/ (coarticulation)."""
    result = coarticulate([("sil", 0, 0.2), ("iy", 0.2, 0.12), ("k", 0.32, 0.07), ("uw", 0.39, 0.15),
                           ("sil", 0.54, 0.3)], MUSCLES, times=[0.355, 0.26])
    protrusion = result.values[result.parameters.index("orbicularis_oris_protrusion")]
    # times come back sorted: (0.26 = middle of /i/, 0.355 = middle of /k/)
    assert protrusion[0] < 0.0 < 0.1 < protrusion[1]


def test_viseme_weights_partition_unity_and_follow_phones():
    u = synthesize("Can you show me the way to the conference hall?")
    result = coarticulate(u, VISEMES, fps=30)
    assert np.allclose(result.values.sum(axis=0), 1.0)
    for phone in u.phones:
        if phone.phone in ("ow", "ey") and phone.duration > 0.1:
            middle = phone.start + 0.3 * phone.duration
            viseme = "viseme_oh" if phone.phone == "ow" else "viseme_E"
            weights = {v: _value(result, v, middle) for v in result.parameters}
            assert max(weights, key=weights.get) == viseme


def test_frame_grid_and_tracks():
    u = synthesize("Bob met a pop star.")
    result = coarticulate(u, MUSCLES, fps=24)
    times = result.times
    assert np.all(np.diff(times) > 0) and times[0] == 0.0
    on_grid = np.isclose(times * 24, np.round(times * 24))
    assert set(result.key_times) <= set(times)
    assert on_grid[~np.isin(times, result.key_times)].all()  # everything but closure keys is on a frame
    tracks = result.tracks
    assert set(tracks.names) == set(MUSCLES.parameters)
    jaw = tracks["jaw_open"]
    assert jaw.values.min() >= 0.0 and jaw.values.max() <= 1.0
    resampled = tracks.resample(30)
    assert np.allclose(np.diff(resampled["jaw_open"].times), 1 / 30)


def test_thirty_seconds_of_tracks_stay_in_range():
    segments = _random_segments(np.random.default_rng(1), 420)  # ~ 30 s of phones
    assert segments[-1][1] > 25
    for target in (MUSCLES, VISEMES):
        result = coarticulate(segments, target, fps=60)
        assert result.times[-1] >= segments[-1][1] and np.isfinite(result.values).all()
        assert np.abs(result.values).max() <= 1 + 1e-9


def test_track_api():
    a = Track("jaw_open", [0.0, 1.0], [0.0, 1.0])
    b = Track("jaw_open", [0.5, 1.5], [1.0, 1.0])
    c = Track("tongue_out", [0.0], [0.3])
    merged = TrackSet({"jaw_open": a}).merged(TrackSet({"jaw_open": b, "tongue_out": c}))
    assert np.allclose(merged["jaw_open"].sample([0.0, 0.5, 1.0]), [1.0, 1.5, 2.0])
    assert "tongue_out" in merged
    assert np.allclose(a.frames(24, start_frame=1), [1, 25])
    with pytest.raises(UserError):
        Track("x", [0.0, 0.0], [1.0, 2.0])
    with pytest.raises(UserError):
        TrackSet({"jaw_open": c})
    with pytest.raises(UserError):
        coarticulate([], MUSCLES)
    with pytest.raises(UserError, match="unknown phone"):
        coarticulate([("zz", 0, 0.1)], MUSCLES)


def _preset():
    return json.loads((SHIPPED_FOLDER / "speech" / "articulation.json").read_text(encoding="utf-8"))


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["classes"]["open"]["targets"].update({"jaw_opne": 0.5}), "unknown parameter 'jaw_opne'"),
    (lambda d: d["classes"]["open"]["phones"].append("zz"), "unknown phone 'zz'"),
    (lambda d: d["classes"]["open"]["phones"].append("p"), "is in classes"),
    (lambda d: d["classes"]["open"]["targets"].update({"jaw_open": 2.0}), "at most 1"),
    (lambda d: d["classes"]["open"].update({"dominance": {"alpha": -1}}), "at least 0"),
    (lambda d: d["classes"]["open"].update({"dominance": {"c": 0}}), "greater than 0"),
    (lambda d: d["classes"].pop("velar"), "no class for the phones k, g, ng, x"),
    (lambda d: d.update({"version": 7}), "unsupported version"),
])
def test_preset_validation(edit, message):
    data = _preset()
    edit(data)
    with pytest.raises(UserError, match=message):
        compile_target_set(data, "articulation.json")


def test_preset_file_errors(tmp_path):
    broken = tmp_path / "broken.json"
    broken.write_text("{ not json", encoding="utf-8")
    with pytest.raises(UserError, match="not valid JSON"):
        load_target_set(broken)
    with pytest.raises(UserError, match="does not exist"):
        load_target_set(tmp_path / "missing.json")
    edited = _preset()
    edited["classes"]["open"]["targets"]["jaw_open"] = 0.5  # an artist's edit is picked up
    path = tmp_path / "mine.json"
    path.write_text(json.dumps(edited), encoding="utf-8")
    assert _target("jaw_open", "aa", load_articulation(path)) == 0.5
