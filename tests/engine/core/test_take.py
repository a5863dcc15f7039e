"""A take is plain data from the text to the file: the bakes start from an ``anim.take.Take`` (never from a
Blender object), its table is its tracks sampled at the frames, it stores and reads back bit for bit, and
speech owns the lips where the layers conflict (Bui et al. 2004, thesis 2.1)."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.anim.bakes import WeightsBake
from faces_hands_addon.anim.take import Span, Take
from faces_hands_addon.anim.tracks import Track, TrackSet
from faces_hands_addon.face.rig import build_default_rig
from faces_hands_addon.performance import load_priority, ownership


def _take() -> Take:
    times = np.array([0.0, 0.1, 0.2, 0.3])
    speech = TrackSet({"jaw_open": Track("jaw_open", times, [0.0, 0.3, 0.0, 0.2]),
                       "orbicularis_oris_upper": Track("orbicularis_oris_upper", times, [0.0, 0.0, 1.0, 0.0])})
    emotion = TrackSet({"zygomaticus_major_L": Track("zygomaticus_major_L", [0.0, 0.3], [0.9, 0.9])})
    return Take({"speech": speech, "emotion": emotion}, 0.3, closures=(Span(0.18, 0.22, "viseme_PP"),),
                owned=((Span(0.18, 0.22, "closure"), frozenset({"jaw_open"})),))


def test_a_take_table_is_its_tracks_at_the_frames_and_it_round_trips_bit_for_bit():
    take = _take()
    specs = build_default_rig("coarse").control_specs()
    table = take.table(specs, range(10, 20), 30.0, start_frame=10)
    column = table.controls.index("jaw_open")
    np.testing.assert_array_equal(table.values["speech"][:, column],
                                  take.layers["speech"]["jaw_open"].sample(np.arange(10) / 30.0))
    assert table.values["ctrl"][0, column] == specs["jaw_open"].default and not table.values["behavior"].any()
    again = Take.from_bytes(take.to_bytes())
    assert again.to_bytes() == take.to_bytes()
    assert again.closures == take.closures and again.owned == take.owned
    for layer in ("speech", "emotion", "behavior", "ctrl"):
        np.testing.assert_array_equal(again.table(specs, range(10), 30.0).values[layer],
                                      take.table(specs, range(10), 30.0).values[layer])
    assert take.owned_rows(range(10), 30.0) == {6: frozenset({"jaw_open"})}
    with pytest.raises(UserError):
        Take.from_bytes(b"PK\x03\x04 not a take")


def test_the_weights_bake_runs_on_plain_data_alone():
    """No Blender object anywhere: the engine rig, a Take, frames, targets and rest arrays (this test also runs
    in the engine-only Python, where bpy does not exist)."""
    rig = build_default_rig("coarse")
    targets = {"viseme_PP": {"orbicularis_oris_upper": 1.0, "orbicularis_oris_lower": 1.0},
               "jawOpen": {"jaw_open": 1.0}, "mouthSmileLeft": {"zygomaticus_major_L": 1.0}}
    bake = WeightsBake(rig, _take(), range(0, 10), 30.0, 0, targets, {}, np.eye(4), correctives=False)
    fraction = 0.0
    while fraction < 1.0:
        fraction = bake.step()
    bake.close()
    fit = bake.fit()
    assert fit.weights.shape == (10, 3) and np.all(np.isfinite(fit.weights))
    assert fit.weights[6, 0] == pytest.approx(1.0)          # the closure's row shows its viseme
    assert fit.weights[6, 1] == 0.0                          # and no target that opens the jaw


def test_speech_owns_the_jaw_and_the_lip_separators_around_a_closure_and_nothing_else():
    articulations = load_priority()
    utterance = [("aa", 0.0, 0.3), ("m", 0.3, 0.1), ("aa", 0.4, 0.6)]        # (phone, start, duration)
    times = np.array([0.05, 0.2, 0.35, 0.5, 0.95])
    owned = ownership(utterance, articulations, times)
    assert owned["jaw_open"][2] == 1.0 and owned["levator_labii_superioris_L"][2] == 1.0
    assert owned["levator_labii_superioris_L"][0] == 0.0 and 0.0 < owned["levator_labii_superioris_L"][1] < 1.0
    assert "zygomaticus_major_L" not in owned or owned["zygomaticus_major_L"][2] == 0.0, \
        "a smile is no conflict with a closed /m/ (it stays)"
    assert owned["jaw_open"][4] == 1.0, "the jaw belongs to speech while it speaks"
