"""Determinism, bounds, the behavior layer and character styles (4.2.2)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.anim.layers import mix
from faces_hands_addon.anim.tracks import TrackSet
from faces_hands_addon.behavior import CharacterStyle, channel_specs, generate_behavior, load_style, style_names
from faces_hands_addon.core import presets
from faces_hands_addon.face.controls import control_specs

from behavior_utterances import monologues, neutral_runs  # noqa: F401  (fixtures)

FACE_MUSCLES = ["frontalis_inner_L", "frontalis_inner_R", "frontalis_outer_L", "frontalis_outer_R",
                "corrugator_supercilii_L", "corrugator_supercilii_R", "procerus", "orbicularis_oculi_L",
                "orbicularis_oculi_R", "zygomaticus_major_L", "zygomaticus_major_R"]


def _bytes(result):
    parts = [t.name.encode() + t.times.tobytes() + t.values.tobytes() for t in result.tracks]
    parts.append(repr([(e.kind, e.start, e.end, sorted(e.params.items())) for e in result.events]).encode())
    return b"".join(parts)


def test_same_seed_same_bytes_other_seed_other_bytes(monologues):
    u, _ = monologues[0]
    a, b, c = (generate_behavior(u, seed=s) for s in (7, 7, 8))
    assert _bytes(a) == _bytes(b)
    assert _bytes(a) != _bytes(c)
    assert [e.kind for e in a.events if e.kind == "brow_raise"] != [] and \
        [e.start for e in a.of_kind("brow_raise")] != [e.start for e in c.of_kind("brow_raise")]


def test_curves_are_tracks_finite_and_within_bounds(neutral_runs):
    specs = channel_specs()
    for u, r in neutral_runs[:20]:
        assert isinstance(r.tracks, TrackSet)
        assert set(r.tracks.names) == set(specs)
        for track in r.tracks:
            spec = specs[track.name]
            assert np.all(np.isfinite(track.values))
            assert track.values.min() >= spec.minimum and track.values.max() <= spec.maximum
            assert track.start == 0.0 and track.end == pytest.approx(u.duration, abs=0.011)
    assert {"head.pitch", "head.yaw", "head.roll"} <= set(specs)
    assert all(specs[n].units == "rad" for n in ("head.pitch", "head.yaw", "head.roll"))


def test_face_channels_mix_into_the_face_rigs_behavior_layer(neutral_runs):
    u, r = neutral_runs[0]
    specs = control_specs(FACE_MUSCLES)
    for t in np.linspace(0, u.duration, 50):
        values = r.layer_values(t)
        mixed = mix({"behavior": values}, specs)
        assert mixed["eyelid_close_L"] == pytest.approx(values["eyelid_close_L"])
        assert mixed["eye_yaw"] == pytest.approx(values["eye_yaw"])


def test_all_five_styles_load_and_neutral_carries_the_thesis_numbers():
    assert {"neutral", "nodder", "brow_raiser", "reserved", "expressive"} <= set(style_names())
    n = load_style("neutral")
    assert (n.blink_interval_s, n.blink_close_s, n.blink_apex_s, n.blink_open_s) == (4.8, 1 / 8, 1 / 24, 1 / 12)
    assert (n.brow_raise_probability, n.head_tilt_probability, n.accent_glance_probability,
            n.phrase_glance_probability, n.thinking_frown_probability, n.head_raise_max_deg) == \
        (0.71, 0.75, 0.7, 0.7, 0.25, 3.0)
    assert load_style("nodder").blink_interval_s == 4.8, "missing keys come from neutral"


def test_styles_accentuate_differently(monologues):
    """4.2.2: some people underline by eyebrow movement, some by nodding."""
    counts = {}
    for name in ("neutral", "nodder", "brow_raiser", "reserved", "expressive"):
        runs = [generate_behavior(u, name, seed=s) for s, (u, _) in enumerate(monologues[:10])]
        counts[name] = {k: sum(r.count(k) for r in runs) for k in ("head_raise", "brow_raise", "accent_glance")}
        counts[name]["head_peak"] = max(r.tracks["head.pitch"].values.max() for r in runs)
    assert counts["nodder"]["head_raise"] > 2 * counts["nodder"]["brow_raise"]
    assert counts["brow_raiser"]["brow_raise"] > counts["brow_raiser"]["head_raise"]
    assert counts["nodder"]["head_peak"] > counts["neutral"]["head_peak"] > counts["reserved"]["head_peak"]
    assert counts["reserved"]["accent_glance"] < counts["neutral"]["accent_glance"] < counts["expressive"]["accent_glance"]


def test_bad_styles_and_arguments_are_refused(monologues, tmp_path):
    u, _ = monologues[0]
    with pytest.raises(UserError, match="unknown character style"):
        generate_behavior(u, "grumpy")
    with pytest.raises(UserError, match="unknown key"):
        generate_behavior(u, {"brow_probability": 0.5})
    with pytest.raises(UserError, match="at most 1"):
        generate_behavior(u, {"brow_raise_probability": 1.5})
    with pytest.raises(UserError, match="seed"):
        generate_behavior(u, seed=-1)
    assert generate_behavior(u, CharacterStyle(brow_raise_probability=0.0)).count("brow_raise") == 0


def test_the_artists_copy_of_the_styles_wins(monologues, tmp_path):
    folder = tmp_path / "behavior"
    folder.mkdir()
    doc = {"format": "faces_hands.behavior_styles", "version": 1,
           "styles": {"neutral": {"brow_raise_probability": 0.0}, "calm": {"head_raise_probability": 0.0}}}
    (folder / "styles.json").write_text(json.dumps(doc), encoding="utf-8")
    old = presets.user_folder()
    presets.set_user_folder(tmp_path)
    try:
        u, _ = monologues[0]
        r = generate_behavior(u, "calm", seed=1)
        assert r.count("brow_raise") == 0 and r.count("head_raise") == 0 and r.count("blink") > 0
        (folder / "styles.json").write_text(json.dumps({"format": "faces_hands.behavior_styles",
                                                        "version": 1, "styles": {}}), encoding="utf-8")
        with pytest.raises(UserError, match="neutral"):
            load_style("neutral")
    finally:
        presets.set_user_folder(old)


def test_head_raise_limit_in_degrees_is_the_styles(monologues):
    u, _ = monologues[1]
    r = generate_behavior(u, {"head_raise_max_deg": 1.0, "question_head_deg": 1.0, "thinking_head_deg": 0.5})
    assert r.tracks["head.pitch"].values.max() <= math.radians(1.0) + 1e-12


def test_short_silent_and_unvoiced_utterances_still_give_valid_tracks():
    from dataclasses import replace

    from faces_hands_addon.speech.pitch import PitchContour

    from behavior_utterances import build
    u, _ = build([(".", [["1"]])])
    unvoiced = replace(u, pitch=PitchContour(u.pitch.times, np.full(u.pitch.times.shape, np.nan), 0.01))
    silent = replace(u, words=[], syllables=[], phrases=[], sentences=[], pitch=unvoiced.pitch)
    tiny = replace(u, samples=u.samples[:1600], words=[], syllables=[], phrases=[], sentences=[], pauses=[],
                   phones=[], pitch=unvoiced.pitch)
    for utterance in (u, unvoiced, silent, tiny):
        r = generate_behavior(utterance, seed=0)
        for track in r.tracks:
            assert np.all(np.isfinite(track.values)) and track.end == pytest.approx(utterance.duration, abs=0.011)
    assert generate_behavior(unvoiced).count("pitch_max") == 0
    long_silence = replace(silent, samples=np.zeros(16000 * 12, np.float32), pauses=[])
    onsets = [e.start for e in generate_behavior(long_silence).of_kind("blink")]
    assert np.diff([0.0] + onsets).max() <= 4.8 + 1e-9 and len(onsets) >= 2
